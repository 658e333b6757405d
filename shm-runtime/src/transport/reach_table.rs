//! What a shared-memory pool knows of the sessions that subscribe to its
//! publishers: how each receives, and when to ask it again.

use std::collections::HashMap;
use std::fmt;
use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

use zenoh::session::ZenohId;

use crate::transport::changes::Changes;

/// How long after a failed probe the session is asked again (its limit may
/// have been raised, or another session released what it had locked),
/// doubling with each failure up to [`RETRY_AFTER_MAX`]: a failed probe
/// leaves its 8-byte chunk referenced for good, so they stay few.
pub(crate) const RETRY_AFTER: Duration = Duration::from_secs(30);
const RETRY_AFTER_MAX: Duration = Duration::from_secs(3600);

/// How long after a failed probe or confirmation to ask again, the `n`th
/// time in a row: [`RETRY_AFTER`], doubling up to [`RETRY_AFTER_MAX`].
pub(crate) fn backoff(failures: u32) -> Duration {
    RETRY_AFTER
        .saturating_mul(1 << failures.saturating_sub(1).min(16))
        .min(RETRY_AFTER_MAX)
}

/// How a subscriber's session receives a publisher's shared-memory messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Reach {
    /// The check is under way (two round trips: the session confirms its
    /// receiver token, then answers the probe): messages go from the heap
    /// meanwhile ([`PayloadKind::ReceiverPending`](crate::PayloadKind::ReceiverPending)) if the session is linked
    /// to the publisher's, or once it has confirmed. A subscriber
    /// that answers no probe stays here until a transport to it opens, and
    /// for good on a session in Zenoh's low-latency mode, whose transports
    /// Zenoh 1.9 cannot list for it (its messages are not held back).
    Checking,
    /// The session maps the pool: messages reach it in place.
    SharedMemory,
    /// The link to the session carries no shared memory (another host,
    /// another user, a router without it, shared memory off in that session,
    /// or a Zenoh line whose shared-memory protocol differs from this
    /// program's, see [`ZenohLine`](crate::ZenohLine): 1.10 cannot share
    /// memory with 1.8 and 1.9, rmw_zenoh_cpp's among them): Zenoh
    /// copies each message into that link, counted in
    /// [`PublishOutcome::copied_to`](crate::PublishOutcome::copied_to) and
    /// [`ShmStats::copied`](crate::ShmStats::copied). Nothing is lost.
    Bytes,
    /// A subscriber that answers no probe (another ROS 2 implementation's,
    /// such as rmw_zenoh_cpp's), over a link that carries shared memory: its
    /// Zenoh maps the pool's messages in place, unless its own process
    /// limits stop it, which it does not tell.
    SharedMemoryUnprobed,
    /// The session could not map the pool (its process's memory-lock or
    /// open-files limit, most often; that process's log names the cause):
    /// messages go from the heap so that it gets every one
    /// ([`PayloadKind::ReceiverCannotMap`](crate::PayloadKind::ReceiverCannotMap)). Asked again every 30 s.
    CannotMap,
    /// A receiver token that the session it names did not confirm within
    /// [`PROBE_TIMEOUT`](crate::PROBE_TIMEOUT): forged by another session, or its session is gone,
    /// is not this project's, or an access-control policy denies the probe
    /// (see the guide's security chapter). It holds no message back; asked
    /// again after 30 s, then less and less often.
    Unconfirmed,
}

impl fmt::Display for Reach {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Checking => "being checked",
            Self::SharedMemory => "shared memory",
            Self::Bytes => "bytes (the link carries no shared memory)",
            Self::SharedMemoryUnprobed => {
                "shared memory (link negotiated; the subscriber answers no probe)"
            }
            Self::CannotMap => "cannot map the pool",
            Self::Unconfirmed => "unconfirmed receiver token (ignored)",
        })
    }
}

/// One session that subscribes to a publisher, and how it gets the
/// publisher's shared-memory messages (see [`RosPublisher::receivers`](crate::RosPublisher::receivers)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub struct Receiver {
    /// The subscribing session.
    pub session: ZenohId,
    /// How it receives.
    pub reach: Reach,
}

/// What a pool knows of one session.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Checked {
    pub(crate) reach: Reach,
    /// When `reach` was settled (or the check started).
    pub(crate) at: Instant,
    /// Probes in a row that got no answer.
    pub(crate) failures: u32,
}

impl Checked {
    /// Whether a session that could not map the pool is due another probe.
    pub(crate) fn due(&self) -> bool {
        self.due_at(Instant::now())
    }

    pub(crate) fn due_at(&self, now: Instant) -> bool {
        self.reach == Reach::CannotMap
            && now.saturating_duration_since(self.at) >= backoff(self.failures)
    }
}

/// What a pool knows of the sessions it has checked.
#[derive(Default)]
pub(crate) struct ReachTable {
    sessions: Mutex<HashMap<ZenohId, Checked>>,
    pub(crate) changes: Changes,
}

impl ReachTable {
    pub(crate) fn lock(&self) -> MutexGuard<'_, HashMap<ZenohId, Checked>> {
        // Each entry is written whole.
        self.sessions.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Set what is known of `session`.
    pub(crate) fn set(&self, session: ZenohId, checked: Checked) {
        self.lock().insert(session, checked);
        self.changes.note();
    }
}
