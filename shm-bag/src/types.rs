//! Message types of live topics: the standard ones this crate is built with,
//! and any other asked of the node that announces it
//! (`~/get_type_description`), each checked against the hash the graph
//! announces, with the definition text a recording keeps.

use std::collections::BTreeMap;
use std::sync::OnceLock;
use std::time::Duration;

use shm_cdr::describe::FullDescription;
use shm_cdr::dynamic::DynamicType;
use shm_cdr::msgs::type_description_interfaces::srv::{
    GetTypeDescription, GetTypeDescription_Request, GetTypeDescription_Response,
};
use shm_cdr::{RosAction, RosMessage, RosService};
use shm_runtime::graph::Graph;
use shm_runtime::RosNode;
use zenoh::Wait;

use crate::definition;
use crate::Error;

/// Which kind of interface.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Message,
    Service,
    Action,
}

/// What the binary knows of a standard interface.
pub struct Known {
    pub kind: Kind,
    pub hash: &'static str,
    pub describe: fn() -> FullDescription,
}

/// Every standard message, service and action type, by name.
pub fn standard() -> &'static BTreeMap<&'static str, Known> {
    static TABLE: OnceLock<BTreeMap<&'static str, Known>> = OnceLock::new();
    TABLE.get_or_init(|| {
        macro_rules! table {
            (
                messages: [$($m:ty),* $(,)?],
                borrowed: [$(($o:ty, $r:ty)),* $(,)?],
                services: [$($s:ty),* $(,)?],
                actions: [$($a:ty),* $(,)?],
            ) => {{
                let mut out = BTreeMap::new();
                $( out.insert(<$m as RosMessage>::TYPE_NAME, Known {
                    kind: Kind::Message,
                    hash: <$m as RosMessage>::type_hash(),
                    describe: <$m as RosMessage>::full_description,
                }); )*
                $( out.insert(<$s as RosService>::TYPE_NAME, Known {
                    kind: Kind::Service,
                    hash: <$s as RosService>::type_hash(),
                    describe: <$s as RosService>::full_description,
                }); )*
                $( out.insert(<$a as RosAction>::TYPE_NAME, Known {
                    kind: Kind::Action,
                    hash: <$a as RosAction>::type_hash(),
                    describe: <$a as RosAction>::full_description,
                }); )*
                out
            }};
        }
        shm_cdr::for_each_interface!(table)
    })
}

/// `pkg/msg/Name` from what users write: `pkg/msg/Name` or `pkg/Name`.
pub fn full_name(name: &str) -> String {
    let parts: Vec<&str> = name.split('/').collect();
    match parts[..] {
        [pkg, ty] => format!("{pkg}/msg/{ty}"),
        _ => name.to_owned(),
    }
}

/// A message type resolved for a topic: the run-time type and its complete
/// definition in rosbag2's `ros2msg` form.
#[derive(Debug, Clone)]
pub struct ResolvedType {
    /// The run-time type (its name and RIHS01 hash are the announced ones).
    pub ty: DynamicType,
    /// The `.msg` text of the type and, after rosbag2's delimiters, of every
    /// type it uses (see [`definition`]).
    pub definition: String,
}

/// A standard message type by name (`pkg/msg/Name` or `pkg/Name`).
pub fn standard_message(name: &str) -> Option<ResolvedType> {
    let known = standard().get(full_name(name).as_str())?;
    if known.kind != Kind::Message {
        return None;
    }
    let description = (known.describe)();
    let ty = DynamicType::from_description(&description).ok()?;
    Some(ResolvedType {
        ty,
        definition: definition::of_description(&description),
    })
}

/// The type of the messages on `topic`, as its publishers (else its
/// subscribers) announce it: the standard type if its hash is the one
/// announced, else the description the announcing node gives through `node`
/// (waiting up to `timeout` for its service).
pub fn of_topic(
    node: &RosNode,
    timeout: Duration,
    graph: &Graph,
    topic: &str,
) -> Result<ResolvedType, Error> {
    let mut endpoints = graph.publishers(topic);
    if endpoints.is_empty() {
        endpoints = graph.subscribers(topic);
    }
    let Some(first) = endpoints.first() else {
        return Err(format!("topic {topic} has no publishers or subscribers").into());
    };
    let announced: std::collections::BTreeSet<(String, String)> = endpoints
        .iter()
        .filter_map(|e| e.endpoint.as_ref())
        .map(|e| (e.type_name.clone(), e.type_hash.clone()))
        .collect();
    if announced.len() > 1 {
        let list: Vec<String> = announced
            .iter()
            .map(|(n, h)| format!("{n} ({h})"))
            .collect();
        return Err(format!(
            "topic {topic} carries more than one type: {}",
            list.join(", ")
        )
        .into());
    }
    let Some(endpoint) = first.endpoint.as_ref() else {
        return Err(format!("topic {topic}: its endpoint announces no type").into());
    };
    if let Some(known) = standard().get(endpoint.type_name.as_str()) {
        if known.hash == endpoint.type_hash {
            let description = (known.describe)();
            return Ok(ResolvedType {
                ty: DynamicType::from_description(&description)?,
                definition: definition::of_description(&description),
            });
        }
    }
    ask_node(
        node,
        timeout,
        &first.node_fqn(),
        &endpoint.type_name,
        &endpoint.type_hash,
    )
}

/// The type `name` with hash `hash`, from `node_fqn`'s
/// `~/get_type_description`, asked through `node`.
pub fn ask_node(
    node: &RosNode,
    timeout: Duration,
    node_fqn: &str,
    name: &str,
    hash: &str,
) -> Result<ResolvedType, Error> {
    let (ty, reply) = ask(node, timeout, node_fqn, name, hash)?;
    Ok(ResolvedType {
        definition: definition::of_reply(&reply.type_description, &reply.type_sources),
        ty,
    })
}

/// `node_fqn`'s description of `name`, checked against `hash`: the type
/// built from it, and the reply (for its sources).
fn ask(
    node: &RosNode,
    timeout: Duration,
    node_fqn: &str,
    name: &str,
    hash: &str,
) -> Result<(DynamicType, GetTypeDescription_Response), Error> {
    let service = format!("{}/get_type_description", node_fqn.trim_end_matches('/'));
    let client = node.declare_client::<GetTypeDescription>(&service).wait()?;
    if !client.wait_for_service(timeout) {
        return Err(format!(
            "{name} is not a type this binary knows, and {node_fqn} does not answer {service} (waited {timeout:?}): \
             run the node with its type-description service on"
        )
        .into());
    }
    let reply = client
        .call(&GetTypeDescription_Request {
            type_name: name.to_owned(),
            type_hash: hash.to_owned(),
            include_type_sources: true,
        })
        .wait()
        .map_err(|e| format!("{service}: {e}"))?;
    if !reply.successful {
        return Err(format!(
            "{service} has no description of {name}: {}",
            reply.failure_reason
        )
        .into());
    }
    let ty = DynamicType::from_type_description_msg(&reply.type_description)?;
    if ty.type_hash() != hash {
        return Err(format!(
            "{service} described {name} with hash {}, not the announced {hash}",
            ty.type_hash()
        )
        .into());
    }
    Ok((ty, reply))
}

/// A service type resolved: its name and hash as announced, and its request
/// and response as run-time types.
#[derive(Debug, Clone)]
pub struct ResolvedService {
    /// `pkg/srv/Name`.
    pub name: String,
    /// Its RIHS01 hash.
    pub hash: String,
    /// `pkg/srv/Name_Request`.
    pub request: DynamicType,
    /// `pkg/srv/Name_Response`.
    pub response: DynamicType,
}

/// The type of `service` as its servers announce it (checked against
/// `expected`, a name as users write it, when given): the standard type if
/// its hash is the one announced, else the description the server's node
/// gives.
pub fn of_service(
    node: &RosNode,
    timeout: Duration,
    graph: &Graph,
    service: &str,
    expected: Option<&str>,
) -> Result<ResolvedService, Error> {
    let servers = graph.servers(service);
    let announced: std::collections::BTreeSet<(String, String)> = servers
        .iter()
        .filter_map(|e| e.endpoint.as_ref())
        .map(|e| (e.type_name.clone(), e.type_hash.clone()))
        .collect();
    let (Some(first), Some((name, hash))) = (servers.first(), announced.first()) else {
        return Err(format!("service {service} has no server").into());
    };
    if announced.len() > 1 {
        return Err(format!("service {service} is served with more than one type").into());
    }
    if let Some(expected) = expected {
        let expected = match expected.split('/').collect::<Vec<_>>()[..] {
            [pkg, ty] => format!("{pkg}/srv/{ty}"),
            _ => expected.to_owned(),
        };
        if &expected != name {
            return Err(format!("service {service} is of type {name}, not {expected}").into());
        }
    }
    let ty = match standard().get(name.as_str()) {
        Some(known) if known.kind == Kind::Service && known.hash == hash => {
            DynamicType::from_description(&(known.describe)())?
        }
        _ => ask(node, timeout, &first.node_fqn(), name, hash)?.0,
    };
    let part = |suffix: &str| {
        ty.member(&format!("{name}{suffix}"))
            .ok_or_else(|| format!("the description of {name} has no {name}{suffix}"))
    };
    Ok(ResolvedService {
        request: part("_Request")?,
        response: part("_Response")?,
        name: name.clone(),
        hash: hash.clone(),
    })
}
