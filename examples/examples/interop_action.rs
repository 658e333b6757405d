//! Interop of actions with an independent implementation of rmw_zenoh_cpp's
//! conventions (`tests/ros2/actions.py`: Python eclipse-zenoh, rclpy's
//! serialization and rcl_action, rosidl's hashes), `test_msgs/action/Fibonacci`:
//!
//! - `interop_action states`: print rcl_action's goal state machine as
//!   shm-runtime implements it, one `STATE EVENT NEXT` line per pair (`NEXT` is
//!   `refused` where the event is not allowed); the script compares it with
//!   what real rcl_action does.
//! - `interop_action client <connect endpoint>`: against the Python server's
//!   `/py_fibonacci`: a goal of order 10 (feedback, result), a goal of order
//!   -1 (rejected), a goal of order 1000 canceled after its first feedback.
//!   Prints one line per goal, then what the ROS graph says of the Python
//!   server (its node, action, servers and status publisher with its QoS).
//! - `interop_action server <listen endpoint>`: serve `/rust_fibonacci` (orders
//!   below 0 rejected, one feedback per number every 10 ms, cancel honoured)
//!   until stdin closes, then print `succeeded <n> canceled <m>`.

use std::io::{BufRead, Write};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use shm_cdr::msgs::test_msgs::action::{
    Fibonacci, Fibonacci_Feedback, Fibonacci_Goal, Fibonacci_Result,
};
use shm_cdr_examples::peer_session;
use shm_runtime::action::{
    transition, ActionError, GoalDecision, GoalEvent, GoalStatus, ServerGoalHandle,
};
use shm_runtime::RosNode;
use zenoh::Wait;

type BoxError = Box<dyn std::error::Error + Send + Sync>;

fn main() -> Result<(), BoxError> {
    let args: Vec<String> = std::env::args().collect();
    match args
        .iter()
        .map(String::as_str)
        .collect::<Vec<_>>()
        .as_slice()
    {
        [_, "states"] => {
            states();
            Ok(())
        }
        [_, "client", endpoint] => client(endpoint),
        [_, "server", endpoint] => server(endpoint),
        _ => Err(
            "usage: interop_action states | client <connect endpoint> | server <listen endpoint>"
                .into(),
        ),
    }
}

fn states() {
    use GoalStatus::*;
    for from in [Accepted, Executing, Canceling, Succeeded, Canceled, Aborted] {
        for event in GoalEvent::ALL {
            let next = transition(from, event).map_or("refused".to_owned(), |s| format!("{s:?}"));
            println!("{from:?} {event:?} {next}");
        }
    }
}

fn client(endpoint: &str) -> Result<(), BoxError> {
    let session = peer_session(endpoint, false)?;
    let node = RosNode::builder(&session, "rust_action_client")
        .domain_id(0)
        .wait()?;
    let client = node
        .declare_action_client::<Fibonacci>("/py_fibonacci")
        .wait()?;
    if !client.wait_for_server(Duration::from_secs(20)) {
        return Err("the Python action server never appeared".into());
    }

    let goal = client.send_goal(Fibonacci_Goal { order: 10 }).wait()?;
    let mut feedback = 0;
    while let Some(f) = goal.recv_feedback() {
        if f.sequence.len() != feedback + 3 {
            return Err(format!("feedback {feedback}: {:?}", f.sequence).into());
        }
        feedback += 1;
    }
    let result = goal.result().wait()?;
    println!(
        "goal {} {:?} {:?} feedback {feedback}",
        hex(&goal.id()),
        result.status,
        result.result.sequence
    );

    match client.send_goal(Fibonacci_Goal { order: -1 }).wait() {
        Err(ActionError::Rejected) => println!("rejected"),
        other => return Err(format!("order -1: {other:?}").into()),
    }

    let long = client.send_goal(Fibonacci_Goal { order: 1000 }).wait()?;
    long.recv_feedback()
        .ok_or("no feedback for the long goal")?;
    let cancel = long.cancel().wait()?;
    let result = long.result().wait()?;
    println!(
        "goal {} cancel code {} canceling {} {:?}",
        hex(&long.id()),
        cancel.return_code,
        cancel.goals_canceling.len(),
        result.status
    );

    // The Python peer's entities, read back from its tokens.
    let graph = node.graph(Duration::from_secs(2))?;
    let types = graph.actions().remove("/py_fibonacci").unwrap_or_default();
    let status = graph.publishers("/py_fibonacci/_action/status");
    println!(
        "graph node {} action {:?} servers {} status publishers {} qos {:?}",
        graph.nodes().contains(&"/py_action_server".to_owned()),
        types,
        graph.action_servers("/py_fibonacci").len(),
        status.len(),
        status
            .first()
            .and_then(|e| e.endpoint.as_ref())
            .map(|e| e.qos)
    );
    Ok(())
}

fn hex(id: &[u8; 16]) -> String {
    id.iter().map(|b| format!("{b:02x}")).collect()
}

fn run(goal: ServerGoalHandle<Fibonacci>, succeeded: &AtomicU64, canceled: &AtomicU64) {
    let mut sequence = vec![0, 1];
    for i in 1..goal.goal().order.max(1) as usize {
        if goal.is_cancel_requested() {
            if goal.canceled(Fibonacci_Result { sequence }).is_ok() {
                canceled.fetch_add(1, Ordering::Relaxed);
            }
            return;
        }
        sequence.push(sequence[i].wrapping_add(sequence[i - 1]));
        let _ = goal.publish_feedback(Fibonacci_Feedback {
            sequence: sequence.clone(),
        });
        std::thread::sleep(Duration::from_millis(10));
    }
    if goal.succeed(Fibonacci_Result { sequence }).is_ok() {
        succeeded.fetch_add(1, Ordering::Relaxed);
    }
}

fn server(endpoint: &str) -> Result<(), BoxError> {
    let session = peer_session(endpoint, true)?;
    let node = RosNode::builder(&session, "rust_action_server")
        .domain_id(0)
        .wait()?;
    let server = node
        .declare_action_server::<Fibonacci>("/rust_fibonacci")
        .on_goal(|_, goal| {
            if goal.order < 0 {
                GoalDecision::Reject
            } else {
                GoalDecision::Accept
            }
        })
        .wait()?;
    let counts = Arc::new((AtomicU64::new(0), AtomicU64::new(0)));
    let worker_counts = counts.clone();
    std::thread::spawn(move || {
        while let Ok(accepted) = server.recv() {
            let counts = worker_counts.clone();
            std::thread::spawn(move || run(accepted.execute(), &counts.0, &counts.1));
        }
    });
    println!("ready");
    std::io::stdout().flush()?;
    for line in std::io::stdin().lock().lines() {
        line?;
    }
    println!(
        "succeeded {} canceled {}",
        counts.0.load(Ordering::Relaxed),
        counts.1.load(Ordering::Relaxed)
    );
    Ok(())
}
