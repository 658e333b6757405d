//! Type resolution: the one place a name and hash seen in the graph, in a
//! recording or on the command line become a run-time type
//! ([`DynamicType`]) with the definition text a recording keeps.
//!
//! A type is looked for, in this order, in
//! - the standard set this crate is built with ([`standard`]), as the
//!   distribution of the system defines it;
//! - interface files ([`LocalInterfaces`]): `.msg`/`.srv`/`.action`
//!   directories, or the definition a recording keeps
//!   ([`LocalInterfaces::from_definition`]);
//! - the node that announces it, through its `~/get_type_description`
//!   ([`ask_node`]), checked against the hash the graph announces.
//!
//! The recorder, the player and `shm-ros2`'s commands all resolve types
//! here.

pub mod definition;
pub mod local;
mod standard;

use std::time::Duration;

use crate::graph::Graph;
use crate::rmw::{Distro, TYPE_HASH_NOT_SUPPORTED};
use crate::RosNode;
use shm_cdr::dynamic::DynamicType;
use shm_cdr::msgs::type_description_interfaces::srv::{
    GetTypeDescription, GetTypeDescription_Request, GetTypeDescription_Response,
};
use zenoh::Wait;

use local::LocalInterfaces;
use standard::standard_message_announced;
pub use standard::{
    full_name, standard, standard_description, standard_message, Kind, Known, ResolvedType,
};
use zenoh::Error;

/// The type of the messages on `topic`, as its publishers (else its
/// subscribers) announce it: the standard type if its hash is the one
/// announced, else the type of the interface files `local` if its hash is,
/// else the description the announcing node gives through `node` (waiting
/// up to `timeout` for its service).
pub fn of_topic(
    node: &RosNode,
    timeout: Duration,
    graph: &Graph,
    topic: &str,
    local: &LocalInterfaces,
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
    let distro = node.info().distro;
    if (endpoint.type_hash == TYPE_HASH_NOT_SUPPORTED) == distro.has_type_hashes() {
        return Err(format!(
            "topic {topic} is announced with type hash {}, and this node speaks {distro}'s conventions; \
             set ROS_DISTRO (or --distro) to the distribution of the nodes on it{}",
            endpoint.type_hash,
            if distro.has_type_hashes() {
                " (humble: its nodes have no type hashes)"
            } else {
                ""
            }
        )
        .into());
    }
    if let Some(resolved) = resolve_locally(distro, &endpoint.type_name, &endpoint.type_hash, local)
    {
        return resolved;
    }
    if !distro.has_type_hashes() {
        return Err(format!(
            "topic {topic} is of type {}, which is not a standard type, and {distro}'s nodes \
             describe no types: give its interface files with --interfaces",
            endpoint.type_name
        )
        .into());
    }
    ask_node(
        node,
        timeout,
        &first.node_fqn(),
        &endpoint.type_name,
        &endpoint.type_hash,
    )
}

/// A message type by name alone (`pkg/msg/Name` or `pkg/Name`), as a
/// program is told it rather than reads it from the graph: the standard
/// type as `distro` defines it, else the type of the interface files
/// `local`. `None` when neither has it.
pub fn message_by_name(
    distro: Distro,
    name: &str,
    local: &LocalInterfaces,
) -> Option<Result<ResolvedType, Error>> {
    if let Some(resolved) = standard_message(name, distro) {
        return Some(Ok(resolved));
    }
    local.resolve(&full_name(name))
}

/// The message type `name` of a recorded topic (`hash` empty when the
/// recording keeps none): from the `definition` the recording keeps
/// (rosbag2's `ros2msg` text), when it gives a type of that hash, else the
/// standard type of that name as `distro` defines it. `None` when neither
/// gives one.
pub fn of_recording(
    name: &str,
    hash: &str,
    definition: Option<&str>,
    distro: Distro,
) -> Option<ResolvedType> {
    let from_definition = definition
        .filter(|text| !text.is_empty())
        .and_then(|text| LocalInterfaces::from_definition(name, text).ok())
        .and_then(|local| local.resolve(name))
        .and_then(Result::ok);
    match from_definition {
        Some(resolved) if hash.is_empty() || resolved.ty.type_hash() == hash => Some(resolved),
        _ => standard_message(name, distro),
    }
}

/// The message type `name` announced with `hash`, from what is known without
/// asking any node: the standard set (on Humble, which announces no hashes,
/// by name as Humble defines it), else the interface files `local` (whose
/// type must have the announced hash, except on Humble). `None` when neither
/// has it.
pub fn resolve_locally(
    distro: Distro,
    name: &str,
    hash: &str,
    local: &LocalInterfaces,
) -> Option<Result<ResolvedType, Error>> {
    if let Some(known) = standard_message_announced(name, hash) {
        // The files as the distribution of the system words them.
        let description = shm_cdr::distro_msgs::with_sources_of(distro.name(), (known.describe)());
        return Some(
            DynamicType::from_description(&description)
                .map(|ty| ResolvedType {
                    ty,
                    definition: definition::of_description(&description),
                })
                .map_err(Error::from),
        );
    }
    match local.resolve(name)? {
        Ok(resolved) if !distro.has_type_hashes() || resolved.ty.type_hash() == hash => {
            Some(Ok(resolved))
        }
        Ok(_) => None,
        Err(e) => Some(Err(e)),
    }
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

/// The most bytes of a type-description reply that are decoded: the
/// description of a type with hundreds of nested types, with their sources,
/// is well within it.
pub const MAX_DESCRIPTION_REPLY: usize = 16 << 20;

/// `node_fqn`'s description of `name`, checked against `hash`: the type
/// built from it, and the reply (for its sources).
fn ask(
    node: &RosNode,
    timeout: Duration,
    node_fqn: &str,
    name: &str,
    hash: &str,
) -> Result<(DynamicType, GetTypeDescription_Response), Error> {
    // The whole question, service discovery and reply, within `timeout`.
    let deadline = std::time::Instant::now() + timeout;
    let service = format!("{}/get_type_description", node_fqn.trim_end_matches('/'));
    let client = node.declare_client::<GetTypeDescription>(&service).wait()?;
    if !client.wait_for_service(timeout) {
        return Err(format!(
            "{name} is not a type this binary knows, and {node_fqn} offers no {service} (waited {timeout:?}): \
             run the node with its type-description service on, or give the type's interface files"
        )
        .into());
    }
    let reply = client
        .call_reply(&GetTypeDescription_Request {
            type_name: name.to_owned(),
            type_hash: hash.to_owned(),
            include_type_sources: true,
        })
        .timeout(deadline.saturating_duration_since(std::time::Instant::now()))
        .wait()
        .map_err(|e| {
            format!(
                "{name} is not a type this binary knows, and {service} gave no description \
                 within {timeout:?} ({e}): give the type's interface files"
            )
        })?;
    // Checked before it is decoded: a reply's size is the node's to choose.
    let size = reply.payload().len();
    if size > MAX_DESCRIPTION_REPLY {
        return Err(format!(
            "{service} answered with {size} bytes for {name}, more than the \
             {MAX_DESCRIPTION_REPLY} read: give the type's interface files"
        )
        .into());
    }
    let reply = reply
        .response()
        .map_err(|e| format!("{service}'s reply does not decode: {e}"))?;
    if !reply.successful {
        return Err(format!(
            "{service} has no description of {name}: {}",
            reply.failure_reason
        )
        .into());
    }
    let ty = DynamicType::from_type_description_msg(&reply.type_description)
        .map_err(|e| format!("{service}'s description of {name} is refused: {e}"))?;
    if ty.type_hash() != hash {
        return Err(format!(
            "{service} described {name} with hash {}, not the announced {hash}",
            ty.type_hash()
        )
        .into());
    }
    Ok((ty, reply))
}

/// A standard type by name, if its hash is `hash`: a message, service or
/// action of the set built in, or a part of a standard action
/// (`pkg/action/Name_SendGoal`, `…_FeedbackMessage`, …).
pub fn standard_type(name: &str, hash: &str) -> Option<DynamicType> {
    let table = standard();
    let ty = match table.get(name) {
        Some(known) => DynamicType::from_description(&(known.describe)()).ok()?,
        None => {
            // The action whose name is the longest prefix of `name` before a `_`.
            let (_, known) = table
                .iter()
                .filter(|(n, known)| {
                    known.kind == Kind::Action
                        && name
                            .strip_prefix(**n)
                            .is_some_and(|rest| rest.starts_with('_'))
                })
                .max_by_key(|(n, _)| n.len())?;
            DynamicType::from_description(&(known.describe)())
                .ok()?
                .member(name)?
        }
    };
    (ty.type_hash() == hash).then_some(ty)
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
    ResolvedService::of_type(&service_type_of(node, timeout, graph, service, expected)?)
}

/// [`of_service`], the service as one run-time type: its own description
/// with its request, response and event, as a server of it describes it to
/// other nodes.
pub fn service_type_of(
    node: &RosNode,
    timeout: Duration,
    graph: &Graph,
    service: &str,
    expected: Option<&str>,
) -> Result<DynamicType, Error> {
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
    Ok(match standard_type(name, hash) {
        Some(ty) => ty,
        None => ask(node, timeout, &first.node_fqn(), name, hash)?.0,
    })
}

/// A service type by name alone (`pkg/srv/Name` or `pkg/Name`), as a
/// program is told it rather than reads it from the graph: the standard
/// service as `distro` defines it. `None` when the standard set has no
/// service of that name.
pub fn service_by_name(distro: Distro, name: &str) -> Option<Result<ResolvedService, Error>> {
    Some(service_type_by_name(distro, name)?.and_then(|ty| ResolvedService::of_type(&ty)))
}

/// [`service_by_name`], the service as one run-time type: its own
/// description with its request, response and event, as a server of it
/// describes it to other nodes.
pub fn service_type_by_name(distro: Distro, name: &str) -> Option<Result<DynamicType, Error>> {
    let name = match name.split('/').collect::<Vec<_>>()[..] {
        [pkg, ty] => format!("{pkg}/srv/{ty}"),
        _ => name.to_owned(),
    };
    let (Kind::Service, description) = standard_description(&name, distro)? else {
        return None;
    };
    Some(DynamicType::from_description(&description).map_err(Error::from))
}

impl ResolvedService {
    /// The service a run-time type describes (its name, its RIHS01 hash,
    /// and its members `<name>_Request` and `<name>_Response`).
    pub fn of_type(ty: &DynamicType) -> Result<Self, Error> {
        Self::of(ty, ty.name(), &ty.type_hash())
    }

    /// The service `name` of hash `hash` from its type, whose members are
    /// its request and response.
    fn of(ty: &DynamicType, name: &str, hash: &str) -> Result<Self, Error> {
        let part = |suffix: &str| {
            ty.member(&format!("{name}{suffix}"))
                .ok_or_else(|| format!("the description of {name} has no {name}{suffix}"))
        };
        Ok(Self {
            request: part("_Request")?,
            response: part("_Response")?,
            name: name.to_owned(),
            hash: hash.to_owned(),
        })
    }
}

/// An action type resolved from its server's endpoints: its goal-sending
/// and result services and its feedback message, as run-time types.
#[derive(Debug, Clone)]
pub struct ResolvedAction {
    /// `pkg/action/Name`.
    pub name: String,
    /// `<action>/_action/send_goal`: `pkg/action/Name_SendGoal`.
    pub send_goal: ResolvedService,
    /// `<action>/_action/get_result`: `pkg/action/Name_GetResult`.
    pub get_result: ResolvedService,
    /// `<action>/_action/feedback`: `pkg/action/Name_FeedbackMessage`, with
    /// its RIHS01 hash.
    pub feedback: (DynamicType, String),
}

/// The type of `action` as its server announces it (checked against
/// `expected`, `pkg/action/Name` or `pkg/Name`, when given): the standard
/// action if its parts' hashes are the ones announced, else the
/// descriptions the server's node gives of each part.
pub fn of_action(
    node: &RosNode,
    timeout: Duration,
    graph: &Graph,
    action: &str,
    expected: Option<&str>,
) -> Result<ResolvedAction, Error> {
    let part = |p: &str| format!("{}/_action/{p}", action.trim_end_matches('/'));
    let send_goal = of_service(node, timeout, graph, &part("send_goal"), None)
        .map_err(|e| format!("action {action}: {e}"))?;
    let Some(name) = send_goal.name.strip_suffix("_SendGoal").map(str::to_owned) else {
        return Err(format!(
            "action {action}: its send_goal service is of type {}",
            send_goal.name
        )
        .into());
    };
    if let Some(expected) = expected {
        let expected = match expected.split('/').collect::<Vec<_>>()[..] {
            [pkg, ty] => format!("{pkg}/action/{ty}"),
            _ => expected.to_owned(),
        };
        if expected != name {
            return Err(format!("action {action} is of type {name}, not {expected}").into());
        }
    }
    let get_result = of_service(node, timeout, graph, &part("get_result"), None)
        .map_err(|e| format!("action {action}: {e}"))?;
    let feedback_topic = part("feedback");
    let feedback_name = format!("{name}_FeedbackMessage");
    // The feedback type: a standard action's, else the description the
    // server's node gives (it publishes the feedback).
    let hash = graph
        .publishers(&feedback_topic)
        .first()
        .and_then(|p| p.endpoint.as_ref().map(|e| e.type_hash.clone()))
        .ok_or_else(|| {
            format!("action {action}: no feedback publisher announces {feedback_name}")
        })?;
    let ty = match standard_type(&feedback_name, &hash) {
        Some(ty) => ty,
        None => {
            let server = graph
                .servers(&part("send_goal"))
                .first()
                .map(|s| s.node_fqn())
                .ok_or_else(|| format!("action {action} has no server"))?;
            ask(node, timeout, &server, &feedback_name, &hash)?.0
        }
    };
    let feedback = (ty, hash);
    Ok(ResolvedAction {
        name,
        send_goal,
        get_result,
        feedback,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use shm_cdr::msgs::std_srvs::srv::SetBool;
    use shm_cdr::RosService;

    #[test]
    fn a_service_by_name_has_rosidl_s_hash_and_its_two_parts() {
        for name in ["std_srvs/srv/SetBool", "std_srvs/SetBool"] {
            let resolved = service_by_name(Distro::Kilted, name).unwrap().unwrap();
            assert_eq!(resolved.name, "std_srvs/srv/SetBool");
            assert_eq!(resolved.hash, SetBool::type_hash());
            assert_eq!(resolved.request.name(), "std_srvs/srv/SetBool_Request");
            assert_eq!(resolved.response.name(), "std_srvs/srv/SetBool_Response");
            let fields: Vec<&str> = resolved
                .response
                .root()
                .fields
                .iter()
                .map(|f| f.name.as_str())
                .collect();
            assert_eq!(fields, ["success", "message"]);
        }
        // A message is not a service, and an unknown name is none.
        assert!(service_by_name(Distro::Kilted, "std_msgs/msg/String").is_none());
        assert!(service_by_name(Distro::Kilted, "my_srvs/srv/Nothing").is_none());
    }
}
