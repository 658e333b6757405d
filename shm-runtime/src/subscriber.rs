//! Typed subscribers: received samples decoded without a copy when the payload is
//! one slice (shared memory or not) or a spliced set of fragments, with one copy
//! otherwise.

use std::fmt;
use std::future::IntoFuture;
use std::marker::PhantomData;
use std::sync::OnceLock;
use std::time::Duration;

use shm_cdr::{CdrDecode, DecodeError, DecodeErrorKind, RosMessage};
use zenoh::bytes::ZBytes;
use zenoh::handlers::FifoChannelHandler;
use zenoh::liveliness::LivelinessToken;
use zenoh::sample::Sample;
use zenoh::{Resolvable, Session, Wait};

use crate::rmw::{Attachment, AttachmentError};

/// Builder of a [`RosSubscriber`]; resolve with `.wait()` or `.await`.
#[must_use = "resolve the builder with .wait() or .await"]
pub struct SubscriberBuilder<'a, T> {
    pub(crate) session: &'a Session,
    pub(crate) key_expr: String,
    /// rmw_zenoh liveliness token (`MS`) to declare, for node subscribers.
    pub(crate) liveliness: Option<String>,
    pub(crate) message: PhantomData<fn() -> T>,
}

impl<'a, T: RosMessage> SubscriberBuilder<'a, T> {
    pub(crate) fn new(session: &'a Session, key_expr: String) -> Self {
        Self {
            session,
            key_expr,
            liveliness: None,
            message: PhantomData,
        }
    }

    fn declare_token(&self) -> zenoh::Result<Option<LivelinessToken>> {
        match &self.liveliness {
            Some(token) => Ok(Some(
                self.session
                    .liveliness()
                    .declare_token(token.clone())
                    .wait()?,
            )),
            None => Ok(None),
        }
    }

    /// Call `callback` with every sample as it arrives, on Zenoh's thread, instead
    /// of queueing samples for [`RosSubscriber::recv`]. Decode inside the callback
    /// to borrow from the sample.
    pub fn callback<F>(self, callback: F) -> CallbackSubscriberBuilder<'a, T, F>
    where
        F: Fn(RosSample) + Send + Sync + 'static,
    {
        CallbackSubscriberBuilder {
            inner: self,
            callback,
        }
    }

    fn build(self) -> zenoh::Result<RosSubscriber<T>> {
        let token = self.declare_token()?;
        let subscriber = self.session.declare_subscriber(self.key_expr).wait()?;
        Ok(RosSubscriber {
            subscriber,
            _token: token,
            message: PhantomData,
        })
    }
}

impl<T: RosMessage> Resolvable for SubscriberBuilder<'_, T> {
    type To = zenoh::Result<RosSubscriber<T>>;
}

impl<T: RosMessage> Wait for SubscriberBuilder<'_, T> {
    fn wait(self) -> Self::To {
        self.build()
    }
}

impl<T: RosMessage> IntoFuture for SubscriberBuilder<'_, T> {
    type Output = zenoh::Result<RosSubscriber<T>>;
    type IntoFuture = std::future::Ready<Self::Output>;
    fn into_future(self) -> Self::IntoFuture {
        std::future::ready(self.build())
    }
}

/// Builder of a callback subscriber; resolve with `.wait()` or `.await`.
#[must_use = "resolve the builder with .wait() or .await"]
pub struct CallbackSubscriberBuilder<'a, T, F> {
    inner: SubscriberBuilder<'a, T>,
    callback: F,
}

/// A subscriber that hands every sample to a callback; undeclared when dropped.
pub struct CallbackSubscriber<T> {
    _subscriber: zenoh::pubsub::Subscriber<()>,
    _token: Option<LivelinessToken>,
    message: PhantomData<fn() -> T>,
}

impl<T: RosMessage, F: Fn(RosSample) + Send + Sync + 'static> CallbackSubscriberBuilder<'_, T, F> {
    fn build(self) -> zenoh::Result<CallbackSubscriber<T>> {
        let token = self.inner.declare_token()?;
        let callback = self.callback;
        let subscriber = self
            .inner
            .session
            .declare_subscriber(self.inner.key_expr)
            .callback(move |sample| callback(RosSample::new(sample)))
            .wait()?;
        Ok(CallbackSubscriber {
            _subscriber: subscriber,
            _token: token,
            message: PhantomData,
        })
    }
}

impl<T: RosMessage, F: Fn(RosSample) + Send + Sync + 'static> Resolvable
    for CallbackSubscriberBuilder<'_, T, F>
{
    type To = zenoh::Result<CallbackSubscriber<T>>;
}

impl<T: RosMessage, F: Fn(RosSample) + Send + Sync + 'static> Wait
    for CallbackSubscriberBuilder<'_, T, F>
{
    fn wait(self) -> Self::To {
        self.build()
    }
}

impl<T: RosMessage, F: Fn(RosSample) + Send + Sync + 'static> IntoFuture
    for CallbackSubscriberBuilder<'_, T, F>
{
    type Output = zenoh::Result<CallbackSubscriber<T>>;
    type IntoFuture = std::future::Ready<Self::Output>;
    fn into_future(self) -> Self::IntoFuture {
        std::future::ready(self.build())
    }
}

/// Receives messages published as `T` (decode them as `T` or as a borrowing
/// variant of the same ROS type).
pub struct RosSubscriber<T> {
    subscriber: zenoh::pubsub::Subscriber<FifoChannelHandler<Sample>>,
    _token: Option<LivelinessToken>,
    message: PhantomData<fn() -> T>,
}

impl<T> fmt::Debug for RosSubscriber<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("RosSubscriber")
            .field("key_expr", &self.subscriber.key_expr().as_str())
            .finish()
    }
}

impl<T: RosMessage> RosSubscriber<T> {
    /// Wait for the next sample.
    pub fn recv(&self) -> zenoh::Result<RosSample> {
        self.subscriber.recv().map(RosSample::new)
    }

    /// Wait for the next sample, asynchronously.
    pub async fn recv_async(&self) -> zenoh::Result<RosSample> {
        self.subscriber.recv_async().await.map(RosSample::new)
    }

    /// Wait at most `timeout` for the next sample.
    pub fn recv_timeout(&self, timeout: Duration) -> zenoh::Result<Option<RosSample>> {
        self.subscriber
            .recv_timeout(timeout)
            .map(|s| s.map(RosSample::new))
    }

    /// The next sample if one is queued.
    pub fn try_recv(&self) -> zenoh::Result<Option<RosSample>> {
        self.subscriber.try_recv().map(|s| s.map(RosSample::new))
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
        self.subscriber.key_expr().as_str()
    }
}

/// Receiving a message failed.
#[derive(Debug)]
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

/// A received sample, decodable into any message type (owned or borrowing from
/// the sample).
pub struct RosSample {
    sample: Sample,
    /// A contiguous copy, made at most once, for payloads that arrived in more
    /// fragments than can be borrowed from.
    copy: OnceLock<Vec<u8>>,
}

impl fmt::Debug for RosSample {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("RosSample")
            .field("key_expr", &self.sample.key_expr().as_str())
            .field("len", &self.sample.payload().len())
            .field("shm", &self.is_shm())
            .finish()
    }
}

impl RosSample {
    fn new(sample: Sample) -> Self {
        Self {
            sample,
            copy: OnceLock::new(),
        }
    }

    /// The Zenoh sample.
    pub fn sample(&self) -> &Sample {
        &self.sample
    }

    /// The payload.
    pub fn payload(&self) -> &ZBytes {
        self.sample.payload()
    }

    /// The key expression it was published on.
    pub fn key_expr(&self) -> &str {
        self.sample.key_expr().as_str()
    }

    /// Whether the whole payload is one shared-memory buffer.
    pub fn is_shm(&self) -> bool {
        self.sample.payload().as_shm().is_some()
    }

    /// How many fragments the payload arrived in (1 for a single buffer; 3 for a
    /// message with one spliced shared-memory field).
    pub fn fragments(&self) -> usize {
        self.sample.payload().slices().count()
    }

    /// The rmw_zenoh attachment, if the sample carries one.
    pub fn attachment(&self) -> Option<Result<Attachment, AttachmentError>> {
        let bytes = self.sample.attachment()?.to_bytes();
        Some(Attachment::parse(&bytes))
    }

    /// Decode the payload as `M`, borrowing from the sample where `M` has borrowed
    /// fields: from the single slice, or from each fragment of a spliced payload
    /// (a `&[u8]` field then points into the shared-memory block); a payload in
    /// other fragments is copied once into a contiguous buffer first.
    pub fn decode<'a, M: CdrDecode<'a>>(&'a self) -> Result<M, DecodeError> {
        self.read_payload(|body| match body {
            Body::Contiguous(bytes) => shm_cdr::from_bytes(bytes),
            Body::Fragments(segments) => shm_cdr::from_segments(segments),
        })
    }

    /// [`decode`](Self::decode) into an existing value, reusing the memory it owns
    /// (see [`shm_cdr::from_bytes_into`]): a subscriber that keeps one message and
    /// decodes every sample into it allocates only when a message outgrows it.
    pub fn decode_into<'a, M: CdrDecode<'a>>(&'a self, out: &mut M) -> Result<(), DecodeError> {
        self.read_payload(|body| match body {
            Body::Contiguous(bytes) => shm_cdr::from_bytes_into(bytes, out),
            Body::Fragments(segments) => shm_cdr::from_segments_into(segments, out),
        })
    }

    /// Hand the payload to `read` in the cheapest form it can be read from: the
    /// single slice; else the fragments themselves; else (a value straddles two
    /// fragments, or there are too many) one contiguous copy, made once per sample.
    fn read_payload<'a, R>(
        &'a self,
        mut read: impl FnMut(Body<'a, '_>) -> Result<R, DecodeError>,
    ) -> Result<R, DecodeError> {
        let payload = self.sample.payload();
        let mut slices = payload.slices();
        match (slices.next(), slices.next()) {
            (Some(only), None) => return read(Body::Contiguous(only)),
            (None, _) => return read(Body::Contiguous(&[])),
            _ => {}
        }
        if self.copy.get().is_none() && payload.slices().count() <= shm_cdr::MAX_SEGMENTS {
            let segments: Vec<&'a [u8]> = payload.slices().collect();
            match read(Body::Fragments(&segments)) {
                Err(e) if matches!(e.kind(), DecodeErrorKind::Fragmented { .. }) => {}
                done => return done,
            }
        }
        read(Body::Contiguous(
            self.copy.get_or_init(|| payload.to_bytes().into_owned()),
        ))
    }
}

/// A payload as [`RosSample::read_payload`] hands it over.
enum Body<'a, 's> {
    Contiguous(&'a [u8]),
    Fragments(&'s [&'a [u8]]),
}
