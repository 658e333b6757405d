//! Managed nodes: the state machine driven by the node itself and by another
//! node through the lifecycle services, the transition events, callbacks that
//! fail, err or panic, and publishers that publish only while active. (The
//! same transitions are compared with rclpy's lifecycle node in
//! `tests/ros2/lifecycle.py`.)

mod common;

use std::sync::{Arc, Mutex};
use std::time::Duration;

use common::loopback_sessions;
use shm_cdr::msgs::lifecycle_msgs::msg::{Transition as TransitionMsg, TransitionEvent};
use shm_cdr::msgs::lifecycle_msgs::srv::{
    ChangeState, ChangeState_Request, GetAvailableTransitions, GetAvailableTransitions_Request,
    GetState, GetState_Request,
};
use shm_cdr::msgs::std_msgs::String as Text;
use shm_runtime::lifecycle::{CallbackReturn, LifecycleError, Managed, State, Transition};
use shm_runtime::RosNode;
use zenoh::Wait;

const TIMEOUT: Duration = Duration::from_secs(10);

/// Answers from a script, one per call of each callback, then success;
/// records every call.
#[derive(Default)]
struct Scripted {
    activate: Vec<CallbackReturn>,
    panic_on_cleanup: bool,
    calls: Arc<Mutex<Vec<(&'static str, State)>>>,
}

impl Scripted {
    fn record(&self, name: &'static str, previous: State) {
        self.calls.lock().unwrap().push((name, previous));
    }
}

impl Managed for Scripted {
    fn on_configure(&mut self, previous: State) -> CallbackReturn {
        self.record("configure", previous);
        CallbackReturn::Success
    }
    fn on_activate(&mut self, previous: State) -> CallbackReturn {
        self.record("activate", previous);
        match self.activate.is_empty() {
            true => CallbackReturn::Success,
            false => self.activate.remove(0),
        }
    }
    fn on_cleanup(&mut self, previous: State) -> CallbackReturn {
        self.record("cleanup", previous);
        if std::mem::take(&mut self.panic_on_cleanup) {
            panic!("cleanup failed");
        }
        CallbackReturn::Success
    }
    fn on_error(&mut self, previous: State) -> CallbackReturn {
        self.record("error", previous);
        CallbackReturn::Success
    }
}

#[test]
fn a_node_drives_itself_and_its_publishers_follow_the_state() {
    let (a, b, _) = loopback_sessions();
    let node = common::node(&a, "camera");
    let calls = Arc::default();
    let lifecycle = node
        .lifecycle(Scripted {
            activate: vec![CallbackReturn::Failure, CallbackReturn::Error],
            panic_on_cleanup: true,
            calls: Arc::clone(&calls),
        })
        .unwrap();
    let status = lifecycle.publisher(node.declare_publisher::<Text>("status").wait().unwrap());
    let listener = common::node(&b, "listener");
    let received = listener
        .declare_subscriber::<Text>("status")
        .wait()
        .unwrap();
    assert!(status.publisher().wait_for_subscribers(TIMEOUT));
    let text = |s: &str| Text { data: s.into() };

    assert_eq!(lifecycle.state(), State::Unconfigured);
    assert!(matches!(
        lifecycle.activate(),
        Err(LifecycleError::NotAvailable {
            state: State::Unconfigured,
            ..
        })
    ));
    assert_eq!(status.publish(&text("too early")).wait().unwrap(), None);
    assert_eq!(lifecycle.configure().unwrap(), CallbackReturn::Success);
    assert_eq!(lifecycle.state(), State::Inactive);
    // A failure goes back; an error goes through on_error to Unconfigured.
    assert_eq!(lifecycle.activate().unwrap(), CallbackReturn::Failure);
    assert_eq!(lifecycle.state(), State::Inactive);
    assert_eq!(lifecycle.activate().unwrap(), CallbackReturn::Error);
    assert_eq!(lifecycle.state(), State::Unconfigured);
    lifecycle.configure().unwrap();
    assert_eq!(lifecycle.activate().unwrap(), CallbackReturn::Success);
    assert!(status.is_active());
    assert!(status.publish(&text("live")).wait().unwrap().is_some());
    let got: Text = received
        .recv_timeout(TIMEOUT)
        .unwrap()
        .unwrap()
        .decode()
        .unwrap();
    assert_eq!(got.data, "live");
    lifecycle.deactivate().unwrap();
    assert_eq!(status.publish(&text("paused")).wait().unwrap(), None);
    // A panicking callback is an error, not a dead process.
    assert_eq!(lifecycle.cleanup().unwrap(), CallbackReturn::Error);
    assert_eq!(lifecycle.state(), State::Unconfigured);
    assert_eq!(
        lifecycle.trigger(Transition::Shutdown).unwrap(),
        CallbackReturn::Success
    );
    assert_eq!(lifecycle.state(), State::Finalized);
    assert!(lifecycle.configure().is_err());
    assert!(
        received.try_recv().unwrap().is_none(),
        "an inactive publisher sent"
    );

    use State::*;
    assert_eq!(
        *calls.lock().unwrap(),
        [
            ("configure", Unconfigured),
            ("activate", Inactive),
            ("activate", Inactive),
            ("error", Inactive),
            ("configure", Unconfigured),
            ("activate", Inactive),
            ("cleanup", Inactive),
            ("error", Inactive),
        ]
    );
}

#[test]
fn a_manager_drives_it_through_the_services_and_sees_every_step() {
    let (a, b, _) = loopback_sessions();
    let node = RosNode::builder(&a, "lc")
        .namespace("/robot")
        .domain_id(0)
        .wait()
        .unwrap();
    let lifecycle = node.lifecycle(Scripted::default()).unwrap();
    let manager = common::node(&b, "manager");
    let change = manager
        .declare_client::<ChangeState>("/robot/lc/change_state")
        .wait()
        .unwrap();
    let get_state = manager
        .declare_client::<GetState>("/robot/lc/get_state")
        .wait()
        .unwrap();
    let available = manager
        .declare_client::<GetAvailableTransitions>("/robot/lc/get_available_transitions")
        .wait()
        .unwrap();
    let events = manager
        .declare_subscriber::<TransitionEvent>("/robot/lc/transition_event")
        .wait()
        .unwrap();
    assert!(change.wait_for_service(TIMEOUT) && get_state.wait_for_service(TIMEOUT));
    assert!(events.wait_for_publishers(TIMEOUT));

    let ask = |id: u8, label: &str| {
        change
            .call(&ChangeState_Request {
                transition: TransitionMsg {
                    id,
                    label: label.into(),
                },
            })
            .wait()
            .unwrap()
            .success
    };
    assert!(!ask(TransitionMsg::TRANSITION_ACTIVATE, ""));
    assert!(ask(TransitionMsg::TRANSITION_CONFIGURE, ""));
    assert!(!ask(0, "bogus"));
    assert!(ask(0, "activate"));
    let state = get_state
        .call(&GetState_Request)
        .wait()
        .unwrap()
        .current_state;
    assert_eq!((state.id, state.label.as_str()), (3, "active"));
    assert_eq!(lifecycle.state(), State::Active);
    let offered: Vec<String> = available
        .call(&GetAvailableTransitions_Request)
        .wait()
        .unwrap()
        .available_transitions
        .into_iter()
        .map(|t| t.transition.label)
        .collect();
    assert_eq!(offered, ["deactivate", "shutdown"]);
    assert!(ask(0, "shutdown"));
    assert_eq!(lifecycle.state(), State::Finalized);

    let mut steps = Vec::new();
    while steps.len() < 6 {
        let Some(event) = events.recv_timeout(TIMEOUT).unwrap() else {
            break;
        };
        let event: TransitionEvent = event.decode().unwrap();
        steps.push((event.start_state.label, event.goal_state.label));
    }
    let expected = [
        ("unconfigured", "configuring"),
        ("configuring", "inactive"),
        ("inactive", "activating"),
        ("activating", "active"),
        ("active", "shuttingdown"),
        ("shuttingdown", "finalized"),
    ]
    .map(|(a, b)| (a.to_owned(), b.to_owned()));
    assert_eq!(steps, expected);
}
