//! Change events of a [`GraphCache`](super::GraphCache): one bounded queue per
//! listener, filled from Zenoh's callback without ever blocking it.

use std::fmt;
use std::pin::Pin;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, Weak};
use std::task::{Context, Poll};
use std::time::Duration;

use super::Entity;

/// One change of the graph, in the order the cache applied it.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub enum GraphEvent {
    /// An entity's token appeared.
    Appeared(Arc<Entity>),
    /// An entity's token went away (undeclared, or its session is gone).
    Left(Arc<Entity>),
    /// The listener's queue was full and the changes from here on were not
    /// queued (see [`GraphEvents::missed`]): read the cache again for the
    /// current state. The events after this one are complete again.
    Missed,
}

/// The sending side of one listener, kept by the cache.
pub(super) struct Listener {
    id: u64,
    sender: flume::Sender<GraphEvent>,
    capacity: usize,
    missed: Arc<AtomicU64>,
}

impl Listener {
    /// Queue `event`, or count it as missed; `false` once the receiver is gone.
    ///
    /// The last slot of the queue is kept for [`GraphEvent::Missed`], so a
    /// run of dropped events is always followed by one marker, at the place
    /// where they were dropped, even if nothing else happens afterwards.
    fn send(&self, event: &GraphEvent) -> bool {
        if self.sender.is_disconnected() {
            return false;
        }
        let queued = self.sender.len();
        if queued + 1 < self.capacity {
            let _ = self.sender.try_send(event.clone());
        } else {
            self.missed.fetch_add(1, Ordering::Relaxed);
            if queued < self.capacity {
                let _ = self.sender.try_send(GraphEvent::Missed);
            }
        }
        true
    }
}

/// Every listener of one cache.
#[derive(Default)]
pub(super) struct Listeners {
    next_id: AtomicU64,
    list: Mutex<Vec<Listener>>,
}

impl Listeners {
    /// A new listener whose queue holds `capacity` events (at least 1; with 1
    /// every change is a [`GraphEvent::Missed`], which is all a waiter needs).
    pub(super) fn add(
        &self,
        capacity: usize,
    ) -> (u64, flume::Receiver<GraphEvent>, Arc<AtomicU64>) {
        let capacity = capacity.max(1);
        let (sender, receiver) = flume::bounded(capacity);
        let id = self.next_id.fetch_add(1, Ordering::Relaxed);
        let missed = Arc::new(AtomicU64::new(0));
        self.lock().push(Listener {
            id,
            sender,
            capacity,
            missed: missed.clone(),
        });
        (id, receiver, missed)
    }

    pub(super) fn remove(&self, id: u64) {
        self.lock().retain(|l| l.id != id);
    }

    /// Hand `events` to every listener; forget those whose receiver is gone.
    pub(super) fn send(&self, events: &[GraphEvent]) {
        if events.is_empty() {
            return;
        }
        self.lock()
            .retain(|listener| events.iter().all(|event| listener.send(event)));
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<Listener>> {
        // A listener list is valid after any panic: entries are whole.
        self.list.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// The changes of a [`GraphCache`](super::GraphCache) from the moment this
/// was made: a blocking receiver and an async [`Stream`](futures_core::Stream).
///
/// Its queue is bounded ([`GraphCache::events_with_capacity`](super::GraphCache::events_with_capacity));
/// when a reader falls behind, what does not fit is counted in
/// [`missed`](Self::missed) and replaced by one [`GraphEvent::Missed`]; the
/// cache itself stays complete.
pub struct GraphEvents {
    receiver: flume::r#async::RecvStream<'static, GraphEvent>,
    blocking: flume::Receiver<GraphEvent>,
    missed: Arc<AtomicU64>,
}

impl fmt::Debug for GraphEvents {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("GraphEvents")
            .field("queued", &self.blocking.len())
            .field("missed", &self.missed())
            .finish()
    }
}

impl GraphEvents {
    pub(super) fn new(receiver: flume::Receiver<GraphEvent>, missed: Arc<AtomicU64>) -> Self {
        Self {
            receiver: receiver.clone().into_stream(),
            blocking: receiver,
            missed,
        }
    }

    /// The next change, waiting up to `timeout`; `None` if there was none.
    pub fn recv_timeout(&self, timeout: Duration) -> Option<GraphEvent> {
        self.blocking.recv_timeout(timeout).ok()
    }

    /// The next change if one is queued.
    pub fn try_recv(&self) -> Option<GraphEvent> {
        self.blocking.try_recv().ok()
    }

    /// The next change, asynchronously; `None` once the cache is gone.
    pub async fn recv_async(&self) -> Option<GraphEvent> {
        self.blocking.recv_async().await.ok()
    }

    /// How many changes did not fit the queue since this was made.
    pub fn missed(&self) -> u64 {
        self.missed.load(Ordering::Relaxed)
    }
}

impl futures_core::Stream for GraphEvents {
    type Item = GraphEvent;

    fn poll_next(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<GraphEvent>> {
        Pin::new(&mut self.receiver).poll_next(cx)
    }
}

/// A callback on every change of a [`GraphCache`](super::GraphCache), from
/// [`GraphCache::on_change`](super::GraphCache::on_change); it stops when this
/// is dropped.
///
/// The callback runs on a thread of its own, never on Zenoh's: a slow one
/// delays only itself (and, past its queue, sees [`GraphEvent::Missed`]).
#[must_use = "the callback stops when this is dropped"]
pub struct GraphCallback {
    pub(super) id: u64,
    pub(super) listeners: Weak<Listeners>,
}

impl fmt::Debug for GraphCallback {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("GraphCallback")
            .field("id", &self.id)
            .finish()
    }
}

impl Drop for GraphCallback {
    fn drop(&mut self) {
        // Its sender goes, so the thread's receive ends and the thread returns.
        if let Some(listeners) = self.listeners.upgrade() {
            listeners.remove(self.id);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn node(i: u64) -> GraphEvent {
        let token = format!("@ros2_lv/0/ab/{i}/{i}/NN/%/%/n{i}");
        GraphEvent::Appeared(Arc::new(Entity::parse(&token).unwrap()))
    }

    #[test]
    fn a_full_queue_ends_in_one_missed_marker_and_counts_the_rest() {
        let listeners = Listeners::default();
        let (_, receiver, missed) = listeners.add(4);
        let events: Vec<GraphEvent> = (0..10).map(node).collect();
        listeners.send(&events);
        let got: Vec<GraphEvent> = receiver.try_iter().collect();
        assert_eq!(got.len(), 4);
        assert!(got[..3]
            .iter()
            .all(|e| matches!(e, GraphEvent::Appeared(_))));
        assert!(matches!(got[3], GraphEvent::Missed));
        assert_eq!(missed.load(Ordering::Relaxed), 7);
        // Read out, the queue takes events again after the marker.
        listeners.send(&[node(11)]);
        assert!(matches!(receiver.try_recv(), Ok(GraphEvent::Appeared(e)) if e.node_name == "n11"));
    }

    #[test]
    fn a_listener_whose_receiver_is_gone_is_forgotten() {
        let listeners = Listeners::default();
        let (_, receiver, _) = listeners.add(4);
        let (_, _kept, _) = listeners.add(4);
        drop(receiver);
        listeners.send(&[node(1)]);
        assert_eq!(listeners.lock().len(), 1);
    }
}
