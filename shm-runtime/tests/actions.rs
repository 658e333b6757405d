//! Actions between peer sessions over TCP loopback: rmw_zenoh_cpp's names and
//! tokens for the three services and two topics, rcl_action's goal state
//! machine and cancel rules, feedback and results, and servers that go away.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use shm_cdr::msgs::action_msgs::msg::GoalStatusArray;
use shm_cdr::msgs::action_msgs::srv::CancelGoal_Response;
use shm_cdr::msgs::test_msgs::action::{
    Fibonacci, Fibonacci_Feedback, Fibonacci_Goal, Fibonacci_Result,
};
use shm_runtime::action::{
    ActionError, CancelDecision, GoalDecision, GoalEvent, GoalStatus, ServerGoalHandle, Stamp,
};
use shm_runtime::rmw::{EntityKind, Qos};
use shm_runtime::service::CallError;
use zenoh::Wait;

mod common;
use common::{loopback_sessions, node};

const TIMEOUT: Duration = Duration::from_secs(10);

/// The Fibonacci numbers up to `order`, one feedback per new number.
fn fibonacci(goal: ServerGoalHandle<Fibonacci>) {
    let mut sequence = vec![0, 1];
    for i in 1..goal.goal().order.max(1) as usize {
        sequence.push(sequence[i] + sequence[i - 1]);
        goal.publish_feedback(Fibonacci_Feedback {
            sequence: sequence.clone(),
        })
        .unwrap();
    }
    goal.succeed(Fibonacci_Result { sequence }).unwrap();
}

/// Wait until `condition` holds or fail after `TIMEOUT`.
fn eventually(what: &str, condition: impl Fn() -> bool) {
    let deadline = Instant::now() + TIMEOUT;
    while !condition() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn a_goal_runs_with_feedback_and_result_under_rmw_zenoh_names() {
    let (a, b, _) = loopback_sessions();
    let server_node = node(&a, "server");
    let client_node = node(&b, "client");
    let server = server_node
        .declare_action_server::<Fibonacci>("fibonacci")
        .wait()
        .unwrap();
    // An independent observer of the status topic, as a late-joining
    // transient-local subscriber would be.
    let statuses = Arc::new(Mutex::new(Vec::<Vec<i8>>::new()));
    let seen = statuses.clone();
    let _observer = client_node
        .declare_subscriber_with_qos::<GoalStatusArray>(
            "/fibonacci/_action/status",
            Qos::transient_local(1),
        )
        // Every status, not only the newest: the callback may fall behind.
        .history(shm_runtime::History::KeepAll)
        .callback(move |sample| {
            let array: GoalStatusArray = sample.decode().unwrap();
            seen.lock()
                .unwrap()
                .push(array.status_list.iter().map(|s| s.status).collect());
        })
        .wait()
        .unwrap();
    let client = client_node
        .declare_action_client::<Fibonacci>("fibonacci")
        .wait()
        .unwrap();
    assert!(client.wait_for_server(TIMEOUT));
    assert_eq!(client.name(), "/fibonacci");

    let worker = std::thread::spawn(move || {
        let accepted = server.recv().unwrap();
        assert_eq!(accepted.goal().order, 10);
        fibonacci(accepted.execute());
        server
    });
    let goal = client
        .send_goal(Fibonacci_Goal { order: 10 })
        .wait()
        .unwrap();
    assert_ne!(goal.id(), [0; 16]);
    assert!(goal.stamp() > Stamp::default());
    let mut feedback = Vec::new();
    while let Some(f) = goal.recv_feedback() {
        feedback.push(f.sequence);
    }
    // Every feedback, in order, then the end of the stream (terminal status).
    assert_eq!(feedback.len(), 9, "{feedback:?}");
    for (i, sequence) in feedback.iter().enumerate() {
        assert_eq!(sequence.len(), i + 3);
    }
    let result = goal.result().wait().unwrap();
    assert_eq!(result.status, GoalStatus::Succeeded);
    assert_eq!(
        result.result.sequence,
        [0, 1, 1, 2, 3, 5, 8, 13, 21, 34, 55]
    );
    assert_eq!(goal.status(), GoalStatus::Succeeded);
    let server = worker.join().unwrap();
    assert_eq!(server.goals(), [(goal.id(), GoalStatus::Succeeded)]);
    eventually("the observer to see the goal succeed", || {
        statuses.lock().unwrap().last() == Some(&vec![GoalStatus::Succeeded.code()])
    });
    // accepted → executing → succeeded, each state published once.
    let seen: Vec<i8> = statuses
        .lock()
        .unwrap()
        .iter()
        .filter_map(|s| s.first().copied())
        .collect();
    assert_eq!(seen, [1, 2, 4]);

    // rmw_zenoh_cpp's entities: three services, two topics, with their types.
    let graph = client_node.graph(Duration::from_secs(2)).unwrap();
    let has = |kind: EntityKind, name: &str, type_name: &str| {
        let found = graph.endpoints(kind, name);
        assert!(
            found
                .iter()
                .any(|e| e.endpoint.as_ref().unwrap().type_name == type_name),
            "{kind:?} {name} {type_name}: {found:?}"
        );
    };
    use EntityKind::*;
    let (send, cancel, result) = (
        "/fibonacci/_action/send_goal",
        "/fibonacci/_action/cancel_goal",
        "/fibonacci/_action/get_result",
    );
    for kind in [ServiceServer, ServiceClient] {
        has(kind, send, "test_msgs/action/Fibonacci_SendGoal");
        has(kind, cancel, "action_msgs/srv/CancelGoal");
        has(kind, result, "test_msgs/action/Fibonacci_GetResult");
    }
    let feedback = "/fibonacci/_action/feedback";
    has(
        Publisher,
        feedback,
        "test_msgs/action/Fibonacci_FeedbackMessage",
    );
    has(
        Subscriber,
        feedback,
        "test_msgs/action/Fibonacci_FeedbackMessage",
    );
    let status = "/fibonacci/_action/status";
    has(Publisher, status, "action_msgs/msg/GoalStatusArray");
    // The status topic: reliable, transient local, keep last 1, both ends.
    for kind in [Publisher, Subscriber] {
        for e in graph.endpoints(kind, status) {
            assert_eq!(e.endpoint.as_ref().unwrap().qos, Qos::transient_local(1));
        }
    }
    let actions = graph.actions();
    assert_eq!(
        actions
            .get("/fibonacci")
            .map(|t| t.iter().cloned().collect::<Vec<_>>()),
        Some(vec!["test_msgs/action/Fibonacci".to_owned()])
    );
    assert_eq!(graph.action_servers("/fibonacci").len(), 1);
    assert_eq!(graph.action_clients("/fibonacci").len(), 1);
}

#[test]
fn rejected_goals_fail_and_leave_no_trace() {
    let (a, b, _) = loopback_sessions();
    let server_node = node(&a, "server");
    let client_node = node(&b, "client");
    let server = server_node
        .declare_action_server::<Fibonacci>("/picky")
        .on_goal(|_, goal| {
            if goal.order < 0 {
                GoalDecision::Reject
            } else {
                GoalDecision::Accept
            }
        })
        .wait()
        .unwrap();
    let client = client_node
        .declare_action_client::<Fibonacci>("/picky")
        .wait()
        .unwrap();
    assert!(client.wait_for_server(TIMEOUT));
    let refused = client.send_goal(Fibonacci_Goal { order: -1 }).wait();
    assert!(matches!(refused, Err(ActionError::Rejected)), "{refused:?}");
    assert!(server.goals().is_empty());
    assert!(server.try_recv().unwrap().is_none());

    // The same id twice: the second is rejected without asking.
    let id = [7; 16];
    let first = client
        .send_goal(Fibonacci_Goal { order: 1 })
        .goal_id(id)
        .wait()
        .unwrap();
    let second = client
        .send_goal(Fibonacci_Goal { order: 1 })
        .goal_id(id)
        .wait();
    assert!(matches!(second, Err(ActionError::Rejected)));
    assert_eq!(server.goals(), [(id, GoalStatus::Accepted)]);
    fibonacci(server.recv().unwrap().execute());
    assert_eq!(first.result().wait().unwrap().status, GoalStatus::Succeeded);
}

#[test]
fn cancel_follows_rcl_action_rules() {
    let (a, b, _) = loopback_sessions();
    let server_node = node(&a, "server");
    let client_node = node(&b, "client");
    let server = server_node
        .declare_action_server::<Fibonacci>("/cancelable")
        .wait()
        .unwrap();
    let client = client_node
        .declare_action_client::<Fibonacci>("/cancelable")
        .wait()
        .unwrap();
    assert!(client.wait_for_server(TIMEOUT));

    // Cancel one running goal: the executor sees it and ends it canceled.
    let goal = client
        .send_goal(Fibonacci_Goal { order: 5 })
        .wait()
        .unwrap();
    let running = server.recv().unwrap().execute();
    assert!(!running.is_cancel_requested());
    let response = goal.cancel().wait().unwrap();
    assert!(response.is_accepted(), "{response:?}");
    assert_eq!(response.goals_canceling, [(goal.id(), goal.stamp())]);
    assert!(running.is_cancel_requested());
    assert_eq!(running.status(), GoalStatus::Canceling);
    running
        .canceled(Fibonacci_Result { sequence: vec![0] })
        .unwrap();
    let result = goal.result().wait().unwrap();
    assert_eq!(result.status, GoalStatus::Canceled);
    assert_eq!(result.result.sequence, [0]);
    assert!(goal.recv_feedback().is_none());

    // A finished goal: ERROR_GOAL_TERMINATED. An unknown id: ERROR_UNKNOWN_GOAL_ID.
    let again = goal.cancel().wait().unwrap();
    assert_eq!(
        again.return_code,
        CancelGoal_Response::ERROR_GOAL_TERMINATED
    );
    assert!(again.goals_canceling.is_empty());
    let unknown = client.cancel_goal([0x42; 16]).wait().unwrap();
    assert_eq!(
        unknown.return_code,
        CancelGoal_Response::ERROR_UNKNOWN_GOAL_ID
    );

    // cancel_before(stamp) takes the goals accepted at or before it, cancel_all
    // the rest; goals already finished are not candidates.
    let early: Vec<_> = (0..2)
        .map(|_| {
            client
                .send_goal(Fibonacci_Goal { order: 3 })
                .wait()
                .unwrap()
        })
        .collect();
    let late = client
        .send_goal(Fibonacci_Goal { order: 3 })
        .wait()
        .unwrap();
    let handles: Vec<_> = (0..3).map(|_| server.recv().unwrap().execute()).collect();
    let cut = client.cancel_before(early[1].stamp()).wait().unwrap();
    let mut canceled: Vec<_> = cut.goals_canceling.iter().map(|(id, _)| *id).collect();
    canceled.sort();
    let mut expected = vec![early[0].id(), early[1].id()];
    expected.sort();
    assert_eq!(canceled, expected);
    let rest = client.cancel_all().wait().unwrap();
    assert_eq!(rest.goals_canceling, [(late.id(), late.stamp())]);
    for handle in handles {
        assert!(handle.is_cancel_requested());
        handle.canceled(Fibonacci_Result::default()).unwrap();
    }
    for goal in early.iter().chain([&late]) {
        assert_eq!(goal.result().wait().unwrap().status, GoalStatus::Canceled);
    }
    // Nothing cancelable left: no candidates is not a rejection.
    let none = client.cancel_all().wait().unwrap();
    assert_eq!(none.return_code, CancelGoal_Response::ERROR_NONE);
    assert!(none.goals_canceling.is_empty());

    // A goal canceled while still waiting to execute: it starts canceling.
    let queued = client
        .send_goal(Fibonacci_Goal { order: 3 })
        .wait()
        .unwrap();
    let accepted = server.recv().unwrap();
    assert!(queued.cancel().wait().unwrap().is_accepted());
    assert!(accepted.is_cancel_requested());
    let handle = accepted.execute();
    assert_eq!(handle.status(), GoalStatus::Canceling);
    handle.canceled(Fibonacci_Result::default()).unwrap();
    assert_eq!(queued.result().wait().unwrap().status, GoalStatus::Canceled);
}

#[test]
fn a_refused_cancel_and_an_unknown_goal() {
    let (a, b, _) = loopback_sessions();
    let server_node = node(&a, "server");
    let client_node = node(&b, "client");
    let server = server_node
        .declare_action_server::<Fibonacci>("/stubborn")
        .on_cancel(|_| CancelDecision::Reject)
        .wait()
        .unwrap();
    let client = client_node
        .declare_action_client::<Fibonacci>("/stubborn")
        .wait()
        .unwrap();
    assert!(client.wait_for_server(TIMEOUT));
    let goal = client
        .send_goal(Fibonacci_Goal { order: 2 })
        .wait()
        .unwrap();
    let running = server.recv().unwrap().execute();
    let refused = goal.cancel().wait().unwrap();
    assert_eq!(refused.return_code, CancelGoal_Response::ERROR_REJECTED);
    assert!(!running.is_cancel_requested());
    assert_eq!(running.status(), GoalStatus::Executing);
    // A cancel that was never requested cannot end it canceled: it is aborted.
    let wrong = running.canceled(Fibonacci_Result::default());
    assert!(
        matches!(
            wrong,
            Err(ActionError::InvalidTransition {
                from: GoalStatus::Executing,
                event: GoalEvent::Canceled
            })
        ),
        "{wrong:?}"
    );
    assert_eq!(goal.result().wait().unwrap().status, GoalStatus::Aborted);

    // An accepted goal the server drops without executing it: aborted.
    let stranger = client
        .send_goal(Fibonacci_Goal { order: 1 })
        .goal_id([1; 16])
        .wait()
        .unwrap();
    drop(server.recv().unwrap());
    assert_eq!(
        stranger.result().wait().unwrap().status,
        GoalStatus::Aborted
    );
}

#[test]
fn dropped_goals_end_and_results_expire() {
    let (a, b, _) = loopback_sessions();
    let server_node = node(&a, "server");
    let client_node = node(&b, "client");
    let server = server_node
        .declare_action_server::<Fibonacci>("/forgetful")
        .result_timeout(Duration::from_millis(300))
        .wait()
        .unwrap();
    let client = client_node
        .declare_action_client::<Fibonacci>("/forgetful")
        .wait()
        .unwrap();
    assert!(client.wait_for_server(TIMEOUT));

    // A result call waits for the goal, however long it runs.
    let goal = client
        .send_goal(Fibonacci_Goal { order: 3 })
        .wait()
        .unwrap();
    let running = server.recv().unwrap().execute();
    std::thread::scope(|scope| {
        let waiting = scope.spawn(|| goal.result().wait());
        std::thread::sleep(Duration::from_millis(200));
        assert!(!waiting.is_finished());
        drop(running); // unfinished: aborted with a default result
        let result = waiting.join().unwrap().unwrap();
        assert_eq!(result.status, GoalStatus::Aborted);
        assert_eq!(result.result, Fibonacci_Result::default());
    });
    // Within the result timeout the result is still there; after it, the
    // goal is unknown and leaves the status array.
    assert_eq!(goal.result().wait().unwrap().status, GoalStatus::Aborted);
    std::thread::sleep(Duration::from_millis(400));
    let expired = goal.result().wait().unwrap();
    assert_eq!(expired.status, GoalStatus::Unknown);
    assert!(server.goals().is_empty());
}

#[test]
fn a_server_that_goes_away_ends_every_wait() {
    let (a, b, _) = loopback_sessions();
    let server_node = node(&a, "server");
    let client_node = node(&b, "client");
    let server = server_node
        .declare_action_server::<Fibonacci>("/fragile")
        .wait()
        .unwrap();
    let client = client_node
        .declare_action_client::<Fibonacci>("/fragile")
        .timeout(Duration::from_secs(60))
        .wait()
        .unwrap();
    assert!(client.wait_for_server(TIMEOUT));
    let goal = client
        .send_goal(Fibonacci_Goal { order: 3 })
        .wait()
        .unwrap();
    let running = server.recv().unwrap().execute();
    running
        .publish_feedback(Fibonacci_Feedback { sequence: vec![1] })
        .unwrap();
    assert_eq!(goal.recv_feedback().unwrap().sequence, [1]);
    let start = Instant::now();
    std::thread::scope(|scope| {
        let waiting = scope.spawn(|| goal.result().wait());
        std::thread::sleep(Duration::from_millis(100));
        // The whole server process goes: its session closes mid-goal.
        std::mem::forget(running);
        drop(server);
        drop(server_node);
        a.close().wait().unwrap();
        let outcome = waiting.join().unwrap();
        assert!(
            matches!(outcome, Err(ActionError::Call(CallError::NoReply))),
            "{outcome:?}"
        );
    });
    assert!(
        goal.recv_feedback().is_none(),
        "feedback ends with the server"
    );
    // Nobody knows the goal any more: not `Executing`, as its last status said.
    assert_eq!(goal.status(), GoalStatus::Unknown);
    assert!(start.elapsed() < Duration::from_secs(10));
    assert!(!client.is_server_available());
    let refused = client.send_goal(Fibonacci_Goal { order: 1 }).wait();
    assert!(
        matches!(refused, Err(ActionError::Call(CallError::NoReply))),
        "{refused:?}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn goals_run_concurrently_with_async_handles() {
    let (a, b, _) = loopback_sessions();
    let server_node = node(&a, "server");
    let client_node = node(&b, "client");
    let server = server_node
        .declare_action_server::<Fibonacci>("/async")
        .await
        .unwrap();
    let client = client_node
        .declare_action_client::<Fibonacci>("/async")
        .await
        .unwrap();
    tokio::time::timeout(TIMEOUT, client.server_available())
        .await
        .unwrap()
        .unwrap();
    let serving =
        tokio::spawn(async move {
            let mut tasks = Vec::new();
            for _ in 0..8 {
                let goal = server.recv_async().await.unwrap().execute();
                tasks.push(tokio::spawn(async move {
                // Each goal runs until it is canceled or finishes its order.
                let order = goal.goal().order;
                for i in 0..order {
                    tokio::select! {
                        _ = goal.cancel_requested() => {
                            return goal.canceled(Fibonacci_Result { sequence: vec![i] }).unwrap();
                        }
                        _ = tokio::time::sleep(Duration::from_millis(5)) => {}
                    }
                    goal.publish_feedback(Fibonacci_Feedback { sequence: vec![i] }).unwrap();
                }
                goal.succeed(Fibonacci_Result { sequence: vec![order] }).unwrap();
            }));
            }
            for task in tasks {
                task.await.unwrap();
            }
            server
        });
    let mut goals = Vec::new();
    for order in 1..=8 {
        goals.push(
            client
                .send_goal(Fibonacci_Goal { order: order * 10 })
                .await
                .unwrap(),
        );
    }
    // Cancel the even ones once they sent some feedback.
    for (i, goal) in goals.iter().enumerate() {
        let first = goal.recv_feedback_async().await.unwrap();
        assert_eq!(first.sequence, [0]);
        if i % 2 == 1 {
            assert!(goal.cancel().await.unwrap().is_accepted());
        }
    }
    for (i, goal) in goals.iter().enumerate() {
        let result = goal.result().await.unwrap();
        if i % 2 == 1 {
            assert_eq!(result.status, GoalStatus::Canceled);
        } else {
            assert_eq!(result.status, GoalStatus::Succeeded);
            assert_eq!(result.result.sequence, [(i as i32 + 1) * 10]);
        }
    }
    let server = serving.await.unwrap();
    assert_eq!(server.goals().len(), 8);
}
