//! `shm-ros2 action …`: ros2action's `list` and `info`, from the graph.

use std::collections::BTreeSet;
use std::io::Write;

use clap::Subcommand;

use shm_cdr::dynamic::{Message, Value};
use shm_runtime::rmw::Qos;
use zenoh::Wait;

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
    /// Send an action goal.
    #[command(name = "send_goal")]
    SendGoal {
        /// Name of the ROS action (e.g. '/fibonacci').
        action_name: String,
        /// Type of the ROS action (e.g. 'example_interfaces/action/Fibonacci').
        action_type: String,
        /// Goal request values in YAML format (e.g. '{order: 10}').
        #[arg(default_value = "{}")]
        goal: String,
        /// Echo feedback messages for the goal.
        #[arg(short = 'f', long)]
        feedback: bool,
    },
}

pub(crate) fn run(context: &Context, command: ActionCommand) -> Result<(), Error> {
    match command {
        ActionCommand::SendGoal {
            action_name,
            action_type,
            goal,
            feedback,
        } => send_goal(context, &action_name, &action_type, &goal, feedback),
        other => inspect(context, other),
    }
}

/// The verbs that read the graph.
fn inspect(context: &Context, command: ActionCommand) -> Result<(), Error> {
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
        ActionCommand::SendGoal { .. } => return Err("not a listing".into()),
    }
    Ok(())
}

/// `ros2 action send_goal`: the goal from YAML, sent with a fresh goal ID;
/// feedback for it (with `-f`) and the result printed as ros2action prints
/// them (`message_to_yaml`).
fn send_goal(
    context: &Context,
    action: &str,
    action_type: &str,
    goal_text: &str,
    echo_feedback: bool,
) -> Result<(), Error> {
    let action = if action.starts_with('/') {
        action.to_owned()
    } else {
        format!("/{action}")
    };
    let send_goal_service = format!("{action}/_action/send_goal");
    println!("Waiting for an action server to become available...");
    let graph = context
        .wait_for(|g| {
            !g.servers(&send_goal_service).is_empty()
                && !g
                    .servers(&format!("{action}/_action/get_result"))
                    .is_empty()
        })
        .ok_or_else(|| {
            format!(
                "action {action} has no server (waited {:?})",
                context.timeout
            )
        })?;
    let node = context.node()?;
    let resolved =
        shm_runtime::types::of_action(node, context.timeout, &graph, &action, Some(action_type))?;
    let goal_type = resolved
        .send_goal
        .request
        .member(&format!("{}_Goal", resolved.name))
        .ok_or_else(|| {
            format!(
                "{}: no {}_Goal in its description",
                resolved.name, resolved.name
            )
        })?;
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap_or_default();
    let goal = goal_type
        .message_from_yaml_at(
            goal_text,
            (
                i32::try_from(now.as_secs()).unwrap_or(i32::MAX),
                now.subsec_nanos(),
            ),
        )
        .map_err(|e| format!("Failed to populate message fields: {e}"))?;
    let goal_id = new_goal_id();
    // The request is `{goal_id: uint8[16], goal}`: 16 bytes keep the goal
    // 8-aligned, so its encoding there is the bytes it encodes to alone.
    let goal_cdr = shm_cdr::to_vec(&goal)?;
    let mut request = goal_cdr[..4].to_vec();
    request.extend_from_slice(&goal_id);
    request.extend_from_slice(&goal_cdr[4..]);
    resolved.send_goal.request.decode(&request).map_err(|e| {
        format!(
            "{}: the goal request does not read back: {e}",
            resolved.name
        )
    })?;

    // Feedback first, so that none of this goal's is missed.
    let (feedback_type, _) = &resolved.feedback;
    let printer = FeedbackPrinter::default();
    let _feedback = if echo_feedback {
        let ty = feedback_type.clone();
        let printer = printer.clone();
        Some(
            node.declare_dynamic_subscriber(
                &format!("{action}/_action/feedback"),
                feedback_type,
                Qos::default(),
            )
            .callback(move |sample| {
                let bytes = sample.payload().to_bytes();
                let Ok(message) = ty.decode(&bytes) else {
                    return;
                };
                let ours = matches!(
                    message.message("goal_id").and_then(|id| id.value("uuid")),
                    Some(Value::U8s(id)) if id[..] == goal_id[..]
                );
                if let (true, Some(feedback)) = (ours, message.message("feedback")) {
                    printer.print(format!(
                        "Feedback:\n    {}",
                        feedback.to_message().to_yaml()
                    ));
                }
            })
            .wait()?,
        )
    } else {
        None
    };

    let client = |service: &shm_runtime::types::ResolvedService, part: &str| {
        node.declare_serialized_client(
            &format!("{action}/_action/{part}"),
            &service.name,
            &service.hash,
        )
        .timeout(std::time::Duration::MAX)
        .wait()
    };
    let send = client(&resolved.send_goal, "send_goal")?;
    let results = client(&resolved.get_result, "get_result")?;
    if !send.wait_for_service(context.timeout) || !results.wait_for_service(context.timeout) {
        return Err(format!(
            "action {action} does not answer (waited {:?})",
            context.timeout
        )
        .into());
    }
    println!("Sending goal:\n     {}", goal.to_yaml());
    let reply = send.call_serialized(&request)?;
    let bytes = reply.payload().to_bytes();
    let response = resolved.send_goal.response.decode(&bytes)?;
    if response.value("accepted") != Some(&Value::Bool(true)) {
        println!("Goal was rejected.");
        return Ok(());
    }
    // From here Ctrl-C cancels the goal (caught before anything says it is
    // accepted, so that a Ctrl-C in answer to that is caught).
    let interrupted = crate::interrupted()?;
    let hex: String = goal_id.iter().map(|b| format!("{b:02x}")).collect();
    println!("Goal accepted with ID: {hex}\n");
    printer.accepted();

    let mut result_request = resolved.get_result.request.default_message();
    result_request.set("goal_id", with_uuid(&result_request, goal_id)?)?;
    let result_request = shm_cdr::to_vec(&result_request)?;
    // The result is awaited on a thread of its own, so that Ctrl-C cancels
    // the goal as ros2action does instead of leaving it running.
    let (done, result) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = done.send(results.call_serialized(&result_request));
    });
    let reply = loop {
        match result.recv_timeout(std::time::Duration::from_millis(50)) {
            Ok(reply) => break reply?,
            Err(std::sync::mpsc::RecvTimeoutError::Timeout)
                if interrupted.load(std::sync::atomic::Ordering::Relaxed) =>
            {
                return cancel(context, &action, goal_id);
            }
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                return Err("the result request ended without an answer".into())
            }
        }
    };
    let bytes = reply.payload().to_bytes();
    let response = resolved.get_result.response.decode(&bytes)?;
    let status = match response.value("status") {
        Some(Value::I8(s)) => *s,
        _ => 0,
    };
    if let Some(result) = response.message("result") {
        println!("Result:\n    {}", result.to_message().to_yaml());
    }
    println!("Goal finished with status: {}", status_name(status));
    Ok(())
}

/// Ask the server to cancel goal `goal_id`, and say what it answered, as
/// ros2action does at Ctrl-C.
fn cancel(context: &Context, action: &str, goal_id: [u8; 16]) -> Result<(), Error> {
    use shm_cdr::msgs::action_msgs::srv::{CancelGoal, CancelGoal_Request};
    println!("Canceling goal...");
    let client = context
        .node()?
        .declare_client::<CancelGoal>(&format!("{action}/_action/cancel_goal"))
        .timeout(context.timeout)
        .wait()?;
    let mut request = CancelGoal_Request::default();
    request.goal_info.goal_id.uuid = goal_id;
    let response = client.call(&request).wait()?;
    match response.goals_canceling.as_slice() {
        [] => println!("Failed to cancel goal"),
        [first, rest @ ..] => {
            if !rest.is_empty() {
                println!("More than one goal canceled");
            }
            if first.goal_id.uuid != goal_id {
                println!("Canceled goal with incorrect goal ID");
            }
            println!("Goal canceled.");
        }
    }
    Ok(())
}

/// Prints feedback once the goal's acceptance is printed: what arrives
/// before it waits, so the output reads in order.
#[derive(Clone, Default)]
struct FeedbackPrinter(std::sync::Arc<std::sync::Mutex<(bool, Vec<String>)>>);

impl FeedbackPrinter {
    fn print(&self, text: String) {
        let mut state = self.0.lock().unwrap_or_else(|e| e.into_inner());
        if state.0 {
            println!("{text}");
        } else {
            state.1.push(text);
        }
    }

    fn accepted(&self) {
        let mut state = self.0.lock().unwrap_or_else(|e| e.into_inner());
        state.0 = true;
        for text in state.1.drain(..) {
            println!("{text}");
        }
    }
}

/// `message`'s `goal_id` (a `unique_identifier_msgs/msg/UUID`) holding `id`.
fn with_uuid(message: &Message<'_>, id: [u8; 16]) -> Result<Value<'static>, Error> {
    let Some(uuid) = message.message("goal_id") else {
        return Err(format!("{} has no goal_id", message.type_name()).into());
    };
    let mut uuid = uuid.to_message().into_owned();
    uuid.set("uuid", Value::U8s(id.to_vec().into()))?;
    Ok(Value::Message(Box::new(uuid)))
}

/// action_msgs/msg/GoalStatus's names, as ros2action prints them.
fn status_name(status: i8) -> &'static str {
    match status {
        1 => "ACCEPTED",
        2 => "EXECUTING",
        3 => "CANCELING",
        4 => "SUCCEEDED",
        5 => "CANCELED",
        6 => "ABORTED",
        _ => "UNKNOWN",
    }
}

/// A random (version 4) UUID, as rclpy makes goal IDs.
fn new_goal_id() -> [u8; 16] {
    use std::io::Read;
    let mut id = [0u8; 16];
    let random = std::fs::File::open("/dev/urandom").and_then(|mut f| f.read_exact(&mut id));
    if random.is_err() {
        // No /dev/urandom: the time and process, which still differ per goal.
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap_or_default()
            .as_nanos();
        id.copy_from_slice(&(now ^ (u128::from(std::process::id()) << 64)).to_le_bytes());
    }
    id[6] = (id[6] & 0x0f) | 0x40;
    id[8] = (id[8] & 0x3f) | 0x80;
    id
}
