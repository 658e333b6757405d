//! ROS 2 actions as rmw_zenoh_cpp carries them: three services and two topics
//! under `<action>/_action/`, driven by rcl_action's goal state machine.
//!
//! | entity | name | type |
//! |---|---|---|
//! | service | `<action>/_action/send_goal` | `<pkg>/action/<Name>_SendGoal` |
//! | service | `<action>/_action/cancel_goal` | `action_msgs/srv/CancelGoal` |
//! | service | `<action>/_action/get_result` | `<pkg>/action/<Name>_GetResult` |
//! | topic | `<action>/_action/feedback` | `<pkg>/action/<Name>_FeedbackMessage` |
//! | topic | `<action>/_action/status` | `action_msgs/msg/GoalStatusArray` (reliable, transient local, keep last 1) |
//!
//! A server ([`ActionServer`]) decides on each goal (a callback, accept all by
//! default), hands accepted goals to the application as [`AcceptedGoal`]s, and
//! keeps every goal's state, publishing the status array on each change. The
//! application executes a goal through its [`ServerGoalHandle`]: feedback, then
//! exactly one of succeed, abort or (after a cancel request) canceled. A
//! client ([`ActionClient`]) sends goals and gets a [`ClientGoalHandle`] for
//! each: its feedback, its status, its result, and cancel.
//!
//! ```no_run
//! use shm_runtime::action::GoalStatus;
//! use shm_runtime::shm_cdr::msgs::test_msgs::action::{Fibonacci, Fibonacci_Feedback, Fibonacci_Goal, Fibonacci_Result};
//! use shm_runtime::RosNode;
//! use zenoh::Wait;
//!
//! let session = zenoh::open(zenoh::Config::default()).wait()?;
//! let node = RosNode::builder(&session, "demo").wait()?;
//! let server = node.declare_action_server::<Fibonacci>("/fibonacci").wait()?;
//! std::thread::spawn(move || {
//!     while let Ok(accepted) = server.recv() {
//!         let goal = accepted.execute();
//!         let mut sequence = vec![0, 1];
//!         for i in 1..goal.goal().order as usize {
//!             sequence.push(sequence[i] + sequence[i - 1]);
//!             let _ = goal.publish_feedback(Fibonacci_Feedback { sequence: sequence.clone() });
//!         }
//!         let _ = goal.succeed(Fibonacci_Result { sequence });
//!     }
//! });
//!
//! let client = node.declare_action_client::<Fibonacci>("/fibonacci").wait()?;
//! let goal = client.send_goal(Fibonacci_Goal { order: 10 }).wait()?;
//! while let Some(feedback) = goal.recv_feedback() {
//!     println!("feedback: {:?}", feedback.sequence);
//! }
//! let result = goal.result().wait()?;
//! assert_eq!(result.status, GoalStatus::Succeeded);
//! # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
//! ```

mod client;
mod server;
mod state;

pub use client::{
    ActionClient, ActionClientBuilder, CancelBuilder, CancelResponse, ClientGoalHandle,
    FeedbackEnded, GoalResult, ResultBuilder, SendGoalBuilder,
};
pub use server::{
    AcceptedGoal, ActionServer, ActionServerBuilder, CancelDecision, GoalDecision, ServerGoalHandle,
};
pub use shm_cdr::interface::{GoalId, Stamp};
pub use state::{transition, GoalEvent, GoalStatus};

use std::fmt;

use crate::ros::service::CallError;
use crate::transport::publisher::PublishError;

/// The names of an action's services and topics: `<action>/_action/<part>`.
pub(crate) fn part_name(action: &str, part: &str) -> String {
    format!("{}/_action/{part}", action.trim_end_matches('/'))
}

/// Why an action operation failed.
#[derive(Debug)]
#[non_exhaustive]
pub enum ActionError {
    /// The server rejected the goal.
    Rejected,
    /// One of the action's service calls failed (no server, the server went
    /// away, timeout, a reply that does not decode…).
    Call(CallError),
    /// Publishing the status array or a feedback message failed.
    Publish(PublishError),
    /// The goal's state does not allow this (rcl_action's state machine), e.g.
    /// `canceled` on a goal whose cancel was not requested.
    InvalidTransition {
        /// The goal's state.
        from: GoalStatus,
        /// What was asked.
        event: GoalEvent,
    },
}

impl fmt::Display for ActionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Rejected => write!(f, "action: the server rejected the goal"),
            Self::Call(e) => write!(f, "action: {e}"),
            Self::Publish(e) => write!(f, "action: {e}"),
            Self::InvalidTransition { from, event } => write!(
                f,
                "action: a goal in state {from:?} cannot take event {event:?} (rcl_action's goal state machine)"
            ),
        }
    }
}

impl std::error::Error for ActionError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Call(e) => Some(e),
            Self::Publish(e) => Some(e),
            _ => None,
        }
    }
}

impl From<CallError> for ActionError {
    fn from(e: CallError) -> Self {
        Self::Call(e)
    }
}

impl From<PublishError> for ActionError {
    fn from(e: PublishError) -> Self {
        Self::Publish(e)
    }
}
