//! `shm-ros2 service …`: ros2service's verbs and output.

use std::io::Write;

use clap::Subcommand;

use zenoh::Wait;

use crate::context::{is_hidden, Context};
use crate::{python, Error};

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
    /// Call a service.
    Call {
        /// Name of the ROS service to call to (e.g. '/add_two_ints').
        service_name: String,
        /// Type of the ROS service (e.g. 'std_srvs/srv/Empty').
        service_type: String,
        /// Values to fill the service request with in YAML format (e.g. '{a: 1, b: 2}'),
        /// otherwise the service request will be published with default values.
        #[arg(default_value = "{}")]
        values: String,
        /// Repeat the call at a specific rate in Hz.
        #[arg(short = 'r', long)]
        rate: Option<f64>,
    },
}

pub(crate) fn run(context: &Context, command: ServiceCommand) -> Result<(), Error> {
    match command {
        ServiceCommand::Call {
            service_name,
            service_type,
            values,
            rate,
        } => call(context, &service_name, &service_type, &values, rate),
        other => inspect(context, other),
    }
}

/// The verbs that read the graph.
fn inspect(context: &Context, command: ServiceCommand) -> Result<(), Error> {
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
        ServiceCommand::Call { .. } => return Err("not a listing".into()),
    }
    Ok(())
}

/// `ros2 service call`: the request filled from YAML, sent, and request and
/// response printed as rclpy prints them (Python's `repr`).
fn call(
    context: &Context,
    service: &str,
    service_type: &str,
    values: &str,
    rate: Option<f64>,
) -> Result<(), Error> {
    if rate.is_some_and(|r| !(r > 0.0 && r.is_finite())) {
        return Err("rate must be greater than zero".into());
    }
    let service = if service.starts_with('/') {
        service.to_owned()
    } else {
        format!("/{service}")
    };
    let mut graph = context.graph();
    if graph.servers(&service).is_empty() {
        println!("waiting for service to become available...");
        graph = context
            .wait_for(|g| !g.servers(&service).is_empty())
            .ok_or_else(|| {
                format!(
                    "service {service} has no server (waited {:?})",
                    context.timeout
                )
            })?;
    }
    let node = context.node()?;
    let resolved = shm_runtime::types::of_service(
        node,
        context.timeout,
        &graph,
        &service,
        Some(service_type),
    )?;
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap_or_default();
    let request = resolved
        .request
        .message_from_yaml_at(
            values,
            (
                i32::try_from(now.as_secs()).unwrap_or(i32::MAX),
                now.subsec_nanos(),
            ),
        )
        .map_err(|e| format!("Failed to populate field: {e}"))?;
    let cdr = shm_cdr::to_vec(&request)?;
    let client = node
        .declare_serialized_client(&service, &resolved.name, &resolved.hash)
        // As ros2cli: wait for the answer as long as the server is there.
        .timeout(std::time::Duration::MAX)
        .wait()?;
    if !client.wait_for_service(context.timeout) {
        return Err(format!(
            "service {service} does not answer (waited {:?})",
            context.timeout
        )
        .into());
    }
    let period = rate.map(|r| std::time::Duration::from_secs_f64(1.0 / r));
    loop {
        let started = std::time::Instant::now();
        println!(
            "requester: making request: {}\n",
            python::message_repr(request.as_message_ref(), &resolved.request)
        );
        let reply = client.call_serialized(&cdr)?;
        let bytes = reply.payload().to_bytes();
        let response = resolved.response.decode(&bytes)?;
        println!(
            "response:\n{}\n",
            python::message_repr(response.as_message_ref(), &resolved.response)
        );
        let Some(period) = period else {
            return Ok(());
        };
        if let Some(left) = period.checked_sub(started.elapsed()) {
            std::thread::sleep(left);
        }
    }
}
