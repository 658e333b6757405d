//! The ROS graph as rmw_zenoh_cpp announces it: every node, publisher,
//! subscriber, service server and client holds a liveliness token
//! `@ros2_lv/<domain>/<zid>/<node id>/<entity id>/<kind>/<enclave>/<namespace>/<node>[/<topic>/<type>/<hash>/<qos>]`;
//! [`Graph`] reads them back into names, types, QoS and GIDs, as
//! `ros2 node list`, `ros2 topic list -t` and `ros2 node info` show them, and
//! [`GraphCache`] keeps one up to date for a whole session, with
//! [events](GraphEvent) as entities come and go.

mod cache;
mod events;

pub use cache::{GraphCache, GraphGuard};
pub use events::{GraphCallback, GraphEvent, GraphEvents};

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::fmt;
use std::sync::Arc;

use std::time::Duration;

use crate::rmw::{
    parse_duration_fields, Durability, EntityKind, Gid, History, Liveliness, Qos, Reliability,
};

/// A token that is not rmw_zenoh_cpp's.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TokenError {
    /// The token.
    pub token: String,
    /// What is wrong with it.
    pub reason: &'static str,
}

impl fmt::Display for TokenError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "liveliness token {:?}: {}", self.token, self.reason)
    }
}

impl std::error::Error for TokenError {}

/// One node or endpoint on the graph, from its liveliness token.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Entity {
    /// ROS domain.
    pub domain_id: u32,
    /// The Zenoh session id of the process that declared it.
    pub zid: String,
    /// The node's id within its session.
    pub node_id: u64,
    /// The entity's id within its session (the node's own for a node).
    pub entity_id: u64,
    /// Node, publisher, subscriber, service server or client.
    pub kind: EntityKind,
    /// Security enclave.
    pub enclave: String,
    /// The node's namespace.
    pub namespace: String,
    /// The node's name.
    pub node_name: String,
    /// Topic or service of an endpoint (`None` for a node).
    pub endpoint: Option<Endpoint>,
    /// The token itself (shared by the graph's indexes).
    pub token: Arc<str>,
    /// The entity's GID: XXH3-128 of the token.
    pub gid: Gid,
}

/// What an endpoint's token says beyond its node.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Endpoint {
    /// Fully qualified topic or service name (`/chatter`).
    pub name: String,
    /// ROS type name (`std_msgs/msg/String`, `std_srvs/srv/Trigger`).
    pub type_name: String,
    /// RIHS01 type hash.
    pub type_hash: String,
    /// QoS, with rmw_zenoh_cpp's defaults where the token leaves a field empty.
    pub qos: Qos,
    /// The names of the buffer backends the endpoint announces (`cpu`,
    /// `cuda`, …), sorted: rmw_zenoh_cpp on Lyrical and Rolling adds them to
    /// the tokens of buffer-aware endpoints (types with a `uint8[]` field of
    /// their own) as a 13th field, `backends:<name>:<metadata>;…`, each part
    /// `%XX`-escaped; the metadata is not kept. Empty otherwise.
    pub backends: Vec<String>,
}

/// How rmw_zenoh_cpp on Lyrical and Rolling starts the field listing an
/// endpoint's buffer backends.
const BACKENDS_FIELD: &str = "backends:";

/// The backend names of a `backends:` field's list, `<name>:<metadata>`
/// entries joined by `;`, read as rmw_zenoh_cpp reads them
/// (`liveliness_utils.cpp`): empty entries and names skipped, a name given
/// twice kept once.
fn backend_names(list: &str) -> Vec<String> {
    let names: std::collections::BTreeSet<String> = list
        .split(';')
        .map(|entry| unescape_backend(entry.split(':').next().unwrap_or_default()))
        .filter(|name| !name.is_empty())
        .collect();
    names.into_iter().collect()
}

/// `%XX` back to its byte, as rmw_zenoh_cpp unescapes a backend's name; a
/// `%` without two hex digits after it stays.
fn unescape_backend(text: &str) -> String {
    let bytes = text.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while let Some(&byte) = bytes.get(i) {
        let hex = |at: usize| bytes.get(at).and_then(|b| (*b as char).to_digit(16));
        if byte == b'%' && i + 2 < bytes.len() {
            if let (Some(hi), Some(lo)) = (hex(i + 1), hex(i + 2)) {
                out.push((hi << 4 | lo) as u8);
                i += 3;
                continue;
            }
        }
        out.push(byte);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// `%` back to `/` (see [`crate::rmw::mangle_name`]).
fn demangle(name: &str) -> String {
    name.replace('%', "/")
}

/// `pkg::msg::dds_::Name_` → `pkg/msg/Name`.
fn ros_type_name(dds: &str) -> Option<String> {
    let mut parts = dds.split("::");
    let (pkg, kind, dds_, name) = (parts.next()?, parts.next()?, parts.next()?, parts.next()?);
    if dds_ != "dds_" || parts.next().is_some() {
        return None;
    }
    Some(format!("{pkg}/{kind}/{}", name.strip_suffix('_')?))
}

/// rmw_zenoh_cpp's `keyexpr_to_qos`: empty fields are its defaults (reliable,
/// volatile, keep last 42); BEST_AVAILABLE policies (Jazzy and later) are
/// announced as they were asked for, unresolved.
fn parse_qos(text: &str) -> Option<Qos> {
    let fields: Vec<&str> = text.split(':').collect();
    let [reliability, durability, history, ..] = fields[..] else {
        return None;
    };
    let reliability = match reliability {
        "" | "1" => Reliability::Reliable,
        "2" => Reliability::BestEffort,
        "4" => Reliability::BestAvailable,
        _ => return None,
    };
    let durability = match durability {
        "" | "2" => Durability::Volatile,
        "1" => Durability::TransientLocal,
        "4" => Durability::BestAvailable,
        _ => return None,
    };
    let (kind, depth) = history.split_once(',')?;
    let depth = if depth.is_empty() {
        42
    } else {
        depth.parse().ok()?
    };
    let history = match kind {
        "" | "1" => History::KeepLast(depth),
        "2" => History::KeepAll,
        _ => return None,
    };
    let mut qos = Qos::with_history(reliability, durability, history);
    // Deadline, lifespan, liveliness: absent in a short token, empty parts
    // are rmw_zenoh's defaults.
    let pair = |field: Option<&&str>| -> Option<Option<Duration>> {
        let Some(field) = field else {
            return Some(None);
        };
        let (sec, nsec) = field.split_once(',')?;
        parse_duration_fields(sec, nsec)
    };
    qos.deadline = pair(fields.get(3))?;
    qos.lifespan = pair(fields.get(4))?;
    if let Some(liveliness) = fields.get(5) {
        let (kind, lease) = liveliness.split_once(',')?;
        qos.liveliness = match kind {
            "" | "1" => Liveliness::Automatic,
            "3" => Liveliness::ManualByTopic,
            "5" => Liveliness::BestAvailable,
            _ => return None,
        };
        let (sec, nsec) = lease.split_once(',')?;
        qos.liveliness_lease = parse_duration_fields(sec, nsec)?;
    }
    Some(qos)
}

impl Entity {
    /// Read a liveliness token.
    pub fn parse(token: &str) -> Result<Self, TokenError> {
        let error = |reason| TokenError {
            token: token.to_owned(),
            reason,
        };
        let rest = token
            .strip_prefix("@ros2_lv/")
            .ok_or(error("does not start with @ros2_lv/"))?;
        let mut parts: Vec<&str> = rest.split('/').collect();
        // rmw_zenoh_cpp reads the 12 fields of an endpoint and ignores any
        // after them, but for a 13th that lists buffer backends (Lyrical and
        // later).
        let backends = if parts.len() > 12 {
            let extra = parts.split_off(12);
            extra
                .first()
                .and_then(|field| field.strip_prefix(BACKENDS_FIELD))
                .map(backend_names)
                .unwrap_or_default()
        } else {
            Vec::new()
        };
        if parts.len() != 8 && parts.len() != 12 {
            return Err(error(
                "has neither 8 (node) nor at least 12 (endpoint) fields",
            ));
        }
        let number = |s: &str| s.parse().map_err(|_| error("an id is not a number"));
        let kind = EntityKind::from_token_field(parts[4]).ok_or(error("unknown entity kind"))?;
        let endpoint = match (kind, parts.len()) {
            (EntityKind::Node, 8) => None,
            (EntityKind::Node, _) => return Err(error("a node token with endpoint fields")),
            (_, 12) => Some(Endpoint {
                name: demangle(parts[8]),
                type_name: ros_type_name(parts[9])
                    .ok_or(error("type is not pkg::kind::dds_::Name_"))?,
                type_hash: parts[10].to_owned(),
                qos: parse_qos(parts[11]).ok_or(error("QoS is not rmw_zenoh's"))?,
                backends,
            }),
            _ => return Err(error("an endpoint token without topic fields")),
        };
        Ok(Self {
            domain_id: number(parts[0])? as u32,
            zid: parts[1].to_owned(),
            node_id: number(parts[2])?,
            entity_id: number(parts[3])?,
            kind,
            enclave: demangle(parts[5]),
            namespace: demangle(parts[6]),
            node_name: demangle(parts[7]),
            endpoint,
            token: token.into(),
            gid: Gid::from_token(token),
        })
    }

    /// The node's fully qualified name (`/ns/name`).
    pub fn node_fqn(&self) -> String {
        if self.namespace.ends_with('/') {
            format!("{}{}", self.namespace, self.node_name)
        } else {
            format!("{}/{}", self.namespace, self.node_name)
        }
    }
}

/// Tokens that could not be read are kept, with why, up to this many (a
/// foreign program on `@ros2_lv` must not grow the graph without bound).
pub const MAX_UNREADABLE: usize = 1024;

/// The longest token read, in bytes: rmw_zenoh_cpp's longest (255-byte
/// names, a namespace, a type name, a hash and a QoS) is well within it.
/// A longer one is unreadable, and only its start is kept.
pub const MAX_TOKEN_LEN: usize = 4096;

/// The most entities a graph holds: any program on the network can declare
/// tokens. Past it, new tokens are unreadable until others leave.
pub const MAX_ENTITIES: usize = 1 << 17;

/// The part of a token an unreadable entry keeps.
const KEPT_TOKEN: usize = 256;

/// Entities by token.
type ByToken = BTreeMap<Arc<str>, Arc<Entity>>;

/// The ROS graph: every entity whose token is alive, indexed by token, by
/// endpoint name and by node, so that each query reads only what it answers.
///
/// A `Graph` is either a snapshot ([`RosNode::graph`](crate::RosNode::graph),
/// [`GraphCache::snapshot`]) or the live one inside a [`GraphCache`]
/// ([`GraphCache::read`]); the queries are the same. Entities are shared
/// (`Arc`), so a snapshot copies no names.
///
/// ```
/// use shm_runtime::graph::Graph;
///
/// let graph = Graph::from_tokens([
///     "@ros2_lv/0/ab/1/1/NN/%/%/talker",
///     "@ros2_lv/0/ab/1/2/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/RIHS01_df66/::,10:,:,:,,",
/// ]);
/// assert_eq!(graph.nodes(), ["/talker"]);
/// assert_eq!(graph.publishers("/chatter")[0].node_fqn(), "/talker");
/// assert_eq!(graph.node_endpoints("/talker").len(), 1);
/// ```
#[derive(Debug, Clone, Default)]
pub struct Graph {
    entities: ByToken,
    /// Endpoints by topic or service name.
    by_name: HashMap<String, ByToken>,
    /// Node tokens by fully qualified node name (several nodes may share one).
    nodes: BTreeMap<String, ByToken>,
    /// Endpoints by their node's fully qualified name.
    by_node: HashMap<String, ByToken>,
    /// By a hash of the whole token: a long one is not kept whole.
    unreadable: BTreeMap<u64, TokenError>,
    counts: HashMap<EntityKind, usize>,
}

/// The key of a token among the unreadable.
fn token_key(token: &str) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut hasher = std::collections::hash_map::DefaultHasher::new();
    token.hash(&mut hasher);
    hasher.finish()
}

impl Graph {
    /// Build a graph from tokens.
    pub fn from_tokens<'a>(tokens: impl IntoIterator<Item = &'a str>) -> Self {
        let mut graph = Self::default();
        for token in tokens {
            graph.insert(token);
        }
        graph
    }

    /// Add the entity of `token`; `Some` if it was not there. A token that
    /// cannot be read is kept in [`unreadable`](Self::unreadable) instead.
    pub(crate) fn insert(&mut self, token: &str) -> Option<Arc<Entity>> {
        if self.entities.contains_key(token) {
            return None;
        }
        let parsed = if token.len() > MAX_TOKEN_LEN {
            Err("longer than any rmw_zenoh_cpp token (4096 bytes)")
        } else if self.entities.len() >= MAX_ENTITIES {
            Err("the graph holds as many entities as it may (131072)")
        } else {
            Entity::parse(token).map_err(|e| e.reason)
        };
        let entity = match parsed {
            Ok(entity) => Arc::new(entity),
            Err(reason) => {
                if self.unreadable.len() < MAX_UNREADABLE {
                    let mut end = token.len().min(KEPT_TOKEN);
                    while !token.is_char_boundary(end) {
                        end -= 1;
                    }
                    let kept = match token.get(..end) {
                        Some(start) if end < token.len() => format!("{start}…"),
                        _ => token.to_owned(),
                    };
                    self.unreadable.insert(
                        token_key(token),
                        TokenError {
                            token: kept,
                            reason,
                        },
                    );
                }
                return None;
            }
        };
        let index = match &entity.endpoint {
            None => self.nodes.entry(entity.node_fqn()).or_default(),
            Some(endpoint) => {
                self.by_name
                    .entry(endpoint.name.clone())
                    .or_default()
                    .insert(entity.token.clone(), entity.clone());
                self.by_node.entry(entity.node_fqn()).or_default()
            }
        };
        index.insert(entity.token.clone(), entity.clone());
        self.entities.insert(entity.token.clone(), entity.clone());
        *self.counts.entry(entity.kind).or_default() += 1;
        Some(entity)
    }

    /// Remove the entity of `token`; `Some` if it was there.
    pub(crate) fn remove(&mut self, token: &str) -> Option<Arc<Entity>> {
        let Some(entity) = self.entities.remove(token) else {
            self.unreadable.remove(&token_key(token));
            return None;
        };
        if let Some(count) = self.counts.get_mut(&entity.kind) {
            *count -= 1;
        }
        fn take(index: &mut ByToken, token: &str) -> bool {
            index.remove(token);
            index.is_empty()
        }
        let fqn = entity.node_fqn();
        match &entity.endpoint {
            None => {
                if self.nodes.get_mut(&fqn).is_some_and(|i| take(i, token)) {
                    self.nodes.remove(&fqn);
                }
            }
            Some(endpoint) => {
                if self.by_node.get_mut(&fqn).is_some_and(|i| take(i, token)) {
                    self.by_node.remove(&fqn);
                }
                if let Some(index) = self.by_name.get_mut(&endpoint.name) {
                    if take(index, token) {
                        self.by_name.remove(&endpoint.name);
                    }
                }
            }
        }
        // Indexes emptied of many entries give their memory back.
        fn fit<K: Eq + std::hash::Hash, V>(index: &mut HashMap<K, V>) {
            if index.capacity() > 4 * index.len().max(64) {
                index.shrink_to_fit();
            }
        }
        fit(&mut self.by_name);
        fit(&mut self.by_node);
        Some(entity)
    }

    /// Every entity, in token order.
    pub fn entities(&self) -> impl Iterator<Item = &Arc<Entity>> + '_ {
        self.entities.values()
    }

    /// The entity of `token`, if it is alive.
    pub fn entity(&self, token: &str) -> Option<&Arc<Entity>> {
        self.entities.get(token)
    }

    /// How many entities there are.
    pub fn len(&self) -> usize {
        self.entities.len()
    }

    /// Whether there is no entity at all.
    pub fn is_empty(&self) -> bool {
        self.entities.is_empty()
    }

    /// How many entities of `kind` there are.
    pub fn count(&self, kind: EntityKind) -> usize {
        self.counts.get(&kind).copied().unwrap_or(0)
    }

    /// Tokens under `@ros2_lv` that could not be read, with why (at most
    /// [`MAX_UNREADABLE`]).
    pub fn unreadable(&self) -> impl ExactSizeIterator<Item = &TokenError> + '_ {
        self.unreadable.values()
    }

    /// Fully qualified node names, sorted, each once (`ros2 node list`).
    pub fn nodes(&self) -> Vec<String> {
        self.nodes.keys().cloned().collect()
    }

    /// Every node with its name, namespace, enclave and session, sorted by
    /// fully qualified name.
    pub fn node_entities(&self) -> Vec<Arc<Entity>> {
        self.nodes
            .values()
            .flat_map(BTreeMap::values)
            .cloned()
            .collect()
    }

    /// Whether a node called `fqn` (`/ns/name`) is on the graph.
    pub fn contains_node(&self, fqn: &str) -> bool {
        self.nodes.contains_key(fqn)
    }

    /// The publishers, subscribers, servers and clients of the node(s) called
    /// `fqn`, in token order (what `ros2 node info` shows).
    pub fn node_endpoints(&self, fqn: &str) -> Vec<Arc<Entity>> {
        self.by_node
            .get(fqn)
            .map(|index| index.values().cloned().collect())
            .unwrap_or_default()
    }

    fn names_and_types(&self, kinds: &[EntityKind]) -> BTreeMap<String, BTreeSet<String>> {
        let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (name, index) in &self.by_name {
            for e in index.values().filter(|e| kinds.contains(&e.kind)) {
                if let Some(endpoint) = &e.endpoint {
                    out.entry(name.clone())
                        .or_default()
                        .insert(endpoint.type_name.clone());
                }
            }
        }
        out
    }

    /// Topics with their types (`ros2 topic list -t`).
    pub fn topics(&self) -> BTreeMap<String, BTreeSet<String>> {
        self.names_and_types(&[EntityKind::Publisher, EntityKind::Subscriber])
    }

    /// Services with their types (`ros2 service list -t`).
    pub fn services(&self) -> BTreeMap<String, BTreeSet<String>> {
        self.names_and_types(&[EntityKind::ServiceServer, EntityKind::ServiceClient])
    }

    /// Actions with their types (`ros2 action list -t`): every
    /// `<action>/_action/send_goal` service, its type
    /// `<pkg>/action/<Name>_SendGoal` read as `<pkg>/action/<Name>`.
    pub fn actions(&self) -> BTreeMap<String, BTreeSet<String>> {
        let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (name, types) in self.services() {
            let Some(action) = name.strip_suffix("/_action/send_goal") else {
                continue;
            };
            let types = types
                .iter()
                .filter_map(|t| t.strip_suffix("_SendGoal"))
                .map(str::to_owned);
            out.entry(action.to_owned()).or_default().extend(types);
        }
        out
    }

    /// The types and RIHS01 hashes announced on topic or service `name`, each
    /// pair once (more than one means endpoints disagree).
    pub fn types_of(&self, name: &str) -> BTreeSet<(String, String)> {
        self.by_name
            .get(name)
            .into_iter()
            .flat_map(BTreeMap::values)
            .filter_map(|e| e.endpoint.as_ref())
            .map(|t| (t.type_name.clone(), t.type_hash.clone()))
            .collect()
    }

    /// Servers of `action` (the servers of its `send_goal` service).
    pub fn action_servers(&self, action: &str) -> Vec<Arc<Entity>> {
        self.servers(&format!("{action}/_action/send_goal"))
    }

    /// Clients of `action` (the clients of its `send_goal` service).
    pub fn action_clients(&self, action: &str) -> Vec<Arc<Entity>> {
        self.clients(&format!("{action}/_action/send_goal"))
    }

    /// The endpoints of `kind` on topic or service `name`, in token order
    /// (`ros2 topic info -v`).
    pub fn endpoints(&self, kind: EntityKind, name: &str) -> Vec<Arc<Entity>> {
        self.by_name
            .get(name)
            .into_iter()
            .flat_map(BTreeMap::values)
            .filter(|e| e.kind == kind)
            .cloned()
            .collect()
    }

    /// Publishers of `topic`.
    pub fn publishers(&self, topic: &str) -> Vec<Arc<Entity>> {
        self.endpoints(EntityKind::Publisher, topic)
    }

    /// Subscribers of `topic`.
    pub fn subscribers(&self, topic: &str) -> Vec<Arc<Entity>> {
        self.endpoints(EntityKind::Subscriber, topic)
    }

    /// Servers of `service`.
    pub fn servers(&self, service: &str) -> Vec<Arc<Entity>> {
        self.endpoints(EntityKind::ServiceServer, service)
    }

    /// Clients of `service`.
    pub fn clients(&self, service: &str) -> Vec<Arc<Entity>> {
        self.endpoints(EntityKind::ServiceClient, service)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_read_back_into_what_they_say() {
        let token = "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%demo/talker/%demo%chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/2:1:,7:,:,:,,";
        let e = Entity::parse(token).unwrap();
        assert_eq!((e.domain_id, e.node_id, e.entity_id), (2, 0, 10));
        assert_eq!(e.kind, EntityKind::Publisher);
        assert_eq!(e.node_fqn(), "/demo/talker");
        assert_eq!(e.enclave, "/");
        let t = e.endpoint.as_ref().unwrap();
        assert_eq!(t.name, "/demo/chatter");
        assert_eq!(t.type_name, "std_msgs/msg/String");
        assert_eq!(
            t.qos,
            Qos::with_history(
                Reliability::BestEffort,
                Durability::TransientLocal,
                History::KeepLast(7)
            )
        );
        assert_eq!(e.gid, Gid::from_token(token));
        // Every profile survives the round trip through the token's text.
        for qos in [
            Qos::default(),
            Qos::sensor_data(),
            Qos::services_default(),
            Qos::parameters(),
            Qos::system_default(),
            Qos::transient_local(1),
            Qos::transient_local(1000).lifespan(Duration::from_secs(10)),
            Qos::default()
                .deadline(Duration::from_millis(1500))
                .liveliness(Liveliness::ManualByTopic, Some(Duration::new(2, 5))),
        ] {
            assert_eq!(parse_qos(&qos.to_key_expr()), Some(qos));
        }
        let node = Entity::parse("@ros2_lv/0/ab/3/3/NN/%/%/listener").unwrap();
        assert_eq!(
            (node.kind, node.node_fqn()),
            (EntityKind::Node, "/listener".into())
        );
        assert!(node.endpoint.is_none());
        assert!(t.backends.is_empty());
    }

    /// rmw_zenoh_cpp on Lyrical and Rolling appends the buffer backends to
    /// the tokens of endpoints whose type has buffer fields, as
    /// `liveliness_utils.cpp` writes them: `backends:<name>:<metadata>`,
    /// sorted, joined by `;`, `%`, `;`, `:` and `/` escaped.
    #[test]
    fn lyrical_tokens_with_buffer_backends_are_read() {
        let plain = "@ros2_lv/0/ab/1/2/MS/%/%/n/%image/sensor_msgs::msg::dds_::Image_/RIHS01_00/::,10:,:,:,,";
        let backends = |field: &str| {
            let token = format!("{plain}/{field}");
            let e = Entity::parse(&token).unwrap();
            // The GID is still the hash of the whole token.
            assert_eq!(e.gid, Gid::from_token(&token));
            e.endpoint.unwrap().backends
        };
        // A default subscriber's, and one with two backends and metadata.
        assert_eq!(backends("backends:cpu:"), ["cpu"]);
        assert_eq!(
            backends("backends:cpu:;cuda:device%3A0%3Bstream%2F1"),
            ["cpu", "cuda"]
        );
        // Names unescaped (a `%` without two hex digits stays); empty
        // entries and names skipped; a name once.
        assert_eq!(
            backends("backends:a%3Bb:x;;:meta;c%3A:;d%3:;e%zz;cpu:1;cpu:2"),
            ["a;b", "c:", "cpu", "d%3", "e%zz"]
        );
        let t = Entity::parse(&format!("{plain}/backends:cpu:"))
            .unwrap()
            .endpoint
            .unwrap();
        assert_eq!(
            (t.name.as_str(), t.type_name.as_str()),
            ("/image", "sensor_msgs/msg/Image")
        );
        assert_eq!(Entity::parse(plain).unwrap().endpoint.unwrap().qos, t.qos);
        // Fields after the twelfth that are not backends are ignored, as
        // rmw_zenoh_cpp ignores them; a node has 8 fields.
        assert!(backends("cuda").is_empty());
        assert_eq!(backends("backends:cpu:/later"), ["cpu"]);
        assert!(Entity::parse("@ros2_lv/0/ab/3/3/NN/%/%/n/backends:cpu").is_err());
    }

    /// An endpoint made with rclpy's `qos_profile_best_available` (or
    /// rclcpp's `BestAvailableQoS`), Jazzy and later: rmw_zenoh_cpp writes
    /// the policies unresolved (`qos_to_keyexpr`: reliability and durability
    /// 4, liveliness 5, deadline and lease one nanosecond short of infinite,
    /// as rclpy's profile holds them: their seconds equal the default's, so
    /// they are left out).
    #[test]
    fn best_available_endpoints_are_read_as_announced() {
        let qos = "4:4:,10:,854775806:,:5,,854775806";
        let token = format!(
            "@ros2_lv/0/ab/1/2/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/RIHS01_00/{qos}"
        );
        let endpoint = Entity::parse(&token).unwrap().endpoint.unwrap();
        let best = Duration::new(9_223_372_036, 854_775_806);
        assert_eq!(endpoint.qos.reliability, Reliability::BestAvailable);
        assert_eq!(endpoint.qos.durability, Durability::BestAvailable);
        assert_eq!(endpoint.qos.liveliness, Liveliness::BestAvailable);
        assert_eq!(endpoint.qos.history, History::KeepLast(10));
        assert_eq!(
            (endpoint.qos.deadline, endpoint.qos.liveliness_lease),
            (Some(best), Some(best))
        );
        // Written back as rmw_zenoh_cpp writes it: the GID peers derive.
        assert_eq!(endpoint.qos.to_key_expr(), qos);
    }

    #[test]
    fn foreign_tokens_are_refused_with_the_reason() {
        for (token, reason) in [
            ("@ros2_lv/0/ab/3/3/XX/%/%/n", "unknown entity kind"),
            ("@ros2_lv/0/ab/3/3/NN/%/%", "has neither"),
            ("@ros2_lv/0/ab/x/3/NN/%/%/n", "not a number"),
            (
                "@ros2_lv/0/ab/1/2/MP/%/%/n/%t/std_msgs::String/RIHS01_x/::,10:,:,:,,",
                "type",
            ),
            (
                "@ros2_lv/0/ab/1/2/MP/%/%/n/%t/a::msg::dds_::B_/RIHS01_x/9::,:,:,:,,",
                "QoS",
            ),
        ] {
            let e = Entity::parse(token).unwrap_err();
            assert!(e.reason.contains(reason), "{token}: {e}");
        }
        let graph = Graph::from_tokens(["@ros2_lv/0/ab/3/3/NN/%/%/n", "@ros2_lv/bad"]);
        assert_eq!(graph.count(EntityKind::Node), 1);
        assert_eq!(graph.nodes(), ["/n"]);
        assert_eq!(graph.unreadable().len(), 1);
    }

    #[test]
    fn every_index_follows_tokens_coming_and_going() {
        let node = |i: u32| format!("@ros2_lv/0/ab/{i}/{i}/NN/%/%demo/n{i}");
        let endpoint = |i: u32, kind: &str, topic: &str| {
            format!("@ros2_lv/0/ab/{i}/{}/{kind}/%/%demo/n{i}/%{topic}/std_msgs::msg::dds_::String_/RIHS01_00/::,10:,:,:,,", 1000 + i)
        };
        let mut graph = Graph::default();
        let mut tokens = Vec::new();
        for i in 0..50 {
            tokens.push(node(i));
            tokens.push(endpoint(i, "MP", "rosout"));
            tokens.push(endpoint(i, if i % 2 == 0 { "MS" } else { "SS" }, "x"));
        }
        for token in &tokens {
            assert!(graph.insert(token).is_some());
            assert!(graph.insert(token).is_none(), "a token counts once");
        }
        assert_eq!(graph.len(), 150);
        assert_eq!(graph.nodes().len(), 50);
        assert_eq!(graph.count(EntityKind::Publisher), 50);
        assert_eq!(graph.count(EntityKind::Subscriber), 25);
        assert_eq!(graph.publishers("/rosout").len(), 50);
        assert_eq!(graph.servers("/x").len(), 25);
        assert_eq!(graph.node_endpoints("/demo/n7").len(), 2);
        assert_eq!(graph.types_of("/rosout").len(), 1);
        assert!(graph.topics().contains_key("/x"));
        assert!(graph.services().contains_key("/x"));
        // Every other one leaves: each index forgets it, empty entries go.
        for token in tokens.iter().step_by(2) {
            assert!(graph.remove(token).is_some());
            assert!(graph.remove(token).is_none());
        }
        let rebuilt = Graph::from_tokens(tokens.iter().skip(1).step_by(2).map(String::as_str));
        assert_eq!(graph.len(), rebuilt.len());
        assert_eq!(graph.nodes(), rebuilt.nodes());
        assert_eq!(graph.topics(), rebuilt.topics());
        assert_eq!(graph.services(), rebuilt.services());
        assert_eq!(graph.by_name.len(), rebuilt.by_name.len());
        assert_eq!(graph.by_node.len(), rebuilt.by_node.len());
        for kind in [
            EntityKind::Node,
            EntityKind::Publisher,
            EntityKind::Subscriber,
            EntityKind::ServiceServer,
        ] {
            assert_eq!(graph.count(kind), rebuilt.count(kind), "{kind:?}");
        }
        for token in tokens.iter().skip(1).step_by(2) {
            graph.remove(token);
        }
        assert!(graph.is_empty());
        assert!(graph.by_name.is_empty() && graph.by_node.is_empty() && graph.nodes.is_empty());
    }

    /// Tokens a hostile program declares: long ones are unreadable and kept
    /// short, the graph holds a bounded number of entities, and everything
    /// goes when the tokens go.
    #[test]
    fn hostile_tokens_are_bounded_and_forgotten() {
        let long = "x".repeat(60_000);
        let tokens: Vec<String> = (0..2200)
            .map(|i| {
                let name = if i % 7 == 0 { long.as_str() } else { "chatter" };
                format!(
                    "@ros2_lv/0/ab/1/{i}/MP/%/%/n/%{name}/std_msgs::msg::dds_::String_/RIHS01_00/::,10:,:,:,,"
                )
            })
            .collect();
        let mut graph = Graph::from_tokens(tokens.iter().map(String::as_str));
        let long_ones = tokens.iter().filter(|t| t.len() > MAX_TOKEN_LEN).count();
        assert_eq!(graph.len(), tokens.len() - long_ones);
        assert_eq!(graph.unreadable().len(), long_ones);
        for e in graph.unreadable() {
            assert!(
                e.token.len() <= KEPT_TOKEN + 3,
                "{} bytes kept",
                e.token.len()
            );
            assert!(e.to_string().contains("4096 bytes"), "{e}");
        }
        for token in &tokens {
            graph.remove(token);
        }
        assert!(graph.is_empty() && graph.unreadable().len() == 0);
        assert!(graph.by_name.capacity() < 1024);

        // At the entity cap, further tokens wait among the unreadable.
        let node = |i: usize| format!("@ros2_lv/0/ab/{i}/{i}/NN/%/%/n{i}");
        let mut graph = Graph::from_tokens(
            (0..MAX_ENTITIES + 5)
                .map(node)
                .collect::<Vec<_>>()
                .iter()
                .map(String::as_str),
        );
        assert_eq!(graph.len(), MAX_ENTITIES);
        assert_eq!(graph.unreadable().len(), 5);
        assert!(graph
            .unreadable()
            .all(|e| e.reason.contains("as many entities")));
        graph.remove(&node(0));
        assert!(graph.insert(&node(MAX_ENTITIES + 9)).is_some());
    }

    /// Heap bytes alive, counted per thread, so tests running beside each
    /// other do not count each other's allocations.
    mod heap {
        use std::alloc::{GlobalAlloc, Layout, System};
        use std::cell::Cell;

        thread_local! {
            static LIVE: Cell<isize> = const { Cell::new(0) };
        }

        fn add(bytes: isize) {
            // A thread being torn down no longer counts.
            let _ = LIVE.try_with(|live| live.set(live.get() + bytes));
        }

        pub fn live() -> isize {
            LIVE.with(Cell::get)
        }

        struct Counting;

        // SAFETY: every call goes to `System` with the caller's own layout
        // and pointer; the counter only adds up sizes on the calling thread.
        unsafe impl GlobalAlloc for Counting {
            unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
                add(layout.size() as isize);
                // SAFETY: the caller's layout, as `GlobalAlloc::alloc` requires.
                unsafe { System.alloc(layout) }
            }
            unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
                add(-(layout.size() as isize));
                // SAFETY: `ptr` came from `alloc` (or `realloc`) with `layout`.
                unsafe { System.dealloc(ptr, layout) }
            }
            unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
                add(new_size as isize - layout.size() as isize);
                // SAFETY: the caller's pointer, layout and size, as
                // `GlobalAlloc::realloc` requires.
                unsafe { System.realloc(ptr, layout, new_size) }
            }
        }

        #[global_allocator]
        static COUNTING: Counting = Counting;
    }

    #[test]
    fn entities_that_leave_give_their_memory_back_and_a_token_costs_a_small_multiple_of_its_size() {
        // Two rounds of 2 000 endpoints with long (4 KB) names appearing and
        // leaving, each round under names never seen before, as churn brings.
        let token = |round: usize, i: usize| {
            let node = crate::rmw::NodeInfo {
                domain_id: 0,
                zid: "8b20917502ee955ac4476e0266340d5c".into(),
                node_id: (i / 50) as u64,
                enclave: "/".into(),
                namespace: "/churn".into(),
                name: format!("node_{round}_{}", i / 50),
                distro: crate::rmw::Distro::Kilted,
            };
            let name = format!("/{}_{round}_{i}", "x".repeat(3800));
            node.topic_token::<shm_cdr::msgs::std_msgs::String>(
                i as u64 + 1,
                EntityKind::Publisher,
                &name,
                &Qos::default(),
            )
        };
        let mut graph = Graph::default();
        let before = heap::live();
        for round in 0..2 {
            let tokens: Vec<String> = (0..2000).map(|i| token(round, i)).collect();
            let token_bytes: usize = tokens.iter().map(String::len).sum();
            let at_start = heap::live();
            for t in &tokens {
                assert!(graph.insert(t).is_some(), "{t}");
            }
            let held = (heap::live() - at_start) as usize;
            assert!(
                held < 4 * token_bytes,
                "2 000 tokens of {} bytes hold {held} bytes",
                token_bytes / 2000
            );
            for t in &tokens {
                assert!(graph.remove(t).is_some());
            }
            assert!(graph.is_empty());
            drop(tokens);
            let after = heap::live() - before;
            assert!(
                after < 64 << 10,
                "round {round}: {after} bytes still held after every entity left (held {held})"
            );
        }
    }
}
