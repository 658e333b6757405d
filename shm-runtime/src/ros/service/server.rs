//! The serving side: a queryable whose queries become [`ServiceRequest`]s, taken
//! from a queue ([`ServiceServer`]), handed to a callback, or answered by a
//! handler function.

use std::fmt;
use std::future::{Future, IntoFuture};
use std::marker::PhantomData;
use std::pin::Pin;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::Duration;

use shm_cdr::interface::RosService;
use shm_cdr::RosMessage;
use shm_cdr::{CdrDecode, DecodeError};
use zenoh::bytes::{Encoding, ZBytes};
use zenoh::key_expr::KeyExpr;
use zenoh::liveliness::LivelinessToken;
use zenoh::query::Query;
use zenoh::{Resolvable, Session, Wait};

use super::error_reply_text;
use crate::rmw::{Attachment, Gid};
use crate::ros::type_description::TypeUse;
use crate::transport::encoded::PayloadKind;
use crate::transport::executor::{Callback, Dispatch, Executor};
use crate::transport::inline_limit::{self, InlineLimit};
use crate::transport::limits::check_key_expr;
use crate::transport::payload::{encode_payload, ShmPolicy};
use crate::transport::publisher::{now_ns, PublishError, ShmSettings};
use crate::transport::queue::History;
use crate::transport::type_check::type_encoding;

/// Builder of a service server; resolve with `.wait()` or `.await` into a
/// [`ServiceServer`] that queues requests, or first turn it into a callback
/// server with [`callback`](Self::callback) or [`handler`](Self::handler).
#[must_use = "resolve the builder with .wait() or .await"]
pub struct ServiceServerBuilder<'a, S> {
    pub(crate) session: &'a Session,
    pub(crate) key_expr: String,
    pub(crate) token: Option<String>,
    pub(crate) gid: Option<Gid>,
    /// The service type in the node's type-description cache.
    pub(crate) type_use: Option<TypeUse>,
    pub(crate) shm: ShmSettings,
    pub(crate) history: History,
    /// The encoding replies carry.
    pub(crate) response_encoding: Encoding,
    /// A name that failed to resolve: reported by `build`.
    pub(crate) invalid: Option<crate::ros::names::NameError>,
    pub(crate) service: PhantomData<fn() -> S>,
}

impl<S> crate::transport::shm_options::sealed::Settings for ServiceServerBuilder<'_, S> {
    fn shm_settings(&mut self) -> &mut ShmSettings {
        &mut self.shm
    }
}

impl<'a, S: RosService> ServiceServerBuilder<'a, S> {
    pub(crate) fn new(session: &'a Session, key_expr: String) -> Self {
        Self::with_response_encoding(
            session,
            key_expr,
            type_encoding(
                <S::Response as RosMessage>::TYPE_NAME,
                <S::Response as RosMessage>::type_hash(),
            ),
        )
    }

    /// Answer every request with `handler(request)`, on an [`Executor`]'s
    /// thread (see [`callback`](Self::callback)). A request that is not a
    /// valid `S::Request` gets an error reply saying where it broke.
    pub fn handler<H>(self, mut handler: H) -> CallbackServiceServerBuilder<'a, S>
    where
        H: FnMut(S::Request) -> S::Response + Send + 'static,
    {
        self.callback(move |request: ServiceRequest<S>| {
            if let Ok(decoded) = request.request() {
                let response = handler(decoded);
                if let Err(e) = request.reply(&response).wait() {
                    tracing::warn!("service reply failed: {e}");
                }
            }
        })
    }
}

impl<'a, S: 'static> ServiceServerBuilder<'a, S> {
    pub(crate) fn with_response_encoding(
        session: &'a Session,
        key_expr: String,
        response_encoding: Encoding,
    ) -> Self {
        Self {
            session,
            key_expr,
            token: None,
            gid: None,
            type_use: None,
            shm: ShmSettings::default(),
            history: History::KeepAll,
            response_encoding,
            invalid: None,
            service: PhantomData,
        }
    }

    /// How many requests wait to be taken from a [`ServiceServer`]'s queue. With
    /// [`History::KeepLast`] (what the service's QoS depth asks for, 10 by
    /// default as in rmw_zenoh_cpp) a request arriving while `n` wait pushes out
    /// the oldest, whose client gets an error reply saying so (counted in
    /// [`ServiceServer::dropped`]); [`History::KeepAll`] never drops.
    pub fn history(mut self, history: History) -> Self {
        self.history = history;
        self
    }

    /// Call `callback` with every request, in arrival order, on a thread of
    /// an [`Executor`] ([`Executor::global`] unless
    /// [`CallbackServiceServerBuilder::executor`] names another): reply there,
    /// or move the request to where the work happens and reply from there (a
    /// [`ServiceRequest`] is `Send`). Requests wait in the server's own queue
    /// under its [`history`](Self::history) meanwhile, so a slow callback
    /// never holds up Zenoh's thread.
    pub fn callback<F>(self, callback: F) -> CallbackServiceServerBuilder<'a, S>
    where
        F: FnMut(ServiceRequest<S>) + Send + 'static,
    {
        CallbackServiceServerBuilder {
            inner: self,
            callback: Callback::Dispatched(Box::new(callback), None),
        }
    }

    /// Call `callback` on Zenoh's receive thread as each request arrives: for
    /// code that only hands the request on, never blocks and returns within
    /// microseconds (the session receives nothing else meanwhile). Prefer
    /// [`callback`](Self::callback).
    pub fn callback_inline<F>(self, callback: F) -> CallbackServiceServerBuilder<'a, S>
    where
        F: Fn(ServiceRequest<S>) + Send + Sync + 'static,
    {
        CallbackServiceServerBuilder {
            inner: self,
            callback: Callback::Inline(Box::new(callback)),
        }
    }

    /// Declare the token and everything shared by every request.
    fn shared(&self) -> zenoh::Result<(Arc<Shared>, Option<LivelinessToken>)> {
        if let Some(invalid) = &self.invalid {
            return Err(invalid.clone().into());
        }
        check_key_expr("key expression", &self.key_expr)?;
        if let Some(token) = &self.token {
            check_key_expr("liveliness token", token)?;
        }
        let policy = self.shm.resolve(self.session, &self.key_expr);
        let response_encoding = self.response_encoding.clone();
        let inline_limit = InlineLimit::of(
            self.session,
            &self.key_expr,
            response_encoding.to_string().len(),
        );
        let key_expr = KeyExpr::try_from(self.key_expr.clone())?;
        let token = match &self.token {
            Some(token) => Some(
                self.session
                    .liveliness()
                    .declare_token(token.clone())
                    .wait()?,
            ),
            None => None,
        };
        let shared = Shared {
            key_expr,
            policy,
            inline_limit,
            response_encoding,
            malformed: AtomicU64::new(0),
            dropped: AtomicU64::new(0),
            _type_use: self.type_use.clone(),
        };
        Ok((Arc::new(shared), token))
    }

    /// A queue of requests under `history`, and what Zenoh's callback does
    /// with each query: take it as a request and queue it (pushing out the
    /// oldest past the depth, whose client gets an error reply); whether it
    /// queued one.
    fn queue(
        &self,
        shared: &Arc<Shared>,
    ) -> (
        flume::Receiver<ServiceRequest<S>>,
        impl Fn(Query) -> bool + Send + Sync + 'static,
    ) {
        let (sender, receiver) = flume::unbounded::<ServiceRequest<S>>();
        let oldest = receiver.clone();
        let history = self.history;
        let for_queue = shared.clone();
        let push = move |query| {
            let Some(request) = ServiceRequest::take(query, &for_queue) else {
                return false;
            };
            if let History::KeepLast(depth) = history {
                while oldest.len() >= depth.get() {
                    let Ok(pushed_out) = oldest.try_recv() else {
                        break;
                    };
                    for_queue.dropped.fetch_add(1, Ordering::Relaxed);
                    pushed_out.refuse(format_args!(
                        "request dropped: {depth} newer requests were waiting for the server (its history depth)"
                    ));
                }
            }
            // The receiver lives as long as the queryable.
            sender.send(request).is_ok()
        };
        (receiver, push)
    }

    fn build(self) -> zenoh::Result<ServiceServer<S>> {
        let (shared, token) = self.shared()?;
        let (receiver, push) = self.queue(&shared);
        let queryable = self
            .session
            .declare_queryable(shared.key_expr.clone())
            .complete(true)
            .callback(move |query| {
                push(query);
            })
            .wait()?;
        Ok(ServiceServer {
            queryable,
            receiver,
            shared,
            gid: self.gid,
            _token: token,
            service: PhantomData,
        })
    }
}

impl<S: 'static> Resolvable for ServiceServerBuilder<'_, S> {
    type To = zenoh::Result<ServiceServer<S>>;
}

impl<S: 'static> Wait for ServiceServerBuilder<'_, S> {
    fn wait(self) -> Self::To {
        self.build()
    }
}

impl<S: 'static> IntoFuture for ServiceServerBuilder<'_, S> {
    type Output = zenoh::Result<ServiceServer<S>>;
    type IntoFuture = std::future::Ready<Self::Output>;
    fn into_future(self) -> Self::IntoFuture {
        std::future::ready(self.build())
    }
}

/// What every request of one server shares.
struct Shared {
    /// The service's key: replies go out on it (a client may have asked with a
    /// wildcard).
    key_expr: KeyExpr<'static>,
    policy: Option<ShmPolicy>,
    /// Set when the session cannot fragment (lowlatency).
    inline_limit: Option<InlineLimit>,
    response_encoding: Encoding,
    malformed: AtomicU64,
    dropped: AtomicU64,
    _type_use: Option<TypeUse>,
}

/// A service server that queues requests until the application takes them;
/// undeclared when dropped (requests still queued then get no reply, which their
/// clients see at once).
pub struct ServiceServer<S> {
    queryable: zenoh::query::Queryable<()>,
    receiver: flume::Receiver<ServiceRequest<S>>,
    shared: Arc<Shared>,
    gid: Option<Gid>,
    _token: Option<LivelinessToken>,
    service: PhantomData<fn() -> S>,
}

impl<S> fmt::Debug for ServiceServer<S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ServiceServer")
            .field("key_expr", &self.queryable.key_expr().as_str())
            .field("gid", &self.gid)
            .finish()
    }
}

impl<S> ServiceServer<S> {
    /// Wait for the next request.
    pub fn recv(&self) -> zenoh::Result<ServiceRequest<S>> {
        Ok(self.receiver.recv()?)
    }

    /// Wait at most `timeout` for the next request.
    pub fn recv_timeout(&self, timeout: Duration) -> zenoh::Result<Option<ServiceRequest<S>>> {
        match self.receiver.recv_timeout(timeout) {
            Ok(request) => Ok(Some(request)),
            Err(flume::RecvTimeoutError::Timeout) => Ok(None),
            Err(e) => Err(e.into()),
        }
    }

    /// The next request if one is queued.
    pub fn try_recv(&self) -> zenoh::Result<Option<ServiceRequest<S>>> {
        match self.receiver.try_recv() {
            Ok(request) => Ok(Some(request)),
            Err(flume::TryRecvError::Empty) => Ok(None),
            Err(e) => Err(e.into()),
        }
    }

    /// Wait for the next request, asynchronously. Cancellation-safe: dropping
    /// the future before it completes loses no request.
    pub async fn recv_async(&self) -> zenoh::Result<ServiceRequest<S>> {
        Ok(self.receiver.recv_async().await?)
    }

    /// How many requests wait to be taken.
    pub fn queued(&self) -> usize {
        self.receiver.len()
    }

    /// How many requests were not valid (an attachment that is not
    /// rmw_zenoh's, a payload that is not an `S::Request`); each got an error
    /// reply.
    pub fn malformed(&self) -> u64 {
        self.shared.malformed.load(Ordering::Relaxed)
    }

    /// How many requests were pushed out of a full [`History::KeepLast`] queue;
    /// each got an error reply.
    pub fn dropped(&self) -> u64 {
        self.shared.dropped.load(Ordering::Relaxed)
    }

    /// The service's key expression.
    pub fn key_expr(&self) -> &str {
        self.queryable.key_expr().as_str()
    }

    /// The server's rmw_zenoh GID (for servers declared on a node).
    pub fn gid(&self) -> Option<Gid> {
        self.gid
    }
}

impl<S: RosService> ServiceServer<S> {
    /// Answer requests one after the other with `handler(request).await`, until
    /// the server is undeclared; a request that is not a valid `S::Request` gets
    /// an error reply. Runs on whatever executor polls it (no runtime of its
    /// own); to answer several at once, take requests with
    /// [`recv_async`](Self::recv_async) and spawn.
    pub async fn serve<H, F>(&self, mut handler: H) -> zenoh::Result<()>
    where
        H: FnMut(S::Request) -> F,
        F: Future<Output = S::Response>,
    {
        while let Ok(request) = self.receiver.recv_async().await {
            let Ok(decoded) = request.request() else {
                continue;
            };
            let response = handler(decoded).await;
            if let Err(e) = request.reply(&response).await {
                tracing::warn!("service reply failed: {e}");
            }
        }
        Ok(())
    }
}

/// Builder of a [`CallbackServiceServer`]; resolve with `.wait()` or `.await`.
#[must_use = "resolve the builder with .wait() or .await"]
pub struct CallbackServiceServerBuilder<'a, S> {
    inner: ServiceServerBuilder<'a, S>,
    callback: Callback<ServiceRequest<S>>,
}

impl<S> CallbackServiceServerBuilder<'_, S> {
    /// Run the callback on `executor`'s threads instead of the global ones
    /// (no effect on an inline callback).
    pub fn executor(mut self, executor: &Executor) -> Self {
        self.callback.set_executor(executor);
        self
    }
}

/// A service server that hands every request to a callback; undeclared when
/// dropped, after which its callback is not called again.
pub struct CallbackServiceServer<S> {
    queryable: zenoh::query::Queryable<()>,
    dispatch: Option<Arc<Dispatch<ServiceRequest<S>>>>,
    shared: Arc<Shared>,
    gid: Option<Gid>,
    _token: Option<LivelinessToken>,
    service: PhantomData<fn() -> S>,
}

impl<S> fmt::Debug for CallbackServiceServer<S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("CallbackServiceServer")
            .field("key_expr", &self.queryable.key_expr().as_str())
            .field("gid", &self.gid)
            .finish()
    }
}

impl<S> CallbackServiceServer<S> {
    /// How many requests were not valid; each got an error reply.
    pub fn malformed(&self) -> u64 {
        self.shared.malformed.load(Ordering::Relaxed)
    }

    /// The service's key expression.
    pub fn key_expr(&self) -> &str {
        self.queryable.key_expr().as_str()
    }

    /// The server's rmw_zenoh GID (for servers declared on a node).
    pub fn gid(&self) -> Option<Gid> {
        self.gid
    }
}

impl<S: 'static> CallbackServiceServerBuilder<'_, S> {
    fn build(self) -> zenoh::Result<CallbackServiceServer<S>> {
        let (shared, token) = self.inner.shared()?;
        let declare = |callback: Box<dyn Fn(Query) + Send + Sync>| {
            self.inner
                .session
                .declare_queryable(shared.key_expr.clone())
                .complete(true)
                .callback(callback)
                .wait()
        };
        let (queryable, dispatch) = match self.callback {
            Callback::Dispatched(callback, executor) => {
                let (receiver, push) = self.inner.queue(&shared);
                let executor = match executor {
                    Some(executor) => executor,
                    None => Executor::global()?.clone(),
                };
                let dispatch =
                    Dispatch::new(receiver, callback, executor, self.inner.key_expr.clone());
                let notify = dispatch.clone();
                let queryable = declare(Box::new(move |query| {
                    if push(query) {
                        notify.notify();
                    }
                }))?;
                (queryable, Some(dispatch))
            }
            Callback::Inline(callback) => {
                let for_requests = shared.clone();
                let queryable = declare(Box::new(move |query| {
                    if let Some(request) = ServiceRequest::take(query, &for_requests) {
                        callback(request);
                    }
                }))?;
                (queryable, None)
            }
        };
        Ok(CallbackServiceServer {
            queryable,
            dispatch,
            shared,
            gid: self.inner.gid,
            _token: token,
            service: PhantomData,
        })
    }
}

impl<S> Drop for CallbackServiceServer<S> {
    fn drop(&mut self) {
        if let Some(dispatch) = &self.dispatch {
            dispatch.close();
        }
    }
}

impl<S: 'static> Resolvable for CallbackServiceServerBuilder<'_, S> {
    type To = zenoh::Result<CallbackServiceServer<S>>;
}

impl<S: 'static> Wait for CallbackServiceServerBuilder<'_, S> {
    fn wait(self) -> Self::To {
        self.build()
    }
}

impl<S: 'static> IntoFuture for CallbackServiceServerBuilder<'_, S> {
    type Output = zenoh::Result<CallbackServiceServer<S>>;
    type IntoFuture = std::future::Ready<Self::Output>;
    fn into_future(self) -> Self::IntoFuture {
        std::future::ready(self.build())
    }
}

/// One call waiting for its reply. Decode it with [`request`](Self::request)
/// (owned) or [`decode`](Self::decode) (borrowing from the payload), then answer
/// with [`reply`](Self::reply) or [`reply_err`](Self::reply_err). Dropping it
/// unanswered ends the call without a reply, which the client sees at once.
pub struct ServiceRequest<S> {
    query: Query,
    /// rmw_zenoh's attachment; absent when a plain Zenoh `get` called.
    attachment: Option<Attachment>,
    shared: Arc<Shared>,
    copy: OnceLock<Vec<u8>>,
    service: PhantomData<fn() -> S>,
}

impl<S> fmt::Debug for ServiceRequest<S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ServiceRequest")
            .field("key_expr", &self.query.key_expr().as_str())
            .field("attachment", &self.attachment)
            .field("len", &self.query.payload().map_or(0, |p| p.len()))
            .finish()
    }
}

impl<S> ServiceRequest<S> {
    /// Accept `query` as a request, or refuse it (error reply, counted) if its
    /// attachment is present but not rmw_zenoh's.
    fn take(query: Query, shared: &Arc<Shared>) -> Option<Self> {
        let attachment = match query.attachment().map(|a| Attachment::parse(&a.to_bytes())) {
            None => None,
            Some(Ok(attachment)) => Some(attachment),
            Some(Err(e)) => {
                shared.malformed.fetch_add(1, Ordering::Relaxed);
                tracing::warn!(key_expr = %shared.key_expr, "service request refused: {e}");
                reply_error(&query, format_args!("request refused: {e}"));
                return None;
            }
        };
        Some(Self {
            query,
            attachment,
            shared: shared.clone(),
            copy: OnceLock::new(),
            service: PhantomData,
        })
    }

    fn payload(&self) -> &ZBytes {
        static EMPTY: OnceLock<ZBytes> = OnceLock::new();
        self.query
            .payload()
            .unwrap_or_else(|| EMPTY.get_or_init(ZBytes::new))
    }

    /// The request decoded as `M` (`S::Request` or a form of it borrowing from
    /// the payload, e.g. the generated `…Ref<'a>`). On error, like
    /// [`request`](Self::request).
    pub fn decode<'a, M: CdrDecode<'a>>(&'a self) -> Result<M, DecodeError> {
        crate::transport::payload::decode(self.payload(), &self.copy).inspect_err(|e| {
            self.shared.malformed.fetch_add(1, Ordering::Relaxed);
            tracing::warn!(key_expr = %self.shared.key_expr, "service request refused: {e}");
            reply_error(&self.query, format_args!("request refused: {e}"));
        })
    }

    /// rmw_zenoh's attachment of the call: the client's GID and its sequence
    /// number for this call (`None` for a plain Zenoh `get`).
    pub fn attachment(&self) -> Option<&Attachment> {
        self.attachment.as_ref()
    }

    /// Whether the request arrived in shared memory.
    pub fn is_shm(&self) -> bool {
        crate::transport::payload::shm_len(self.payload()) > 0
    }

    /// Answer with an error: the client's call fails with
    /// [`CallError::Remote`](super::CallError::Remote) carrying `why`.
    pub fn reply_err(self, why: impl fmt::Display) {
        reply_error(&self.query, why);
    }

    /// Refuse a request the server will not serve (pushed out of its queue).
    fn refuse(self, why: impl fmt::Display) {
        tracing::debug!(key_expr = %self.shared.key_expr, "{why}");
        reply_error(&self.query, why);
    }
}

impl<S: RosService> ServiceRequest<S> {
    /// The request, decoded as an owned `S::Request`. If it is not valid, the
    /// client gets an error reply with the decoder's message (offset included),
    /// the server counts it in `malformed()`, and this request can no longer be
    /// answered.
    pub fn request(&self) -> Result<S::Request, DecodeError> {
        self.decode::<S::Request>()
    }

    /// Answer with `response`; resolve with `.wait()` or `.await`. It goes out
    /// in shared memory at or above the server's threshold.
    pub fn reply(self, response: &S::Response) -> ReplyBuilder<S> {
        ReplyBuilder {
            encoded: encode_payload(response, self.shared.policy.as_ref()).map_err(Into::into),
            request: self,
        }
    }
}

impl ServiceRequest<crate::Serialized> {
    /// The request's serialized bytes (its CDR encapsulation header first),
    /// in shared memory if it arrived there.
    pub fn serialized(&self) -> &ZBytes {
        self.payload()
    }

    /// Answer with a response already serialized (its CDR encapsulation
    /// header first); resolve with `.wait()` or `.await`. It is copied once,
    /// into an exact-size shared-memory buffer at or above the server's
    /// threshold, else the heap. Bytes that are not CDR are refused
    /// ([`PublishError::NotCdr`]) and the client gets an error reply.
    pub fn reply_serialized(self, cdr: &[u8]) -> ReplyBuilder<crate::Serialized> {
        let encoded =
            crate::transport::payload::serialized_payload(cdr, self.shared.policy.as_ref())
                .map_err(|_| PublishError::NotCdr { len: cdr.len() });
        ReplyBuilder {
            encoded,
            request: self,
        }
    }
}

/// Send an error reply; a failure to send it is only logged (the client then
/// sees the call end without a reply).
fn reply_error(query: &Query, why: impl fmt::Display) {
    if let Err(e) = query.reply_err(error_reply_text(why)).wait() {
        tracing::debug!("service error reply failed: {e}");
    }
}

/// A pending reply; resolve with `.wait()` or `.await` into where the response's
/// bytes went.
#[must_use = "resolve the reply with .wait() or .await"]
pub struct ReplyBuilder<S> {
    request: ServiceRequest<S>,
    encoded: Result<crate::EncodedPayload, PublishError>,
}

impl<S> ReplyBuilder<S> {
    fn send(self) -> Result<PayloadKind, PublishError> {
        let Self { request, encoded } = self;
        let encoded = match encoded {
            Ok(encoded) => encoded,
            Err(e) => {
                // The client is told rather than left waiting for its timeout.
                request.reply_err(format_args!(
                    "the server could not encode its response: {e}"
                ));
                return Err(e);
            }
        };
        if let Err(e) = inline_limit::check(request.shared.inline_limit, encoded.inline) {
            request.reply_err(format_args!("the server could not send its response: {e}"));
            return Err(e.into());
        }
        let reply = request
            .query
            .reply(request.shared.key_expr.clone(), encoded.bytes)
            .encoding(request.shared.response_encoding.clone());
        let reply = match request.attachment {
            Some(call) => reply.attachment(ZBytes::from(
                Attachment {
                    sequence_number: call.sequence_number,
                    source_timestamp: now_ns(),
                    gid: call.gid,
                }
                .to_bytes(),
            )),
            None => reply,
        };
        reply.wait().map_err(PublishError::Zenoh)?;
        Ok(encoded.kind)
    }
}

impl<S> Resolvable for ReplyBuilder<S> {
    type To = Result<PayloadKind, PublishError>;
}

impl<S> Wait for ReplyBuilder<S> {
    fn wait(self) -> Self::To {
        self.send()
    }
}

impl<S> IntoFuture for ReplyBuilder<S> {
    type Output = Result<PayloadKind, PublishError>;
    type IntoFuture = Pin<Box<dyn Future<Output = Self::Output> + Send>>;
    fn into_future(self) -> Self::IntoFuture {
        // A reply is queued to Zenoh's transmit queue without waiting, as a put is.
        let sent = self.send();
        Box::pin(std::future::ready(sent))
    }
}
