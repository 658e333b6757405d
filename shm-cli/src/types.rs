//! Message types: the standard ones this binary was built with, and any other
//! asked of the node that uses it (`~/get_type_description`), as shm-bag
//! resolves them.

use shm_cdr::dynamic::DynamicType;
use shm_runtime::graph::Graph;

pub(crate) use shm_bag::types::{full_name, standard, Kind};

use crate::context::Context;
use crate::Error;

/// A standard message type by name, as a run-time type.
pub(crate) fn standard_message(name: &str) -> Option<DynamicType> {
    shm_bag::types::standard_message(name).map(|resolved| resolved.ty)
}

/// The type of the messages on `topic`, as its publishers (else its
/// subscribers) announce it: the standard type if its hash is the one
/// announced, else the description the announcing node gives.
pub(crate) fn of_topic(
    context: &Context,
    graph: &Graph,
    topic: &str,
) -> Result<DynamicType, Error> {
    if graph.publishers(topic).is_empty() && graph.subscribers(topic).is_empty() {
        return Err(format!(
            "topic {topic} has no publishers or subscribers; give its type: shm-ros2 topic echo {topic} <pkg/msg/Type>"
        )
        .into());
    }
    shm_bag::types::of_topic(context.node()?, context.timeout, graph, topic)
        .map(|resolved| resolved.ty)
}
