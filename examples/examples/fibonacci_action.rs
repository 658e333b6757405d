//! An action (`test_msgs/action/Fibonacci`) between two rmw_zenoh_cpp-compatible
//! nodes: a goal that runs to its result with feedback on the way, one the
//! server rejects, and one the client cancels while it runs.
//!
//! `cargo run -p shm-cdr-examples --example fibonacci_action`

use std::time::Duration;

use shm_cdr::msgs::test_msgs::action::{
    Fibonacci, Fibonacci_Feedback, Fibonacci_Goal, Fibonacci_Result,
};
use shm_cdr_examples::loopback_pair;
use shm_runtime::action::{GoalDecision, ServerGoalHandle};
use shm_runtime::RosNode;
use zenoh::Wait;

/// The server's work: one number per 20 ms, feedback after each, until done
/// or canceled.
fn execute(goal: ServerGoalHandle<Fibonacci>) {
    let mut sequence = vec![0, 1];
    for i in 1..goal.goal().order as usize {
        if goal.is_cancel_requested() {
            let _ = goal.canceled(Fibonacci_Result { sequence });
            return;
        }
        sequence.push(sequence[i] + sequence[i - 1]);
        let _ = goal.publish_feedback(Fibonacci_Feedback {
            sequence: sequence.clone(),
        });
        std::thread::sleep(Duration::from_millis(20));
    }
    let _ = goal.succeed(Fibonacci_Result { sequence });
}

fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    // Warnings (a pool that fell back to the heap, a message missed) reach
    // stderr only through a logger: `RUST_LOG=info` shows more.
    shm_runtime::init_logging();
    let (a, b) = loopback_pair(7455)?;
    let server_node = RosNode::builder(&a, "fibonacci_server").wait()?;
    let client_node = RosNode::builder(&b, "fibonacci_client").wait()?;

    let server = server_node
        .declare_action_server::<Fibonacci>("/fibonacci")
        .on_goal(|_id, goal| {
            if (0..=46).contains(&goal.order) {
                GoalDecision::Accept
            } else {
                GoalDecision::Reject // i32 overflows past order 46
            }
        })
        .wait()?;
    std::thread::spawn(move || {
        while let Ok(accepted) = server.recv() {
            std::thread::spawn(move || execute(accepted.execute()));
        }
    });

    let client = client_node
        .declare_action_client::<Fibonacci>("/fibonacci")
        .wait()?;
    client.wait_for_server(Duration::from_secs(5));

    let goal = client.send_goal(Fibonacci_Goal { order: 8 }).wait()?;
    println!(
        "goal     {} accepted at {:?}",
        hex(&goal.id()),
        goal.stamp()
    );
    while let Some(feedback) = goal.recv_feedback() {
        println!("feedback {:?}", feedback.sequence);
    }
    let result = goal.result().wait()?;
    println!("result   {:?} {:?}", result.status, result.result.sequence);

    let refused = client.send_goal(Fibonacci_Goal { order: 100 }).wait();
    println!("order 100: {}", refused.map(|_| ()).unwrap_err());

    let long = client.send_goal(Fibonacci_Goal { order: 40 }).wait()?;
    long.recv_feedback();
    let cancel = long.cancel().wait()?;
    let result = long.result().wait()?;
    println!(
        "cancel   return code {}, {} goal(s) canceling -> {:?} after {} numbers",
        cancel.return_code,
        cancel.goals_canceling.len(),
        result.status,
        result.result.sequence.len()
    );
    Ok(())
}

fn hex(id: &[u8; 16]) -> String {
    id.iter().map(|b| format!("{b:02x}")).collect()
}
