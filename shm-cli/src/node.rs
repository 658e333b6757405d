//! `shm-ros2 node …`: ros2node's verbs and output.

use std::collections::{BTreeMap, BTreeSet};
use std::io::Write;

use clap::Subcommand;
use shm_runtime::graph::Graph;
use shm_runtime::rmw::EntityKind;

use crate::context::{is_hidden, Context};
use crate::Error;

#[derive(Debug, Subcommand)]
pub(crate) enum NodeCommand {
    /// Output a list of available nodes.
    List {
        /// Display all nodes even hidden ones.
        #[arg(short, long)]
        all: bool,
        /// Only display the number of nodes discovered.
        #[arg(short, long)]
        count_nodes: bool,
    },
    /// Output information about a node.
    Info {
        /// Fully qualified node name to request information.
        node_name: String,
        /// Display hidden topics, services, and actions as well.
        #[arg(long)]
        include_hidden: bool,
    },
}

pub(crate) fn run(context: &Context, command: NodeCommand) -> Result<(), Error> {
    match command {
        NodeCommand::List { all, count_nodes } => {
            let graph = context.graph();
            let nodes: BTreeSet<String> = graph
                .nodes()
                .into_iter()
                .filter(|n| {
                    all || !n
                        .rsplit('/')
                        .next()
                        .is_some_and(|name| name.starts_with('_'))
                })
                .collect();
            let mut out = std::io::stdout().lock();
            if count_nodes {
                writeln!(out, "{}", nodes.len())?;
            } else {
                for node in nodes {
                    writeln!(out, "{node}")?;
                }
            }
            Ok(())
        }
        NodeCommand::Info {
            node_name,
            include_hidden,
        } => {
            let graph = context
                .wait_for(|g| g.contains_node(&node_name))
                .ok_or_else(|| format!("Unable to find node '{node_name}'"))?;
            info(&graph, &node_name, include_hidden)
        }
    }
}

/// Names and types of one kind of a node's endpoints, sorted by name.
fn names_and_types(
    graph: &Graph,
    node: &str,
    kind: EntityKind,
    include_hidden: bool,
) -> BTreeMap<String, BTreeSet<String>> {
    let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for entity in graph.node_endpoints(node) {
        let Some(endpoint) = &entity.endpoint else {
            continue;
        };
        if entity.kind != kind || (!include_hidden && is_hidden(&endpoint.name)) {
            continue;
        }
        out.entry(endpoint.name.clone())
            .or_default()
            .insert(endpoint.type_name.clone());
    }
    out
}

/// A node's actions: the `send_goal` services of its action servers or
/// clients, `<pkg>/action/<Name>_SendGoal` read as `<pkg>/action/<Name>`.
fn actions(graph: &Graph, node: &str, kind: EntityKind) -> BTreeMap<String, BTreeSet<String>> {
    names_and_types(graph, node, kind, true)
        .into_iter()
        .filter_map(|(name, types)| {
            let action = name.strip_suffix("/_action/send_goal")?.to_owned();
            let types = types
                .iter()
                .filter_map(|t| t.strip_suffix("_SendGoal"))
                .map(str::to_owned)
                .collect();
            Some((action, types))
        })
        .collect()
}

fn info(graph: &Graph, node: &str, include_hidden: bool) -> Result<(), Error> {
    let count = graph.nodes().iter().filter(|n| *n == node).count();
    if count > 1 {
        eprintln!(
            "There are {count} nodes in the graph with the exact name \"{node}\". \
             You are seeing information about only one of them."
        );
    }
    let mut out = std::io::stdout().lock();
    writeln!(out, "{node}")?;
    let sections = [
        (
            "Subscribers",
            names_and_types(graph, node, EntityKind::Subscriber, include_hidden),
        ),
        (
            "Publishers",
            names_and_types(graph, node, EntityKind::Publisher, include_hidden),
        ),
        (
            "Service Servers",
            names_and_types(graph, node, EntityKind::ServiceServer, include_hidden),
        ),
        (
            "Service Clients",
            names_and_types(graph, node, EntityKind::ServiceClient, include_hidden),
        ),
        (
            "Action Servers",
            actions(graph, node, EntityKind::ServiceServer),
        ),
        (
            "Action Clients",
            actions(graph, node, EntityKind::ServiceClient),
        ),
    ];
    for (title, entries) in sections {
        writeln!(out, "  {title}:")?;
        // ros2cli prints the list joined by line breaks: an empty section is
        // one empty line.
        let lines: Vec<String> = entries
            .iter()
            .map(|(name, types)| {
                let types: Vec<&str> = types.iter().map(String::as_str).collect();
                format!("    {name}: {}", types.join(", "))
            })
            .collect();
        writeln!(out, "{}", lines.join("\n"))?;
    }
    Ok(())
}
