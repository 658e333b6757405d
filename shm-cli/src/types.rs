//! Message types: the standard ones this binary was built with, and any other
//! asked of the node that uses it (`~/get_type_description`).

use std::collections::BTreeMap;
use std::sync::OnceLock;

use shm_cdr::describe::FullDescription;
use shm_cdr::dynamic::DynamicType;
use shm_cdr::msgs::type_description_interfaces::srv::{
    GetTypeDescription, GetTypeDescription_Request,
};
use shm_cdr::{RosAction, RosMessage, RosService};
use shm_runtime::graph::Graph;
use zenoh::Wait;

use crate::context::Context;
use crate::Error;

/// Which kind of interface.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    Message,
    Service,
    Action,
}

/// What the binary knows of a standard interface.
pub(crate) struct Known {
    pub(crate) kind: Kind,
    pub(crate) hash: &'static str,
    pub(crate) describe: fn() -> FullDescription,
}

/// Every standard message, service and action type, by name.
pub(crate) fn standard() -> &'static BTreeMap<&'static str, Known> {
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
pub(crate) fn full_name(name: &str) -> String {
    let parts: Vec<&str> = name.split('/').collect();
    match parts[..] {
        [pkg, ty] => format!("{pkg}/msg/{ty}"),
        _ => name.to_owned(),
    }
}

/// A standard message type by name, as a run-time type.
pub(crate) fn standard_message(name: &str) -> Option<DynamicType> {
    let known = standard().get(full_name(name).as_str())?;
    DynamicType::from_description(&(known.describe)()).ok()
}

/// The type of the messages on `topic`, as its publishers (else its
/// subscribers) announce it: the standard type if its hash is the one
/// announced, else the description the announcing node gives.
pub(crate) fn of_topic(
    context: &Context,
    graph: &Graph,
    topic: &str,
) -> Result<DynamicType, Error> {
    let mut endpoints = graph.publishers(topic);
    if endpoints.is_empty() {
        endpoints = graph.subscribers(topic);
    }
    let Some(first) = endpoints.first() else {
        return Err(format!(
            "topic {topic} has no publishers or subscribers; give its type: shm-ros2 topic echo {topic} <pkg/msg/Type>"
        )
        .into());
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
            return Ok(DynamicType::from_description(&(known.describe)())?);
        }
    }
    ask_node(
        context,
        &first.node_fqn(),
        &endpoint.type_name,
        &endpoint.type_hash,
    )
}

/// The type `name` with hash `hash`, from `node`'s `~/get_type_description`.
pub(crate) fn ask_node(
    context: &Context,
    node: &str,
    name: &str,
    hash: &str,
) -> Result<DynamicType, Error> {
    let service = format!("{}/get_type_description", node.trim_end_matches('/'));
    let client = context
        .node()?
        .declare_client::<GetTypeDescription>(&service)
        .wait()?;
    if !client.wait_for_service(context.timeout) {
        return Err(format!(
            "{name} is not a type this binary knows, and {node} does not answer {service} (waited {:?}): \
             run the node with its type-description service on",
            context.timeout
        )
        .into());
    }
    let reply = client
        .call(&GetTypeDescription_Request {
            type_name: name.to_owned(),
            type_hash: hash.to_owned(),
            include_type_sources: false,
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
    Ok(ty)
}
