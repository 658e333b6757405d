//! Typed publishers: exact-size encoding into shared memory or the heap, put
//! through the caller's own `zenoh::Session`.

use std::fmt;
use std::future::{Future, IntoFuture};
use std::marker::PhantomData;
use std::pin::Pin;
use std::sync::atomic::{AtomicI64, AtomicU32, Ordering};
use std::sync::Arc;

use shm_cdr::dynamic::{DynamicType, Message};
use shm_cdr::{EncodeError, RosMessage};
use zenoh::bytes::{Encoding, ZBytes};
use zenoh::liveliness::LivelinessToken;
use zenoh::qos::{CongestionControl, Reliability as ZenohReliability};
use zenoh::sample::SourceInfo;
use zenoh::{Resolvable, Session, Wait};
use zenoh_ext::{AdvancedPublisher, AdvancedPublisherBuilderExt, CacheConfig, MissDetectionConfig};

use crate::rmw::TopicType;
use crate::rmw::{
    counterpart_tokens_key_expr, Attachment, Durability, EntityKind, Gid, History, Qos,
    Reliability, TopicEndpoint, ATTACHMENT_LEN,
};
use crate::transport::encoded::{EncodedPayload, PayloadKind};
use crate::transport::inline_limit::{self, InlineLimit, Unfragmentable};
use crate::transport::limits::check_key_expr;
use crate::transport::payload::{
    encode_payload, encode_sized, on_heap, packed, serialized_payload, splice_or_size, ShmPolicy,
};
use crate::transport::pool::ShmContext;
use crate::transport::reach::{Receivers, PROBE_TIMEOUT};
use crate::transport::reach_table::Receiver;
use crate::transport::shm_bytes::Splice;
use crate::transport::shm_options;
use crate::transport::type_registration::{owned_sources, Registered};

/// Why a publish failed. A full pool is not a failure: the message then goes on
/// the heap ([`PayloadKind::HeapFallback`]).
#[derive(Debug)]
#[non_exhaustive]
pub enum PublishError {
    /// The message could not be encoded (e.g. a bounded field over its bound).
    Encode(EncodeError),
    /// Zenoh refused the put.
    Zenoh(zenoh::Error),
    /// A loaned message still had strings or sequences to write.
    Loan(shm_cdr::loan::LoanError),
    /// The session's transport cannot fragment (Zenoh's lowlatency) and the
    /// message's inline part is larger than one frame: it was not sent.
    Unfragmentable(Unfragmentable),
    /// A run-time typed message of another type than the publisher's.
    WrongType {
        /// The publisher's type.
        expected: String,
        /// The message's.
        found: String,
    },
    /// Bytes given as a serialized message do not start with a CDR
    /// encapsulation header (`00 00` or `00 01`, then two option bytes).
    NotCdr {
        /// How many bytes were given.
        len: usize,
    },
    /// A [`LoanedPayload`](crate::LoanedPayload) lent from another pool than
    /// the publisher's: it was not sent.
    OtherPool,
}

impl fmt::Display for PublishError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Encode(e) => write!(f, "publish: {e}"),
            Self::Zenoh(e) => write!(f, "publish: zenoh: {e}"),
            Self::Loan(e) => write!(f, "publish: loan: {e}"),
            Self::Unfragmentable(e) => write!(f, "publish: {e}"),
            Self::WrongType { expected, found } => {
                write!(f, "publish: a {found} message on a publisher of {expected}")
            }
            Self::NotCdr { len } => write!(
                f,
                "publish: {len} bytes that do not start with a CDR encapsulation header \
                 (00 00 or 00 01, then two option bytes)"
            ),
            Self::OtherPool => write!(
                f,
                "publish: a buffer lent from another pool than this publisher's: loan it from \
                 the publisher that publishes it (RosPublisher::loan_buffer)"
            ),
        }
    }
}

impl std::error::Error for PublishError {}

impl From<Unfragmentable> for PublishError {
    fn from(e: Unfragmentable) -> Self {
        Self::Unfragmentable(e)
    }
}

impl From<EncodeError> for PublishError {
    fn from(e: EncodeError) -> Self {
        Self::Encode(e)
    }
}

/// What one publish did: where the bytes went, how many, and to how many
/// subscribing sessions they were copied.
///
/// # Example
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
/// use shm_cdr::msgs::sensor_msgs::Image;
/// use shm_runtime::{RosNode, ShmConfig, ShmContext};
/// use zenoh::Wait;
///
/// let session = zenoh::open(shm_runtime::rmw::config::session_config()?).wait()?;
/// let shm = ShmContext::new(ShmConfig::enabled())?;
/// let node = RosNode::builder(&session, "camera").shm(&shm).wait()?;
/// use shm_runtime::PayloadKind;
///
/// let publisher = node.declare_publisher::<Image>("image").wait()?;
/// let outcome = publisher.publish(&Image::default()).wait()?;
/// match outcome.kind {
///     PayloadKind::Shm | PayloadKind::Spliced => {} // written once, in shared memory
///     PayloadKind::Heap => {} // below the threshold: on the heap by design
///     other => eprintln!("from the heap: {other:?}"), // the variant says why
/// }
/// if outcome.copied_to > 0 {
///     eprintln!("{} subscribing sessions get copies", outcome.copied_to);
/// }
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub struct PublishOutcome {
    /// Where the bytes went.
    pub kind: PayloadKind,
    /// Encoded size in bytes, header included.
    pub size: usize,
    /// The rmw_zenoh sequence number attached, for ROS-style publishers.
    pub sequence_number: Option<i64>,
    /// How many subscribing sessions get this shared-memory message as a
    /// copy, because the link to them carries no shared memory (another
    /// host or user, or a Zenoh whose shared memory differs; see
    /// [`Reach::Bytes`](crate::Reach::Bytes)). 0 for a message sent from the
    /// heap, which every subscriber gets as a copy.
    pub copied_to: usize,
}

/// The shared-memory settings of one publisher, server or client, as its
/// builder collects them ([`ShmOptions`](crate::ShmOptions)).
#[derive(Debug, Clone, Default)]
pub struct ShmSettings {
    /// The default of where the entity is declared (its node's pool; none on a
    /// bare session).
    pub(crate) inherited: Option<ShmContext>,
    choice: ShmChoice,
    threshold: Option<usize>,
}

/// An entity's own choice, overriding the inherited default.
#[derive(Debug, Clone, Default)]
enum ShmChoice {
    #[default]
    Inherit,
    Use(ShmContext),
    Off,
}

impl ShmSettings {
    /// Use this pool.
    pub(crate) fn use_pool(&mut self, context: &ShmContext) {
        self.choice = ShmChoice::Use(context.clone());
    }

    /// Use shared memory from `bytes` encoded bytes on.
    pub(crate) fn threshold(&mut self, bytes: usize) {
        self.threshold = Some(bytes);
    }

    /// Heap only.
    pub(crate) fn off(&mut self) {
        self.choice = ShmChoice::Off;
    }

    /// How an entity on `key_expr` encodes: its choice over the inherited
    /// default, with the pool's threshold unless overridden; heap only if the
    /// session does not carry shared memory.
    pub(crate) fn resolve(&self, session: &Session, key_expr: &str) -> Option<ShmPolicy> {
        self.resolve_with(session, key_expr, None).ok().flatten()
    }

    /// [`resolve`](Self::resolve) for a publisher: its messages go through the
    /// pool only to subscribing sessions that map it (see [`Receivers`]).
    /// `ros_subscribers` is the key expression of the graph tokens of the
    /// ROS subscribers it matches, for those that answer no probe.
    pub(crate) fn resolve_for_publisher(
        &self,
        session: &Session,
        key_expr: &str,
        ros_subscribers: Option<&str>,
    ) -> zenoh::Result<Option<ShmPolicy>> {
        self.resolve_with(session, key_expr, Some(ros_subscribers))
    }

    fn resolve_with(
        &self,
        session: &Session,
        key_expr: &str,
        follow_receivers: Option<Option<&str>>,
    ) -> zenoh::Result<Option<ShmPolicy>> {
        let context = match &self.choice {
            ShmChoice::Inherit => match self.inherited.clone() {
                Some(context) => context,
                None => return Ok(None),
            },
            ShmChoice::Use(context) => context.clone(),
            ShmChoice::Off => return Ok(None),
        };
        if !session_has_shm(session) {
            // Zenoh would copy every SHM buffer out again: report what goes out.
            tracing::warn!(
                key_expr,
                "the session has transport/shared_memory/enabled=false: this entity sends from the heap"
            );
            return Ok(None);
        }
        let threshold = self.threshold.unwrap_or(context.config().threshold);
        let receivers = match follow_receivers {
            Some(ros_subscribers) if context.pool_size().is_some() => Some(Arc::new(
                Receivers::follow(session, key_expr, &context, ros_subscribers)?,
            )),
            _ => None,
        };
        Ok(Some(ShmPolicy {
            context,
            threshold,
            receivers,
        }))
    }
}

/// The current time in nanoseconds since the Unix epoch, as rmw_zenoh_cpp puts
/// it in attachments; 0 if the clock cannot be read or is before 1970.
#[inline]
pub(crate) fn now_ns() -> i64 {
    // Read straight, in 64-bit arithmetic: every message takes the time, and
    // `SystemTime`'s `duration_since` and `as_nanos` cost as much again.
    match nix::time::clock_gettime(nix::time::ClockId::CLOCK_REALTIME) {
        Ok(t) if t.tv_sec() >= 0 => t
            .tv_sec()
            .checked_mul(1_000_000_000)
            .and_then(|ns| ns.checked_add(t.tv_nsec()))
            .unwrap_or(i64::MAX),
        _ => 0,
    }
}

/// rmw_zenoh identity of a ROS-style publisher.
pub(crate) struct RmwPublisher {
    pub(crate) gid: Gid,
    pub(crate) token: String,
    pub(crate) liveliness: Option<LivelinessToken>,
    /// Keeps the message type in the node's type-description cache.
    pub(crate) _type_use: Option<Registered>,
}

/// Builder of a [`RosPublisher`]; resolve with `.wait()` or `.await`.
#[must_use = "resolve the builder with .wait() or .await"]
pub struct PublisherBuilder<'a, T> {
    pub(crate) session: &'a Session,
    pub(crate) key_expr: String,
    pub(crate) shm: ShmSettings,
    /// A node publisher's identity, but its QoS (see [`TopicEndpoint`]).
    pub(crate) node: Option<TopicEndpoint>,
    /// The message type, in the node's type-description cache while the
    /// publisher lives (not a serialized publisher's, whose fields are unknown).
    pub(crate) type_use: Option<Registered>,
    pub(crate) congestion_control: Option<CongestionControl>,
    pub(crate) qos: Qos,
    /// How many published messages to keep for subscribers that missed them.
    pub(crate) recovery: Option<usize>,
    /// An error found before the builder was made (a node publisher's name
    /// that failed to resolve): reported by `build`.
    pub(crate) invalid: Option<zenoh::Error>,
    pub(crate) topic_type: TopicType,
    /// The run-time type of a publisher of [`DynamicType`] messages.
    pub(crate) dynamic: Option<DynamicType>,
    pub(crate) message: PhantomData<fn(&T)>,
}

impl<T> shm_options::sealed::Settings for PublisherBuilder<'_, T> {
    fn shm_settings(&mut self) -> &mut ShmSettings {
        &mut self.shm
    }
}

impl<'a, T> PublisherBuilder<'a, T> {
    pub(crate) fn new(session: &'a Session, key_expr: String, topic_type: TopicType) -> Self {
        Self {
            session,
            key_expr,
            topic_type,
            dynamic: None,
            shm: ShmSettings::default(),
            node: None,
            type_use: None,
            congestion_control: None,
            qos: Qos::default(),
            recovery: None,
            invalid: None,
            message: PhantomData,
        }
    }

    /// What Zenoh does when its transmit queue is full: `Block` (the default
    /// for reliable publishers here: `publish` waits rather than drop; if the
    /// queue stays full for Zenoh's `wait_before_close`, 5 s, Zenoh closes that
    /// transport and what it held is lost, which subscribers count in
    /// [`RosSubscriber::missed`](crate::RosSubscriber::missed)) or `Drop`
    /// (Zenoh's own default, and that of best-effort publishers and of those
    /// with [`recovery`](Self::recovery), which repair drops from their cache).
    pub fn congestion_control(mut self, congestion_control: CongestionControl) -> Self {
        self.congestion_control = Some(congestion_control);
        self
    }

    /// The QoS this publisher's Zenoh declaration follows, as rmw_zenoh_cpp maps
    /// it: best effort is Zenoh best effort with congestion control `Drop`;
    /// transient local keeps the last `depth` messages in a zenoh-ext
    /// `AdvancedPublisher` cache for subscribers that join later (with
    /// publisher detection, and heartbeats every 500 ms for sample-miss
    /// recovery when reliable). A node publisher's liveliness token, and the
    /// GID made from it, carry the QoS given last, here or to
    /// [`RosNode::declare_publisher_with_qos`](crate::RosNode::declare_publisher_with_qos).
    pub fn qos(mut self, qos: Qos) -> Self {
        self.qos = qos;
        self
    }

    /// Keep the last `depth` published messages, so that subscribers declared
    /// with [`SubscriberBuilder::recovery`](crate::SubscriberBuilder::recovery)
    /// get back, in order, those that never reached them: a stalled reader, a
    /// connection Zenoh closed and re-opened. Subscribers learn of a miss from
    /// the next message's sequence number, or from the heartbeat this
    /// publisher sends every 500 ms, and ask this cache for it; only what
    /// has left the cache (more than `depth` newer messages) is lost, and
    /// counted in [`RosSubscriber::missed`](crate::RosSubscriber::missed).
    ///
    /// With recovery, a reliable publisher *drops* when Zenoh's transmit queue
    /// is full (congestion control `Drop`, unless
    /// [`congestion_control`](Self::congestion_control) says otherwise), as a
    /// DDS keep-last writer does: a dropped message is repaired from the cache
    /// once the reader reads again, whereas `Block` waiting past Zenoh's
    /// `wait_before_close` (5 s) closes the whole transport, and Zenoh
    /// can corrupt a message in that close (see the README). `publish` never
    /// waits on a stalled reader.
    ///
    /// The cost is memory: the cache holds `depth` payloads, and for shared
    /// memory their chunks, out of the pool (publishes fall back to the heap
    /// when the pool runs short); size the pool for `depth` messages more. In
    /// time, 0–4% on put → received (`recovery_cost` bench). A `depth`
    /// of 0 is refused when the builder resolves.
    pub fn recovery(mut self, depth: usize) -> Self {
        self.recovery = Some(depth);
        self
    }

    fn build(self) -> zenoh::Result<RosPublisher<T>> {
        if let Some(invalid) = self.invalid {
            return Err(invalid);
        }
        check_key_expr("key expression", &self.key_expr)?;
        // The token (and the GID made from it) says the QoS the declaration
        // below follows.
        let rmw = match &self.node {
            Some(node) => {
                let token = node.token(&self.topic_type, &self.qos);
                check_key_expr("liveliness token", &token)?;
                Some(RmwPublisher {
                    gid: Gid::from_token(&token),
                    token,
                    liveliness: None,
                    _type_use: self.type_use.clone(),
                })
            }
            None => None,
        };
        let ros_subscribers = rmw
            .as_ref()
            .and_then(|rmw| counterpart_tokens_key_expr(&rmw.token, EntityKind::Subscriber));
        let policy = self.shm.resolve_for_publisher(
            self.session,
            &self.key_expr,
            ros_subscribers.as_deref(),
        )?;
        // A node's key expression names the type (and its hash), as
        // rmw_zenoh_cpp's does, which puts no encoding on its samples either;
        // on a plain key the encoding names it for the subscriber's check.
        let encoding = match &rmw {
            Some(_) => Encoding::default(),
            None => crate::transport::type_check::type_encoding(
                &self.topic_type.name,
                &self.topic_type.hash,
            ),
        };
        let inline_limit =
            InlineLimit::of(self.session, &self.key_expr, encoding.to_string().len());
        if self.recovery == Some(0) {
            return Err(format!(
                "publisher on {}: recovery depth 0 keeps nothing; give at least 1",
                self.key_expr
            )
            .into());
        }
        let (reliability, congestion_control) = match self.qos.reliability {
            // Keep-last with a cache to repair from: drop rather than block.
            Reliability::Reliable if self.recovery.is_some() => {
                (ZenohReliability::Reliable, CongestionControl::Drop)
            }
            Reliability::Reliable => (ZenohReliability::Reliable, CongestionControl::Block),
            Reliability::BestEffort | Reliability::BestAvailable => {
                (ZenohReliability::BestEffort, CongestionControl::Drop)
            }
        };
        let builder = self
            .session
            .declare_publisher(self.key_expr)
            .reliability(reliability)
            .congestion_control(self.congestion_control.unwrap_or(congestion_control))
            .encoding(encoding);
        let transient_local = match (self.qos.durability, self.qos.history) {
            (Durability::Volatile | Durability::BestAvailable, _) => None,
            (Durability::TransientLocal, History::KeepLast(depth)) => Some(depth.max(1)),
            // rmw_zenoh_cpp passes the profile's depth, whatever the kind.
            (Durability::TransientLocal, History::KeepAll) => Some(usize::MAX),
        };
        let publisher = match transient_local.max(self.recovery) {
            None => ZenohPublisher::Plain(builder.wait()?),
            Some(depth) => {
                // Sequence numbers always (zenoh-ext would otherwise need
                // timestamping on the session for a cache). Heartbeats tell
                // subscribers what they missed. They are periodic, for
                // reliable transient local too, where rmw_zenoh_cpp sends
                // sporadic ones (one after a burst of publishes): a subscriber
                // whose declaration reaches this session just after a burst
                // misses the burst, and zenoh-ext skips a heartbeat from a
                // publisher it meets while its history query is out, so a
                // single heartbeat can leave the burst missing for good.
                // zenoh-ext also sends sporadic ones with `Block`, which on a
                // stalled connection would close the transport that recovery
                // keeps open; periodic ones go with `Drop`.
                let miss_detection =
                    if self.recovery.is_some() || self.qos.reliability == Reliability::Reliable {
                        MissDetectionConfig::default().heartbeat(HEARTBEAT_PERIOD)
                    } else {
                        MissDetectionConfig::default()
                    };
                let builder = builder
                    .cache(CacheConfig::default().max_samples(depth))
                    .sample_miss_detection(miss_detection);
                let builder = if transient_local.is_some() {
                    builder.publisher_detection()
                } else {
                    builder
                };
                ZenohPublisher::Advanced(builder.wait()?)
            }
        };
        let rmw = match rmw {
            Some(mut rmw) => {
                rmw.liveliness = Some(
                    self.session
                        .liveliness()
                        .declare_token(rmw.token.clone())
                        .wait()?,
                );
                Some(rmw)
            }
            None => None,
        };
        Ok(RosPublisher {
            publisher,
            policy,
            inline_limit,
            rmw,
            sequence: AtomicI64::new(0),
            source_sn: AtomicU32::new(0),
            dynamic: self.dynamic,
            message: PhantomData,
        })
    }
}

impl PublisherBuilder<'_, DynamicType> {
    /// The interface files' own text of the publisher's type and the types
    /// it uses, as `(pkg/msg/Name, text)`: what the node's
    /// `~/get_type_description` gives as the type's sources (comments and
    /// constants included), in place of text written back from the type.
    /// A recording's definitions are such texts.
    ///
    /// ```no_run
    /// use shm_cdr::dynamic::DynamicType;
    /// use shm_cdr::msgs::std_msgs::String as RosString;
    /// use shm_cdr::RosMessage;
    /// use shm_runtime::rmw::Qos;
    /// use shm_runtime::RosNode;
    /// use zenoh::Wait;
    ///
    /// let session = zenoh::open(zenoh::Config::default()).wait()?;
    /// let node = RosNode::builder(&session, "player").wait()?;
    /// let ty = DynamicType::from_description(&RosString::full_description())?;
    /// let publisher = node
    ///     .declare_dynamic_publisher("/chatter", &ty, Qos::default())
    ///     .type_sources([("std_msgs/msg/String", "# Some text.\nstring data\n")])
    ///     .wait()?;
    /// # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
    /// ```
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

impl<T> Resolvable for PublisherBuilder<'_, T> {
    type To = zenoh::Result<RosPublisher<T>>;
}

impl<T> Wait for PublisherBuilder<'_, T> {
    fn wait(self) -> Self::To {
        self.build()
    }
}

impl<'a, T> IntoFuture for PublisherBuilder<'a, T> {
    type Output = zenoh::Result<RosPublisher<T>>;
    type IntoFuture = std::future::Ready<Self::Output>;

    fn into_future(self) -> Self::IntoFuture {
        // Declaring is local bookkeeping in Zenoh; nothing to await.
        std::future::ready(self.build())
    }
}

/// Whether the session's transports carry shared memory (Zenoh's
/// `transport/shared_memory/enabled`, on by default).
fn session_has_shm(session: &Session) -> bool {
    session
        .config()
        .get_typed::<bool>("transport/shared_memory/enabled")
        .unwrap_or(true)
}

/// How often [`RosPublisher::wait_for_subscribers`] looks whether the
/// subscribing sessions have answered the pool's probe.
const RECEIVER_POLL: std::time::Duration = std::time::Duration::from_millis(1);

/// Heartbeat period of reliable transient-local publishers (rmw_zenoh_cpp's
/// period) and of publishers with recovery.
const HEARTBEAT_PERIOD: std::time::Duration = std::time::Duration::from_millis(500);

/// A plain Zenoh publisher, or zenoh-ext's advanced one (transient local,
/// recovery).
pub(crate) enum ZenohPublisher {
    Plain(zenoh::pubsub::Publisher<'static>),
    Advanced(AdvancedPublisher<'static>),
}

impl ZenohPublisher {
    fn key_expr(&self) -> &str {
        match self {
            Self::Plain(p) => p.key_expr().as_str(),
            Self::Advanced(p) => p.key_expr().as_str(),
        }
    }

    fn matching_status(&self) -> zenoh::Result<zenoh::matching::MatchingStatus> {
        match self {
            Self::Plain(p) => p.matching_status().wait(),
            Self::Advanced(p) => p.matching_status().wait(),
        }
    }

    fn matching_listener(&self) -> zenoh::Result<crate::transport::matching::Listener> {
        match self {
            Self::Plain(p) => crate::transport::matching::listen(p.matching_listener()),
            Self::Advanced(p) => crate::transport::matching::listen(p.matching_listener()),
        }
    }
}

/// Publishes messages of type `T`: each one encoded once, straight into an
/// exact-size buffer of the node's shared-memory pool (on the heap below the
/// threshold), and sent on rmw_zenoh_cpp's key for the topic. Undeclared
/// when dropped.
///
/// # Example
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
/// use shm_cdr::msgs::sensor_msgs::Image;
/// use shm_runtime::{RosNode, ShmConfig, ShmContext};
/// use zenoh::Wait;
///
/// let session = zenoh::open(shm_runtime::rmw::config::session_config()?).wait()?;
/// let shm = ShmContext::new(ShmConfig::enabled())?;
/// let node = RosNode::builder(&session, "camera").shm(&shm).wait()?;
/// let publisher = node.declare_publisher::<Image>("image").wait()?;
/// publisher.wait_for_subscribers(std::time::Duration::from_secs(5));
/// let image = Image {
///     width: 640,
///     height: 480,
///     encoding: "rgb8".into(),
///     step: 640 * 3,
///     data: vec![0; 640 * 480 * 3],
///     ..Default::default()
/// };
/// let outcome = publisher.publish(&image).wait()?;
/// println!("{} bytes, {:?}", outcome.size, outcome.kind); // 921 648 bytes, Shm
/// # Ok(())
/// # }
/// ```
pub struct RosPublisher<T> {
    publisher: ZenohPublisher,
    policy: Option<ShmPolicy>,
    /// Set when the session cannot fragment (lowlatency).
    inline_limit: Option<InlineLimit>,
    rmw: Option<RmwPublisher>,
    sequence: AtomicI64,
    /// Zenoh `SourceInfo` sequence number of the next put, from 0 (as zenoh-ext
    /// numbers them): subscribers count the gaps as missed messages.
    source_sn: AtomicU32,
    /// The type of a publisher of run-time typed messages.
    dynamic: Option<DynamicType>,
    message: PhantomData<fn(&T)>,
}

impl<T> fmt::Debug for RosPublisher<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("RosPublisher")
            .field("key_expr", &self.publisher.key_expr())
            .field("shm", &self.policy)
            .field("gid", &self.rmw.as_ref().map(|r| r.gid))
            .finish()
    }
}

impl<T: RosMessage> RosPublisher<T> {
    /// Publish `msg`; resolve with `.wait()` or `.await`.
    pub fn publish<'p>(&'p self, msg: &'p T) -> PublishBuilder<'p, T> {
        PublishBuilder {
            publisher: self,
            msg,
        }
    }

    /// Encode `msg` exactly as [`publish`](Self::publish) would, without sending.
    pub fn encode(&self, msg: &T) -> Result<EncodedPayload, EncodeError> {
        encode_payload(msg, self.policy.as_ref())
    }
}

impl RosPublisher<DynamicType> {
    /// Publish a run-time typed message (see
    /// [`RosNode::declare_dynamic_publisher`](crate::RosNode::declare_dynamic_publisher));
    /// resolve with `.wait()` or `.await`. A message of another type than the
    /// publisher's is refused ([`PublishError::WrongType`]).
    pub fn publish_dynamic<'p, 'm>(
        &'p self,
        msg: &'p Message<'m>,
    ) -> PublishBuilder<'p, DynamicType, Message<'m>> {
        PublishBuilder {
            publisher: self,
            msg,
        }
    }
}

impl<T> RosPublisher<T> {
    /// Publish a message already serialized, its CDR encapsulation header
    /// first (what a subscriber's [`RosSample::payload`](crate::RosSample::payload)
    /// holds, or a recording keeps): copied once, into an exact-size
    /// shared-memory buffer at or above the threshold, else the heap. The
    /// bytes are not checked against the publisher's type beyond the header,
    /// so they must be a message of it (a recorded one, say).
    pub fn publish_serialized(&self, cdr: &[u8]) -> Result<PublishOutcome, PublishError> {
        let encoded = serialized_payload(cdr, self.policy.as_ref())
            .map_err(|_| PublishError::NotCdr { len: cdr.len() })?;
        self.put_encoded_wait(encoded)
    }

    /// Wait until at least one subscriber matches this publisher, or `timeout`
    /// passes; returns whether one did. (Zenoh drops what is published before a
    /// subscriber is known, like any pub/sub.) Built on Zenoh's matching
    /// listener: it wakes when the match happens.
    ///
    /// A publisher with a pool also waits, within the same `timeout`, until
    /// every subscribing session has confirmed its receiver token and answered
    /// whether it maps the pool (two round trips; see
    /// [`receivers`](Self::receivers)), so that the messages
    /// published next take their final path.
    pub fn wait_for_subscribers(&self, timeout: std::time::Duration) -> bool {
        let deadline = std::time::Instant::now() + timeout;
        if !crate::transport::matching::wait(
            self.publisher.matching_listener(),
            || self.has_subscribers(),
            timeout,
        ) {
            return false;
        }
        while !self.receivers_checked() {
            if std::time::Instant::now() >= deadline {
                break;
            }
            std::thread::sleep(RECEIVER_POLL);
        }
        true
    }

    /// Whether every receiver token has been confirmed or not, and every
    /// session known to subscribe has answered whether it maps the pool
    /// (starting the checks that are due).
    fn receivers_checked(&self) -> bool {
        self.policy
            .as_ref()
            .and_then(|p| p.receivers.as_ref())
            .is_none_or(|r| r.settled())
    }

    /// Resolves once at least one subscriber matches this publisher (at once if
    /// one already does), and the subscribing sessions have answered whether
    /// they map the pool, as [`wait_for_subscribers`](Self::wait_for_subscribers)
    /// does (for at most twice [`PROBE_TIMEOUT`]). Cancellation-safe; bound it with your runtime's
    /// timeout (e.g. `tokio::time::timeout`).
    pub async fn subscribers_matched(&self) -> zenoh::Result<()> {
        crate::transport::matching::matched(self.publisher.matching_listener(), || {
            self.has_subscribers()
        })
        .await?;
        // A confirmation, then a probe.
        let deadline = std::time::Instant::now() + 2 * PROBE_TIMEOUT;
        while !self.receivers_checked() && std::time::Instant::now() < deadline {
            futures_timer::Delay::new(RECEIVER_POLL).await;
        }
        Ok(())
    }

    /// Whether a subscriber matches this publisher now.
    pub fn has_subscribers(&self) -> bool {
        self.publisher.matching_status().is_ok_and(|s| s.matching())
    }

    /// The key expression published on.
    pub fn key_expr(&self) -> &str {
        self.publisher.key_expr()
    }

    /// The rmw_zenoh GID, for ROS-style publishers.
    pub fn gid(&self) -> Option<Gid> {
        self.rmw.as_ref().map(|r| r.gid)
    }

    /// The rmw_zenoh liveliness token, for ROS-style publishers.
    pub fn liveliness_token(&self) -> Option<&str> {
        self.rmw.as_ref().map(|r| r.token.as_str())
    }

    /// The sessions that subscribe to this publisher, each with how it gets
    /// the messages that go through shared memory: mapped in place, copied into
    /// a link that carries no shared memory (another host or user, a Zenoh
    /// whose shared memory differs), or from the heap because it cannot map
    /// the pool (see [`Reach`](crate::Reach)). Empty for a publisher without
    /// a pool. This project's subscribers are checked by a probe; on a node,
    /// the other ROS 2 subscribers of the topic (rmw_zenoh_cpp's) are listed
    /// too, by their graph tokens, with what the link to their session
    /// negotiated ([`Reach::SharedMemoryUnprobed`](crate::Reach::SharedMemoryUnprobed)
    /// or [`Reach::Bytes`](crate::Reach::Bytes)).
    pub fn receivers(&self) -> Vec<Receiver> {
        self.policy
            .as_ref()
            .and_then(|p| p.receivers.as_ref())
            .map_or_else(Vec::new, |r| r.list())
    }

    /// The shared-memory pool used, if any.
    pub fn shm_context(&self) -> Option<&ShmContext> {
        self.policy.as_ref().map(|p| &p.context)
    }

    /// Encode `msg` and stamp it: everything a put needs.
    fn prepare<M: sealed::Publishable<T> + ?Sized>(
        &self,
        msg: &M,
    ) -> Result<Prepared, PublishError> {
        msg.check_type(self.dynamic.as_ref())?;
        self.prepare_encoded(encode_payload(msg, self.policy.as_ref())?)
    }

    /// Encode `msg`, stamp it and put it, waiting. A small message on the heap
    /// is packed with its attachment ([`packed`]); the synchronous path
    /// gathers no [`Prepared`], as moving one costs a small message
    /// measurably.
    #[inline]
    fn publish_wait<M: sealed::Publishable<T> + ?Sized>(
        &self,
        msg: &M,
    ) -> Result<PublishOutcome, PublishError> {
        msg.check_type(self.dynamic.as_ref())?;
        let policy = self.policy.as_ref();
        let size = match splice_or_size(msg, policy)? {
            Splice::Done(spliced) => return self.put_encoded_wait(spliced),
            Splice::NotNeeded(size) => size,
        };
        if on_heap(size, policy) {
            let packed = packed(size, |body, tail| {
                shm_cdr::encode_into(msg, body)?;
                if let Some(policy) = policy {
                    policy.context.count(PayloadKind::Heap, size);
                }
                let (outcome, stamp) = self.stamp(PayloadKind::Heap, size, size)?;
                if let Stamp::Attachment(attachment) = &stamp {
                    *tail = *attachment;
                }
                Ok::<_, PublishError>((outcome, stamp))
            });
            if let Some(packed) = packed {
                let (payload, tail, (outcome, stamp)) = packed?;
                match stamp {
                    Stamp::Attachment(_) => put_attached_wait(&self.publisher, payload, tail),
                    other => other.put_wait(&self.publisher, payload),
                }?;
                return Ok(outcome);
            }
        }
        self.put_encoded_wait(encode_sized(msg, size, policy)?)
    }

    /// Stamp an encoded message and put it, waiting.
    #[inline]
    pub(crate) fn put_encoded_wait(
        &self,
        encoded: EncodedPayload,
    ) -> Result<PublishOutcome, PublishError> {
        let (outcome, stamp) = self.stamp(encoded.kind, encoded.size, encoded.inline)?;
        stamp.put_wait(&self.publisher, encoded.bytes)?;
        Ok(outcome)
    }

    /// An encoded message with its stamp, to put later (the awaited paths).
    pub(crate) fn prepare_encoded(
        &self,
        encoded: EncodedPayload,
    ) -> Result<Prepared, PublishError> {
        let (outcome, stamp) = self.stamp(encoded.kind, encoded.size, encoded.inline)?;
        Ok(Prepared {
            outcome,
            payload: encoded.bytes,
            stamp,
        })
    }

    /// What goes out with an encoded message of `kind` and `size`, `inline`
    /// bytes of it in Zenoh's frames: its outcome and its stamp; refused if
    /// the session cannot carry it (see [`Unfragmentable`]). Numbers are taken
    /// only for messages that go out.
    #[inline]
    fn stamp(
        &self,
        kind: PayloadKind,
        size: usize,
        inline: usize,
    ) -> Result<(PublishOutcome, Stamp), PublishError> {
        inline_limit::check(self.inline_limit, inline)?;
        let copied_to = match kind.is_shm() {
            true => self.policy.as_ref().map_or(0, ShmPolicy::copied_to),
            false => 0,
        };
        let mut outcome = PublishOutcome {
            kind,
            size,
            sequence_number: None,
            copied_to,
        };
        // A node's attachment already numbers its messages per publisher (its
        // GID), which is what subscribers count gaps by; a second numbering
        // would cost every message its bytes and its decoding. zenoh-ext
        // numbers an advanced publisher's samples itself (its `SourceInfo`,
        // from 0 like ours).
        let stamp = match (&self.rmw, &self.publisher) {
            (Some(rmw), _) => {
                let sequence_number = self.sequence.fetch_add(1, Ordering::Relaxed) + 1;
                outcome.sequence_number = Some(sequence_number);
                Stamp::Attachment(
                    Attachment {
                        sequence_number,
                        source_timestamp: now_ns(),
                        gid: rmw.gid,
                    }
                    .to_bytes(),
                )
            }
            (None, ZenohPublisher::Plain(p)) => Stamp::SourceInfo(SourceInfo::new(
                p.id(),
                self.source_sn.fetch_add(1, Ordering::Relaxed),
            )),
            (None, ZenohPublisher::Advanced(_)) => Stamp::Numbered,
        };
        Ok((outcome, stamp))
    }

    /// The pool and threshold, if any.
    pub(crate) fn policy(&self) -> Option<&ShmPolicy> {
        self.policy.as_ref()
    }

    /// The Zenoh publisher, to put prepared payloads.
    pub(crate) fn zenoh(&self) -> &ZenohPublisher {
        &self.publisher
    }
}

/// What a put carries beside its payload.
pub(crate) enum Stamp {
    /// A node publisher's: rmw_zenoh_cpp's attachment.
    Attachment([u8; ATTACHMENT_LEN]),
    /// A plain Zenoh publisher's: its number, in Zenoh's source info.
    SourceInfo(SourceInfo),
    /// An advanced publisher without a node: zenoh-ext numbers the samples.
    Numbered,
}

impl Stamp {
    /// Put `payload` with this stamp, waiting. The builder is set only with
    /// what the message carries: each setter moves the whole builder.
    #[inline]
    fn put_wait(self, publisher: &ZenohPublisher, payload: ZBytes) -> Result<(), PublishError> {
        match (publisher, self) {
            (_, Self::Attachment(a)) => {
                return put_attached_wait(publisher, payload, ZBytes::from(a))
            }
            (ZenohPublisher::Plain(p), Self::SourceInfo(info)) => {
                p.put(payload).source_info(Some(info)).wait()
            }
            (ZenohPublisher::Plain(p), Self::Numbered) => p.put(payload).wait(),
            (ZenohPublisher::Advanced(p), Self::SourceInfo(_) | Self::Numbered) => {
                p.put(payload).wait()
            }
        }
        .map_err(PublishError::Zenoh)
    }

    /// As [`put_wait`](Self::put_wait), awaited.
    async fn put_async(
        self,
        publisher: &ZenohPublisher,
        payload: ZBytes,
    ) -> Result<(), PublishError> {
        match (publisher, self) {
            (ZenohPublisher::Plain(p), Self::Attachment(a)) => {
                p.put(payload).attachment(ZBytes::from(a)).await
            }
            (ZenohPublisher::Plain(p), Self::SourceInfo(info)) => {
                p.put(payload).source_info(Some(info)).await
            }
            (ZenohPublisher::Advanced(p), Self::Attachment(a)) => {
                p.put(payload).attachment(ZBytes::from(a)).await
            }
            (ZenohPublisher::Plain(p), Self::Numbered) => p.put(payload).await,
            (ZenohPublisher::Advanced(p), Self::SourceInfo(_) | Self::Numbered) => {
                p.put(payload).await
            }
        }
        .map_err(PublishError::Zenoh)
    }
}

/// Put `payload` with rmw_zenoh_cpp's `attachment`, waiting.
#[inline]
fn put_attached_wait(
    publisher: &ZenohPublisher,
    payload: ZBytes,
    attachment: ZBytes,
) -> Result<(), PublishError> {
    match publisher {
        ZenohPublisher::Plain(p) => p.put(payload).attachment(attachment).wait(),
        ZenohPublisher::Advanced(p) => p.put(payload).attachment(attachment).wait(),
    }
    .map_err(PublishError::Zenoh)
}

/// An encoded message with its stamp, ready to put.
pub(crate) struct Prepared {
    outcome: PublishOutcome,
    payload: ZBytes,
    stamp: Stamp,
}

impl Prepared {
    /// Put, awaited, then say what went out.
    pub(crate) async fn put_async(
        self,
        publisher: &ZenohPublisher,
    ) -> Result<PublishOutcome, PublishError> {
        self.stamp.put_async(publisher, self.payload).await?;
        Ok(self.outcome)
    }
}

mod sealed {
    use super::{DynamicType, Message, PublishError, RosMessage};

    /// What a publisher of `T` publishes: `T` itself, or run-time typed
    /// messages of its type for a publisher of [`DynamicType`].
    pub trait Publishable<T>: shm_cdr::CdrEncode {
        /// Refuse a message that is not of the publisher's type.
        fn check_type(&self, publisher: Option<&DynamicType>) -> Result<(), PublishError>;
    }

    impl<T: RosMessage> Publishable<T> for T {
        fn check_type(&self, _: Option<&DynamicType>) -> Result<(), PublishError> {
            Ok(())
        }
    }

    impl Publishable<DynamicType> for Message<'_> {
        fn check_type(&self, publisher: Option<&DynamicType>) -> Result<(), PublishError> {
            match publisher {
                Some(ty) if self.is_of(ty) => Ok(()),
                other => Err(PublishError::WrongType {
                    expected: other.map_or_else(String::new, |t| t.name().to_owned()),
                    found: self.type_name().to_owned(),
                }),
            }
        }
    }
}

/// The message type of a publisher of messages given already serialized
/// (see [`RosNode::declare_serialized_publisher`](crate::RosNode::declare_serialized_publisher)):
/// it publishes with [`RosPublisher::publish_serialized`] only.
#[derive(Debug)]
pub enum Serialized {}

/// One pending publish; resolve with `.wait()` or `.await`.
#[must_use = "resolve the publish with .wait() or .await"]
pub struct PublishBuilder<'p, T, M: ?Sized = T> {
    publisher: &'p RosPublisher<T>,
    msg: &'p M,
}

impl<T, M: sealed::Publishable<T> + ?Sized> Resolvable for PublishBuilder<'_, T, M> {
    type To = Result<PublishOutcome, PublishError>;
}

impl<T, M: sealed::Publishable<T> + ?Sized> Wait for PublishBuilder<'_, T, M> {
    fn wait(self) -> Self::To {
        self.publisher.publish_wait(self.msg)
    }
}

impl<'p, T, M: sealed::Publishable<T> + ?Sized> IntoFuture for PublishBuilder<'p, T, M> {
    type Output = Result<PublishOutcome, PublishError>;
    type IntoFuture = Pin<Box<dyn Future<Output = Self::Output> + Send + 'p>>;

    fn into_future(self) -> Self::IntoFuture {
        // Encoding is synchronous CPU work: do it now, so the future only holds the
        // finished payload (and `T` need not be `Sync`).
        let prepared = self.publisher.prepare(self.msg);
        let publisher = &self.publisher.publisher;
        Box::pin(async move { prepared?.put_async(publisher).await })
    }
}
