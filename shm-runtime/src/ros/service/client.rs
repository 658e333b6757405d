//! The calling side: each call is one Zenoh query, answered by the first reply
//! that carries its sequence number and this client's GID.

use std::fmt;
use std::future::{Future, IntoFuture};
use std::marker::PhantomData;
use std::pin::Pin;
use std::sync::atomic::{AtomicI64, Ordering};
use std::sync::OnceLock;
use std::time::Duration;

use shm_cdr::interface::RosService;
use shm_cdr::RosMessage;
use shm_cdr::{CdrDecode, DecodeError, EncodeError};
use zenoh::bytes::{Encoding, ZBytes};
use zenoh::key_expr::KeyExpr;
use zenoh::liveliness::LivelinessToken;
use zenoh::query::{ConsolidationMode, QueryTarget, Reply};
use zenoh::sample::Sample;
use zenoh::{Resolvable, Session, Wait};

use crate::rmw::{Attachment, AttachmentError, Gid};
use crate::ros::type_description::TypeUse;
use crate::transport::inline_limit::{self, InlineLimit, Unfragmentable};
use crate::transport::limits::check_key_expr;
use crate::transport::payload::{encode_payload, ShmPolicy};
use crate::transport::publisher::{now_ns, ShmSettings};
use crate::transport::type_check::type_encoding;

/// Zenoh's default query timeout, which rmw_zenoh_cpp's clients use too.
const DEFAULT_TIMEOUT: Duration = Duration::from_secs(10);

/// Replies to one call that may wait to be read (Zenoh's own channel holds
/// as many).
const REPLY_QUEUE: usize = 256;

pub(crate) use crate::transport::limits::NO_TIMEOUT;

/// Why a call failed.
#[derive(Debug)]
#[non_exhaustive]
pub enum CallError {
    /// The request could not be encoded (e.g. a bounded field over its bound).
    Encode(EncodeError),
    /// Zenoh refused the query.
    Zenoh(zenoh::Error),
    /// No reply within the call's timeout.
    Timeout(Duration),
    /// The call ended without a reply: no server was reachable, or the server
    /// went away during the call, or it dropped the request unanswered.
    NoReply,
    /// The server answered with an error (e.g. it could not decode the request,
    /// or its queue pushed the request out).
    Remote(String),
    /// The response is not a valid `S::Response`.
    Decode(DecodeError),
    /// The reply's attachment is not rmw_zenoh's.
    Attachment(AttachmentError),
    /// The session's transport cannot fragment (Zenoh's lowlatency) and the
    /// request's inline part is larger than one frame: it was not sent.
    Unfragmentable(Unfragmentable),
    /// Bytes given as a serialized request do not start with a CDR
    /// encapsulation header.
    NotCdr {
        /// How many bytes were given.
        len: usize,
    },
}

impl fmt::Display for CallError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Encode(e) => write!(f, "service call: {e}"),
            Self::Zenoh(e) => write!(f, "service call: zenoh: {e}"),
            Self::Timeout(t) => write!(f, "service call: no reply within {t:?}"),
            Self::NoReply => write!(
                f,
                "service call ended without a reply: no server was reachable, or it went away or dropped the request"
            ),
            Self::Remote(why) => write!(f, "service call: the server replied with an error: {why}"),
            Self::Decode(e) => write!(f, "service call: the response is not valid: {e}"),
            Self::Attachment(e) => write!(f, "service call: reply {e}"),
            Self::Unfragmentable(e) => write!(f, "service call: {e}"),
            Self::NotCdr { len } => write!(
                f,
                "service call: {len} bytes that do not start with a CDR encapsulation header \
                 (00 00 or 00 01, then two option bytes)"
            ),
        }
    }
}

impl std::error::Error for CallError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Encode(e) => Some(e),
            Self::Decode(e) => Some(e),
            Self::Attachment(e) => Some(e),
            Self::Unfragmentable(e) => Some(e),
            _ => None,
        }
    }
}

/// Builder of a [`ServiceClient`]; resolve with `.wait()` or `.await`.
#[must_use = "resolve the builder with .wait() or .await"]
pub struct ServiceClientBuilder<'a, S> {
    pub(crate) session: &'a Session,
    pub(crate) key_expr: String,
    pub(crate) token: String,
    pub(crate) gid: Gid,
    /// The service type in the node's type-description cache.
    pub(crate) type_use: Option<TypeUse>,
    pub(crate) shm: ShmSettings,
    pub(crate) timeout: Duration,
    /// A name that failed to resolve: reported by `build`.
    pub(crate) invalid: Option<crate::ros::names::NameError>,
    /// The encoding requests carry.
    pub(crate) request_encoding: Encoding,
    pub(crate) service: PhantomData<fn() -> S>,
}

impl<S> crate::transport::shm_options::sealed::Settings for ServiceClientBuilder<'_, S> {
    fn shm_settings(&mut self) -> &mut ShmSettings {
        &mut self.shm
    }
}

impl<'a, S: RosService> ServiceClientBuilder<'a, S> {
    pub(crate) fn new(session: &'a Session, key_expr: String, token: String) -> Self {
        Self::with_request_encoding(
            session,
            key_expr,
            token,
            type_encoding(
                <S::Request as RosMessage>::TYPE_NAME,
                <S::Request as RosMessage>::type_hash(),
            ),
        )
    }
}

impl<'a, S> ServiceClientBuilder<'a, S> {
    pub(crate) fn with_request_encoding(
        session: &'a Session,
        key_expr: String,
        token: String,
        request_encoding: Encoding,
    ) -> Self {
        Self {
            session,
            key_expr,
            gid: Gid::from_token(&token),
            token,
            type_use: None,
            shm: ShmSettings::default(),
            timeout: DEFAULT_TIMEOUT,
            invalid: None,
            request_encoding,
            service: PhantomData,
        }
    }

    /// How long a call waits for its reply (default 10 s, Zenoh's and
    /// rmw_zenoh_cpp's); [`Duration::MAX`] waits as long as the server is there.
    /// [`CallBuilder::timeout`] overrides it for one call.
    pub fn timeout(mut self, timeout: Duration) -> Self {
        self.timeout = timeout.min(NO_TIMEOUT);
        self
    }

    fn build(self) -> zenoh::Result<ServiceClient<S>> {
        if let Some(invalid) = self.invalid {
            return Err(invalid.into());
        }
        check_key_expr("key expression", &self.key_expr)?;
        check_key_expr("liveliness token", &self.token)?;
        let policy = self.shm.resolve(self.session, &self.key_expr);
        let request_encoding = self.request_encoding;
        let inline_limit = InlineLimit::of(
            self.session,
            &self.key_expr,
            request_encoding.to_string().len(),
        );
        let key_expr = KeyExpr::try_from(self.key_expr)?;
        // Calls are session gets (each with its own timeout); the querier is
        // declared for its matching status: whether a server is there.
        let querier = self
            .session
            .declare_querier(key_expr.clone())
            .target(QueryTarget::AllComplete)
            .wait()?;
        let token = self.session.liveliness().declare_token(self.token).wait()?;
        Ok(ServiceClient {
            session: self.session.clone(),
            key_expr,
            querier,
            policy,
            inline_limit,
            gid: self.gid,
            sequence: AtomicI64::new(0),
            timeout: self.timeout,
            request_encoding,
            _token: token,
            _type_use: self.type_use,
            service: PhantomData,
        })
    }
}

impl<S> Resolvable for ServiceClientBuilder<'_, S> {
    type To = zenoh::Result<ServiceClient<S>>;
}

impl<S> Wait for ServiceClientBuilder<'_, S> {
    fn wait(self) -> Self::To {
        self.build()
    }
}

impl<S> IntoFuture for ServiceClientBuilder<'_, S> {
    type Output = zenoh::Result<ServiceClient<S>>;
    type IntoFuture = std::future::Ready<Self::Output>;
    fn into_future(self) -> Self::IntoFuture {
        std::future::ready(self.build())
    }
}

/// Calls service `S`; undeclared when dropped. Calls may be made from several
/// threads or tasks at once: each is its own query, matched to its reply by
/// sequence number.
pub struct ServiceClient<S> {
    session: Session,
    key_expr: KeyExpr<'static>,
    querier: zenoh::query::Querier<'static>,
    policy: Option<ShmPolicy>,
    /// Set when the session cannot fragment (lowlatency).
    inline_limit: Option<InlineLimit>,
    gid: Gid,
    sequence: AtomicI64,
    timeout: Duration,
    request_encoding: Encoding,
    _token: LivelinessToken,
    _type_use: Option<TypeUse>,
    service: PhantomData<fn() -> S>,
}

impl<S> fmt::Debug for ServiceClient<S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ServiceClient")
            .field("key_expr", &self.key_expr.as_str())
            .field("gid", &self.gid)
            .field("timeout", &self.timeout)
            .finish()
    }
}

impl<S: RosService> ServiceClient<S> {
    /// Call the service with `request`; resolve with `.wait()` or `.await` into
    /// the response.
    pub fn call<'c>(&'c self, request: &'c S::Request) -> CallBuilder<'c, S, S::Response> {
        CallBuilder {
            client: self,
            request,
            timeout: self.timeout,
            finish: |reply| reply.response().map_err(CallError::Decode),
        }
    }

    /// Like [`call`](Self::call), resolving into the reply itself, to decode the
    /// response borrowing from it ([`ServiceReply::decode`]) or look at its
    /// attachment.
    pub fn call_reply<'c>(
        &'c self,
        request: &'c S::Request,
    ) -> CallBuilder<'c, S, ServiceReply<S>> {
        CallBuilder {
            client: self,
            request,
            timeout: self.timeout,
            finish: Ok,
        }
    }

    /// Encode `request` and number the call.
    fn prepare(&self, request: &S::Request) -> Result<Prepared, CallError> {
        let encoded = encode_payload(request, self.policy.as_ref()).map_err(CallError::Encode)?;
        self.number(encoded)
    }
}

impl ServiceClient<crate::Serialized> {
    /// Call the service with a request already serialized (its CDR
    /// encapsulation header first), waiting up to the client's timeout; the
    /// reply's bytes are [`ServiceReply::payload`]. The request is copied
    /// once, into an exact-size shared-memory buffer at or above the
    /// threshold, else the heap.
    pub fn call_serialized(
        &self,
        cdr: &[u8],
    ) -> Result<ServiceReply<crate::Serialized>, CallError> {
        let encoded = crate::transport::payload::serialized_payload(cdr, self.policy.as_ref())
            .map_err(|_| CallError::NotCdr { len: cdr.len() })?;
        let prepared = self.number(encoded)?;
        let sequence_number = prepared.sequence_number;
        let (query, replies) = self.get(prepared, self.timeout);
        query.wait().map_err(CallError::Zenoh)?;
        while let Ok(reply) = replies.recv() {
            if let Some(answer) = self.answer(reply, sequence_number, self.timeout) {
                return answer;
            }
        }
        Err(CallError::NoReply)
    }
}

impl<S> ServiceClient<S> {
    /// Whether a server is there now.
    pub fn is_service_available(&self) -> bool {
        self.querier
            .matching_status()
            .wait()
            .is_ok_and(|s| s.matching())
    }

    /// Wait until a server is there, or `timeout` passes; returns whether one is.
    /// Built on Zenoh's matching listener: it wakes when the server appears.
    pub fn wait_for_service(&self, timeout: Duration) -> bool {
        crate::transport::matching::wait(
            crate::transport::matching::listen(self.querier.matching_listener()),
            || self.is_service_available(),
            timeout,
        )
    }

    /// Resolves once a server is there (at once if one is). Cancellation-safe;
    /// bound it with your runtime's timeout.
    pub async fn service_available(&self) -> zenoh::Result<()> {
        crate::transport::matching::matched(
            crate::transport::matching::listen(self.querier.matching_listener()),
            || self.is_service_available(),
        )
        .await
    }

    /// Call `changed(matching)` whenever the first server appears or the last
    /// one goes away, until the client is undeclared.
    pub(crate) fn on_matching_change(
        &self,
        changed: impl Fn(bool) + Send + Sync + 'static,
    ) -> zenoh::Result<()> {
        self.querier
            .matching_listener()
            .callback(move |status| changed(status.matching()))
            .background()
            .wait()
    }

    /// The service's key expression.
    pub fn key_expr(&self) -> &str {
        self.key_expr.as_str()
    }

    /// The client's rmw_zenoh GID, which its calls carry.
    pub fn gid(&self) -> Gid {
        self.gid
    }

    /// Check an encoded request against the link and number the call.
    fn number(
        &self,
        encoded: crate::transport::encoded::EncodedPayload,
    ) -> Result<Prepared, CallError> {
        inline_limit::check(self.inline_limit, encoded.inline)
            .map_err(CallError::Unfragmentable)?;
        let sequence_number = self.sequence.fetch_add(1, Ordering::Relaxed) + 1;
        Ok(Prepared {
            payload: encoded.bytes,
            sequence_number,
        })
    }

    /// The call's query, and where its replies arrive. A reply that comes
    /// after the caller took its answer (another server's, one past the
    /// timeout) is dropped without a word: Zenoh's own channel would log an
    /// ERROR for it on a call that worked. Past `REPLY_QUEUE` replies waiting
    /// at once (many servers answering one call), the rest are dropped.
    fn get(
        &self,
        prepared: Prepared,
        timeout: Duration,
    ) -> (
        zenoh::session::SessionGetBuilder<'_, '_, zenoh::handlers::Callback<Reply>>,
        flume::Receiver<Reply>,
    ) {
        let attachment = Attachment {
            sequence_number: prepared.sequence_number,
            source_timestamp: now_ns(),
            gid: self.gid,
        };
        let (sender, replies) = flume::bounded(REPLY_QUEUE);
        let key_expr = self.key_expr.clone();
        let builder = self
            .session
            .get(&self.key_expr)
            .payload(prepared.payload)
            .encoding(self.request_encoding.clone())
            .attachment(ZBytes::from(attachment.to_bytes()))
            .target(QueryTarget::AllComplete)
            .consolidation(ConsolidationMode::None)
            .timeout(timeout)
            .callback(move |reply| {
                if let Err(flume::TrySendError::Full(_)) = sender.try_send(reply) {
                    tracing::debug!(%key_expr, "more than {REPLY_QUEUE} replies to one call waiting: one dropped");
                }
            });
        (builder, replies)
    }

    /// What one reply means for call `sequence_number`: its answer, or `None`
    /// to wait for another (a reply that belongs to another call).
    fn answer(
        &self,
        reply: Reply,
        sequence_number: i64,
        timeout: Duration,
    ) -> Option<Result<ServiceReply<S>, CallError>> {
        match reply.into_result() {
            Ok(sample) => {
                if let Some(attachment) = sample.attachment() {
                    match Attachment::parse(&attachment.to_bytes()) {
                        Ok(a) if a.sequence_number == sequence_number && a.gid == self.gid => {}
                        Ok(a) => {
                            tracing::debug!(
                                key_expr = %self.key_expr,
                                "reply for call {} of {:?} ignored (waiting for call {sequence_number})",
                                a.sequence_number,
                                a.gid
                            );
                            return None;
                        }
                        Err(e) => return Some(Err(CallError::Attachment(e))),
                    }
                }
                Some(Ok(ServiceReply {
                    sample,
                    copy: OnceLock::new(),
                    service: PhantomData,
                }))
            }
            // Zenoh's timeout, from this session or from the routing node that
            // held the query (servers' own errors are prefixed, see
            // `error_reply_text`).
            Err(e) if e.payload().to_bytes().as_ref() == b"Timeout" => {
                Some(Err(CallError::Timeout(timeout)))
            }
            Err(e) => Some(Err(CallError::Remote(
                String::from_utf8_lossy(&e.payload().to_bytes()).into_owned(),
            ))),
        }
    }
}

/// An encoded request with its sequence number.
struct Prepared {
    payload: ZBytes,
    sequence_number: i64,
}

/// One pending call; resolve with `.wait()` or `.await`.
#[must_use = "resolve the call with .wait() or .await"]
pub struct CallBuilder<'c, S: RosService, O> {
    client: &'c ServiceClient<S>,
    request: &'c S::Request,
    timeout: Duration,
    finish: fn(ServiceReply<S>) -> Result<O, CallError>,
}

impl<S: RosService, O> CallBuilder<'_, S, O> {
    /// How long this call waits for its reply (overrides the client's);
    /// [`Duration::MAX`] waits as long as the server is there.
    pub fn timeout(mut self, timeout: Duration) -> Self {
        self.timeout = timeout.min(NO_TIMEOUT);
        self
    }
}

impl<S: RosService, O> Resolvable for CallBuilder<'_, S, O> {
    type To = Result<O, CallError>;
}

impl<S: RosService, O> Wait for CallBuilder<'_, S, O> {
    fn wait(self) -> Self::To {
        let client = self.client;
        let prepared = client.prepare(self.request)?;
        let sequence_number = prepared.sequence_number;
        let (query, replies) = client.get(prepared, self.timeout);
        query.wait().map_err(CallError::Zenoh)?;
        while let Ok(reply) = replies.recv() {
            if let Some(answer) = client.answer(reply, sequence_number, self.timeout) {
                return answer.and_then(self.finish);
            }
        }
        Err(CallError::NoReply)
    }
}

impl<'c, S: RosService, O: Send + 'c> IntoFuture for CallBuilder<'c, S, O> {
    type Output = Result<O, CallError>;
    type IntoFuture = Pin<Box<dyn Future<Output = Self::Output> + Send + 'c>>;

    fn into_future(self) -> Self::IntoFuture {
        // Encode now, so the future holds the payload and not the request.
        let client = self.client;
        let prepared = client.prepare(self.request);
        let (timeout, finish) = (self.timeout, self.finish);
        Box::pin(async move {
            let prepared = prepared?;
            let sequence_number = prepared.sequence_number;
            let (query, replies) = client.get(prepared, timeout);
            query.await.map_err(CallError::Zenoh)?;
            while let Ok(reply) = replies.recv_async().await {
                if let Some(answer) = client.answer(reply, sequence_number, timeout) {
                    return answer.and_then(finish);
                }
            }
            Err(CallError::NoReply)
        })
    }
}

/// A service's reply: decode the response owned or borrowing from it.
pub struct ServiceReply<S> {
    sample: Sample,
    copy: OnceLock<Vec<u8>>,
    service: PhantomData<fn() -> S>,
}

impl<S> fmt::Debug for ServiceReply<S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ServiceReply")
            .field("key_expr", &self.sample.key_expr().as_str())
            .field("len", &self.sample.payload().len())
            .field(
                "shm",
                &(crate::transport::payload::shm_len(self.sample.payload()) > 0),
            )
            .finish()
    }
}

impl<S: RosService> ServiceReply<S> {
    /// The response as an owned `S::Response`.
    pub fn response(&self) -> Result<S::Response, DecodeError> {
        self.decode()
    }
}

impl<S> ServiceReply<S> {
    /// The response's bytes (CDR, its encapsulation header first).
    pub fn payload(&self) -> &ZBytes {
        self.sample.payload()
    }

    /// The response decoded as `M` (`S::Response` or a form of it borrowing from
    /// the reply).
    pub fn decode<'a, M: CdrDecode<'a>>(&'a self) -> Result<M, DecodeError> {
        crate::transport::payload::decode(self.sample.payload(), &self.copy)
    }

    /// rmw_zenoh's attachment of the reply (the call's sequence number, the
    /// client's GID, the server's timestamp), if it carries one.
    pub fn attachment(&self) -> Option<Result<Attachment, AttachmentError>> {
        let bytes = self.sample.attachment()?.to_bytes();
        Some(Attachment::parse(&bytes))
    }

    /// Whether the response arrived in shared memory.
    pub fn is_shm(&self) -> bool {
        crate::transport::payload::shm_len(self.sample.payload()) > 0
    }

    /// The Zenoh sample of the reply.
    pub fn sample(&self) -> &Sample {
        &self.sample
    }
}
