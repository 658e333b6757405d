//! Messages Zenoh drops because this process could not map the sender's
//! shared memory (the memory-lock limit, another user's segment, the
//! open-files limit, a segment that is gone). Zenoh drops each one with only a
//! debug-level log line and no error anywhere; [`receive_failure_layer`]
//! watches for that line, so every such message is counted
//! ([`shm_receive_failures`]) and a warning names the cause and the fix.

use std::fmt;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

use nix::errno::Errno;
use std::time::{Duration, Instant};

use tracing::field::{Field, Visit};
use tracing::{Event, Level, Subscriber};
use tracing_subscriber::filter::{Filtered, Targets};
use tracing_subscriber::layer::{Context, Layer};

/// What Zenoh's receive path logs when it cannot map a shared-memory buffer
/// (and then drops the message).
const ZENOH_DROP_MESSAGE: &str = "Error receiving SHM buffer";

/// Why a message could not be taken from shared memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ReceiveFailureCause {
    /// `mlock` refused: the memory-lock limit (`RLIMIT_MEMLOCK`) is used up
    /// by the segments this process maps.
    MemoryLock,
    /// The segment belongs to another user (segments are created `0600`).
    Permission,
    /// The open-files limit (`RLIMIT_NOFILE`): each mapped segment holds a
    /// file descriptor.
    OpenFiles,
    /// The segment no longer exists, or Zenoh found it invalid: its process
    /// exited.
    Vanished,
    /// Anything else; the warning quotes Zenoh's message.
    Other,
    /// Zenoh's watchdog marked the buffer invalid before this process took
    /// the message, as it does with a buffer no process confirms for about
    /// 100 ms: one in flight to a process that is stopped or starved. The
    /// message is lost, whoever sent it.
    Invalidated,
}

impl ReceiveFailureCause {
    /// In declaration order: a cause's index is its discriminant.
    const ALL: [Self; 6] = [
        Self::MemoryLock,
        Self::Permission,
        Self::OpenFiles,
        Self::Vanished,
        Self::Other,
        Self::Invalidated,
    ];

    /// Read Zenoh's error text (`… OS error 12`).
    fn of(error: &str) -> Self {
        let errno = error
            .split("OS error ")
            .nth(1)
            .and_then(|rest| rest.split(|c: char| !c.is_ascii_digit()).next())
            .and_then(|n| n.parse::<i32>().ok());
        match errno.map(Errno::from_raw) {
            Some(Errno::ENOMEM | Errno::EAGAIN) => Self::MemoryLock,
            Some(Errno::EACCES | Errno::EPERM) => Self::Permission,
            Some(Errno::EMFILE | Errno::ENFILE) => Self::OpenFiles,
            Some(Errno::ENOENT) => Self::Vanished,
            // `Buffer is invalidated`: the buffer's watchdog lapsed; the
            // segment itself may well be there.
            None if error.contains("invalidated") => Self::Invalidated,
            None if error.contains("invalid") => Self::Vanished,
            _ => Self::Other,
        }
    }

    /// What became of the message.
    fn outcome(self) -> &'static str {
        match self {
            Self::Invalidated => {
                "It was a message, lost, from whichever publisher sent it (a node subscriber \
                 counts it in missed())."
            }
            _ => {
                "From an shm-runtime publisher this was its probe: it sends to this process \
                 from the heap and nothing is lost; from another sender (rmw_zenoh_cpp) it was \
                 a message, lost."
            }
        }
    }

    fn index(self) -> usize {
        self as usize
    }

    /// What to change.
    fn advice(self) -> &'static str {
        match self {
            Self::MemoryLock => {
                "Zenoh locks every segment it maps in RAM and this process's RLIMIT_MEMLOCK \
                 is used up: raise it (`ulimit -l`, /etc/security/limits.conf, systemd's \
                 LimitMEMLOCK=, Docker's --ulimit memlock=-1 or --cap-add IPC_LOCK), or make \
                 the publishers' pools smaller"
            }
            Self::Permission => {
                "the publisher runs as another user and its segments are private to it: run \
                 both as one user"
            }
            Self::OpenFiles => {
                "each mapped segment holds a file descriptor and RLIMIT_NOFILE is reached: \
                 raise it (`ulimit -n`, LimitNOFILE=)"
            }
            Self::Vanished => "the publisher's segment is gone (its process exited)",
            Self::Invalidated => {
                "Zenoh's watchdog took the buffer back before this process read it, as it does \
                 when a buffer's receivers stop confirming it for about 100 ms: this process was \
                 stopped or starved (a debugger, SIGSTOP, swapping, a CPU quota) while messages \
                 were in flight to it"
            }
            Self::Other => "see Zenoh's message",
        }
    }
}

impl fmt::Display for ReceiveFailureCause {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::MemoryLock => "memory-lock limit",
            Self::Permission => "another user's segment",
            Self::OpenFiles => "open-files limit",
            Self::Vanished => "segment gone",
            Self::Invalidated => "buffer invalidated",
            Self::Other => "other",
        })
    }
}

static COUNTS: [AtomicU64; ReceiveFailureCause::ALL.len()] =
    [const { AtomicU64::new(0) }; ReceiveFailureCause::ALL.len()];

/// How many messages this process could not take from shared memory, by
/// cause, since it started. This project's publishers check each
/// subscribing session with one probe message first and send to a session
/// that cannot map their pool from the heap, so for them a failure to map
/// counts the probe, and nothing is lost; the messages of other senders
/// (rmw_zenoh_cpp's) counted here were lost. A buffer
/// [invalidated](ReceiveFailureCause::Invalidated) while this process was
/// stopped is a message lost, whoever sent it. Counted only while a
/// [`receive_failure_layer`] is installed ([`init_logging`](crate::init_logging)
/// installs one).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ShmReceiveFailures {
    counts: [u64; ReceiveFailureCause::ALL.len()],
}

impl ShmReceiveFailures {
    /// Messages (and probes) not mapped for `cause`.
    pub fn count(&self, cause: ReceiveFailureCause) -> u64 {
        self.counts[cause.index()]
    }

    /// Messages (and probes) not mapped for any cause.
    pub fn total(&self) -> u64 {
        self.counts.iter().sum()
    }
}

/// The messages this process could not map so far (see [`ShmReceiveFailures`]).
pub fn shm_receive_failures() -> ShmReceiveFailures {
    ShmReceiveFailures {
        counts: COUNTS.each_ref().map(|c| c.load(Ordering::Relaxed)),
    }
}

/// A `tracing` layer that counts the messages Zenoh drops because this
/// process cannot map their shared memory, and warns with the cause and the
/// fix. [`init_logging`](crate::init_logging) installs it; add it yourself
/// next to your own subscriber's layers:
///
/// ```
/// use tracing_subscriber::prelude::*;
///
/// let _ = tracing_subscriber::registry()
///     .with(tracing_subscriber::fmt::layer())
///     .with(shm_runtime::receive_failure_layer())
///     .try_init();
/// ```
pub fn receive_failure_layer<S>() -> Filtered<ReceiveFailureLayer, Targets, S>
where
    S: Subscriber + for<'a> tracing_subscriber::registry::LookupSpan<'a>,
{
    // Only Zenoh's transport, at debug: this layer sees no other event.
    ReceiveFailureLayer(()).with_filter(Targets::new().with_target("zenoh_transport", Level::DEBUG))
}

/// See [`receive_failure_layer`].
#[derive(Debug)]
pub struct ReceiveFailureLayer(());

impl<S: Subscriber> Layer<S> for ReceiveFailureLayer {
    fn on_event(&self, event: &Event<'_>, _ctx: Context<'_, S>) {
        let mut message = MessageText(String::new());
        event.record(&mut message);
        let Some(error) = message.0.strip_prefix(ZENOH_DROP_MESSAGE) else {
            return;
        };
        let cause = ReceiveFailureCause::of(error);
        COUNTS[cause.index()].fetch_add(1, Ordering::Relaxed);
        // An event sent from inside a subscriber's callback is dropped by
        // `tracing`; the warning is sent from a thread of its own.
        warner().notify(cause, error.trim_start_matches(':').trim());
    }
}

struct MessageText(String);

impl Visit for MessageText {
    fn record_debug(&mut self, field: &Field, value: &dyn fmt::Debug) {
        if field.name() == "message" {
            self.0 = format!("{value:?}");
        }
    }
}

/// Warns once per cause at once, then at most every 10 s with the count.
struct Warner {
    sender: flume::Sender<(ReceiveFailureCause, String)>,
}

const WARN_EVERY: Duration = Duration::from_secs(10);

impl Warner {
    fn notify(&self, cause: ReceiveFailureCause, error: &str) {
        // Bounded: a flood of failures costs counts, never memory.
        let _ = self.sender.try_send((cause, error.to_owned()));
    }
}

fn warner() -> &'static Warner {
    static WARNER: OnceLock<Warner> = OnceLock::new();
    WARNER.get_or_init(|| {
        let (sender, receiver) = flume::bounded::<(ReceiveFailureCause, String)>(64);
        let spawned = std::thread::Builder::new()
            .name("shm-receive-failures".into())
            .spawn(move || {
                let mut last = [None::<Instant>; ReceiveFailureCause::ALL.len()];
                while let Ok((cause, error)) = receiver.recv() {
                    let due = last[cause.index()].is_none_or(|at| at.elapsed() >= WARN_EVERY);
                    if due {
                        last[cause.index()] = Some(Instant::now());
                        // What this process has locked against its limit, for
                        // the memory-lock cause: the numbers to size pools by.
                        let budget = match cause {
                            ReceiveFailureCause::MemoryLock => {
                                format!(" ({})", crate::MemlockBudget::read())
                            }
                            _ => String::new(),
                        };
                        tracing::warn!(
                            "this process could not take a message from a sender's shared memory \
                             ({cause}: {error}); {} so far for this cause. {} Cause: {}{budget}",
                            COUNTS[cause.index()].load(Ordering::Relaxed),
                            cause.outcome(),
                            cause.advice()
                        );
                    }
                }
            });
        if let Err(e) = spawned {
            eprintln!("shm-runtime: no thread for shared-memory receive warnings: {e}");
        }
        Warner { sender }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_cause_has_its_own_count() {
        for (i, cause) in ReceiveFailureCause::ALL.into_iter().enumerate() {
            assert_eq!(cause.index(), i, "{cause}");
        }
    }

    #[test]
    fn zenohs_error_text_names_the_cause() {
        for (text, cause) in [
            (
                ": Unable to open POSIX shm segment: OS error 12",
                ReceiveFailureCause::MemoryLock,
            ),
            (
                ": Unable to open POSIX shm segment: OS error 13 at foo.rs:1",
                ReceiveFailureCause::Permission,
            ),
            (": OS error 24", ReceiveFailureCause::OpenFiles),
            (": OS error 2", ReceiveFailureCause::Vanished),
            (
                ": Unable to open POSIX shm segment: segment is invalid!",
                ReceiveFailureCause::Vanished,
            ),
            (": Unsupported SHM protocol: 3", ReceiveFailureCause::Other),
            (": Buffer is invalidated", ReceiveFailureCause::Invalidated),
        ] {
            assert_eq!(ReceiveFailureCause::of(text), cause, "{text}");
        }
    }
}
