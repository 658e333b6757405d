//! Typed subscribers: received samples decoded without a copy when the payload is
//! one slice (shared memory or not) or a spliced set of fragments, with one copy
//! otherwise.

use std::fmt;
use std::future::IntoFuture;
use std::marker::PhantomData;
use std::num::NonZeroUsize;
use std::pin::Pin;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::task::{Context, Poll};
use std::time::Duration;

use shm_cdr::DecodeError;
use zenoh::liveliness::LivelinessToken;
use zenoh::sample::Sample;
use zenoh::{Resolvable, Session, Wait};
use zenoh_ext::{AdvancedSubscriber, AdvancedSubscriberBuilderExt, HistoryConfig, RecoveryConfig};

use crate::rmw::{
    counterpart_tokens_key_expr, Durability, EntityKind, History as RmwHistory, Qos, Reliability,
    TopicEndpoint, TopicType,
};
use crate::transport::executor::{Callback, Dispatch, Executor};
use crate::transport::limits::{check_key_expr, NO_TIMEOUT};
use crate::transport::queue::{Queue, DEFAULT_MAX_QUEUED_BYTES};
use crate::transport::reach::ReceiverMark;
use crate::transport::sample::RosSample;
use crate::transport::type_check::TypeCheck;
use crate::transport::type_registration::{owned_sources, Registered};

pub use crate::transport::queue::History;

/// The depth rmw_zenoh_cpp gives a keep-last QoS of depth 0.
const RMW_ZENOH_DEFAULT_DEPTH: NonZeroUsize = match NonZeroUsize::new(42) {
    Some(depth) => depth,
    None => panic!("42 is not zero"),
};

/// Builder of a [`RosSubscriber`]; resolve with `.wait()` or `.await`.
#[must_use = "resolve the builder with .wait() or .await"]
pub struct SubscriberBuilder<'a, T> {
    pub(crate) session: &'a Session,
    pub(crate) key_expr: String,
    /// A node subscriber's identity but its QoS, for its rmw_zenoh
    /// liveliness token (`MS`) and its own key, which buffer-aware
    /// publishers may send its messages to instead (see
    /// [`crate::rmw::buffer_key_expr`]).
    pub(crate) node: Option<TopicEndpoint>,
    /// The message type in the node's type-description cache, for node
    /// subscribers.
    pub(crate) type_use: Option<Registered>,
    /// As given to [`history`](Self::history); else what a node subscriber's
    /// QoS announces, and every sample for a plain subscriber.
    pub(crate) history: Option<History>,
    pub(crate) max_queued_bytes: usize,
    pub(crate) qos: Qos,
    /// Ask publishers declared with recovery for what never arrived.
    pub(crate) recovery: bool,
    /// An error found before the builder was made (a node subscriber's name
    /// that failed to resolve): reported by `build`.
    pub(crate) invalid: Option<zenoh::Error>,
    pub(crate) topic_type: TopicType,
    pub(crate) message: PhantomData<fn() -> T>,
}

impl<'a, T> SubscriberBuilder<'a, T> {
    pub(crate) fn new(session: &'a Session, key_expr: String, topic_type: TopicType) -> Self {
        Self {
            session,
            key_expr,
            topic_type,
            node: None,
            type_use: None,
            history: None,
            max_queued_bytes: DEFAULT_MAX_QUEUED_BYTES,
            qos: Qos::default(),
            recovery: false,
            invalid: None,
            message: PhantomData,
        }
    }

    /// How many unread samples to keep: by default what a node subscriber's QoS
    /// announces (keep last 10 for ROS 2's default profile), every sample
    /// ([`History::KeepAll`]) for a subscriber on a plain key expression.
    pub fn history(mut self, history: History) -> Self {
        self.history = Some(history);
        self
    }

    /// The history the queue keeps: as given, else as a node subscriber's QoS
    /// announces (as rmw_zenoh_cpp's queue does: a reader that stops reading
    /// holds `depth` samples and their shared-memory chunks, not everything
    /// published meanwhile), else every sample.
    fn queue_history(&self) -> History {
        match (self.history, &self.node, self.qos.history) {
            (Some(history), _, _) => history,
            (None, Some(_), RmwHistory::KeepLast(depth)) => {
                History::KeepLast(NonZeroUsize::new(depth).unwrap_or(RMW_ZENOH_DEFAULT_DEPTH))
            }
            (None, _, _) => History::KeepAll,
        }
    }

    /// A node subscriber's liveliness token, saying the QoS the builder holds.
    fn token(&self) -> Option<String> {
        let node = self.node.as_ref()?;
        Some(node.token(&self.topic_type, &self.qos))
    }

    /// The memory budget of a [`History::KeepAll`] subscriber: the bytes of
    /// samples it may hold, queued or not yet dropped by the application
    /// (default 256 MiB). Past it, arriving samples are dropped and counted in
    /// [`RosSubscriber::lost`] until the application releases some.
    pub fn max_queued_bytes(mut self, bytes: usize) -> Self {
        self.max_queued_bytes = bytes;
        self
    }

    /// The QoS this subscriber's Zenoh declaration follows, as rmw_zenoh_cpp
    /// maps it: transient local is a zenoh-ext `AdvancedSubscriber` that asks
    /// every transient-local publisher, including ones that appear later, for
    /// its last `depth` messages before the live ones (and, when reliable,
    /// recovers messages it missed, told by the publisher's heartbeats).
    /// Volatile (the default) receives only what is published after it is
    /// declared. A node subscriber's liveliness token carries the QoS given
    /// last, here or to
    /// [`RosNode::declare_subscriber_with_qos`](crate::RosNode::declare_subscriber_with_qos),
    /// and its queue keeps the QoS's history unless given one with
    /// [`history`](Self::history).
    pub fn qos(mut self, qos: Qos) -> Self {
        self.qos = qos;
        self
    }

    /// Get back, in order, the messages that never arrived from publishers
    /// declared with [`PublisherBuilder::recovery`](crate::PublisherBuilder::recovery):
    /// a gap in a publisher's sequence numbers, or its heartbeat (every
    /// 500 ms) naming a message this subscriber has not seen, makes it ask that
    /// publisher's cache for the missing ones, and the messages after a gap
    /// wait until they are back. What the cache no longer holds (or, on a
    /// volatile topic, what does not come back within 10 s) is given up and
    /// counted in [`RosSubscriber::missed`]. Samples of other publishers (without
    /// recovery, rmw_zenoh_cpp's, plain Zenoh) are taken as they come.
    ///
    /// This is a zenoh-ext `AdvancedSubscriber` with heartbeat recovery, as
    /// transient-local reliable subscribers already are.
    pub fn recovery(mut self) -> Self {
        self.recovery = true;
        self
    }

    /// Declare the Zenoh subscriber `qos` and `recovery` ask for, calling
    /// `callback`.
    fn declare(
        &self,
        callback: impl Fn(Sample) + Send + Sync + 'static,
    ) -> zenoh::Result<ZenohSubscriber> {
        let qos = self.qos;
        let callback = std::sync::Arc::new(callback);
        let buffer_key = match (&self.node, self.token()) {
            (Some(node), Some(token)) => crate::rmw::buffer_key_expr(
                node.info.distro,
                &self.key_expr,
                &token,
                self.topic_type.has_buffer_fields,
            ),
            _ => None,
        };
        let buffer = match buffer_key {
            Some(key) => {
                check_key_expr("key expression", &key)?;
                let callback = callback.clone();
                Some(
                    self.session
                        .declare_subscriber(key.clone())
                        .callback(move |sample| callback(sample))
                        .wait()?,
                )
            }
            None => None,
        };
        let builder = self
            .session
            .declare_subscriber(self.key_expr.clone())
            .callback(move |sample| callback(sample));
        let transient_local = qos.durability == Durability::TransientLocal;
        let recovery =
            self.recovery || (transient_local && qos.reliability == Reliability::Reliable);
        if !transient_local && !recovery {
            return Ok(ZenohSubscriber {
                main: MainSubscriber::Plain(builder.wait()?),
                _buffer: buffer,
            });
        }
        let builder = builder.advanced();
        let builder = if transient_local {
            let depth = match qos.history {
                RmwHistory::KeepLast(depth) => depth.max(1),
                RmwHistory::KeepAll => usize::MAX,
            };
            builder
                .history(
                    HistoryConfig::default()
                        .detect_late_publishers()
                        .max_samples(depth),
                )
                .subscriber_detection()
                .query_timeout(NO_TIMEOUT)
        } else {
            builder.query_timeout(RECOVERY_QUERY_TIMEOUT)
        };
        let builder = if recovery {
            builder.recovery(RecoveryConfig::default().heartbeat())
        } else {
            builder
        };
        Ok(ZenohSubscriber {
            main: MainSubscriber::Advanced(builder.wait()?),
            _buffer: buffer,
        })
    }

    /// The announcements a subscriber keeps while it lives, declared before
    /// its Zenoh subscriber so that publishers learn of them first: the
    /// rmw_zenoh liveliness token of a node subscriber, and the session's
    /// receiver mark (see [`ReceiverMark`]).
    fn declare_token(&mut self) -> zenoh::Result<Announced> {
        if let Some(invalid) = self.invalid.take() {
            return Err(invalid);
        }
        check_key_expr("key expression", &self.key_expr)?;
        let token = self.token();
        if let Some(token) = &token {
            check_key_expr("liveliness token", token)?;
        }
        let receiver = ReceiverMark::announce(self.session, &self.key_expr)?;
        let rmw = match token {
            Some(token) => Some(self.session.liveliness().declare_token(token).wait()?),
            None => None,
        };
        Ok(Announced {
            _rmw: rmw,
            _receiver: receiver,
            _type_use: self.type_use.clone(),
        })
    }

    /// Call `callback` with every sample, in arrival order, on a thread of an
    /// [`Executor`] ([`Executor::global`] unless
    /// [`CallbackSubscriberBuilder::executor`] names another), instead of
    /// queueing samples for [`RosSubscriber::recv`]. Samples wait in the
    /// subscriber's own queue under its [`History`] while the callback runs,
    /// so a slow callback costs its own queue (counted in
    /// [`CallbackSubscriber::lost`]), never Zenoh's thread, the publishers or
    /// other subscribers. Decode inside the callback to borrow from the sample.
    pub fn callback<F>(self, callback: F) -> CallbackSubscriberBuilder<'a, T>
    where
        F: FnMut(RosSample) + Send + 'static,
    {
        CallbackSubscriberBuilder {
            inner: self,
            callback: Callback::Dispatched(Box::new(callback), None),
        }
    }

    /// Call `callback` on Zenoh's receive thread, as each sample arrives: the
    /// lowest latency, for code that never blocks and returns within
    /// microseconds. While it runs, that thread receives nothing else for the
    /// session (a callback that blocks for seconds stalls the publishers and
    /// makes Zenoh close the connection). Prefer [`callback`](Self::callback).
    pub fn callback_inline<F>(self, callback: F) -> CallbackSubscriberBuilder<'a, T>
    where
        F: Fn(RosSample) + Send + Sync + 'static,
    {
        CallbackSubscriberBuilder {
            inner: self,
            callback: Callback::Inline(Box::new(callback)),
        }
    }

    fn build(mut self) -> zenoh::Result<RosSubscriber<T>> {
        let token = self.declare_token()?;
        let (queue, receiver) = Queue::new(
            self.queue_history(),
            self.max_queued_bytes,
            &self.key_expr,
            TypeCheck::new(&self.key_expr, &self.topic_type),
        );
        let lost = queue.lost.clone();
        let missed = queue.gaps.missed.clone();
        let wrong_type = queue.type_check.rejected.clone();
        let subscriber = self.declare(move |sample| {
            queue.push(sample);
        })?;
        let publishers = self.token().and_then(|token| {
            let key = counterpart_tokens_key_expr(&token, EntityKind::Publisher)?;
            Some((self.session.clone(), key))
        });
        Ok(RosSubscriber {
            subscriber,
            publishers,
            receiver,
            lost,
            missed,
            wrong_type,
            _token: token,
            message: PhantomData,
        })
    }
}

impl SubscriberBuilder<'_, shm_cdr::dynamic::DynamicType> {
    /// The interface files' own text of the subscriber's type and the types
    /// it uses, as `(pkg/msg/Name, text)`, for the node's
    /// `~/get_type_description` (see
    /// [`PublisherBuilder::type_sources`](crate::PublisherBuilder::type_sources)).
    pub fn type_sources<N: Into<String>, S: Into<String>>(
        self,
        sources: impl IntoIterator<Item = (N, S)>,
    ) -> Self {
        if let Some(type_use) = &self.type_use {
            type_use.offer_sources(&owned_sources(sources));
        }
        self
    }
}

impl<T> Resolvable for SubscriberBuilder<'_, T> {
    type To = zenoh::Result<RosSubscriber<T>>;
}

impl<T> Wait for SubscriberBuilder<'_, T> {
    fn wait(self) -> Self::To {
        self.build()
    }
}

impl<T> IntoFuture for SubscriberBuilder<'_, T> {
    type Output = zenoh::Result<RosSubscriber<T>>;
    type IntoFuture = std::future::Ready<Self::Output>;
    fn into_future(self) -> Self::IntoFuture {
        std::future::ready(self.build())
    }
}

/// What a subscriber announces while it lives.
struct Announced {
    _rmw: Option<LivelinessToken>,
    _receiver: ReceiverMark,
    _type_use: Option<Registered>,
}

/// How long a recovering subscriber waits for a publisher's cache to answer
/// before it gives the missing messages up (zenoh-ext's default, stated here
/// because [`SubscriberBuilder::recovery`] documents it).
const RECOVERY_QUERY_TIMEOUT: Duration = Duration::from_secs(10);

/// A plain Zenoh subscriber, or zenoh-ext's advanced one (transient local,
/// recovery), with the plain subscriber on the subscriber's own key for
/// buffer-aware publishers, where it has one.
struct ZenohSubscriber {
    main: MainSubscriber,
    _buffer: Option<zenoh::pubsub::Subscriber<()>>,
}

enum MainSubscriber {
    Plain(zenoh::pubsub::Subscriber<()>),
    Advanced(AdvancedSubscriber<()>),
}

impl ZenohSubscriber {
    fn key_expr(&self) -> &str {
        match &self.main {
            MainSubscriber::Plain(s) => s.key_expr().as_str(),
            MainSubscriber::Advanced(s) => s.key_expr().as_str(),
        }
    }
}

/// Builder of a callback subscriber; resolve with `.wait()` or `.await`.
#[must_use = "resolve the builder with .wait() or .await"]
pub struct CallbackSubscriberBuilder<'a, T> {
    inner: SubscriberBuilder<'a, T>,
    callback: Callback<RosSample>,
}

impl<T> CallbackSubscriberBuilder<'_, T> {
    /// Run the callback on `executor`'s threads instead of the global ones
    /// (no effect on an inline callback).
    pub fn executor(mut self, executor: &Executor) -> Self {
        self.callback.set_executor(executor);
        self
    }

    fn build(mut self) -> zenoh::Result<CallbackSubscriber<T>> {
        let token = self.inner.declare_token()?;
        let key_expr = self.inner.key_expr.clone();
        let (queue, receiver) = Queue::new(
            self.inner.queue_history(),
            self.inner.max_queued_bytes,
            &key_expr,
            TypeCheck::new(&key_expr, &self.inner.topic_type),
        );
        let counters = Counters {
            lost: queue.lost.clone(),
            missed: queue.gaps.missed.clone(),
            wrong_type: queue.type_check.rejected.clone(),
        };
        let (subscriber, dispatch) = match self.callback {
            Callback::Dispatched(callback, executor) => {
                let executor = match executor {
                    Some(executor) => executor,
                    None => Executor::global()?.clone(),
                };
                let dispatch = Dispatch::new(receiver, callback, executor, key_expr);
                let notify = dispatch.clone();
                let subscriber = self.inner.declare(move |sample| {
                    if queue.push(sample) {
                        notify.notify();
                    }
                })?;
                (subscriber, Some(dispatch))
            }
            Callback::Inline(callback) => {
                let (type_check, gaps) = (queue.type_check, queue.gaps);
                let subscriber = self.inner.declare(move |sample| {
                    if type_check.accepts(&sample) {
                        gaps.check(&sample);
                        callback(RosSample::new(sample))
                    }
                })?;
                (subscriber, None)
            }
        };
        Ok(CallbackSubscriber {
            subscriber,
            dispatch,
            counters,
            _token: token,
            message: PhantomData,
        })
    }
}

/// A subscriber that hands every sample to a callback (see
/// [`SubscriberBuilder::callback`]); undeclared when dropped, after which its
/// callback is not called again.
pub struct CallbackSubscriber<T> {
    subscriber: ZenohSubscriber,
    dispatch: Option<Arc<Dispatch<RosSample>>>,
    counters: Counters,
    _token: Announced,
    message: PhantomData<fn() -> T>,
}

struct Counters {
    lost: Arc<AtomicU64>,
    missed: Arc<AtomicU64>,
    wrong_type: Arc<AtomicU64>,
}

impl<T> fmt::Debug for CallbackSubscriber<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("CallbackSubscriber")
            .field("key_expr", &self.subscriber.key_expr())
            .field("queued", &self.queued())
            .finish()
    }
}

impl<T> CallbackSubscriber<T> {
    /// Samples dropped because the callback did not keep up: its queue's
    /// [`History`] depth, or the memory budget of a `KeepAll` queue, was
    /// exceeded (see [`RosSubscriber::lost`]). Always 0 inline.
    pub fn lost(&self) -> u64 {
        self.counters.lost.load(Ordering::Relaxed)
    }

    /// Messages that never arrived (see [`RosSubscriber::missed`]), counted
    /// for inline and dispatched callbacks alike.
    pub fn missed(&self) -> u64 {
        self.counters.missed.load(Ordering::Relaxed)
    }

    /// Samples of another message type, dropped (see
    /// [`RosSubscriber::wrong_type`]).
    pub fn wrong_type(&self) -> u64 {
        self.counters.wrong_type.load(Ordering::Relaxed)
    }

    /// Samples waiting for the callback.
    pub fn queued(&self) -> usize {
        self.dispatch.as_ref().map_or(0, |d| d.queued())
    }

    /// The key expression subscribed to.
    pub fn key_expr(&self) -> &str {
        self.subscriber.key_expr()
    }
}

impl<T> Drop for CallbackSubscriber<T> {
    fn drop(&mut self) {
        if let Some(dispatch) = &self.dispatch {
            dispatch.close();
        }
    }
}

impl<T> Resolvable for CallbackSubscriberBuilder<'_, T> {
    type To = zenoh::Result<CallbackSubscriber<T>>;
}

impl<T> Wait for CallbackSubscriberBuilder<'_, T> {
    fn wait(self) -> Self::To {
        self.build()
    }
}

impl<T> IntoFuture for CallbackSubscriberBuilder<'_, T> {
    type Output = zenoh::Result<CallbackSubscriber<T>>;
    type IntoFuture = std::future::Ready<Self::Output>;
    fn into_future(self) -> Self::IntoFuture {
        std::future::ready(self.build())
    }
}

/// Receives messages published as `T` (decode them as `T` or as a borrowing
/// variant of the same ROS type). Samples wait in the subscriber's own queue
/// (see [`History`]) until read; undeclared when dropped.
///
/// # Example
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
/// use shm_cdr::msgs::sensor_msgs::Image;
/// use shm_runtime::RosNode;
/// use zenoh::Wait;
///
/// let session = zenoh::open(shm_runtime::rmw::config::session_config()?).wait()?;
/// let node = RosNode::builder(&session, "viewer").wait()?;
/// let subscriber = node.declare_subscriber::<Image>("image").wait()?;
/// loop {
///     let sample = subscriber.recv()?;
///     let image: Image = sample.decode()?;
///     println!("{}x{}, in shared memory: {}", image.width, image.height, sample.is_shm());
///     if subscriber.missed() > 0 {
///         eprintln!("{} messages never arrived", subscriber.missed());
///     }
/// }
/// # }
/// ```
pub struct RosSubscriber<T> {
    subscriber: ZenohSubscriber,
    /// For node subscribers: the session and the key expression of the
    /// tokens of the publishers this subscriber matches.
    publishers: Option<(Session, String)>,
    receiver: flume::Receiver<RosSample>,
    lost: Arc<AtomicU64>,
    missed: Arc<AtomicU64>,
    wrong_type: Arc<AtomicU64>,
    _token: Announced,
    message: PhantomData<fn() -> T>,
}

impl<T> fmt::Debug for RosSubscriber<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("RosSubscriber")
            .field("key_expr", &self.subscriber.key_expr())
            .finish()
    }
}

impl<T> RosSubscriber<T> {
    /// Wait for the next sample.
    pub fn recv(&self) -> zenoh::Result<RosSample> {
        Ok(self.receiver.recv()?)
    }

    /// Wait for the next sample, asynchronously. Cancellation-safe: dropping the
    /// future before it completes loses no sample.
    pub async fn recv_async(&self) -> zenoh::Result<RosSample> {
        Ok(self.receiver.recv_async().await?)
    }

    /// Wait at most `timeout` for the next sample.
    pub fn recv_timeout(&self, timeout: Duration) -> zenoh::Result<Option<RosSample>> {
        match self.receiver.recv_timeout(timeout) {
            Ok(sample) => Ok(Some(sample)),
            Err(flume::RecvTimeoutError::Timeout) => Ok(None),
            Err(e) => Err(e.into()),
        }
    }

    /// The next sample if one is queued.
    pub fn try_recv(&self) -> zenoh::Result<Option<RosSample>> {
        match self.receiver.try_recv() {
            Ok(sample) => Ok(Some(sample)),
            Err(flume::TryRecvError::Empty) => Ok(None),
            Err(e) => Err(e.into()),
        }
    }

    /// The samples as a [`Stream`](futures_core::Stream), in arrival order; it
    /// ends when the subscriber is undeclared. Decode each item with
    /// [`RosSample::decode`] as `T` or as a form borrowing from the item.
    /// Cancellation-safe like [`recv_async`](Self::recv_async).
    pub fn stream(&self) -> SampleStream<'_> {
        SampleStream {
            inner: self.receiver.stream(),
        }
    }

    /// The messages, decoded as owned `T`, as a [`Stream`](futures_core::Stream);
    /// a sample that is not a valid `T` is an `Err` item, and the stream goes on.
    pub fn messages(&self) -> MessageStream<'_, T>
    where
        T: shm_cdr::DecodeOwned,
    {
        MessageStream {
            samples: self.stream(),
            message: PhantomData,
        }
    }

    /// How many samples were dropped because the application did not read them
    /// before [`History::KeepLast`]'s depth was exceeded (always 0 with
    /// [`History::KeepAll`]).
    pub fn lost(&self) -> u64 {
        self.lost.load(Ordering::Relaxed)
    }

    /// How many messages never arrived: the gaps in each publisher's sequence
    /// numbers (the rmw_zenoh attachment of a node's or rmw_zenoh_cpp's
    /// publishers, or the Zenoh `SourceInfo` of publishers on a plain key). Zenoh loses messages when it
    /// closes a transport that stayed congested past its `wait_before_close`
    /// (e.g. this process was stopped); a loss at the very end of a stream shows
    /// only once that publisher sends again. Each publisher is followed from
    /// the first of its messages this subscriber receives: what it sent before
    /// (to a subscriber that had not yet joined, or lost before that first
    /// message) is not counted.
    pub fn missed(&self) -> u64 {
        self.missed.load(Ordering::Relaxed)
    }

    /// How many samples were dropped because their encoding names another
    /// message type (name or RIHS01 hash) than `T`: e.g. a `Duration` publisher
    /// on a key where this subscriber expects `Time`. The first one is logged
    /// with both types.
    pub fn wrong_type(&self) -> u64 {
        self.wrong_type.load(Ordering::Relaxed)
    }

    /// How many samples wait to be read.
    pub fn queued(&self) -> usize {
        self.receiver.len()
    }

    /// Wait for the next sample and decode it as an owned `T`.
    pub fn recv_message(&self) -> Result<T, RecvError>
    where
        T: shm_cdr::DecodeOwned,
    {
        let sample = self.recv().map_err(RecvError::Zenoh)?;
        sample.decode().map_err(RecvError::Decode)
    }

    /// The key expression subscribed to.
    pub fn key_expr(&self) -> &str {
        self.subscriber.key_expr()
    }

    /// Wait until at least one publisher of this topic and type is on the ROS
    /// graph (its `MP` liveliness token: ours, rmw_zenoh_cpp's), or `timeout`
    /// passes; returns whether one is. It wakes when the publisher appears.
    /// Only node subscribers have a ROS topic: one on a raw key returns
    /// `false`.
    pub fn wait_for_publishers(&self, timeout: Duration) -> bool {
        let Some(publishers) = self.publisher_tokens() else {
            return false;
        };
        let deadline = std::time::Instant::now() + timeout;
        let mut alive = std::collections::HashSet::new();
        loop {
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            match publishers.recv_timeout(left) {
                Ok(sample) => {
                    if track(&mut alive, &sample) {
                        return true;
                    }
                }
                Err(_) => return false,
            }
        }
    }

    /// Resolves once at least one publisher of this topic and type is on the
    /// ROS graph (at once if one is). Cancellation-safe; bound it with your
    /// runtime's timeout. A subscriber on a raw key has no ROS topic: an error.
    pub async fn publishers_matched(&self) -> zenoh::Result<()> {
        let publishers = self
            .publisher_tokens()
            .ok_or("a subscriber on a raw key expression has no ROS topic to match")?;
        let mut alive = std::collections::HashSet::new();
        loop {
            if track(&mut alive, &publishers.recv_async().await?) {
                return Ok(());
            }
        }
    }

    /// A liveliness subscriber to the publishers' tokens, with the ones alive
    /// now delivered first (history). Its channel is unbounded: Zenoh replays
    /// the history on this thread before `wait` returns, and a bounded one
    /// (the default holds 256) would never return with more publishers.
    fn publisher_tokens(&self) -> Option<zenoh::pubsub::Subscriber<flume::Receiver<Sample>>> {
        let (session, key) = self.publishers.as_ref()?;
        session
            .liveliness()
            .declare_subscriber(key.as_str())
            .history(true)
            .with(flume::unbounded())
            .wait()
            .ok()
    }
}

/// Follow one liveliness change in `alive`; whether any token is alive.
fn track(alive: &mut std::collections::HashSet<String>, sample: &Sample) -> bool {
    let key = sample.key_expr().as_str().to_owned();
    match sample.kind() {
        zenoh::sample::SampleKind::Put => alive.insert(key),
        zenoh::sample::SampleKind::Delete => alive.remove(&key),
    };
    !alive.is_empty()
}

/// The samples of a [`RosSubscriber`], from [`RosSubscriber::stream`].
#[must_use = "streams do nothing unless polled"]
pub struct SampleStream<'a> {
    inner: flume::r#async::RecvStream<'a, RosSample>,
}

impl fmt::Debug for SampleStream<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SampleStream").finish_non_exhaustive()
    }
}

impl futures_core::Stream for SampleStream<'_> {
    type Item = RosSample;

    fn poll_next(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<RosSample>> {
        Pin::new(&mut self.inner).poll_next(cx)
    }
}

/// The decoded messages of a [`RosSubscriber`], from [`RosSubscriber::messages`].
#[must_use = "streams do nothing unless polled"]
pub struct MessageStream<'a, T> {
    samples: SampleStream<'a>,
    message: PhantomData<fn() -> T>,
}

impl<T> fmt::Debug for MessageStream<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("MessageStream").finish_non_exhaustive()
    }
}

impl<T: shm_cdr::DecodeOwned> futures_core::Stream for MessageStream<'_, T> {
    type Item = Result<T, DecodeError>;

    fn poll_next(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Self::Item>> {
        Pin::new(&mut self.samples)
            .poll_next(cx)
            .map(|sample| sample.map(|s| s.decode::<T>()))
    }
}

/// Receiving a message failed.
#[derive(Debug)]
#[non_exhaustive]
pub enum RecvError {
    /// The subscriber is closed.
    Zenoh(zenoh::Error),
    /// A sample arrived but is not a valid message.
    Decode(DecodeError),
}

impl fmt::Display for RecvError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Zenoh(e) => write!(f, "receive: zenoh: {e}"),
            Self::Decode(e) => write!(f, "receive: {e}"),
        }
    }
}

impl std::error::Error for RecvError {}
