//! `shm-ros2 service …`: ros2service's verbs and output.

use std::io::Write;

use clap::Subcommand;

use crate::context::{is_hidden, Context};
use crate::Error;

#[derive(Debug, Subcommand)]
pub(crate) enum ServiceCommand {
    /// Output a list of available services.
    List {
        /// Additionally show the service type.
        #[arg(short = 't', long)]
        show_types: bool,
        /// Only display the number of services discovered.
        #[arg(short = 'c', long)]
        count_services: bool,
        /// Consider hidden services as well.
        #[arg(long)]
        include_hidden_services: bool,
    },
    /// Output a service's type.
    Type {
        /// Name of the ROS service to get type (e.g. '/add_two_ints').
        service_name: String,
    },
}

pub(crate) fn run(context: &Context, command: ServiceCommand) -> Result<(), Error> {
    let graph = context.graph();
    let mut out = std::io::stdout().lock();
    match command {
        ServiceCommand::List {
            show_types,
            count_services,
            include_hidden_services,
        } => {
            let services: Vec<_> = graph
                .services()
                .into_iter()
                .filter(|(name, _)| include_hidden_services || !is_hidden(name))
                .collect();
            if count_services {
                writeln!(out, "{}", services.len())?;
                return Ok(());
            }
            for (name, types) in services {
                if show_types {
                    let types: Vec<&str> = types.iter().map(String::as_str).collect();
                    writeln!(out, "{name} [{}]", types.join(", "))?;
                } else {
                    writeln!(out, "{name}")?;
                }
            }
        }
        ServiceCommand::Type { service_name } => {
            let Some(types) = graph.services().remove(&service_name) else {
                return Err(format!("Unknown service '{service_name}'").into());
            };
            for ty in types {
                writeln!(out, "{ty}")?;
            }
        }
    }
    Ok(())
}
