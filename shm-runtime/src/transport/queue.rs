//! The receive side between Zenoh and the application: every sample is checked
//! for its message type and its publisher's sequence number, then queued under
//! the subscriber's [`History`], on Zenoh's thread, without ever blocking it.

use std::num::NonZeroUsize;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;

use zenoh::sample::Sample;

use crate::transport::gaps::Gaps;
use crate::transport::sample::RosSample;
use crate::transport::type_check::TypeCheck;

/// What a [`History::KeepAll`] queue may hold unless told otherwise
/// ([`SubscriberBuilder::max_queued_bytes`](crate::SubscriberBuilder::max_queued_bytes)).
pub const DEFAULT_MAX_QUEUED_BYTES: usize = 256 << 20;

/// What a sample costs beyond its payload (Zenoh's `Sample`, our wrapper),
/// so that many tiny samples count too.
const SAMPLE_OVERHEAD: usize = 256;

/// How many received samples a [`RosSubscriber`](crate::RosSubscriber) keeps
/// while the application is not reading: ROS 2's history QoS, applied on the
/// subscriber's side.
///
/// Either way, Zenoh's receive thread never waits for the application. (With a
/// bounded channel that blocks, as Zenoh's default handler does, a subscriber
/// that stops reading stalls the whole connection; the publisher's `Block`
/// congestion control then gives up after Zenoh's `wait_before_close` (5 s),
/// closes the transport and drops what was in flight, with every `publish`
/// having returned `Ok`.)
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum History {
    /// Keep every sample until it is read (the default on a plain key
    /// expression; a node subscriber follows its QoS), up to a memory budget
    /// (256 MiB of samples queued or still held by the application, see
    /// [`SubscriberBuilder::max_queued_bytes`](crate::SubscriberBuilder::max_queued_bytes)):
    /// past it, arriving samples are dropped and counted in
    /// [`RosSubscriber::lost`](crate::RosSubscriber::lost) until the
    /// application releases some.
    #[default]
    KeepAll,
    /// Keep the newest `n`: a sample arriving while `n` wait drops the oldest,
    /// which is counted in [`RosSubscriber::lost`](crate::RosSubscriber::lost) (and logged once).
    KeepLast(NonZeroUsize),
}

/// The queue between Zenoh's receive thread and the application.
pub(crate) struct Queue {
    sender: flume::Sender<RosSample>,
    /// Kept by the callback to drop the oldest sample under `KeepLast`.
    receiver: flume::Receiver<RosSample>,
    /// `KeepAll`'s budget, in bytes, and what is held now.
    max_bytes: Option<usize>,
    held: Arc<AtomicUsize>,
    pub(crate) lost: Arc<AtomicU64>,
    /// Messages that never arrived.
    pub(crate) gaps: Gaps,
    key_expr: String,
    pub(crate) type_check: TypeCheck,
}

impl Queue {
    pub(crate) fn new(
        history: History,
        max_bytes: usize,
        key_expr: &str,
        type_check: TypeCheck,
    ) -> (Self, flume::Receiver<RosSample>) {
        let (sender, receiver) = match history {
            History::KeepAll => flume::unbounded(),
            History::KeepLast(n) => flume::bounded(n.get()),
        };
        let queue = Self {
            sender,
            receiver: receiver.clone(),
            max_bytes: (history == History::KeepAll).then_some(max_bytes),
            held: Arc::new(AtomicUsize::new(0)),
            lost: Arc::new(AtomicU64::new(0)),
            gaps: Gaps::new(key_expr),
            key_expr: key_expr.to_owned(),
            type_check,
        };
        (queue, receiver)
    }

    /// Called on Zenoh's thread for every sample; never blocks. Whether the
    /// sample was queued.
    pub(crate) fn push(&self, sample: Sample) -> bool {
        if !self.type_check.accepts(&sample) {
            return false;
        }
        self.gaps.check(&sample);
        let cost = sample.payload().len() + SAMPLE_OVERHEAD;
        if let Some(max) = self.max_bytes {
            let held = self.held.fetch_add(cost, Ordering::Relaxed) + cost;
            if held > max {
                self.held.fetch_sub(cost, Ordering::Relaxed);
                if self.lost.fetch_add(1, Ordering::Relaxed) == 0 {
                    tracing::warn!(
                        key_expr = %self.key_expr,
                        max_bytes = max,
                        "subscriber holds its whole memory budget (History::KeepAll, max_queued_bytes): arriving samples are dropped until the application releases some; RosSubscriber::lost() counts them"
                    );
                }
                return false;
            }
        }
        let held = self.max_bytes.map(|_| (self.held.clone(), cost));
        let mut sample = RosSample::queued(sample, held);
        loop {
            match self.sender.try_send(sample) {
                Ok(()) => return true,
                Err(flume::TrySendError::Full(back)) => {
                    sample = back;
                    if self.receiver.try_recv().is_ok()
                        && self.lost.fetch_add(1, Ordering::Relaxed) == 0
                    {
                        tracing::warn!(
                            key_expr = %self.key_expr,
                            "subscriber queue full (History::KeepLast): dropping the oldest samples; RosSubscriber::lost() counts them"
                        );
                    }
                }
                // The subscriber is gone; nobody will read.
                Err(flume::TrySendError::Disconnected(_)) => return false,
            }
        }
    }
}
