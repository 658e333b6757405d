//! `shm-ros2 action …`: ros2action's `list` and `info`, from the graph.

use std::collections::BTreeSet;
use std::io::Write;

use clap::Subcommand;

use crate::context::Context;
use crate::Error;

#[derive(Debug, Subcommand)]
pub(crate) enum ActionCommand {
    /// Output a list of action names.
    List {
        /// Additionally show the action type.
        #[arg(short = 't', long)]
        show_types: bool,
        /// Only display the number of actions discovered.
        #[arg(short = 'c', long)]
        count_actions: bool,
    },
    /// Print information about an action.
    Info {
        /// Name of the ROS action to get info (e.g. '/fibonacci').
        action_name: String,
        /// Additionally show the action type.
        #[arg(short = 't', long)]
        show_types: bool,
        /// Only display the number of action clients and action servers.
        #[arg(short = 'c', long)]
        count: bool,
    },
}

pub(crate) fn run(context: &Context, command: ActionCommand) -> Result<(), Error> {
    let graph = context.graph();
    let mut out = std::io::stdout().lock();
    match command {
        ActionCommand::List {
            show_types,
            count_actions,
        } => {
            let actions = graph.actions();
            if count_actions {
                writeln!(out, "{}", actions.len())?;
                return Ok(());
            }
            for (name, types) in actions {
                if show_types {
                    let types: Vec<&str> = types.iter().map(String::as_str).collect();
                    writeln!(out, "{name} [{}]", types.join(", "))?;
                } else {
                    writeln!(out, "{name}")?;
                }
            }
        }
        ActionCommand::Info {
            action_name,
            show_types,
            count,
        } => {
            writeln!(out, "Action: {action_name}")?;
            for (label, entities) in [
                ("Action clients", graph.action_clients(&action_name)),
                ("Action servers", graph.action_servers(&action_name)),
            ] {
                // One line per node, with the action types it uses.
                let mut nodes: std::collections::BTreeMap<String, BTreeSet<String>> =
                    std::collections::BTreeMap::new();
                for entity in &entities {
                    let types = nodes.entry(entity.node_fqn()).or_default();
                    if let Some(endpoint) = &entity.endpoint {
                        if let Some(ty) = endpoint.type_name.strip_suffix("_SendGoal") {
                            types.insert(ty.to_owned());
                        }
                    }
                }
                writeln!(out, "{label}: {}", nodes.len())?;
                if count {
                    continue;
                }
                for (node, types) in nodes {
                    if show_types {
                        let types: Vec<&str> = types.iter().map(String::as_str).collect();
                        writeln!(out, "    {node} [{}]", types.join(", "))?;
                    } else {
                        writeln!(out, "    {node}")?;
                    }
                }
            }
        }
    }
    Ok(())
}
