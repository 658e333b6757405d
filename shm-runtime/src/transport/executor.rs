//! [`Executor`]: the threads that run subscribers' and servers' callbacks,
//! so that no user code runs on Zenoh's receive thread.
//!
//! Each callback entity has its own bounded queue (its QoS history). When an
//! item arrives, Zenoh's thread queues it and, if the entity is not already
//! waiting for a thread, puts the entity on the executor's ready list; that is
//! all it does. A worker takes the entity, runs its callback on what is queued
//! (a few items at a time, then it yields to the others) and puts it back if
//! more came meanwhile. One entity's callback never runs on two threads at
//! once, so its items are handled in order and the callback may be `FnMut`;
//! different entities run in parallel, one per thread.

use std::fmt;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

/// How many items a worker hands to one callback before it lets the next
/// ready entity have the thread.
const BATCH: usize = 16;

/// Something with queued work: a subscriber's or a server's dispatch.
pub(crate) trait Ready: Send + Sync {
    /// Run the callback on up to `limit` queued items, and schedule itself
    /// again if more are queued.
    fn run(self: Arc<Self>, limit: usize);
}

/// A pool of threads that run callbacks (see the module documentation).
///
/// Callbacks declared without an executor run on the process's
/// [`Executor::global`] one. Make your own to give a group of callbacks threads
/// of their own, e.g. one thread for callbacks that must never run in
/// parallel (rclcpp's single-threaded executor), more for independent ones.
///
/// ```no_run
/// use shm_runtime::{Executor, SessionExt};
/// use zenoh::Wait;
/// # #[derive(shm_cdr::RosMessage)] #[ros(type_name = "my_pkg/msg/Tick")] struct Tick { n: u32 }
///
/// let session = zenoh::open(zenoh::Config::default()).wait()?;
/// let executor = Executor::new(1)?; // these callbacks take turns
/// let _ticks = session
///     .declare_ros_subscriber::<Tick>("ticks")
///     .callback(|sample| println!("{} bytes", sample.payload().len()))
///     .executor(&executor)
///     .wait()?;
/// # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
/// ```
#[derive(Clone)]
pub struct Executor {
    inner: Arc<Inner>,
}

struct Inner {
    ready: flume::Sender<Arc<dyn Ready>>,
    threads: usize,
}

impl fmt::Debug for Executor {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Executor")
            .field("threads", &self.inner.threads)
            .field("ready", &self.inner.ready.len())
            .finish()
    }
}

impl Executor {
    /// An executor with `threads` threads (at least one). They end once the
    /// executor and every entity using it are dropped.
    pub fn new(threads: usize) -> std::io::Result<Self> {
        let threads = threads.max(1);
        let (ready, queue) = flume::unbounded::<Arc<dyn Ready>>();
        for i in 0..threads {
            let queue = queue.clone();
            std::thread::Builder::new()
                .name(format!("shm-callbacks-{i}"))
                .spawn(move || work(queue))?;
        }
        Ok(Self {
            inner: Arc::new(Inner { ready, threads }),
        })
    }

    /// The process's executor, made on first use, with as many threads as
    /// the machine has CPUs (at least two, at most eight). An error if its
    /// threads could not be started (then, and on every later call).
    pub fn global() -> std::io::Result<&'static Executor> {
        static GLOBAL: OnceLock<Result<Executor, String>> = OnceLock::new();
        let made = GLOBAL.get_or_init(|| {
            let cpus = std::thread::available_parallelism().map_or(2, |n| n.get());
            Executor::new(cpus.clamp(2, 8)).map_err(|e| e.to_string())
        });
        made.as_ref().map_err(|e| {
            std::io::Error::other(format!("shm-runtime: cannot start callback threads: {e}"))
        })
    }

    /// How many threads run callbacks.
    pub fn threads(&self) -> usize {
        self.inner.threads
    }

    fn schedule(&self, entity: Arc<dyn Ready>) {
        // Unbounded, but holds each entity at most once (see `Dispatch`).
        let _ = self.inner.ready.send(entity);
    }
}

fn work(queue: flume::Receiver<Arc<dyn Ready>>) {
    while let Ok(entity) = queue.recv() {
        entity.run(BATCH);
    }
}

/// One entity's queue and callback, driven by an [`Executor`].
pub(crate) struct Dispatch<I> {
    receiver: flume::Receiver<I>,
    callback: Mutex<Box<dyn FnMut(I) + Send>>,
    /// On the ready list or running: then a new item needs no scheduling.
    scheduled: AtomicBool,
    /// The entity was dropped: what is still queued is discarded.
    closed: AtomicBool,
    executor: Executor,
    what: String,
}

impl<I> Dispatch<I> {
    /// Items waiting for the callback.
    pub(crate) fn queued(&self) -> usize {
        self.receiver.len()
    }

    /// The entity is gone: its callback is not called again (one running
    /// now finishes).
    pub(crate) fn close(&self) {
        self.closed.store(true, Ordering::SeqCst);
        self.receiver.drain().for_each(drop);
    }
}

impl<I: Send + 'static> Dispatch<I> {
    pub(crate) fn new(
        receiver: flume::Receiver<I>,
        callback: impl FnMut(I) + Send + 'static,
        executor: Executor,
        what: String,
    ) -> Arc<Self> {
        Arc::new(Self {
            receiver,
            callback: Mutex::new(Box::new(callback)),
            scheduled: AtomicBool::new(false),
            closed: AtomicBool::new(false),
            executor,
            what,
        })
    }

    /// Called (on Zenoh's thread) after an item was queued: never blocks.
    pub(crate) fn notify(self: &Arc<Self>) {
        if !self.scheduled.swap(true, Ordering::SeqCst) {
            self.executor.schedule(self.clone());
        }
    }
}

impl<I: Send + 'static> Ready for Dispatch<I> {
    fn run(self: Arc<Self>, limit: usize) {
        {
            let mut callback = self.callback.lock().unwrap_or_else(|e| e.into_inner());
            for _ in 0..limit {
                if self.closed.load(Ordering::SeqCst) {
                    self.receiver.drain().for_each(drop);
                    break;
                }
                let Ok(item) = self.receiver.try_recv() else {
                    break;
                };
                // A panicking callback loses its item, not the thread.
                if catch_unwind(AssertUnwindSafe(|| callback(item))).is_err() {
                    tracing::error!(entity = %self.what, "a callback panicked; the next item goes on");
                }
            }
        }
        self.scheduled.store(false, Ordering::SeqCst);
        // An item queued after the last `try_recv` but before the store saw
        // `scheduled` still set and did not schedule: look again.
        if !self.receiver.is_empty() && !self.scheduled.swap(true, Ordering::SeqCst) {
            let executor = self.executor.clone();
            executor.schedule(self);
        }
    }
}

/// A callback as a builder keeps it: dispatched on an executor (the
/// default) or inline on Zenoh's thread (the explicit opt-in).
pub(crate) enum Callback<I> {
    Dispatched(Box<dyn FnMut(I) + Send>, Option<Executor>),
    Inline(Box<dyn Fn(I) + Send + Sync>),
}

impl<I> Callback<I> {
    /// Run a dispatched callback on `executor` (no effect inline).
    pub(crate) fn set_executor(&mut self, executor: &Executor) {
        if let Self::Dispatched(_, chosen) = self {
            *chosen = Some(executor.clone());
        }
    }
}
