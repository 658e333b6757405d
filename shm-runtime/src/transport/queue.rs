//! The receive side between Zenoh and the application: every sample is checked
//! for its message type and its publisher's sequence number, then queued under
//! the subscriber's [`History`], on Zenoh's thread, without ever blocking it.

use std::num::NonZeroUsize;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;

use shm_cdr::RosMessage;
use zenoh::sample::Sample;

use crate::transport::gaps::Gaps;
use crate::transport::subscriber::RosSample;

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

/// The check that a sample is of the subscriber's type: our publishers on a
/// plain key name the type and its RIHS01 hash in the sample's encoding
/// (`application/cdr;<type name>;<hash>`, see [`type_encoding`]). Samples
/// without that (a node's, whose key names the type; rmw_zenoh_cpp, plain
/// Zenoh, other tools) are taken as they are.
pub(crate) struct TypeCheck {
    /// `type_encoding(..)` of the type: the common case is one comparison.
    expected: zenoh::bytes::Encoding,
    ty: TopicType,
    key_expr: String,
    pub(crate) rejected: Arc<AtomicU64>,
}

impl TypeCheck {
    pub(crate) fn new(key_expr: &str, ty: &TopicType) -> Self {
        Self {
            expected: type_encoding(&ty.name, &ty.hash),
            ty: ty.clone(),
            key_expr: key_expr.to_owned(),
            rejected: Arc::new(AtomicU64::new(0)),
        }
    }

    /// Whether `sample` may be of this type; if it names another, count it and
    /// say (once) which type arrived.
    pub(crate) fn accepts(&self, sample: &Sample) -> bool {
        let encoding = sample.encoding();
        // Only a schema can name a type: rmw_zenoh_cpp's samples and a node's
        // (whose key names the type) carry none.
        if encoding.schema().is_none() || *encoding == self.expected {
            return true;
        }
        let Some((name, hash)) = sample_type(sample) else {
            return true;
        };
        if *name == *self.ty.name && *hash == *self.ty.hash {
            return true;
        }
        if self.rejected.fetch_add(1, Ordering::Relaxed) == 0 {
            tracing::warn!(
                key_expr = %self.key_expr,
                expected = %format!("{} {}", self.ty.name, self.ty.hash),
                received = %format!("{name} {hash}"),
                "samples of another message type on this key are dropped (RosSubscriber::wrong_type() counts them)"
            );
        }
        false
    }
}

/// The message type (name, RIHS01 hash) a sample's encoding names, if it names
/// one: `application/cdr;<name>;<hash>`.
pub(crate) fn sample_type(sample: &Sample) -> Option<(String, String)> {
    let encoding = sample.encoding().to_string();
    let (name, hash) = encoding.strip_prefix("application/cdr;")?.split_once(';')?;
    Some((name.to_owned(), hash.to_owned()))
}

/// The message type of a publisher or subscriber: its name (`pkg/msg/Name`)
/// and RIHS01 hash, from a compiled type or from a
/// [`DynamicType`](shm_cdr::dynamic::DynamicType) given at run time.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct TopicType {
    pub(crate) name: std::sync::Arc<str>,
    pub(crate) hash: std::sync::Arc<str>,
    /// Whether the type has a `uint8[]` field of its own, which C++ code
    /// generated on Lyrical and later holds as a `rosidl::Buffer` (see
    /// [`crate::rmw::buffer_key_expr`]).
    pub(crate) has_buffer_fields: bool,
}

impl TopicType {
    pub(crate) fn of<T: RosMessage>() -> Self {
        let description = T::type_description();
        Self {
            name: T::TYPE_NAME.into(),
            hash: T::type_hash().into(),
            has_buffer_fields: description.fields.iter().any(|f| {
                f.field_type.element == shm_cdr::describe::TypeId::Uint8
                    && f.field_type.container == shm_cdr::describe::Container::Sequence
            }),
        }
    }

    pub(crate) fn of_dynamic(ty: &shm_cdr::dynamic::DynamicType) -> Self {
        use shm_cdr::dynamic::Element;
        Self {
            name: ty.name().into(),
            hash: ty.type_hash().into(),
            has_buffer_fields: ty.root().fields.iter().any(|f| {
                f.element == Element::U8 && f.container == shm_cdr::describe::Container::Sequence
            }),
        }
    }

    /// rmw_zenoh's (DDS's) name of the type: `pkg::msg::dds_::Name_`.
    pub(crate) fn dds_name(&self) -> String {
        let mut parts = self.name.splitn(3, '/');
        match (parts.next(), parts.next(), parts.next()) {
            (Some(pkg), Some(kind), Some(name)) => format!("{pkg}::{kind}::dds_::{name}_"),
            _ => self.name.to_string(),
        }
    }
}

/// The encoding our publishers on a plain key give every sample of a type:
/// `application/cdr;<type name>;<RIHS01 hash>`, or plain `application/cdr`
/// for a type whose name is too long for that: Zenoh writes an encoding's
/// schema with a one-byte length, and panics on anything longer than 255
/// bytes (a type name of more than 183 characters with its hash).
pub(crate) fn type_encoding(name: &str, hash: &str) -> zenoh::bytes::Encoding {
    const ZENOH_SCHEMA_MAX: usize = 255;
    let schema = format!("{name};{hash}");
    if schema.len() > ZENOH_SCHEMA_MAX {
        return zenoh::bytes::Encoding::APPLICATION_CDR;
    }
    zenoh::bytes::Encoding::APPLICATION_CDR.with_schema(schema)
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
