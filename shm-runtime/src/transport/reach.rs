//! Whether the processes that subscribe to a publisher can map its pool.
//!
//! Zenoh maps a sender's shared memory in the receiving process on the first
//! message that needs it, locks it in RAM, and drops the message (with a
//! debug-level log line, nothing else) when it cannot: the memory-lock limit
//! is used up, the open-files limit is reached. The publisher's `put`
//! succeeded; the subscriber never learns a message existed. So before a
//! pool's messages go to a receiving session through shared memory, the pool
//! checks that session once: a query to its probe queryable carrying a small
//! chunk of the pool. A reply says the chunk was mapped, or arrived as bytes
//! because the link between them carries no shared memory (other users,
//! other hosts, a router without it); no reply says the session could not map
//! it. Until a subscriber's session has answered, and for good if it cannot
//! map, the publishers of that pool send from the heap, which every
//! subscriber can read.
//!
//! Receiving sessions announce themselves per key expression with a
//! liveliness token `<key>/@shm_cdr_rx/<zid>/<n>`, so a publisher checks only
//! the sessions that subscribe to what it publishes. Any session can declare
//! any token, so a token counts only once the session it names has confirmed
//! it: a query to that session's probe queryable, answered by that session
//! (Zenoh's replier id) with "I hold it". A token nobody confirms (forged, or
//! its session is gone or denied the probe) holds no message back; while one
//! is being confirmed, messages wait for it only if its session is linked to
//! ours directly (the transport's handshake named it) and has not left a
//! token unconfirmed before. So a peer can hold a topic's messages on the
//! heap only as what it is: a session that really subscribes and cannot map
//! the pool (the trust model is in the guide's security chapter).
//!
//! Subscribers of other ROS 2 implementations (rmw_zenoh_cpp's) answer no
//! probe; a ROS publisher follows their graph tokens instead, and tells how
//! each gets its messages from the transport to its session ([`Links`]):
//! one that carries no shared memory gets copies, which every publish counts.

use std::collections::hash_map::Entry;
use std::collections::{HashMap, HashSet};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, Weak};
use std::time::{Duration, Instant};

use zenoh::liveliness::LivelinessToken;
use zenoh::query::{ConsolidationMode, QueryTarget, Queryable, Reply};
use zenoh::sample::SampleKind;
use zenoh::session::ZenohId;
use zenoh::{Session, Wait};

use crate::rmw::token_session;
use crate::transport::changes::Changes;
use crate::transport::encoded::PayloadKind;
use crate::transport::limits::check_key_expr;
use crate::transport::links::{LinkReach, Links};
use crate::transport::pool::ShmContext;
use crate::transport::reach_table::{backoff, Checked, Reach, Receiver};
use crate::transport::zenoh_line::other_lines_hint;
use crate::ZenohLine;

/// The verbatim chunk between a subscriber's key expression and its session
/// in a receiver token.
const RECEIVER_CHUNK: &str = "@shm_cdr_rx";

/// How long a publisher waits for a subscribing session to confirm its
/// receiver token (past it, the token is taken as unconfirmed and holds
/// nothing back: [`Reach::Unconfirmed`]), and then for its probe's reply
/// (past it, the session is taken as unable to map the pool:
/// [`Reach::CannotMap`]).
pub const PROBE_TIMEOUT: Duration = Duration::from_secs(5);

/// What a probe's reply says.
const MAPPED: &[u8] = b"shm";
const AS_BYTES: &[u8] = b"bytes";

/// The selector parameter that makes a query to a probe queryable a
/// confirmation: its payload is a receiver token's key, and the reply says
/// whether the session holds that token.
const CONFIRM: &str = "confirm";
const HOLDS: &[u8] = b"holds";
const DOES_NOT_HOLD: &[u8] = b"unknown";

/// Every session's probe queryable, shared by its subscribers.
type Responders = HashMap<ZenohId, Weak<Responder>>;
static RESPONDERS: Mutex<Option<Responders>> = Mutex::new(None);

/// Numbers receiver tokens apart within a process.
static NEXT_RECEIVER: AtomicU64 = AtomicU64::new(0);

/// Answers probes and confirmations for one session.
struct Responder {
    /// The receiver tokens the session holds: what a confirmation asks about.
    held: Arc<Mutex<HashSet<String>>>,
    _queryable: Queryable<()>,
}

fn probe_key(session: ZenohId) -> String {
    format!("@shm_cdr/probe/{session}")
}

impl Responder {
    /// The responder of `session`: the one its subscribers share, or a new one.
    fn of(session: &Session) -> zenoh::Result<Arc<Self>> {
        let mut responders = lock(&RESPONDERS);
        let responders = responders.get_or_insert_with(HashMap::new);
        if let Some(responder) = responders.get(&session.zid()).and_then(Weak::upgrade) {
            return Ok(responder);
        }
        responders.retain(|_, r| r.strong_count() > 0);
        let held = Arc::new(Mutex::new(HashSet::new()));
        let tokens = Arc::clone(&held);
        let queryable = session
            .declare_queryable(probe_key(session.zid()))
            .callback(move |query| {
                let answer = if query.parameters().contains_key(CONFIRM) {
                    let key = query.payload().map(|p| p.to_bytes());
                    let holds = key
                        .as_deref()
                        .and_then(|k| std::str::from_utf8(k).ok())
                        .is_some_and(|k| lock(&tokens).contains(k));
                    match holds {
                        true => HOLDS,
                        false => DOES_NOT_HOLD,
                    }
                } else {
                    // Reaching this callback means Zenoh mapped the chunk, or
                    // the link brought it as bytes.
                    match query.payload().is_some_and(|p| p.as_shm().is_some()) {
                        true => MAPPED,
                        false => AS_BYTES,
                    }
                };
                if let Err(e) = query.reply(query.key_expr().clone(), answer).wait() {
                    tracing::debug!("shared-memory probe: could not reply: {e}");
                }
            })
            .wait()?;
        let responder = Arc::new(Self {
            held,
            _queryable: queryable,
        });
        responders.insert(session.zid(), Arc::downgrade(&responder));
        Ok(responder)
    }
}

/// A subscriber's announcement that its session receives `key_expr`: kept
/// for as long as the subscriber lives.
pub(crate) struct ReceiverMark {
    token_key: String,
    _token: LivelinessToken,
    responder: Arc<Responder>,
}

impl ReceiverMark {
    /// Announce that `session` subscribes to `key_expr`, answering probes.
    pub(crate) fn announce(session: &Session, key_expr: &str) -> zenoh::Result<Self> {
        let n = NEXT_RECEIVER.fetch_add(1, Ordering::Relaxed);
        let token_key = format!("{key_expr}/{RECEIVER_CHUNK}/{}/{n}", session.zid());
        check_key_expr("key expression", &token_key)?;
        let responder = Responder::of(session)?;
        // Held before it is declared: a publisher asks as soon as it sees it.
        lock(&responder.held).insert(token_key.clone());
        let token = match session.liveliness().declare_token(&token_key).wait() {
            Ok(token) => token,
            Err(e) => {
                lock(&responder.held).remove(&token_key);
                return Err(e);
            }
        };
        Ok(Self {
            token_key,
            _token: token,
            responder,
        })
    }
}

impl Drop for ReceiverMark {
    fn drop(&mut self) {
        lock(&self.responder.held).remove(&self.token_key);
    }
}

/// The sessions that subscribe to one publisher, followed through their
/// tokens, and the gate they put on its use of shared memory.
pub(crate) struct Receivers {
    shared: Arc<Shared>,
    /// What the gate and the copy count last were: every message through
    /// the pool asks both, and they change only with the receivers' state.
    kept: Mutex<Kept>,
    _subscriber: zenoh::pubsub::Subscriber<()>,
    _ros_subscriber: Option<zenoh::pubsub::Subscriber<()>>,
}

/// The counts of changes to all that [`Receivers::look`] and
/// [`Receivers::copied_to`] read: the receiver tokens and ROS subscribers,
/// the pool's reach table and the session's links.
type Seen = [u64; 3];

/// What [`Receivers::look`] found.
#[derive(Debug, Clone, Copy)]
struct Looked {
    gate: Option<PayloadKind>,
    settled: bool,
    /// When a token or a session is next due to be asked again, if any is
    /// waiting to be: the answer holds until then.
    until: Option<Instant>,
}

/// The last answers, each with the state it was found in.
#[derive(Debug, Default)]
struct Kept {
    look: Option<(Seen, Looked)>,
    copied: Option<(Seen, usize)>,
}

/// Where a receiver token stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Confirmation {
    /// Its session is being asked whether it holds the token, for the
    /// `tries`th time.
    Asking { tries: u32 },
    /// Its session holds it.
    Confirmed,
    /// Its session did not say it holds it, `tries` times in a row, the last
    /// settled `at`.
    Unconfirmed { at: Instant, tries: u32 },
}

/// One receiver token seen by a publisher.
#[derive(Debug, Clone, Copy)]
struct Token {
    /// The session it names.
    session: ZenohId,
    confirmation: Confirmation,
}

impl Token {
    /// Whether an unconfirmed token is due to be asked about again.
    fn due_at(&self, now: Instant) -> bool {
        match self.confirmation {
            Confirmation::Unconfirmed { at, tries } => {
                now.saturating_duration_since(at) >= backoff(tries)
            }
            _ => false,
        }
    }
}

struct Shared {
    session: Session,
    pool: ShmContext,
    key_expr: String,
    /// Alive receiver tokens.
    tokens: Mutex<HashMap<String, Token>>,
    /// Sessions linked to ours that left a receiver token unconfirmed: their
    /// tokens hold nothing back while being confirmed. Bounded by the
    /// transports the session has had.
    distrusted: Mutex<HashSet<ZenohId>>,
    /// Alive graph tokens of ROS subscribers that match, and their session.
    ros_subscribers: Mutex<HashMap<String, ZenohId>>,
    links: Arc<Links>,
    /// Sessions already warned about for getting copies.
    warned: Mutex<Vec<ZenohId>>,
    /// Whether an unconfirmed receiver token was reported at warning level
    /// (later ones are debug lines: forged tokens may come by the thousand).
    warned_unconfirmed: AtomicBool,
    /// Changes to `tokens`, `distrusted` and `ros_subscribers`.
    changes: Changes,
}

fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    // Each entry is written whole.
    mutex.lock().unwrap_or_else(|e| e.into_inner())
}

impl Shared {
    fn tokens(&self) -> MutexGuard<'_, HashMap<String, Token>> {
        lock(&self.tokens)
    }

    /// The counts of changes to what the gate reads, taken before reading it.
    fn seen(&self) -> Seen {
        [
            self.changes.seen(),
            self.pool.reach_table().changes.seen(),
            self.links.changes(),
        ]
    }

    /// Sessions of matching ROS subscribers that announce no receiver token
    /// that stands (being confirmed, or confirmed): they answer no probe.
    fn unprobed(&self) -> Vec<ZenohId> {
        let probed: Vec<ZenohId> = self
            .tokens()
            .values()
            .filter(|t| !matches!(t.confirmation, Confirmation::Unconfirmed { .. }))
            .map(|t| t.session)
            .collect();
        let mut sessions: Vec<ZenohId> = lock(&self.ros_subscribers)
            .values()
            .copied()
            .filter(|zid| !probed.contains(zid))
            .collect();
        sessions.sort_unstable();
        sessions.dedup();
        sessions
    }

    /// How an unprobed session gets the pool's messages.
    fn unprobed_reach(&self, session: ZenohId) -> Reach {
        match self.links.reach(session) {
            LinkReach::SharedMemory => Reach::SharedMemoryUnprobed,
            LinkReach::Bytes => Reach::Bytes,
            LinkReach::Unknown => Reach::Checking,
        }
    }

    /// Whether messages wait for a token of `session` while it is being
    /// confirmed: only if the session is linked to ours (its identity came
    /// from the transport's handshake, not from the token) and has left no
    /// token unconfirmed. Anything else could be any peer's forgery.
    fn held_while_asking(&self, session: ZenohId) -> bool {
        self.links.is_linked(session) && !lock(&self.distrusted).contains(&session)
    }

    /// Say once per session that it gets this publisher's messages as copies.
    fn warn_copies(&self, session: ZenohId) {
        {
            let mut warned = lock(&self.warned);
            if warned.contains(&session) {
                return;
            }
            warned.push(session);
        }
        if self.links.is_local(session) {
            tracing::warn!(
                key_expr = %self.key_expr,
                %session,
                zenoh_line = %ZenohLine::BUILT,
                shm_protocol = ZenohLine::BUILT_SHM_PROTOCOL,
                "a subscribing session on this host is linked without shared memory: it gets each shared-memory message as a copy \
                 (PublishOutcome::copied_to, ShmStats::copied). {}, shared memory is off there (transport/shared_memory/enabled), \
                 or it runs as another user",
                other_lines_hint()
            );
        } else {
            tracing::info!(
                key_expr = %self.key_expr,
                %session,
                "a subscribing session is linked without shared memory (another host, another user, or a router without it): \
                 it gets each shared-memory message as a copy"
            );
        }
    }

    /// Report a receiver token its session did not confirm.
    fn report_unconfirmed(&self, token: &str, session: ZenohId) {
        if self.warned_unconfirmed.swap(true, Ordering::Relaxed) {
            tracing::debug!(key_expr = %self.key_expr, %session, token, "receiver token not confirmed: ignored");
            return;
        }
        tracing::warn!(
            key_expr = %self.key_expr,
            %session,
            token,
            "a shared-memory receiver token was not confirmed by the session it names within {PROBE_TIMEOUT:?}, and is ignored \
             (Reach::Unconfirmed): another session declared it, that session is gone, or an access-control policy denies \
             queries and replies on @shm_cdr/probe/** (the guide's security chapter lists the keys to allow). \
             Later ones are logged at debug level"
        );
    }
}

/// The session named in a receiver token.
fn session_of(token: &str) -> Option<ZenohId> {
    let rest = token.rsplit_once(&format!("/{RECEIVER_CHUNK}/"))?.1;
    rest.split('/').next()?.parse().ok()
}

/// The session a reply came from, as Zenoh's protocol carries it: set by the
/// replying session's Zenoh, not by its application.
fn replier(reply: &Reply) -> Option<ZenohId> {
    reply.replier_id().map(|id| id.zid())
}

impl Receivers {
    /// Follow the sessions that subscribe to `key_expr`, checking each one
    /// against `pool` as it appears; with `ros_subscribers` (the key
    /// expression of the graph tokens of the ROS subscribers that match), also
    /// those that answer no probe.
    pub(crate) fn follow(
        session: &Session,
        key_expr: &str,
        pool: &ShmContext,
        ros_subscribers: Option<&str>,
    ) -> zenoh::Result<Self> {
        let shared = Arc::new(Shared {
            session: session.clone(),
            pool: pool.clone(),
            key_expr: key_expr.to_owned(),
            tokens: Mutex::default(),
            distrusted: Mutex::default(),
            ros_subscribers: Mutex::default(),
            links: Links::of(session)?,
            warned: Mutex::default(),
            warned_unconfirmed: AtomicBool::new(false),
            changes: Changes::default(),
        });
        let ros_subscriber = match ros_subscribers {
            Some(selector) => Some(follow_ros_subscribers(session, selector, &shared)?),
            None => None,
        };
        let selector = format!("{key_expr}/{RECEIVER_CHUNK}/**");
        check_key_expr("key expression", &selector)?;
        let on_sample = Arc::downgrade(&shared);
        // A callback: Zenoh replays every alive token before `wait` returns.
        let subscriber = session
            .liveliness()
            .declare_subscriber(selector)
            .history(true)
            .callback(move |sample| {
                let Some(shared) = on_sample.upgrade() else {
                    return;
                };
                let token = sample.key_expr().as_str();
                let Some(zid) = session_of(token) else {
                    return;
                };
                match sample.kind() {
                    SampleKind::Put => {
                        let new = match shared.tokens().entry(token.to_owned()) {
                            // Seen already (a replayed token): as it stands.
                            Entry::Occupied(_) => false,
                            Entry::Vacant(entry) => {
                                entry.insert(Token {
                                    session: zid,
                                    confirmation: Confirmation::Asking { tries: 0 },
                                });
                                true
                            }
                        };
                        if new {
                            shared.changes.note();
                            confirm(&shared, token, zid, 0);
                        }
                    }
                    SampleKind::Delete => {
                        shared.tokens().remove(token);
                        shared.changes.note();
                    }
                }
            })
            .wait()?;
        Ok(Self {
            shared,
            kept: Mutex::default(),
            _subscriber: subscriber,
            _ros_subscriber: ros_subscriber,
        })
    }

    /// The sessions subscribing now, each with how it receives.
    pub(crate) fn list(&self) -> Vec<Receiver> {
        // Per session, its token that stands best.
        let mut sessions: HashMap<ZenohId, Confirmation> = HashMap::new();
        for token in self.shared.tokens().values() {
            let rank = |c: &Confirmation| match c {
                Confirmation::Confirmed => 2,
                Confirmation::Asking { .. } => 1,
                Confirmation::Unconfirmed { .. } => 0,
            };
            let best = sessions.entry(token.session).or_insert(token.confirmation);
            if rank(&token.confirmation) > rank(best) {
                *best = token.confirmation;
            }
        }
        let unprobed = self.shared.unprobed();
        let mut receivers: Vec<Receiver> = {
            let table = self.shared.pool.reach_table().lock();
            sessions
                .into_iter()
                .filter(|(session, c)| {
                    // An ignored token of a ROS subscriber's session: listed below.
                    !(matches!(c, Confirmation::Unconfirmed { .. }) && unprobed.contains(session))
                })
                .map(|(session, confirmation)| Receiver {
                    session,
                    reach: match confirmation {
                        Confirmation::Confirmed => {
                            table.get(&session).map_or(Reach::Checking, |c| c.reach)
                        }
                        Confirmation::Asking { .. } => Reach::Checking,
                        Confirmation::Unconfirmed { .. } => Reach::Unconfirmed,
                    },
                })
                .collect()
        };
        receivers.extend(unprobed.into_iter().map(|session| Receiver {
            session,
            reach: self.shared.unprobed_reach(session),
        }));
        receivers.sort_unstable_by_key(|r| r.session);
        receivers
    }

    /// How many subscribing sessions get a message sent through the pool as
    /// a copy (their link carries no shared memory), each warned about once.
    pub(crate) fn copied_to(&self) -> usize {
        let seen = self.shared.seen();
        if let Some((at, copied)) = lock(&self.kept).copied {
            if at == seen {
                return copied;
            }
        }
        let copied = self.count_copied();
        lock(&self.kept).copied = Some((seen, copied));
        copied
    }

    /// [`copied_to`](Self::copied_to), found again.
    fn count_copied(&self) -> usize {
        let mut copied: Vec<ZenohId> = Vec::new();
        {
            // Lock order: tokens, then the pool's table (as `probe` takes them).
            let tokens = self.shared.tokens();
            let table = self.shared.pool.reach_table().lock();
            for token in tokens.values() {
                if token.confirmation != Confirmation::Confirmed {
                    continue;
                }
                let session = token.session;
                let bytes = table.get(&session).is_some_and(|c| c.reach == Reach::Bytes);
                if bytes && !copied.contains(&session) {
                    copied.push(session);
                }
            }
        }
        if !lock(&self.shared.ros_subscribers).is_empty() {
            copied.extend(
                self.shared
                    .unprobed()
                    .into_iter()
                    .filter(|s| self.shared.unprobed_reach(*s) == Reach::Bytes),
            );
        }
        for session in &copied {
            self.shared.warn_copies(*session);
        }
        copied.len()
    }

    /// Why a message above the threshold must go from the heap now, if it
    /// must: a subscribing session not yet checked, or one that cannot map
    /// the pool. Starts the checks and confirmations that are due.
    pub(crate) fn gate(&self) -> Option<PayloadKind> {
        self.look().0
    }

    /// Whether every receiver token has been confirmed or not, and every
    /// confirmed session has answered its probe or not (starting the checks
    /// that are due): what [`wait_for_subscribers`](crate::RosPublisher::wait_for_subscribers) waits for.
    pub(crate) fn settled(&self) -> bool {
        self.look().1
    }

    /// The gate, and whether every check has settled: found again only
    /// when something it reads changed, or a check fell due.
    fn look(&self) -> (Option<PayloadKind>, bool) {
        let seen = self.shared.seen();
        if let Some((at, looked)) = lock(&self.kept).look {
            if at == seen && looked.until.is_none_or(|until| Instant::now() < until) {
                return (looked.gate, looked.settled);
            }
        }
        let looked = self.look_again();
        lock(&self.kept).look = Some((seen, looked));
        (looked.gate, looked.settled)
    }

    /// [`look`](Self::look), found again, starting the checks that are due.
    fn look_again(&self) -> Looked {
        let mut gate = None;
        let mut settled = true;
        let mut until: Option<Instant> = None;
        let mut wait_until = |at: Instant| until = Some(until.map_or(at, |u| u.min(at)));
        let mut due_probes = Vec::new();
        let mut due_confirmations = Vec::new();
        {
            // Lock order: tokens, then the pool's table (as `probe` takes them).
            let mut tokens = self.shared.tokens();
            if tokens.is_empty() {
                return Looked {
                    gate: None,
                    settled: true,
                    until: None,
                };
            }
            let now = Instant::now();
            let table = self.shared.pool.reach_table().lock();
            for (key, token) in tokens.iter_mut() {
                let session = token.session;
                match token.confirmation {
                    Confirmation::Asking { .. } => {
                        settled = false;
                        if self.shared.held_while_asking(session) {
                            gate = gate.or(Some(PayloadKind::ReceiverPending));
                        }
                        continue;
                    }
                    Confirmation::Unconfirmed { at, tries } => {
                        if token.due_at(now) {
                            token.confirmation = Confirmation::Asking { tries };
                            due_confirmations.push((key.clone(), session, tries));
                        } else {
                            wait_until(at + backoff(tries));
                        }
                        continue;
                    }
                    Confirmation::Confirmed => {}
                }
                match table.get(&session) {
                    None => {
                        due_probes.push(session);
                        settled = false;
                        gate = gate.or(Some(PayloadKind::ReceiverPending));
                    }
                    Some(checked) => match checked.reach {
                        Reach::Checking => {
                            settled = false;
                            gate = gate.or(Some(PayloadKind::ReceiverPending));
                        }
                        Reach::CannotMap => {
                            if checked.due_at(now) {
                                due_probes.push(session);
                            } else {
                                wait_until(checked.at + backoff(checked.failures));
                            }
                            gate = Some(PayloadKind::ReceiverCannotMap);
                        }
                        Reach::SharedMemory
                        | Reach::Bytes
                        | Reach::SharedMemoryUnprobed
                        | Reach::Unconfirmed => {}
                    },
                }
            }
        }
        if !due_confirmations.is_empty() {
            self.shared.changes.note();
        }
        for session in due_probes {
            probe(&self.shared, session);
        }
        for (key, session, tries) in due_confirmations {
            confirm(&self.shared, &key, session, tries);
        }
        Looked {
            gate,
            settled,
            until,
        }
    }
}

/// Follow the graph tokens of the ROS subscribers matching `selector`.
fn follow_ros_subscribers(
    session: &Session,
    selector: &str,
    shared: &Arc<Shared>,
) -> zenoh::Result<zenoh::pubsub::Subscriber<()>> {
    let own = session.zid();
    let on_sample = Arc::downgrade(shared);
    session
        .liveliness()
        .declare_subscriber(selector)
        .history(true)
        .callback(move |sample| {
            let Some(shared) = on_sample.upgrade() else {
                return;
            };
            let token = sample.key_expr().as_str();
            let Some(zid) = token_session(token).filter(|zid| *zid != own) else {
                return;
            };
            {
                let mut subscribers = lock(&shared.ros_subscribers);
                match sample.kind() {
                    SampleKind::Put => {
                        subscribers.insert(token.to_owned(), zid);
                    }
                    SampleKind::Delete => {
                        subscribers.remove(token);
                    }
                }
            }
            shared.changes.note();
        })
        .wait()
}

/// Ask `session` whether it holds the receiver token `token` (the
/// `tries + 1`th time); once it says so, its pool check starts.
fn confirm(shared: &Arc<Shared>, token: &str, session: ZenohId, tries: u32) {
    let settle = Confirming {
        shared: Arc::downgrade(shared),
        token: token.to_owned(),
        session,
        tries,
        holds: AtomicBool::new(false),
    };
    let sent = shared
        .session
        .get(format!("{}?{CONFIRM}", probe_key(session)))
        .payload(token.as_bytes().to_vec())
        // Every queryable on the key, and every reply: one forged answer
        // must not hide the real one.
        .target(QueryTarget::All)
        .consolidation(ConsolidationMode::None)
        .timeout(PROBE_TIMEOUT)
        .callback(move |reply| {
            let holds = replier(&reply) == Some(session)
                && reply
                    .result()
                    .is_ok_and(|sample| &*sample.payload().to_bytes() == HOLDS);
            if holds {
                settle.holds.store(true, Ordering::Relaxed);
            }
        })
        .wait();
    if let Err(e) = sent {
        // Settled as unconfirmed by the dropped callback; asked again later.
        tracing::debug!("receiver token confirmation of session {session}: {e}");
    }
}

/// Settles a confirmation when Zenoh drops its reply callback: after the
/// replies and the final, or at the timeout.
struct Confirming {
    shared: Weak<Shared>,
    token: String,
    session: ZenohId,
    tries: u32,
    holds: AtomicBool,
}

impl Drop for Confirming {
    fn drop(&mut self) {
        let Some(shared) = self.shared.upgrade() else {
            return;
        };
        let holds = *self.holds.get_mut();
        {
            let mut tokens = shared.tokens();
            // Gone meanwhile: nothing to settle.
            let Some(token) = tokens.get_mut(&self.token) else {
                return;
            };
            token.confirmation = match holds {
                true => Confirmation::Confirmed,
                false => Confirmation::Unconfirmed {
                    at: Instant::now(),
                    tries: self.tries.saturating_add(1),
                },
            };
        }
        if holds {
            lock(&shared.distrusted).remove(&self.session);
            shared.changes.note();
            probe(&shared, self.session);
        } else {
            if shared.links.is_linked(self.session) {
                lock(&shared.distrusted).insert(self.session);
            }
            shared.changes.note();
            shared.report_unconfirmed(&self.token, self.session);
        }
    }
}

/// Ask `session` whether it maps `shared`'s pool, unless a check is under
/// way or settled (a failed one is repeated after a backoff, see
/// [`RETRY_AFTER`](crate::transport::reach_table::RETRY_AFTER)).
fn probe(shared: &Shared, session: ZenohId) {
    let pool = &shared.pool;
    let failures = {
        let mut table = pool.reach_table().lock();
        let failures = match table.get(&session) {
            None => 0,
            Some(checked) if checked.due() => checked.failures,
            Some(_) => return,
        };
        // Keep showing `CannotMap` while it is asked again.
        let reach = match failures {
            0 => Reach::Checking,
            _ => Reach::CannotMap,
        };
        table.insert(
            session,
            Checked {
                reach,
                at: Instant::now(),
                failures,
            },
        );
        failures
    };
    pool.reach_table().changes.note();
    // Never wait for room here (this may run on Zenoh's thread): with the
    // pool full, the next publish asks again.
    let Some(mut chunk) = pool.alloc_message(8, Duration::ZERO) else {
        forget(pool, session, failures);
        return;
    };
    chunk.fill(0);
    let verdict = Verdict {
        pool: pool.clone(),
        session,
        key_expr: shared.key_expr.clone(),
        answer: Mutex::new(None),
    };
    let sent = shared
        .session
        .get(probe_key(session))
        .payload(chunk)
        .target(QueryTarget::All)
        .consolidation(ConsolidationMode::None)
        .timeout(PROBE_TIMEOUT)
        .callback(move |reply| {
            // Only the session asked about answers for it.
            if replier(&reply) != Some(session) {
                return;
            }
            if let Ok(sample) = reply.result() {
                let reach = match &*sample.payload().to_bytes() {
                    MAPPED => Reach::SharedMemory,
                    _ => Reach::Bytes,
                };
                *lock(&verdict.answer) = Some(reach);
            }
        })
        .wait();
    if let Err(e) = sent {
        tracing::debug!("shared-memory probe of session {session}: {e}");
        forget(pool, session, failures);
    }
}

/// A probe that could not be sent: asked again on the next publish (or, after
/// failures, at the next backoff).
fn forget(pool: &ShmContext, session: ZenohId, failures: u32) {
    let table = pool.reach_table();
    match failures {
        0 => {
            table.lock().remove(&session);
            table.changes.note();
        }
        _ => table.set(
            session,
            Checked {
                reach: Reach::CannotMap,
                at: Instant::now(),
                failures,
            },
        ),
    }
}

/// Settles a probe when Zenoh drops its reply callback: after the reply and
/// the final, or at the timeout with none.
struct Verdict {
    pool: ShmContext,
    session: ZenohId,
    key_expr: String,
    answer: Mutex<Option<Reach>>,
}

impl Drop for Verdict {
    fn drop(&mut self) {
        let answer = self.answer.get_mut().unwrap_or_else(|e| e.into_inner());
        let reach = answer.unwrap_or(Reach::CannotMap);
        let first_failure = {
            let mut table = self.pool.reach_table().lock();
            let failures = match reach {
                Reach::CannotMap => table.get(&self.session).map_or(0, |c| c.failures) + 1,
                _ => 0,
            };
            table.insert(
                self.session,
                Checked {
                    reach,
                    at: Instant::now(),
                    failures,
                },
            );
            failures == 1
        };
        self.pool.reach_table().changes.note();
        if first_failure {
            tracing::warn!(
                key_expr = %self.key_expr,
                session = %self.session,
                pool_size = self.pool.pool_size().unwrap_or(0),
                "a subscriber's process could not map this shared-memory pool (no answer to the probe within {PROBE_TIMEOUT:?}): \
                 messages to it go from the heap, so that it gets every one (ShmStats::cannot_map counts them); asked again after 30 s, then less and less often. \
                 That process's log names the cause; most often its memory-lock limit (RLIMIT_MEMLOCK) is used up \
                 by the segments it maps: raise it there, or make the publishers' pools smaller"
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_session_that_cannot_map_is_asked_again_less_and_less_often() {
        let at = Instant::now();
        let due = |reach, failures, secs| {
            Checked {
                reach,
                at,
                failures,
            }
            .due_at(at + Duration::from_secs(secs))
        };
        assert!(due(Reach::CannotMap, 1, 31));
        assert!(!due(Reach::CannotMap, 2, 31));
        assert!(due(Reach::CannotMap, 2, 61));
        assert!(!due(Reach::CannotMap, 30, 3599));
        assert!(due(Reach::CannotMap, 30, 3601));
        assert!(!due(Reach::SharedMemory, 0, 7200));
        assert!(!due(Reach::Checking, 0, 7200));
    }

    /// A session's receivers on a pool, with a token of `other`'s confirmed
    /// and `other` unable to map the pool since `at` (one failure).
    fn receivers_of_one_that_cannot_map(at: Instant) -> (Session, ShmContext, Receivers, ZenohId) {
        let port = crate::testing::free_port().unwrap();
        let session = zenoh::open(crate::testing::peer_config(port, true).unwrap())
            .wait()
            .unwrap();
        let pool = ShmContext::new(crate::ShmConfig::enabled().pool_size(1 << 20)).unwrap();
        let receivers = Receivers::follow(&session, "kept/gate", &pool, None).unwrap();
        let other: ZenohId = "a1b2c3".parse().unwrap();
        let checked = Checked {
            reach: Reach::CannotMap,
            at,
            failures: 1,
        };
        pool.reach_table().set(other, checked);
        receivers.shared.tokens().insert(
            format!("kept/gate/{RECEIVER_CHUNK}/{other}/0"),
            Token {
                session: other,
                confirmation: Confirmation::Confirmed,
            },
        );
        (session, pool, receivers, other)
    }

    #[test]
    fn the_kept_gate_is_found_again_after_a_change_is_noted() {
        let (_session, _pool, receivers, _) = receivers_of_one_that_cannot_map(Instant::now());
        // The token went in without a note: the answer kept from before stands.
        receivers.shared.tokens().clear();
        assert_eq!(receivers.gate(), None);
        receivers.shared.tokens().insert(
            format!("kept/gate/{RECEIVER_CHUNK}/a1b2c3/0"),
            Token {
                session: "a1b2c3".parse().unwrap(),
                confirmation: Confirmation::Confirmed,
            },
        );
        assert_eq!(receivers.gate(), None, "kept while nothing was noted");
        receivers.shared.changes.note();
        assert_eq!(receivers.gate(), Some(PayloadKind::ReceiverCannotMap));
        assert_eq!(receivers.copied_to(), 0);
    }

    #[test]
    fn the_kept_gate_is_found_again_when_a_session_falls_due_for_a_probe() {
        // Due again in 300 ms.
        let at = Instant::now().checked_sub(backoff(1)).unwrap() + Duration::from_millis(300);
        let (_session, pool, receivers, other) = receivers_of_one_that_cannot_map(at);
        let asked_at = || pool.reach_table().lock().get(&other).map(|c| c.at);
        assert_eq!(receivers.gate(), Some(PayloadKind::ReceiverCannotMap));
        assert_eq!(asked_at(), Some(at), "not due yet: not asked");
        std::thread::sleep(Duration::from_millis(400));
        // Nothing changed meanwhile, but the check fell due: asked again
        // (showing CannotMap while it is).
        assert_eq!(receivers.gate(), Some(PayloadKind::ReceiverCannotMap));
        assert!(
            asked_at().is_some_and(|again| again > at),
            "due: asked again"
        );
    }

    #[test]
    fn a_receiver_token_names_its_session() {
        let zid: ZenohId = "a1b2c3".parse().unwrap();
        assert_eq!(
            session_of(&format!("0/chatter/{RECEIVER_CHUNK}/{zid}/7")),
            Some(zid)
        );
        assert_eq!(
            session_of(&format!("demo/**/{RECEIVER_CHUNK}/{zid}/0")),
            Some(zid)
        );
        assert_eq!(session_of("0/chatter"), None);
        assert_eq!(session_of(&format!("a/{RECEIVER_CHUNK}/not-hex/1")), None);
    }
}
