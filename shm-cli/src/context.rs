//! The Zenoh session, the graph and (when a command needs one) a hidden node
//! of the command line's own.

use std::sync::OnceLock;
use std::time::Duration;

use shm_runtime::graph::{Graph, GraphCache};
use shm_runtime::rmw::{self, Distro};
use shm_runtime::types::local::LocalInterfaces;
use shm_runtime::RosNode;
use zenoh::{Session, Wait};

use crate::Error;

/// How to reach the ROS 2 system. Every command takes these; its help lists
/// them under a heading of their own, after the command's own options.
#[derive(Debug, clap::Args)]
#[command(next_help_heading = "Reaching the system (every command)")]
pub(crate) struct Connection {
    /// ROS domain id.
    #[arg(long, global = true, env = "ROS_DOMAIN_ID", default_value_t = 0)]
    domain_id: u32,
    /// Zenoh endpoint to connect to (repeatable), in place of the
    /// configuration's (rmw_zenoh_cpp's router, tcp/localhost:7447, by
    /// default). (No short form: `-e` is `bag record`'s regular expression,
    /// as in ros2bag.)
    #[arg(long = "connect", global = true)]
    connect: Vec<String>,
    /// A Zenoh session configuration file (JSON5) to start from, as
    /// rmw_zenoh_cpp's `ZENOH_SESSION_CONFIG_URI` (for instance one that
    /// zenoh_security_tools generated); `ZENOH_CONFIG_OVERRIDE` applies on
    /// top. Default: rmw_zenoh_cpp's default session configuration.
    #[arg(long, global = true, env = "ZENOH_SESSION_CONFIG_URI")]
    zenoh_config: Option<std::path::PathBuf>,
    /// The ROS 2 distribution of the nodes to talk with (humble, jazzy,
    /// kilted, lyrical, rolling): their rmw_zenoh_cpp conventions and
    /// interface definitions. Default: kilted.
    #[arg(long, global = true, env = "ROS_DISTRO", value_parser = parse_distro)]
    distro: Option<Distro>,
    /// Seconds to wait for the graph and for answers.
    #[arg(long, global = true, default_value_t = 5.0)]
    timeout: f64,
    /// Interface files to read types from (repeatable): a package directory
    /// (with msg, srv or action), or a directory of packages. A type they
    /// define is used when its hash is the one announced.
    #[arg(long, global = true)]
    interfaces: Vec<std::path::PathBuf>,
}

impl Connection {
    /// The distribution `--distro` or `ROS_DISTRO` names, else the default.
    pub(crate) fn distro(&self) -> Distro {
        self.distro.unwrap_or_default()
    }
}

/// What the session reached when it opened.
pub(crate) struct Reached {
    /// A router or a peer (or the check was turned off).
    found: bool,
    /// The endpoints it connects to (JSON).
    endpoints: String,
}

pub(crate) struct Context {
    pub(crate) session: Session,
    pub(crate) reached: Reached,
    pub(crate) domain_id: u32,
    pub(crate) distro: Distro,
    pub(crate) timeout: Duration,
    /// The types of `--interfaces`.
    pub(crate) local: LocalInterfaces,
    graph: GraphCache,
    node: OnceLock<RosNode>,
}

/// How long no new peer must connect before the system counts as seen
/// (see [`rmw::config::wait_for_peers`]), and the most that is waited.
const PEERS_QUIET: Duration = Duration::from_millis(150);
const PEERS_LIMIT: Duration = Duration::from_secs(2);

/// Why `option`'s endpoints could not be set, with what to write instead.
pub(crate) fn endpoints_error(
    option: &str,
    endpoints: &[String],
    error: &dyn std::fmt::Display,
) -> String {
    let given = endpoints.join(" ");
    match endpoints.iter().find(|e| !e.contains('/')) {
        Some(bare) => format!(
            "{option} {given}: an endpoint is <protocol>/<address>; write tcp/{bare} (or tls/, \
             quic/, udp/, unixsock-stream/)"
        ),
        None => format!("{option} {given}: {}", rmw::config::zenoh_reason(error)),
    }
}

impl Context {
    pub(crate) fn open(connection: &Connection) -> Result<Self, Error> {
        let mut config = rmw::config::session_config_from(connection.zenoh_config.as_deref())?;
        if !connection.connect.is_empty() {
            let endpoints = serde_json::to_string(&connection.connect)?;
            config
                .insert_json5("connect/endpoints", &endpoints)
                .map_err(|e| endpoints_error("--connect", &connection.connect, &e))?;
        }
        let endpoints = config
            .get_json("connect/endpoints")
            .unwrap_or_else(|_| "[]".to_owned());
        let session = zenoh::open(config).wait().map_err(|e| {
            format!(
                "cannot open a Zenoh session (connecting to {endpoints}): {}. Check that a \
                     router is there (`shm-ros2 router`, `ros2 run rmw_zenoh_cpp rmw_zenohd`) \
                     and the transport and credentials it expects (TLS certificates, user and \
                     password)",
                rmw::config::zenoh_reason(&e)
            )
        })?;
        let check = rmw::config::RouterCheck::from_env()?;
        let found = rmw::config::wait_for_router_or_peer(&session, check, |_| {});
        rmw::config::router_looked_for(&session);
        if found {
            rmw::config::wait_for_peers(&session, PEERS_QUIET, PEERS_LIMIT);
        }
        let timeout = Duration::try_from_secs_f64(connection.timeout)
            .map_err(|_| format!("--timeout {}: give a number of seconds", connection.timeout))?;
        let graph = GraphCache::of(&session, connection.domain_id)?;
        let local = LocalInterfaces::load(&connection.interfaces)?;
        Ok(Self {
            reached: Reached { found, endpoints },
            session,
            domain_id: connection.domain_id,
            distro: connection.distro(),
            timeout,
            local,
            graph,
            node: OnceLock::new(),
        })
    }

    /// For verbs that ask the system something: an error when the session
    /// reached neither a router nor a peer, since nothing could answer.
    pub(crate) fn require_reached(&self) -> Result<(), Error> {
        if self.reached.found {
            return Ok(());
        }
        Err(self.unreached().into())
    }

    /// For verbs that may wait for the system to appear (echo, record, …):
    /// say so once on stderr when no router was reached, as rmw_zenoh_cpp's
    /// nodes do, and go on.
    pub(crate) fn warn_unreached(&self) {
        if !self.reached.found {
            eprintln!("{} Waiting for one.", self.unreached());
        }
    }

    fn unreached(&self) -> String {
        format!(
            "No Zenoh router or peer reached at {}: {}. To connect elsewhere: --connect, \
             ZENOH_SESSION_CONFIG_URI, ZENOH_CONFIG_OVERRIDE; ZENOH_ROUTER_CHECK_ATTEMPTS=N \
             waits N seconds for a router.",
            self.reached.endpoints,
            rmw::config::why_unreached(&self.session)
        )
    }

    /// The graph, once the first answers are in; what is known after the
    /// timeout otherwise, with a word on stderr that it may be incomplete.
    pub(crate) fn graph(&self) -> Graph {
        if !self.graph.wait_synced(self.timeout) {
            eprintln!(
                "The ROS graph's first answers did not all arrive within {:?}: what is shown \
                 may be incomplete. Give it longer with --timeout.",
                self.timeout
            );
        }
        self.graph.snapshot()
    }

    /// Wait until `condition` holds on the graph, or the timeout passes.
    pub(crate) fn wait_for(&self, condition: impl FnMut(&Graph) -> bool) -> Option<Graph> {
        self.graph
            .wait_until(self.timeout, condition)
            .then(|| self.graph.snapshot())
    }

    /// A hidden node of the command line's own, for the commands that
    /// subscribe, publish or call services. It keeps out of what it inspects:
    /// no parameter services, no type-description service.
    pub(crate) fn node(&self) -> Result<&RosNode, Error> {
        if let Some(node) = self.node.get() {
            return Ok(node);
        }
        let node = RosNode::builder(&self.session, &format!("_shm_ros2_{}", std::process::id()))
            .domain_id(self.domain_id)
            .distro(self.distro)
            .parameter_services(false)
            .type_description_service(false)
            .wait()?;
        Ok(self.node.get_or_init(|| node))
    }
}

/// `--distro` and `ROS_DISTRO`: a distribution name; empty is the default,
/// as an unset `ROS_DISTRO`.
fn parse_distro(text: &str) -> Result<Distro, String> {
    if text.trim().is_empty() {
        return Ok(Distro::DEFAULT);
    }
    text.parse()
        .map_err(|e: shm_runtime::rmw::UnknownDistro| e.to_string())
}

/// Whether a name is hidden from listings (a part starting with `_`), as
/// ros2cli decides.
pub(crate) fn is_hidden(name: &str) -> bool {
    name.split('/').any(|part| part.starts_with('_'))
}
