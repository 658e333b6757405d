//! Message types as the commands need them, resolved by the runtime's type
//! resolution ([`shm_runtime::types`]): the standard ones this binary was
//! built with, the `--interfaces` files, and any other asked of the node that
//! uses it (`~/get_type_description`).

use shm_cdr::dynamic::DynamicType;
use shm_runtime::graph::Graph;

pub(crate) use shm_runtime::types::{full_name, standard, Kind};

use crate::context::Context;
use crate::Error;

/// For a message type name nothing here knows: the closest standard message
/// name, as " (did you mean pkg/msg/Name?)", when one is a few edits away
/// (a misspelling), else nothing.
pub(crate) fn did_you_mean(name: &str) -> String {
    let name = full_name(name);
    standard()
        .iter()
        .filter(|(_, known)| known.kind == Kind::Message)
        .map(|(known, _)| (strsim::levenshtein(&name, known), *known))
        .filter(|(distance, _)| *distance <= 3)
        .min()
        .map(|(_, known)| format!(" (did you mean {known}?)"))
        .unwrap_or_default()
}

/// A message type by name, as a run-time type: a standard one, else one of
/// the `--interfaces` files.
pub(crate) fn message_by_name(context: &Context, name: &str) -> Result<Option<DynamicType>, Error> {
    match shm_runtime::types::message_by_name(context.distro, name, &context.local) {
        Some(resolved) => Ok(Some(resolved?.ty)),
        None => Ok(None),
    }
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
    shm_runtime::types::of_topic(
        context.node()?,
        context.timeout,
        graph,
        topic,
        &context.local,
    )
    .map(|resolved| resolved.ty)
}
