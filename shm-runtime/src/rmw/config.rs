//! Zenoh configuration as rmw_zenoh_cpp reads it, so that a program of this
//! crate joins whatever system an rmw_zenoh_cpp node joins from the same
//! environment: a secured one (TLS, authentication, access control, as
//! `zenoh_security_tools` generates per enclave), one over other transports,
//! one with its router elsewhere. Every rmw_zenoh_cpp release (Humble 0.1.9
//! to Rolling 0.12.0) reads the same variables:
//!
//! - [`SESSION_CONFIG_URI`] (`ZENOH_SESSION_CONFIG_URI`) and
//!   [`ROUTER_CONFIG_URI`] (`ZENOH_ROUTER_CONFIG_URI`): a JSON5 file to start
//!   from. Unset, rmw_zenoh_cpp's default configuration
//!   ([`default_session_config`], [`default_router_config`]).
//! - [`CONFIG_OVERRIDE`] (`ZENOH_CONFIG_OVERRIDE`): `key=value` pairs
//!   separated by `;`, each value JSON5, set on top (`mode="client";
//!   connect/endpoints=["tls/10.0.0.1:7447"]`). rmw_zenoh_cpp ignores a pair
//!   it cannot set, with a warning; here it is an error naming the pair.
//! - [`SHM_ALLOC_SIZE`] (`ZENOH_SHM_ALLOC_SIZE`) and
//!   [`SHM_MESSAGE_SIZE_THRESHOLD`] (`ZENOH_SHM_MESSAGE_SIZE_THRESHOLD`): a
//!   session's `transport/shared_memory/transport_optimization/pool_size`
//!   and `message_size_threshold`, set last. rmw_zenoh_cpp's own publishers
//!   use that pool and threshold; this crate's publishers have pools of their
//!   own ([`crate::ShmContext`]), so these size only Zenoh's pool.
//! - [`ROUTER_CHECK_ATTEMPTS`] (`ZENOH_ROUTER_CHECK_ATTEMPTS`): how many
//!   times, a second apart, a session looks for its router before going on
//!   without one (default 1; 0: until there is one; negative: not at all).
//!
//! rmw_zenoh_cpp uses the enclave (`--ros-args --enclave`) only in its
//! graph tokens ([`crate::RosNodeBuilder::enclave`]); the security of an
//! enclave is the session configuration `zenoh_security_tools` writes for
//! it, given through `ZENOH_SESSION_CONFIG_URI`.

use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Duration;

use zenoh::{Config, Session};

/// The variable naming the session configuration file.
pub const SESSION_CONFIG_URI: &str = "ZENOH_SESSION_CONFIG_URI";
/// The variable naming the router configuration file.
pub const ROUTER_CONFIG_URI: &str = "ZENOH_ROUTER_CONFIG_URI";
/// The variable with `key=value;…` pairs set on top of either configuration.
pub const CONFIG_OVERRIDE: &str = "ZENOH_CONFIG_OVERRIDE";
/// The variable with the size in bytes of Zenoh's shared-memory pool.
pub const SHM_ALLOC_SIZE: &str = "ZENOH_SHM_ALLOC_SIZE";
/// The variable with the size in bytes from which Zenoh's pool is used (a
/// power of two).
pub const SHM_MESSAGE_SIZE_THRESHOLD: &str = "ZENOH_SHM_MESSAGE_SIZE_THRESHOLD";
/// The variable with the number of router checks.
pub const ROUTER_CHECK_ATTEMPTS: &str = "ZENOH_ROUTER_CHECK_ATTEMPTS";
/// Where a session looks for its router by default (rmw_zenohd's port).
pub const DEFAULT_ROUTER_ENDPOINT: &str = "tcp/localhost:7447";

/// What rmw_zenoh_cpp's default session and router configurations
/// (`config/DEFAULT_RMW_ZENOH_SESSION_CONFIG.json5` and
/// `DEFAULT_RMW_ZENOH_ROUTER_CONFIG.json5`, the same in every release from
/// Humble 0.1.9 to Rolling 0.12.0) both set, as Zenoh reads them, wherever
/// that differs from Zenoh's own default configuration: no multicast,
/// gossip to routers only, long timeouts and lease, more sessions, the
/// admin space, timestamps, shared memory off with a 48 MiB pool for Zenoh's
/// copies of large payloads. Keys Zenoh leaves unset (`null`) are set as the
/// files set them, though most equal what Zenoh assumes, so that the
/// configuration is the files' whatever Zenoh line reads it.
/// A test compares the result with a release's files (the directory
/// `config` of an rmw_zenoh_cpp release in `RMW_ZENOH_CPP_CONFIG`, then
/// `cargo test -p shm-runtime --lib -- --ignored a_release_s_files`).
const COMMON_DEFAULTS: &[(&str, &str)] = &[
    ("adminspace/enabled", "true"),
    ("connect/timeout_ms", "{ router: -1, peer: -1, client: 0 }"),
    (
        "connect/exit_on_failure",
        "{ router: false, peer: false, client: true }",
    ),
    (
        "connect/retry",
        "{ period_init_ms: 1000, period_max_ms: 4000, period_increase_factor: 2.0 }",
    ),
    ("listen/timeout_ms", "0"),
    ("listen/exit_on_failure", "true"),
    (
        "listen/retry",
        "{ period_init_ms: 1000, period_max_ms: 4000, period_increase_factor: 2.0 }",
    ),
    (
        "open/return_conditions",
        "{ connect_scouted: true, declares: true }",
    ),
    ("scouting/timeout", "3000"),
    ("scouting/delay", "500"),
    ("scouting/multicast/enabled", "false"),
    ("scouting/multicast/address", r#""224.0.0.224:7446""#),
    ("scouting/multicast/interface", r#""auto""#),
    ("scouting/multicast/ttl", "1"),
    ("scouting/multicast/listen", "true"),
    (
        "scouting/multicast/autoconnect",
        r#"{ router: [], peer: ["router", "peer"], client: ["router"] }"#,
    ),
    ("scouting/gossip/enabled", "true"),
    ("scouting/gossip/multihop", "false"),
    (
        "scouting/gossip/target",
        r#"{ router: ["router", "peer"], peer: ["router"] }"#,
    ),
    (
        "scouting/gossip/autoconnect",
        r#"{ router: [], peer: ["router", "peer"] }"#,
    ),
    (
        "timestamping/enabled",
        "{ router: true, peer: true, client: true }",
    ),
    ("timestamping/drop_future_timestamp", "false"),
    ("queries_default_timeout", "600000"),
    ("routing/interests/timeout", "10000"),
    ("transport/unicast/open_timeout", "60000"),
    ("transport/unicast/accept_timeout", "60000"),
    ("transport/unicast/accept_pending", "10000"),
    ("transport/unicast/max_sessions", "10000"),
    ("transport/unicast/max_links", "1"),
    ("transport/link/tx/lease", "60000"),
    ("transport/link/tx/keep_alive", "2"),
    ("transport/link/tls/enable_mtls", "false"),
    ("transport/link/tls/verify_name_on_connect", "true"),
    ("transport/link/tls/close_link_on_expiration", "false"),
    ("transport/shared_memory/enabled", "false"),
    (
        "transport/shared_memory/transport_optimization/pool_size",
        "50331648",
    ),
    (
        "transport/shared_memory/transport_optimization/message_size_threshold",
        "512",
    ),
];

/// The session file's own settings: a peer that reaches the others through
/// the router at [`DEFAULT_ROUTER_ENDPOINT`] and listens on a local port of
/// its own, connecting to a peer it learns of only if its id is the greater
/// one, and blocking a congested publisher for up to a minute before
/// dropping; then the two places where this crate's sessions differ from
/// rmw_zenoh_cpp's (`DIFFERENCES_FROM_THE_RELEASE` in the tests holds the release's
/// values).
const SESSION_DEFAULTS: &[(&str, &str)] = &[
    ("mode", r#""peer""#),
    ("connect/endpoints", r#"["tcp/localhost:7447"]"#),
    ("listen/endpoints", r#"["tcp/localhost:0"]"#),
    (
        "scouting/multicast/autoconnect_strategy",
        r#"{ peer: { to_router: "always", to_peer: "greater-zid" } }"#,
    ),
    (
        "scouting/gossip/autoconnect_strategy",
        r#"{ peer: { to_router: "always", to_peer: "greater-zid" } }"#,
    ),
    (
        "transport/link/tx/queue/congestion_control/block/wait_before_close",
        "60000000",
    ),
    // Shared memory on, where rmw_zenoh_cpp ships it off.
    ("transport/shared_memory/enabled", "true"),
    // Zenoh's implicit copy of large heap payloads into a pool of its own,
    // whose collection can overwrite a sample a stalled reader holds (the
    // guide's Reliability chapter): off, as the guide says for every session.
    (
        "transport/shared_memory/transport_optimization/enabled",
        "false",
    ),
    // A peer gossips to peers as well as to routers (Zenoh's default, where
    // rmw_zenoh_cpp gossips to routers only), so that peers joined to one
    // another without a router still find each other.
    (
        "scouting/gossip/target",
        r#"{ router: ["router", "peer"], peer: ["router", "peer"] }"#,
    ),
];

/// Where [`default_session_config`] differs from rmw_zenoh_cpp's default
/// session configuration, each key with its value there; the router's
/// configuration has no difference.
#[cfg(test)]
const DIFFERENCES_FROM_THE_RELEASE: &[(&str, &str)] = &[
    ("transport/shared_memory/enabled", "false"),
    (
        "transport/shared_memory/transport_optimization/enabled",
        "true",
    ),
    (
        "scouting/gossip/target",
        r#"{ router: ["router", "peer"], peer: ["router"] }"#,
    ),
];

/// The router file's own settings: rmw_zenohd on port 7447 of every
/// interface, gossiping to routers and peers.
const ROUTER_DEFAULTS: &[(&str, &str)] = &[
    ("mode", r#""router""#),
    ("connect/endpoints", "[]"),
    ("listen/endpoints", r#"["tcp/[::]:7447"]"#),
    (
        "scouting/multicast/autoconnect_strategy",
        r#"{ router: { to_router: "always", to_peer: "always" } }"#,
    ),
    (
        "scouting/gossip/autoconnect_strategy",
        r#"{ router: { to_router: "always", to_peer: "always" } }"#,
    ),
];

/// What went wrong reading the configuration; each says what to change.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RmwConfigError {
    /// The file a variable names could not be read as a Zenoh configuration.
    File {
        /// The variable (or the option standing for it).
        variable: &'static str,
        /// The file it names.
        path: PathBuf,
        /// Zenoh's words.
        reason: String,
    },
    /// A `key=value` pair of `ZENOH_CONFIG_OVERRIDE` could not be set.
    Override {
        /// The pair as given.
        pair: String,
        /// Why it could not be set.
        reason: String,
    },
    /// `ZENOH_ROUTER_CHECK_ATTEMPTS` is not a whole number.
    Attempts(String),
    /// A variable's value is not Unicode.
    NotUnicode(&'static str),
}

impl fmt::Display for RmwConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::File {
                variable,
                path,
                reason,
            } if variable.starts_with("--") => write!(
                f,
                "{variable} {}: not a Zenoh configuration ({reason}); give the path of a JSON5 \
                 Zenoh configuration file",
                path.display()
            ),
            Self::File {
                variable,
                path,
                reason,
            } => write!(
                f,
                "{variable}={}: not a Zenoh configuration ({reason}); give the path of a JSON5 \
                 Zenoh configuration file, or unset {variable} for rmw_zenoh_cpp's default",
                path.display()
            ),
            Self::Override { pair, reason } => write!(
                f,
                "{CONFIG_OVERRIDE}: `{pair}` cannot be set ({reason}); write `key=value` pairs \
                 separated by `;`, each key a path in the Zenoh configuration \
                 (`connect/endpoints`) and each value JSON5 (`[\"tls/host:7447\"]`, `\"client\"`)"
            ),
            Self::Attempts(value) => write!(
                f,
                "{ROUTER_CHECK_ATTEMPTS}={value}: give a whole number (N: check N times a second \
                 apart, 0: until a router is there, negative: do not check)"
            ),
            Self::NotUnicode(variable) => write!(f, "{variable} is not valid Unicode"),
        }
    }
}

impl std::error::Error for RmwConfigError {}

/// Zenoh's words in an error, without what is only for Zenoh's developers:
/// the source locations (` at /…/file.rs:132.`) and the Rust debug wrapping
/// of the JSON5 parser's message (`Json5Err(Message { msg: "…", … })`).
pub fn zenoh_reason(error: &dyn fmt::Display) -> String {
    let text = error.to_string();
    let mut out = String::with_capacity(text.len());
    let mut rest = text.as_str();
    while let Some(at) = rest.find(" at ") {
        out.push_str(&rest[..at]);
        let after = &rest[at + 4..];
        // ` at <path>.rs:<line>` and a full stop after it, if there is one.
        let location = after
            .find(".rs:")
            .filter(|end| !after[..*end].contains(char::is_whitespace))
            .map(|end| {
                let digits = after[end + 4..]
                    .find(|c: char| !c.is_ascii_digit())
                    .unwrap_or(after.len() - end - 4);
                let mut len = end + 4 + digits;
                if after[len..].starts_with('.') {
                    len += 1;
                }
                len
            });
        match location {
            Some(len) if len > 0 => rest = &after[len..],
            _ => {
                out.push_str(" at ");
                rest = after;
            }
        }
    }
    out.push_str(rest);
    // The parser's own message, out of its debug form.
    if let Some(message) = out
        .strip_prefix("Json5Err(Message { msg: \"")
        .and_then(|m| m.split_once("\", location:"))
        .map(|(m, _)| m.replace("\\\"", "\""))
    {
        out = message;
    }
    if let Some(message) = out
        .strip_prefix("Str(\"")
        .and_then(|m| m.strip_suffix("\")"))
    {
        out = message.to_owned();
    }
    let out = out.trim_end_matches(['.', ' ']).to_owned();
    match out.as_str() {
        "unknown key" => "no such key in Zenoh's configuration".to_owned(),
        _ => out,
    }
}

fn variable(name: &'static str) -> Result<Option<String>, RmwConfigError> {
    match std::env::var(name) {
        Ok(value) if value.is_empty() => Ok(None),
        Ok(value) => Ok(Some(value)),
        Err(std::env::VarError::NotPresent) => Ok(None),
        Err(std::env::VarError::NotUnicode(_)) => Err(RmwConfigError::NotUnicode(name)),
    }
}

fn with_defaults(defaults: &[(&str, &str)]) -> Config {
    let mut config = Config::default();
    for (key, value) in COMMON_DEFAULTS.iter().chain(defaults) {
        // The table is this crate's own and checked by its tests.
        let _ = config.insert_json5(key, value);
    }
    config
}

/// rmw_zenoh_cpp's default session configuration (see the module's
/// documentation), shared memory on.
pub fn default_session_config() -> Config {
    with_defaults(SESSION_DEFAULTS)
}

/// rmw_zenohd's default router configuration.
pub fn default_router_config() -> Config {
    with_defaults(ROUTER_DEFAULTS)
}

/// The session configuration an rmw_zenoh_cpp node would use in this
/// environment: the file `ZENOH_SESSION_CONFIG_URI` names (else
/// [`default_session_config`]), then `ZENOH_CONFIG_OVERRIDE`.
pub fn session_config() -> Result<Config, RmwConfigError> {
    session_config_from(None)
}

/// [`session_config`] starting from `file` when it is given (a
/// command line's `--zenoh-config`, which its error names) instead of the
/// one `ZENOH_SESSION_CONFIG_URI` names.
pub fn session_config_from(file: Option<&Path>) -> Result<Config, RmwConfigError> {
    let mut config = from_env(
        SESSION_CONFIG_URI,
        "--zenoh-config",
        file,
        default_session_config,
    )?;
    apply_shm_variables(
        &mut config,
        variable(SHM_ALLOC_SIZE)?.as_deref(),
        variable(SHM_MESSAGE_SIZE_THRESHOLD)?.as_deref(),
    );
    Ok(config)
}

/// `ZENOH_SHM_ALLOC_SIZE` and `ZENOH_SHM_MESSAGE_SIZE_THRESHOLD` (given as
/// `alloc_size` and `threshold`) set on top of a session's configuration, as
/// rmw_zenoh_cpp sets them. A value that is not a positive whole number, or
/// a threshold that is not a power of two, is left out with a warning naming
/// it, as rmw_zenoh_cpp leaves it out with an error in its log.
fn apply_shm_variables(config: &mut Config, alloc_size: Option<&str>, threshold: Option<&str>) {
    const POOL_SIZE: &str = "transport/shared_memory/transport_optimization/pool_size";
    const THRESHOLD: &str = "transport/shared_memory/transport_optimization/message_size_threshold";
    for (variable, key, value, power_of_two) in [
        (SHM_ALLOC_SIZE, POOL_SIZE, alloc_size, false),
        (SHM_MESSAGE_SIZE_THRESHOLD, THRESHOLD, threshold, true),
    ] {
        let Some(value) = value else { continue };
        match value.trim().parse::<u64>() {
            Ok(bytes) if bytes > 0 && (!power_of_two || bytes.is_power_of_two()) => {
                if let Err(e) = config.insert_json5(key, &bytes.to_string()) {
                    tracing::warn!("{variable}={value} left out: {}", zenoh_reason(&e));
                }
            }
            _ => tracing::warn!(
                "{variable}={value} left out: give a positive whole number of bytes{}",
                if power_of_two {
                    " that is a power of two"
                } else {
                    ""
                }
            ),
        }
    }
}

/// The router configuration rmw_zenohd would use in this environment: the
/// file `ZENOH_ROUTER_CONFIG_URI` names (else [`default_router_config`]),
/// then `ZENOH_CONFIG_OVERRIDE`.
pub fn router_config() -> Result<Config, RmwConfigError> {
    router_config_from(None)
}

/// [`router_config`] starting from `file` when it is given (a command
/// line's `--config`, which its error names) instead of the one
/// `ZENOH_ROUTER_CONFIG_URI` names.
pub fn router_config_from(file: Option<&Path>) -> Result<Config, RmwConfigError> {
    from_env(ROUTER_CONFIG_URI, "--config", file, default_router_config)
}

/// `file` (given by `option`), else the one the variable `uri` names, else
/// `defaults`; then `ZENOH_CONFIG_OVERRIDE`.
fn from_env(
    uri: &'static str,
    option: &'static str,
    file: Option<&Path>,
    defaults: fn() -> Config,
) -> Result<Config, RmwConfigError> {
    let (source, named) = match file {
        Some(file) => (option, Some(file.to_owned())),
        None => (uri, variable(uri)?.map(PathBuf::from)),
    };
    configure(
        source,
        named.as_deref(),
        defaults,
        variable(CONFIG_OVERRIDE)?.as_deref(),
    )
}

/// A configuration from `file` (as the variable `variable` gives it) or the
/// defaults, with `overrides` set on top.
pub fn configure(
    variable: &'static str,
    file: Option<&Path>,
    defaults: impl FnOnce() -> Config,
    overrides: Option<&str>,
) -> Result<Config, RmwConfigError> {
    let mut config = match file {
        Some(path) => Config::from_file(path).map_err(|e| RmwConfigError::File {
            variable,
            path: path.to_owned(),
            reason: zenoh_reason(&e),
        })?,
        None => defaults(),
    };
    if let Some(overrides) = overrides {
        apply_override(&mut config, overrides)?;
    }
    Ok(config)
}

/// Set the `key=value;…` pairs of `ZENOH_CONFIG_OVERRIDE` in `config`, as
/// rmw_zenoh_cpp splits them (at each `;`, then at a pair's first `=`); a
/// pair that cannot be set is an error naming it.
pub fn apply_override(config: &mut Config, overrides: &str) -> Result<(), RmwConfigError> {
    for pair in overrides.split(';') {
        if pair.trim().is_empty() {
            continue;
        }
        let Some((key, value)) = pair.split_once('=') else {
            return Err(RmwConfigError::Override {
                pair: pair.to_owned(),
                reason: "no `=` in it".to_owned(),
            });
        };
        config
            .insert_json5(key.trim(), value.trim())
            .map_err(|e| RmwConfigError::Override {
                pair: pair.to_owned(),
                reason: zenoh_reason(&e),
            })?;
    }
    Ok(())
}

/// How a session looks for its router.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RouterCheck {
    /// Not at all.
    Skip,
    /// Up to this many times, a second apart.
    Attempts(u64),
    /// Until there is one.
    Forever,
}

impl RouterCheck {
    /// From `ZENOH_ROUTER_CHECK_ATTEMPTS` (unset: once).
    pub fn from_env() -> Result<Self, RmwConfigError> {
        match variable(ROUTER_CHECK_ATTEMPTS)? {
            None => Ok(Self::Attempts(1)),
            Some(value) => Self::parse(&value),
        }
    }

    /// From the variable's text: `N` times, `0` until there is one, a
    /// negative number not at all.
    pub fn parse(value: &str) -> Result<Self, RmwConfigError> {
        let n: i64 = value
            .trim()
            .parse()
            .map_err(|_| RmwConfigError::Attempts(value.to_owned()))?;
        Ok(match n {
            0 => Self::Forever,
            n if n < 0 => Self::Skip,
            n => Self::Attempts(n.unsigned_abs()),
        })
    }
}

/// Look for a router reached by `session` as `check` says: each attempt
/// waits up to a second for one, and `missed` is called with the attempt's
/// number when it found none. Whether one was found (`true` for
/// [`RouterCheck::Skip`]).
pub fn wait_for_router(session: &Session, check: RouterCheck, missed: impl FnMut(u64)) -> bool {
    wait_for(session, check, missed, |session| {
        use zenoh::Wait;
        session.info().routers_zid().wait().next().is_some()
    })
}

/// [`wait_for_router`] that is also content with a peer: for a program that
/// only needs someone to talk to (a system of peers has no router).
pub fn wait_for_router_or_peer(
    session: &Session,
    check: RouterCheck,
    missed: impl FnMut(u64),
) -> bool {
    wait_for(session, check, missed, |session| {
        use zenoh::Wait;
        session.info().routers_zid().wait().next().is_some()
            || session.info().peers_zid().wait().next().is_some()
    })
}

/// Wait until the peers `session` connects to stop coming: no new one for
/// `quiet`, at most `limit` in all. Returns how many it is connected to.
///
/// A peer that joins through a router learns the other peers from the
/// router's gossip and connects to each directly, after its `open` has
/// returned. Until it has, a query about the graph misses their entities,
/// because a router answers a peer's liveliness query only with what it
/// holds itself: a program that asks once (as `shm-ros2 node list` does)
/// waits for this first, as ros2cli waits its `--spin-time` for discovery.
pub fn wait_for_peers(session: &Session, quiet: Duration, limit: Duration) -> usize {
    use zenoh::Wait;
    let start = std::time::Instant::now();
    let count = || session.info().peers_zid().wait().count();
    let mut peers = count();
    let mut changed = start;
    while changed.elapsed() < quiet && start.elapsed() < limit {
        std::thread::sleep(Duration::from_millis(10));
        let now = count();
        if now != peers {
            peers = now;
            changed = std::time::Instant::now();
        }
    }
    peers
}

/// What rmw_zenoh_cpp's nodes do when they start, once per session: when
/// the session's configuration connects somewhere, look for a router or peer
/// as [`RouterCheck::from_env`] says (one second by default), and warn,
/// naming the endpoints and what to start, when none was reached. The
/// session goes on and connects when one comes. [`RosNode`](crate::RosNode)s
/// do this as they are built.
pub fn look_for_router_once(session: &Session) {
    if !first_look(session) {
        return;
    }
    let endpoints: Vec<String> = session
        .config()
        .get_typed("connect/endpoints")
        .unwrap_or_default();
    if endpoints.is_empty() {
        return;
    }
    let endpoints = format!("{endpoints:?}");
    let check = match RouterCheck::from_env() {
        Ok(check) => check,
        Err(e) => {
            tracing::warn!("{e}; looking for a router for 1 s");
            RouterCheck::Attempts(1)
        }
    };
    if !wait_for_router_or_peer(session, check, |_| {}) {
        tracing::warn!(
            "No Zenoh router or peer reached at {endpoints}: {}. To connect elsewhere: \
             ZENOH_SESSION_CONFIG_URI, ZENOH_CONFIG_OVERRIDE. The node goes on, and finds the \
             others when one comes",
            why_unreached(session)
        );
    }
}

/// Why `session` reached no router or peer at its `connect` endpoints, as
/// far as can be told from outside Zenoh, and what to do about it. Each
/// endpoint carried over TCP (`tcp/`, `tls/`) is tried with a plain TCP
/// connection (at most 500 ms):
///
/// - nothing answers at any of them: no router runs there, so start one;
/// - something answers: a router (or another program) runs there and did
///   not open a session with this one, so its transport or credentials
///   differ: a `tls/` endpoint to a `tcp/` router, a refused user and
///   password, certificates it does not trust.
///
/// Other transports (QUIC, UDP, Unix sockets) cannot be told apart this way;
/// the text then names both causes.
pub fn why_unreached(session: &Session) -> String {
    let endpoints: Vec<String> = session
        .config()
        .get_typed("connect/endpoints")
        .unwrap_or_default();
    let login = session
        .config()
        .get_typed::<String>("transport/auth/usrpwd/user")
        .is_ok_and(|user| !user.is_empty());
    why_unreached_at(&endpoints, login, Duration::from_millis(500))
}

/// [`why_unreached`] for `endpoints`, with a user and password configured
/// or not, each TCP try bounded by `patience`.
fn why_unreached_at(endpoints: &[String], login: bool, patience: Duration) -> String {
    use std::net::{TcpStream, ToSocketAddrs};
    const START: &str =
        "start a router (`shm-ros2 router`, or `ros2 run rmw_zenoh_cpp rmw_zenohd`)";
    let mut answered = None;
    let mut over_tcp = 0;
    for endpoint in endpoints {
        let Some((protocol, rest)) = endpoint.split_once('/') else {
            continue;
        };
        if !matches!(protocol, "tcp" | "tls") {
            continue;
        }
        over_tcp += 1;
        let address = rest.split(['?', '#']).next().unwrap_or(rest);
        let reached = address
            .to_socket_addrs()
            .ok()
            .into_iter()
            .flatten()
            .any(|socket| TcpStream::connect_timeout(&socket, patience).is_ok());
        if reached && answered.is_none() {
            answered = Some((protocol, address));
        }
    }
    match answered {
        Some((protocol, address)) if login => format!(
            "a process listens at {address} and closed the session: it refused the user and \
             password (transport/auth/usrpwd), or expects another transport than {protocol}/"
        ),
        Some(("tls", address)) => format!(
            "a process listens at {address} and no TLS session opened with it: it may listen \
             with tcp/ where tls/ was given, or not trust the certificates (transport/link/tls)"
        ),
        Some((protocol, address)) => format!(
            "a process listens at {address} and opened no Zenoh session with {protocol}/: check \
             the transport it expects (tls/, quic/) and its credentials (TLS certificates, user \
             and password)"
        ),
        None if over_tcp > 0 && over_tcp == endpoints.len() => {
            format!("nothing listens there; {START}")
        }
        None => format!(
            "{START}, or check the transport and credentials it expects (TLS certificates, user \
             and password)"
        ),
    }
}

/// Tell [`look_for_router_once`] that the program looked for a router on
/// `session` itself (and said what it found), so that its nodes do not look
/// again.
pub fn router_looked_for(session: &Session) {
    first_look(session);
}

/// Whether this is the first look for a router on `session`.
fn first_look(session: &Session) -> bool {
    static LOOKED: std::sync::Mutex<Vec<zenoh::session::ZenohId>> =
        std::sync::Mutex::new(Vec::new());
    let mut looked = LOOKED.lock().unwrap_or_else(|e| e.into_inner());
    if looked.contains(&session.zid()) {
        return false;
    }
    looked.push(session.zid());
    true
}

fn wait_for(
    session: &Session,
    check: RouterCheck,
    mut missed: impl FnMut(u64),
    found: impl Fn(&Session) -> bool,
) -> bool {
    let attempts = match check {
        RouterCheck::Skip => return true,
        RouterCheck::Attempts(n) => n,
        RouterCheck::Forever => u64::MAX,
    };
    for attempt in 1..=attempts {
        let deadline = std::time::Instant::now() + Duration::from_secs(1);
        loop {
            if found(session) {
                return true;
            }
            if std::time::Instant::now() >= deadline {
                break;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        missed(attempt);
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cause told from a TCP try: nothing there, a process there (with
    /// a login, over TLS, or neither), or a transport that cannot be tried.
    #[test]
    fn why_a_router_was_not_reached_is_told_from_what_answers() {
        let patience = Duration::from_millis(500);
        let nobody = {
            let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
            listener.local_addr().unwrap().port()
        };
        let why = why_unreached_at(&[format!("tcp/127.0.0.1:{nobody}")], false, patience);
        assert!(
            why.starts_with("nothing listens there; start a router"),
            "{why}"
        );

        let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let port = listener.local_addr().unwrap().port();
        let at = |protocol: &str| vec![format!("{protocol}/127.0.0.1:{port}#iface=lo")];
        let why = why_unreached_at(&at("tcp"), true, patience);
        assert!(
            why.starts_with(&format!("a process listens at 127.0.0.1:{port} and closed the session: it refused the user and password")),
            "{why}"
        );
        let why = why_unreached_at(&at("tls"), false, patience);
        assert!(why.contains("no TLS session opened with it"), "{why}");
        let why = why_unreached_at(&at("tcp"), false, patience);
        assert!(why.contains("opened no Zenoh session with tcp/"), "{why}");
        // A router on one endpoint of two is enough to say so.
        let mut both = vec![format!("tcp/127.0.0.1:{nobody}")];
        both.extend(at("tcp"));
        assert!(why_unreached_at(&both, false, patience).starts_with("a process listens"));
        // QUIC cannot be tried over TCP: both causes are named.
        let why = why_unreached_at(&at("quic"), false, patience);
        assert!(
            why.starts_with("start a router") && why.contains("transport and credentials"),
            "{why}"
        );
    }

    /// Zenoh's own errors, in the words a user reads: no source paths, no
    /// debug wrapping.
    #[test]
    fn zenoh_errors_read_without_zenohs_internals() {
        let mut config = Config::default();
        let bare = config
            .insert_json5("connect/endpoints", r#"["127.0.0.1:7447"]"#)
            .unwrap_err();
        assert!(bare.to_string().contains(".rs:"), "{bare}");
        let reason = zenoh_reason(&bare);
        assert!(
            reason.starts_with("Endpoints must be of the form <protocol>/<address>")
                && reason.ends_with("127.0.0.1:7447"),
            "{reason}"
        );
        let unknown = config
            .insert_json5("scouting/multicst/enabled", "true")
            .unwrap_err();
        assert_eq!(
            zenoh_reason(&unknown),
            "no such key in Zenoh's configuration"
        );
        let missing = Config::from_file("/nonexistent/zenoh.json5").unwrap_err();
        assert_eq!(
            zenoh_reason(&missing),
            "No such file or directory (os error 2)"
        );
        // Text without a location is kept as it is.
        assert_eq!(zenoh_reason(&"stopped at the door"), "stopped at the door");
        let err = session_config_from(Some(Path::new("/nonexistent/zenoh.json5"))).unwrap_err();
        assert_eq!(
            err.to_string(),
            "--zenoh-config /nonexistent/zenoh.json5: not a Zenoh configuration (No such file \
             or directory (os error 2)); give the path of a JSON5 Zenoh configuration file"
        );
    }

    #[test]
    fn every_default_is_a_key_zenoh_knows_with_a_value_it_takes() {
        for (key, value) in COMMON_DEFAULTS
            .iter()
            .chain(SESSION_DEFAULTS)
            .chain(ROUTER_DEFAULTS)
        {
            let mut config = Config::default();
            config
                .insert_json5(key, value)
                .unwrap_or_else(|e| panic!("{key}={value}: {e}"));
        }
        let session = default_session_config();
        assert_eq!(session.get_json("mode").unwrap(), r#""peer""#);
        assert_eq!(
            session.get_json("connect/endpoints").unwrap(),
            r#"["tcp/localhost:7447"]"#
        );
        assert_eq!(
            session.get_json("transport/link/tx/lease").unwrap(),
            "60000"
        );
        let router = default_router_config();
        assert_eq!(router.get_json("mode").unwrap(), r#""router""#);
        assert_eq!(
            router.get_json("listen/endpoints").unwrap(),
            r#"["tcp/[::]:7447"]"#
        );
        // Each deviation is a key the session sets, to another value.
        for (key, release) in DIFFERENCES_FROM_THE_RELEASE {
            let ours = json(&session, key);
            let mut theirs = Config::default();
            theirs.insert_json5(key, release).unwrap();
            assert_ne!(ours, json(&theirs, key), "{key}");
            assert!(SESSION_DEFAULTS.iter().any(|(k, _)| k == key), "{key}");
        }
    }

    fn json(config: &Config, key: &str) -> serde_json::Value {
        serde_json::from_str(&config.get_json(key).unwrap()).unwrap()
    }

    /// Every key of `theirs` whose value differs in `ours`, as `key: ours
    /// != theirs`.
    fn differences(ours: &Config, theirs: &Config) -> Vec<String> {
        // Every key of `a` (and under it), with `b`'s value beside it.
        fn walk(
            path: &str,
            a: &serde_json::Value,
            b: &serde_json::Value,
            out: &mut Vec<(String, String, String)>,
        ) {
            match (a, b) {
                (serde_json::Value::Object(a), serde_json::Value::Object(b)) => {
                    for (key, value) in a {
                        let path = if path.is_empty() {
                            key.clone()
                        } else {
                            format!("{path}/{key}")
                        };
                        walk(
                            &path,
                            value,
                            b.get(key).unwrap_or(&serde_json::Value::Null),
                            out,
                        );
                    }
                }
                _ if a != b => out.push((path.to_owned(), a.to_string(), b.to_string())),
                _ => {}
            }
        }
        let ours: serde_json::Value = serde_json::from_str(&ours.to_string()).unwrap();
        let theirs: serde_json::Value = serde_json::from_str(&theirs.to_string()).unwrap();
        let mut both = Vec::new();
        walk("", &ours, &theirs, &mut both);
        let mut reversed = Vec::new();
        walk("", &theirs, &ours, &mut reversed);
        both.extend(reversed.into_iter().map(|(key, t, o)| (key, o, t)));
        let mut out: Vec<String> = both
            .into_iter()
            .map(|(key, o, t)| format!("{key}: {o} != {t}"))
            .collect();
        out.sort();
        out.dedup();
        out
    }

    /// The defaults against a release's own files, as Zenoh reads both:
    /// equal, but for the session's deviations, which hold the release's
    /// values. Run it with `RMW_ZENOH_CPP_CONFIG=<the release's config
    /// directory> cargo test -p shm-runtime --lib -- --ignored
    /// a_release_s_files`.
    #[test]
    #[ignore = "needs RMW_ZENOH_CPP_CONFIG: the config directory of an rmw_zenoh_cpp release"]
    fn the_defaults_are_a_release_s_files() {
        let dir = PathBuf::from(
            std::env::var_os("RMW_ZENOH_CPP_CONFIG")
                .expect("RMW_ZENOH_CPP_CONFIG: the config directory of an rmw_zenoh_cpp release"),
        );
        let release_router =
            Config::from_file(dir.join("DEFAULT_RMW_ZENOH_ROUTER_CONFIG.json5")).unwrap();
        assert_eq!(
            differences(&default_router_config(), &release_router),
            Vec::<String>::new()
        );
        let release_session =
            Config::from_file(dir.join("DEFAULT_RMW_ZENOH_SESSION_CONFIG.json5")).unwrap();
        let mut as_released = default_session_config();
        for (key, value) in DIFFERENCES_FROM_THE_RELEASE {
            as_released.insert_json5(key, value).unwrap();
        }
        assert_eq!(
            differences(&as_released, &release_session),
            Vec::<String>::new()
        );
        // And each deviation is one.
        assert_eq!(
            differences(&default_session_config(), &release_session).len(),
            DIFFERENCES_FROM_THE_RELEASE.len()
        );
    }

    #[test]
    fn the_shm_variables_size_zenoh_s_pool_as_rmw_zenoh_cpp_reads_them() {
        let pool = "transport/shared_memory/transport_optimization/pool_size";
        let threshold = "transport/shared_memory/transport_optimization/message_size_threshold";
        let mut config = default_session_config();
        apply_shm_variables(&mut config, Some("1048576"), Some("1024"));
        assert_eq!(config.get_json(pool).unwrap(), "1048576");
        assert_eq!(config.get_json(threshold).unwrap(), "1024");
        // Left out, as rmw_zenoh_cpp leaves them out: the defaults stay.
        for (alloc, limit) in [("0", "1000"), ("lots", "-4"), ("", "0")] {
            let mut config = default_session_config();
            apply_shm_variables(&mut config, Some(alloc), Some(limit));
            assert_eq!(config.get_json(pool).unwrap(), "50331648", "{alloc}");
            assert_eq!(config.get_json(threshold).unwrap(), "512", "{limit}");
        }
    }

    #[test]
    fn an_override_sets_each_pair_and_names_the_one_it_cannot_set() {
        let mut config = default_session_config();
        apply_override(
            &mut config,
            r#"mode="client";connect/endpoints=["tls/10.0.0.1:7447","tcp/10.0.0.2:7447"]; ;"#,
        )
        .unwrap();
        assert_eq!(config.get_json("mode").unwrap(), r#""client""#);
        assert_eq!(
            config.get_json("connect/endpoints").unwrap(),
            r#"["tls/10.0.0.1:7447","tcp/10.0.0.2:7447"]"#
        );
        for (bad, named) in [
            ("mode=\"client\";nonsense/key=1", "`nonsense/key=1`"),
            ("mode=\"emperor\"", "`mode=\"emperor\"`"),
            (
                "transport/link/tx/lease=soon",
                "`transport/link/tx/lease=soon`",
            ),
            ("mode", "`mode` cannot be set (no `=` in it)"),
        ] {
            let error = apply_override(&mut default_session_config(), bad)
                .unwrap_err()
                .to_string();
            assert!(error.contains(named), "{bad}: {error}");
            assert!(error.starts_with(CONFIG_OVERRIDE), "{error}");
        }
    }

    #[test]
    fn a_file_that_is_not_a_configuration_is_named_with_its_variable() {
        let path =
            std::env::temp_dir().join(format!("shm-runtime-config-{}.json5", std::process::id()));
        std::fs::write(&path, "{ mode: 42 }").unwrap();
        let error = configure(
            SESSION_CONFIG_URI,
            Some(&path),
            default_session_config,
            None,
        )
        .unwrap_err()
        .to_string();
        assert!(error.starts_with("ZENOH_SESSION_CONFIG_URI="), "{error}");
        assert!(error.contains(&path.display().to_string()), "{error}");
        std::fs::write(
            &path,
            r#"{ mode: "client", connect: { endpoints: ["tcp/127.0.0.1:1"] } }"#,
        )
        .unwrap();
        let config = configure(
            SESSION_CONFIG_URI,
            Some(&path),
            default_session_config,
            Some(r#"connect/endpoints=["tcp/127.0.0.1:2"]"#),
        )
        .unwrap();
        assert_eq!(config.get_json("mode").unwrap(), r#""client""#);
        assert_eq!(
            config.get_json("connect/endpoints").unwrap(),
            r#"["tcp/127.0.0.1:2"]"#
        );
        let _ = std::fs::remove_file(&path);
    }

    #[test]
    fn router_check_attempts_read_as_rmw_zenoh_cpp_reads_them() {
        assert_eq!(RouterCheck::parse("3"), Ok(RouterCheck::Attempts(3)));
        assert_eq!(RouterCheck::parse("0"), Ok(RouterCheck::Forever));
        assert_eq!(RouterCheck::parse("-1"), Ok(RouterCheck::Skip));
        assert!(RouterCheck::parse("often")
            .unwrap_err()
            .to_string()
            .contains("give a whole number"));
    }
}
