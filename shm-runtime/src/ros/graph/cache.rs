//! [`GraphCache`]: the ROS graph of one domain, kept up to date for a whole
//! session by one liveliness subscriber, as rmw_zenoh_cpp keeps its own.

use std::collections::{HashMap, HashSet};
use std::fmt;
use std::ops::Deref;
use std::sync::{Arc, Condvar, Mutex, MutexGuard, RwLock, RwLockReadGuard, Weak};
use std::time::{Duration, Instant};

use zenoh::sample::SampleKind;
use zenoh::session::ZenohId;
use zenoh::{Session, Wait};

use super::events::{GraphCallback, GraphEvent, GraphEvents, Listeners};
use super::Graph;

/// How long the first look at the graph waits for the other sessions'
/// answers (Zenoh's default query timeout).
const SYNC_TIMEOUT: Duration = Duration::from_secs(10);

/// The queue of [`GraphCache::events`].
const DEFAULT_EVENT_CAPACITY: usize = 1024;

/// One cache per session and domain, shared by every node of that session.
type Registry = HashMap<(ZenohId, u32), Weak<Handle>>;
static CACHES: Mutex<Option<Registry>> = Mutex::new(None);

/// What the Zenoh callbacks update.
struct Shared {
    domain_id: u32,
    graph: RwLock<Graph>,
    listeners: Arc<Listeners>,
    sync: Mutex<SyncState>,
    synced: Condvar,
}

/// Until the first query has answered, a token that left may still come back
/// in an answer sent before it left: those are remembered and not re-added.
#[derive(Default)]
struct SyncState {
    done: bool,
    gone: HashSet<String>,
    /// Async waiters, woken by dropping these.
    waiters: Vec<flume::Sender<()>>,
}

/// Where a token's news came from.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Source {
    Subscriber,
    Query,
}

impl Shared {
    fn apply(&self, token: &str, kind: SampleKind, source: Source) {
        let mut graph = self.graph.write().unwrap_or_else(|e| e.into_inner());
        {
            let mut sync = lock(&self.sync);
            if !sync.done {
                match (kind, source) {
                    (SampleKind::Delete, Source::Subscriber) => {
                        sync.gone.insert(token.to_owned());
                    }
                    (SampleKind::Put, Source::Query) if sync.gone.contains(token) => return,
                    _ => {}
                }
            }
        }
        let event = match kind {
            SampleKind::Put => graph.insert(token).map(GraphEvent::Appeared),
            SampleKind::Delete => graph.remove(token).map(GraphEvent::Left),
        };
        // Queued while the graph is still locked: listeners see the changes
        // in the order they were applied.
        if let Some(event) = event {
            self.listeners.send(&[event]);
        }
    }

    fn mark_synced(&self) {
        let mut sync = lock(&self.sync);
        sync.done = true;
        sync.gone = HashSet::new();
        sync.waiters.clear();
        self.synced.notify_all();
    }
}

fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    // Every state behind these locks is whole between statements.
    mutex.lock().unwrap_or_else(|e| e.into_inner())
}

/// Marks the cache synced when the first query's callback is dropped, which
/// Zenoh does once every answer arrived or the query timed out.
struct SyncOnDrop(Arc<Shared>);

impl Drop for SyncOnDrop {
    fn drop(&mut self) {
        self.0.mark_synced();
    }
}

/// Holds the liveliness subscriber: the cache lives as long as this.
struct Handle {
    shared: Arc<Shared>,
    _subscriber: zenoh::pubsub::Subscriber<()>,
}

/// The ROS graph of one domain, kept live for a whole session: one liveliness
/// subscriber (with history) follows every node's and endpoint's token as it
/// comes and goes, and queries read memory, not the network.
///
/// Every [`RosNode`](crate::RosNode) of a session shares one
/// ([`RosNode::graph_cache`](crate::RosNode::graph_cache)); it is made on
/// first use and undeclared with its last handle. Zenoh replays the tokens
/// alive at that moment into a callback, so no number of entities can block
/// it; the first query after that (answered within 10 s) tells when the
/// picture is complete ([`wait_synced`](Self::wait_synced)).
///
/// ```no_run
/// use std::time::Duration;
/// use shm_runtime::RosNode;
/// use zenoh::Wait;
///
/// let session = zenoh::open(zenoh::Config::default()).wait()?;
/// let node = RosNode::builder(&session, "inspector").wait()?;
/// let cache = node.graph_cache()?;
/// // Wait for a node without polling; then read the live graph.
/// if cache.wait_until(Duration::from_secs(5), |graph| graph.contains_node("/talker")) {
///     for endpoint in cache.read().node_endpoints("/talker") {
///         println!("{:?} {}", endpoint.kind, endpoint.endpoint.as_ref().map_or("", |e| &e.name));
///     }
/// }
/// # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
/// ```
#[derive(Clone)]
pub struct GraphCache {
    handle: Arc<Handle>,
}

impl fmt::Debug for GraphCache {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("GraphCache")
            .field("domain_id", &self.handle.shared.domain_id)
            .field("entities", &self.read().len())
            .field("synced", &self.is_synced())
            .finish()
    }
}

impl GraphCache {
    /// Whether `other` is this very cache (a clone of it), not one of another
    /// session or domain.
    pub(crate) fn is(&self, other: &GraphCache) -> bool {
        Arc::ptr_eq(&self.handle, &other.handle)
    }

    /// The graph cache of `session` for ROS domain `domain_id`: the one its
    /// nodes already share, or a new one.
    pub fn of(session: &Session, domain_id: u32) -> zenoh::Result<Self> {
        let mut caches = lock(&CACHES);
        let caches = caches.get_or_insert_with(HashMap::new);
        let key = (session.zid(), domain_id);
        if let Some(handle) = caches.get(&key).and_then(Weak::upgrade) {
            return Ok(Self { handle });
        }
        caches.retain(|_, cache| cache.strong_count() > 0);
        let handle = Arc::new(Self::declare(session, domain_id)?);
        caches.insert(key, Arc::downgrade(&handle));
        Ok(Self { handle })
    }

    fn declare(session: &Session, domain_id: u32) -> zenoh::Result<Handle> {
        let shared = Arc::new(Shared {
            domain_id,
            graph: RwLock::default(),
            listeners: Arc::default(),
            sync: Mutex::default(),
            synced: Condvar::new(),
        });
        let key = format!("@ros2_lv/{domain_id}/**");
        // Callbacks, not channels: Zenoh replays every alive token on this
        // thread before `wait` returns, and a bounded channel past its
        // capacity would block it for ever.
        let on_sample = shared.clone();
        let subscriber = session
            .liveliness()
            .declare_subscriber(&key)
            .history(true)
            .callback(move |sample| {
                on_sample.apply(
                    sample.key_expr().as_str(),
                    sample.kind(),
                    Source::Subscriber,
                );
            })
            .wait()?;
        let on_reply = shared.clone();
        let done = SyncOnDrop(shared.clone());
        session
            .liveliness()
            .get(&key)
            .timeout(SYNC_TIMEOUT)
            .callback(move |reply| {
                let _until_dropped = &done;
                if let Ok(sample) = reply.result() {
                    on_reply.apply(sample.key_expr().as_str(), SampleKind::Put, Source::Query);
                }
            })
            .wait()?;
        Ok(Handle {
            shared,
            _subscriber: subscriber,
        })
    }

    /// The ROS domain this cache follows.
    pub fn domain_id(&self) -> u32 {
        self.handle.shared.domain_id
    }

    /// Whether the first query has answered: every token alive when the
    /// cache was made is in it.
    pub fn is_synced(&self) -> bool {
        lock(&self.handle.shared.sync).done
    }

    /// Wait until [`is_synced`](Self::is_synced) or `timeout` passes; returns
    /// whether it is.
    pub fn wait_synced(&self, timeout: Duration) -> bool {
        let shared = &self.handle.shared;
        let sync = lock(&shared.sync);
        let (sync, _) = shared
            .synced
            .wait_timeout_while(sync, timeout, |sync| !sync.done)
            .unwrap_or_else(|e| e.into_inner());
        sync.done
    }

    /// Resolves once [`is_synced`](Self::is_synced) (at most 10 s after the
    /// cache was made).
    pub async fn synced(&self) {
        let waiter = {
            let mut sync = lock(&self.handle.shared.sync);
            if sync.done {
                return;
            }
            let (sender, receiver) = flume::bounded::<()>(1);
            sync.waiters.push(sender);
            receiver
        };
        // Nothing is ever sent: the sender is dropped when synced.
        let _ = waiter.recv_async().await;
    }

    /// The live graph, read-locked: query it and drop the guard. Zenoh's
    /// thread waits to apply changes while a guard is held, so take a
    /// [`snapshot`](Self::snapshot) to keep one.
    pub fn read(&self) -> GraphGuard<'_> {
        GraphGuard(
            self.handle
                .shared
                .graph
                .read()
                .unwrap_or_else(|e| e.into_inner()),
        )
    }

    /// A copy of the graph as it is now (entities are shared, not copied).
    pub fn snapshot(&self) -> Graph {
        self.read().clone()
    }

    /// The changes from now on, in a queue of 1024 (see
    /// [`events_with_capacity`](Self::events_with_capacity)). Take it before
    /// reading the graph, and no change falls between the two.
    pub fn events(&self) -> GraphEvents {
        self.events_with_capacity(DEFAULT_EVENT_CAPACITY)
    }

    /// [`events`](Self::events) with a queue of `capacity` events (at least
    /// 2); past it, changes are counted as missed and one
    /// [`GraphEvent::Missed`] takes their place.
    pub fn events_with_capacity(&self, capacity: usize) -> GraphEvents {
        let (_, receiver, missed) = self.handle.shared.listeners.add(capacity.max(2));
        GraphEvents::new(receiver, missed)
    }

    /// Call `callback` with every change from now on, on a thread of its own
    /// (never on Zenoh's), until the returned handle is dropped.
    pub fn on_change(
        &self,
        mut callback: impl FnMut(GraphEvent) + Send + 'static,
    ) -> std::io::Result<GraphCallback> {
        let listeners = &self.handle.shared.listeners;
        let (id, receiver, _) = listeners.add(DEFAULT_EVENT_CAPACITY);
        let spawned = std::thread::Builder::new()
            .name("graph-callback".into())
            .spawn(move || {
                while let Ok(event) = receiver.recv() {
                    callback(event);
                }
            });
        if let Err(e) = spawned {
            listeners.remove(id);
            return Err(e);
        }
        Ok(GraphCallback {
            id,
            listeners: Arc::downgrade(listeners),
        })
    }

    /// Wait until `condition` holds on the graph or `timeout` passes; returns
    /// whether it holds. It is checked now and after each change, never by
    /// polling.
    pub fn wait_until(&self, timeout: Duration, mut condition: impl FnMut(&Graph) -> bool) -> bool {
        let deadline = Instant::now() + timeout;
        // A queue of one: every change is a wake-up, none is kept.
        let (id, changes, _) = self.handle.shared.listeners.add(1);
        let _remove = RemoveOnDrop(&self.handle.shared.listeners, id);
        loop {
            if condition(&self.read()) {
                return true;
            }
            if changes.recv_deadline(deadline).is_err() {
                return condition(&self.read());
            }
        }
    }

    /// Resolves once `condition` holds on the graph (at once if it does now);
    /// checked after each change. Cancellation-safe; bound it with your
    /// runtime's timeout.
    pub async fn until(&self, mut condition: impl FnMut(&Graph) -> bool) {
        let (id, changes, _) = self.handle.shared.listeners.add(1);
        let _remove = RemoveOnDrop(&self.handle.shared.listeners, id);
        loop {
            if condition(&self.read()) {
                return;
            }
            if changes.recv_async().await.is_err() {
                return;
            }
        }
    }
}

struct RemoveOnDrop<'a>(&'a Listeners, u64);

impl Drop for RemoveOnDrop<'_> {
    fn drop(&mut self) {
        self.0.remove(self.1);
    }
}

/// The live [`Graph`] of a [`GraphCache`], read-locked until dropped.
pub struct GraphGuard<'a>(RwLockReadGuard<'a, Graph>);

impl Deref for GraphGuard<'_> {
    type Target = Graph;
    fn deref(&self) -> &Graph {
        &self.0
    }
}

impl fmt::Debug for GraphGuard<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("GraphGuard")
            .field("entities", &self.0.len())
            .finish()
    }
}
