//! The ROS graph as rmw_zenoh_cpp announces it: every node, publisher,
//! subscriber, service server and client holds a liveliness token
//! `@ros2_lv/<domain>/<zid>/<node id>/<entity id>/<kind>/<enclave>/<namespace>/<node>[/<topic>/<type>/<hash>/<qos>]`;
//! [`Graph`] is a snapshot of them, read back into names, types, QoS and GIDs,
//! as `ros2 node list`, `ros2 topic list -t` and `ros2 topic info -v` show them.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;

use crate::ros::rmw::{Durability, EntityKind, Gid, History, Qos, Reliability};

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
    /// The token itself.
    pub token: String,
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
}

/// `%` back to `/` (see [`crate::ros::rmw::mangle_name`]).
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
/// volatile, keep last 42).
fn parse_qos(text: &str) -> Option<Qos> {
    let fields: Vec<&str> = text.split(':').collect();
    let [reliability, durability, history, ..] = fields[..] else {
        return None;
    };
    let reliability = match reliability {
        "" | "1" => Reliability::Reliable,
        "2" => Reliability::BestEffort,
        _ => return None,
    };
    let durability = match durability {
        "" | "2" => Durability::Volatile,
        "1" => Durability::TransientLocal,
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
    Some(Qos {
        reliability,
        durability,
        history,
    })
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
        let parts: Vec<&str> = rest.split('/').collect();
        if parts.len() != 8 && parts.len() != 12 {
            return Err(error("has neither 8 (node) nor 12 (endpoint) fields"));
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
            token: token.to_owned(),
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

/// A snapshot of the graph: every entity whose token was alive.
#[derive(Debug, Clone, Default)]
pub struct Graph {
    /// Every entity, in token order.
    pub entities: Vec<Entity>,
    /// Tokens under `@ros2_lv` that could not be read, with why.
    pub unreadable: Vec<TokenError>,
}

impl Graph {
    /// Build a graph from tokens.
    pub fn from_tokens<'a>(tokens: impl IntoIterator<Item = &'a str>) -> Self {
        let mut graph = Self::default();
        let mut tokens: Vec<&str> = tokens.into_iter().collect();
        tokens.sort_unstable();
        tokens.dedup();
        for token in tokens {
            match Entity::parse(token) {
                Ok(entity) => graph.entities.push(entity),
                Err(e) => graph.unreadable.push(e),
            }
        }
        graph
    }

    /// Fully qualified node names, sorted (`ros2 node list`).
    pub fn nodes(&self) -> Vec<String> {
        let names: BTreeSet<String> = self
            .entities
            .iter()
            .filter(|e| e.kind == EntityKind::Node)
            .map(Entity::node_fqn)
            .collect();
        names.into_iter().collect()
    }

    fn names_and_types(&self, kinds: &[EntityKind]) -> BTreeMap<String, BTreeSet<String>> {
        let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for e in &self.entities {
            if let (true, Some(endpoint)) = (kinds.contains(&e.kind), &e.endpoint) {
                out.entry(endpoint.name.clone())
                    .or_default()
                    .insert(endpoint.type_name.clone());
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

    /// Servers of `action` (the servers of its `send_goal` service).
    pub fn action_servers(&self, action: &str) -> Vec<&Entity> {
        self.servers(&format!("{action}/_action/send_goal"))
    }

    /// Clients of `action` (the clients of its `send_goal` service).
    pub fn action_clients(&self, action: &str) -> Vec<&Entity> {
        self.endpoints(
            EntityKind::ServiceClient,
            &format!("{action}/_action/send_goal"),
        )
    }

    /// The endpoints of `kind` on topic or service `name` (`ros2 topic info -v`).
    pub fn endpoints(&self, kind: EntityKind, name: &str) -> Vec<&Entity> {
        self.entities
            .iter()
            .filter(|e| e.kind == kind && e.endpoint.as_ref().is_some_and(|t| t.name == name))
            .collect()
    }

    /// Publishers of `topic`.
    pub fn publishers(&self, topic: &str) -> Vec<&Entity> {
        self.endpoints(EntityKind::Publisher, topic)
    }

    /// Subscribers of `topic`.
    pub fn subscribers(&self, topic: &str) -> Vec<&Entity> {
        self.endpoints(EntityKind::Subscriber, topic)
    }

    /// Servers of `service`.
    pub fn servers(&self, service: &str) -> Vec<&Entity> {
        self.endpoints(EntityKind::ServiceServer, service)
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
            Qos {
                reliability: Reliability::BestEffort,
                durability: Durability::TransientLocal,
                history: History::KeepLast(7),
            }
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
        ] {
            assert_eq!(parse_qos(&qos.to_key_expr()), Some(qos));
        }
        let node = Entity::parse("@ros2_lv/0/ab/3/3/NN/%/%/listener").unwrap();
        assert_eq!(
            (node.kind, node.node_fqn()),
            (EntityKind::Node, "/listener".into())
        );
        assert!(node.endpoint.is_none());
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
        assert_eq!(graph.nodes(), ["/n"]);
        assert_eq!(graph.unreadable.len(), 1);
    }
}
