//! The serving side: three service servers and two publishers around one table
//! of goals, which follows rcl_action's state machine and its cancel and
//! result rules.

use std::fmt;
use std::future::{Future, IntoFuture};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use shm_cdr::interface::RosAction;
use shm_cdr::msgs::action_msgs::msg as wire;
use shm_cdr::msgs::action_msgs::srv::{CancelGoal, CancelGoal_Response};
use zenoh::{Resolvable, Wait};

use super::state::{transition, GoalEvent, GoalStatus};
use super::{part_name, ActionError, GoalId, Stamp};
use crate::rmw::Qos;
use crate::ros::service::{CallbackServiceServer, ServiceRequest};
use crate::ros::type_description::TypeUse;
use crate::transport::publisher::{now_ns, PublishOutcome};
use crate::{RosNode, RosPublisher};

/// rcl_action's default `result_timeout` (Kilted): how long a finished goal's
/// result is kept for `get_result`.
const DEFAULT_RESULT_TIMEOUT: Duration = Duration::from_secs(10);

/// What the server does with a new goal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GoalDecision {
    /// Accept it: it is queued for [`ActionServer::recv`].
    Accept,
    /// Reject it: the client's `send_goal` fails with
    /// [`ActionError::Rejected`].
    Reject,
}

/// What the server does with a request to cancel one goal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CancelDecision {
    /// Accept: the goal moves to canceling; its executor sees
    /// [`ServerGoalHandle::is_cancel_requested`] and ends it.
    Accept,
    /// Reject: the goal goes on.
    Reject,
}

type GoalCallback<A> = dyn Fn(GoalId, &<A as RosAction>::Goal) -> GoalDecision + Send + Sync;
type CancelCallback = dyn Fn(GoalId) -> CancelDecision + Send + Sync;

/// Builder of an [`ActionServer`]; resolve with `.wait()` or `.await`.
#[must_use = "resolve the builder with .wait() or .await"]
pub struct ActionServerBuilder<'a, A: RosAction> {
    pub(crate) node: &'a RosNode,
    pub(crate) name: String,
    on_goal: Option<Box<GoalCallback<A>>>,
    on_cancel: Option<Box<CancelCallback>>,
    result_timeout: Duration,
}

impl<'a, A: RosAction> ActionServerBuilder<'a, A> {
    pub(crate) fn new(node: &'a RosNode, name: &str) -> Self {
        Self {
            node,
            name: name.to_owned(),
            on_goal: None,
            on_cancel: None,
            result_timeout: DEFAULT_RESULT_TIMEOUT,
        }
    }

    /// Decide on each new goal with `decide(goal_id, &goal)` (on an
    /// [`Executor`](crate::Executor) thread, before the client gets its
    /// answer). Without it,
    /// every goal is accepted. A goal whose id the server already has is
    /// rejected without asking.
    pub fn on_goal<F>(mut self, decide: F) -> Self
    where
        F: Fn(GoalId, &A::Goal) -> GoalDecision + Send + Sync + 'static,
    {
        self.on_goal = Some(Box::new(decide));
        self
    }

    /// Decide on each goal a cancel request names (on an
    /// [`Executor`](crate::Executor) thread). Without
    /// it, every cancel of an accepted or executing goal is accepted.
    pub fn on_cancel<F>(mut self, decide: F) -> Self
    where
        F: Fn(GoalId) -> CancelDecision + Send + Sync + 'static,
    {
        self.on_cancel = Some(Box::new(decide));
        self
    }

    /// How long a finished goal's result stays available to `get_result`
    /// (rcl_action's `result_timeout`, 10 s by default); after that the goal
    /// leaves the status array and `get_result` answers `UNKNOWN`.
    pub fn result_timeout(mut self, timeout: Duration) -> Self {
        self.result_timeout = timeout;
        self
    }

    fn build(self) -> zenoh::Result<ActionServer<A>> {
        let node = self.node;
        let name = node.resolve_topic_name(&self.name)?;
        let type_use = node.register_type(A::type_hash(), A::full_description);
        let status = node
            .declare_publisher_with_qos::<wire::GoalStatusArray>(
                &part_name(&name, "status"),
                Qos::transient_local(1),
            )
            .wait()?;
        let feedback = node
            .declare_publisher::<A::FeedbackMessage>(&part_name(&name, "feedback"))
            .wait()?;
        let core = Arc::new(Core {
            goals: Mutex::new(Vec::new()),
            status,
            feedback,
            result_timeout: self.result_timeout,
            on_cancel: self.on_cancel,
        });
        let (accepted_tx, accepted) = flume::unbounded();
        let on_goal = self.on_goal;
        let for_goals = core.clone();
        let send_goal = node
            .declare_service::<A::SendGoal>(&part_name(&name, "send_goal"))
            .callback(move |request: ServiceRequest<A::SendGoal>| {
                let Ok(decoded) = request.request() else {
                    return; // refused with an error reply, counted
                };
                let (id, goal) = A::send_goal_request_parts(decoded);
                let decision = on_goal
                    .as_ref()
                    .map_or(GoalDecision::Accept, |f| f(id, &goal));
                if let Some(accepted) = for_goals.new_goal(request, id, goal, decision) {
                    // The receiver lives as long as the server's services.
                    let _ = accepted_tx.send(accepted);
                }
            })
            .wait()?;
        let for_cancel = core.clone();
        let cancel_goal = node
            .declare_service::<CancelGoal>(&part_name(&name, "cancel_goal"))
            .callback(move |request: ServiceRequest<CancelGoal>| {
                let Ok(decoded) = request.request() else {
                    return;
                };
                let info = decoded.goal_info;
                let cut_off = Stamp {
                    sec: info.stamp.sec,
                    nanosec: info.stamp.nanosec,
                };
                let response = for_cancel.cancel(info.goal_id.uuid, cut_off);
                if let Err(e) = request.reply(&response).wait() {
                    tracing::warn!("action cancel reply failed: {e}");
                }
            })
            .wait()?;
        let for_results = core.clone();
        let get_result = node
            .declare_service::<A::GetResult>(&part_name(&name, "get_result"))
            .callback(move |request: ServiceRequest<A::GetResult>| {
                let Ok(decoded) = request.request() else {
                    return;
                };
                for_results.result_request(request, A::get_result_request_goal_id(&decoded));
            })
            .wait()?;
        Ok(ActionServer {
            name,
            core,
            accepted,
            _send_goal: send_goal,
            _cancel_goal: cancel_goal,
            _get_result: get_result,
            _type_use: type_use,
        })
    }
}

impl<A: RosAction> Resolvable for ActionServerBuilder<'_, A> {
    type To = zenoh::Result<ActionServer<A>>;
}

impl<A: RosAction> Wait for ActionServerBuilder<'_, A> {
    fn wait(self) -> Self::To {
        self.build()
    }
}

impl<A: RosAction> IntoFuture for ActionServerBuilder<'_, A> {
    type Output = zenoh::Result<ActionServer<A>>;
    type IntoFuture = std::future::Ready<Self::Output>;
    fn into_future(self) -> Self::IntoFuture {
        std::future::ready(self.build())
    }
}

/// One goal the server knows.
struct Goal<A: RosAction> {
    id: GoalId,
    stamp: Stamp,
    status: GoalStatus,
    /// Set with the terminal status.
    result: Option<A::Result>,
    finished_at: Option<Instant>,
    /// `get_result` calls waiting for the goal to finish.
    waiting: Vec<ServiceRequest<A::GetResult>>,
    /// Dropped when a cancel is accepted: the goal's handle sees its channel
    /// disconnect.
    cancel: Option<flume::Sender<()>>,
}

/// What the services, the publishers and every goal handle share.
struct Core<A: RosAction> {
    /// In acceptance order, as rcl_action keeps them (and lists them in the
    /// status array).
    goals: Mutex<Vec<Goal<A>>>,
    status: RosPublisher<wire::GoalStatusArray>,
    feedback: RosPublisher<A::FeedbackMessage>,
    result_timeout: Duration,
    on_cancel: Option<Box<CancelCallback>>,
}

impl<A: RosAction> Core<A> {
    /// The goal table, without the results that expired.
    fn goals(&self) -> MutexGuard<'_, Vec<Goal<A>>> {
        // A panic in another thread while holding the lock left the table
        // consistent (every change is a single assignment): go on with it.
        let mut goals = self.goals.lock().unwrap_or_else(|e| e.into_inner());
        let timeout = self.result_timeout;
        goals.retain(|g| g.finished_at.is_none_or(|t| t.elapsed() < timeout));
        goals
    }

    /// Publish the status of every goal in `goals` (called with the lock held,
    /// so status arrays go out in the order of the changes they report; the
    /// last one is what late subscribers get).
    fn publish_status(&self, goals: &[Goal<A>]) {
        let array = wire::GoalStatusArray {
            status_list: goals
                .iter()
                .map(|g| {
                    let mut status = wire::GoalStatus {
                        status: g.status.code(),
                        ..Default::default()
                    };
                    status.goal_info.goal_id.uuid = g.id;
                    status.goal_info.stamp.sec = g.stamp.sec;
                    status.goal_info.stamp.nanosec = g.stamp.nanosec;
                    status
                })
                .collect(),
        };
        if let Err(e) = self.status.publish(&array).wait() {
            tracing::warn!("action status publish failed: {e}");
        }
    }

    /// A `send_goal` request: answer it, and return the goal if accepted.
    fn new_goal(
        self: &Arc<Self>,
        request: ServiceRequest<A::SendGoal>,
        id: GoalId,
        goal: A::Goal,
        decision: GoalDecision,
    ) -> Option<AcceptedGoal<A>> {
        let mut goals = self.goals();
        if decision == GoalDecision::Reject || goals.iter().any(|g| g.id == id) {
            drop(goals);
            if decision == GoalDecision::Accept {
                tracing::warn!("action goal {} rejected: its id is taken", uuid_text(&id));
            }
            let response = A::send_goal_response(false, Stamp::default());
            if let Err(e) = request.reply(&response).wait() {
                tracing::warn!("action send_goal reply failed: {e}");
            }
            return None;
        }
        let stamp = Stamp::from_nanos(now_ns());
        let (cancel, canceled) = flume::bounded(1);
        goals.push(Goal {
            id,
            stamp,
            status: GoalStatus::Accepted,
            result: None,
            finished_at: None,
            waiting: Vec::new(),
            cancel: Some(cancel),
        });
        // Answer before the status array announces the goal, as rclcpp does.
        if let Err(e) = request.reply(&A::send_goal_response(true, stamp)).wait() {
            tracing::warn!("action send_goal reply failed: {e}");
        }
        self.publish_status(&goals);
        drop(goals);
        Some(AcceptedGoal {
            goal,
            stamp,
            handle: Handle {
                core: self.clone(),
                id,
                canceled,
                done: false,
            },
        })
    }

    /// A `cancel_goal` request, decided as rcl_action's
    /// `rcl_action_process_cancel_request` and rclcpp's server do.
    fn cancel(&self, id: GoalId, cut_off: Stamp) -> CancelGoal_Response {
        let by_id = id != [0; 16];
        let mut cut_off = cut_off.as_nanos();
        let mut return_code = CancelGoal_Response::ERROR_NONE;
        let candidates: Vec<GoalId> = {
            let goals = self.goals();
            if by_id && cut_off == 0 {
                match goals.iter().find(|g| g.id == id) {
                    None => return_code = CancelGoal_Response::ERROR_UNKNOWN_GOAL_ID,
                    Some(g) if !g.status.is_cancelable() => {
                        return_code = CancelGoal_Response::ERROR_GOAL_TERMINATED;
                    }
                    Some(_) => {}
                }
                goals
                    .iter()
                    .filter(|g| g.id == id && g.status.is_cancelable())
                    .map(|g| g.id)
                    .collect()
            } else {
                if !by_id && cut_off == 0 {
                    cut_off = i64::MAX; // every goal
                }
                goals
                    .iter()
                    .filter(|g| {
                        g.status.is_cancelable() && (g.stamp.as_nanos() <= cut_off || g.id == id)
                    })
                    .map(|g| g.id)
                    .collect()
            }
        };
        // The application decides without the lock held.
        let accepted: Vec<GoalId> = candidates
            .iter()
            .copied()
            .filter(|&id| {
                self.on_cancel
                    .as_ref()
                    .is_none_or(|decide| decide(id) == CancelDecision::Accept)
            })
            .collect();
        let mut goals = self.goals();
        let mut canceling = Vec::new();
        for goal in goals.iter_mut().filter(|g| accepted.contains(&g.id)) {
            if let Some(next) = transition(goal.status, GoalEvent::CancelGoal) {
                goal.status = next;
                goal.cancel = None;
                let mut info = wire::GoalInfo::default();
                info.goal_id.uuid = goal.id;
                info.stamp.sec = goal.stamp.sec;
                info.stamp.nanosec = goal.stamp.nanosec;
                canceling.push(info);
            }
        }
        if !candidates.is_empty() && canceling.is_empty() {
            return_code = CancelGoal_Response::ERROR_REJECTED;
        }
        if !canceling.is_empty() {
            self.publish_status(&goals);
        }
        CancelGoal_Response {
            return_code,
            goals_canceling: canceling,
        }
    }

    /// A `get_result` request: answered now if the goal is finished or
    /// unknown, else when it finishes.
    fn result_request(&self, request: ServiceRequest<A::GetResult>, id: GoalId) {
        let mut goals = self.goals();
        let (status, result) = match goals.iter_mut().find(|g| g.id == id) {
            Some(goal) => match &goal.result {
                Some(result) => (goal.status, result.clone()),
                None => {
                    goal.waiting.push(request);
                    return;
                }
            },
            None => (GoalStatus::Unknown, A::Result::default()),
        };
        drop(goals);
        let response = A::get_result_response(status.code(), result);
        if let Err(e) = request.reply(&response).wait() {
            tracing::warn!("action get_result reply failed: {e}");
        }
    }

    /// The state of goal `id`.
    fn status(&self, id: &GoalId) -> GoalStatus {
        self.goals()
            .iter()
            .find(|g| g.id == *id)
            .map_or(GoalStatus::Unknown, |g| g.status)
    }

    /// Apply `event` to goal `id`; with a terminal event, store `result`,
    /// answer the waiting `get_result` calls, then publish the status.
    fn apply(
        &self,
        id: &GoalId,
        event: GoalEvent,
        result: Option<A::Result>,
    ) -> Result<(), ActionError> {
        let mut goals = self.goals();
        let Some(goal) = goals.iter_mut().find(|g| g.id == *id) else {
            return Err(ActionError::InvalidTransition {
                from: GoalStatus::Unknown,
                event,
            });
        };
        let Some(next) = transition(goal.status, event) else {
            return Err(ActionError::InvalidTransition {
                from: goal.status,
                event,
            });
        };
        goal.status = next;
        if next.is_terminal() {
            let result = result.unwrap_or_default();
            let mut waiting = std::mem::take(&mut goal.waiting);
            // The results go out before the status says the goal finished, as
            // rclcpp's server does, so a client that sees the terminal status
            // already has (or is about to get) its result.
            for request in waiting.drain(..) {
                let response = A::get_result_response(next.code(), result.clone());
                if let Err(e) = request.reply(&response).wait() {
                    tracing::warn!("action get_result reply failed: {e}");
                }
            }
            goal.result = Some(result);
            goal.finished_at = Some(Instant::now());
            goal.cancel = None;
        }
        self.publish_status(&goals);
        Ok(())
    }
}

/// An action server; its services and publishers are undeclared when it is
/// dropped (goal handles still held keep the goal table, so they can finish).
pub struct ActionServer<A: RosAction> {
    name: String,
    core: Arc<Core<A>>,
    accepted: flume::Receiver<AcceptedGoal<A>>,
    _send_goal: CallbackServiceServer<A::SendGoal>,
    _cancel_goal: CallbackServiceServer<CancelGoal>,
    _get_result: CallbackServiceServer<A::GetResult>,
    _type_use: TypeUse,
}

impl<A: RosAction> fmt::Debug for ActionServer<A> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ActionServer")
            .field("name", &self.name)
            .field("queued", &self.accepted.len())
            .finish()
    }
}

impl<A: RosAction> ActionServer<A> {
    /// Wait for the next accepted goal.
    pub fn recv(&self) -> zenoh::Result<AcceptedGoal<A>> {
        Ok(self.accepted.recv()?)
    }

    /// Wait at most `timeout` for the next accepted goal.
    pub fn recv_timeout(&self, timeout: Duration) -> zenoh::Result<Option<AcceptedGoal<A>>> {
        match self.accepted.recv_timeout(timeout) {
            Ok(goal) => Ok(Some(goal)),
            Err(flume::RecvTimeoutError::Timeout) => Ok(None),
            Err(e) => Err(e.into()),
        }
    }

    /// The next accepted goal if one waits.
    pub fn try_recv(&self) -> zenoh::Result<Option<AcceptedGoal<A>>> {
        match self.accepted.try_recv() {
            Ok(goal) => Ok(Some(goal)),
            Err(flume::TryRecvError::Empty) => Ok(None),
            Err(e) => Err(e.into()),
        }
    }

    /// Wait for the next accepted goal, asynchronously. Cancellation-safe.
    pub async fn recv_async(&self) -> zenoh::Result<AcceptedGoal<A>> {
        Ok(self.accepted.recv_async().await?)
    }

    /// Every goal the server knows (finished ones until their result
    /// expires), in acceptance order, with its state: what the status topic
    /// carries.
    pub fn goals(&self) -> Vec<(GoalId, GoalStatus)> {
        self.core.goals().iter().map(|g| (g.id, g.status)).collect()
    }

    /// The action's fully qualified name.
    pub fn name(&self) -> &str {
        &self.name
    }
}

/// What both goal handles share: the goal's id in the server's table, the
/// cancel signal, and whether a terminal state was reached.
struct Handle<A: RosAction> {
    core: Arc<Core<A>>,
    id: GoalId,
    canceled: flume::Receiver<()>,
    done: bool,
}

impl<A: RosAction> Handle<A> {
    fn is_cancel_requested(&self) -> bool {
        self.canceled.is_disconnected()
    }

    fn finish(&mut self, event: GoalEvent, result: A::Result) -> Result<(), ActionError> {
        let outcome = self.core.apply(&self.id, event, Some(result));
        self.done = true;
        outcome
    }
}

impl<A: RosAction> Drop for Handle<A> {
    /// A goal must end: one dropped unfinished is aborted (canceled, if a
    /// cancel was accepted) with a default result, as rclcpp does, so its
    /// clients are not left waiting.
    fn drop(&mut self) {
        if self.done {
            return;
        }
        tracing::warn!(
            "action goal {} dropped before it finished: ending it with a default result",
            uuid_text(&self.id)
        );
        let events: &[GoalEvent] = match self.core.status(&self.id) {
            GoalStatus::Accepted => &[GoalEvent::Execute, GoalEvent::Abort],
            GoalStatus::Executing => &[GoalEvent::Abort],
            GoalStatus::Canceling => &[GoalEvent::Canceled],
            _ => &[],
        };
        for &event in events {
            let _ = self.core.apply(&self.id, event, None);
        }
    }
}

/// A goal the server accepted, not yet executing. Start it with
/// [`execute`](Self::execute); dropping it aborts the goal.
pub struct AcceptedGoal<A: RosAction> {
    goal: A::Goal,
    stamp: Stamp,
    handle: Handle<A>,
}

impl<A: RosAction> fmt::Debug for AcceptedGoal<A> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("AcceptedGoal")
            .field("id", &uuid_text(&self.handle.id))
            .field("stamp", &self.stamp)
            .finish()
    }
}

impl<A: RosAction> AcceptedGoal<A> {
    /// The goal's id.
    pub fn id(&self) -> GoalId {
        self.handle.id
    }

    /// The goal.
    pub fn goal(&self) -> &A::Goal {
        &self.goal
    }

    /// When the server accepted it.
    pub fn stamp(&self) -> Stamp {
        self.stamp
    }

    /// Whether a cancel of this goal was accepted while it waited.
    pub fn is_cancel_requested(&self) -> bool {
        self.handle.is_cancel_requested()
    }

    /// Start executing: the status becomes executing (unless a cancel was
    /// accepted meanwhile: then it stays canceling, and the handle says so).
    pub fn execute(self) -> ServerGoalHandle<A> {
        if let Err(e) = self
            .handle
            .core
            .apply(&self.handle.id, GoalEvent::Execute, None)
        {
            tracing::debug!("{e}");
        }
        ServerGoalHandle {
            goal: self.goal,
            stamp: self.stamp,
            handle: self.handle,
        }
    }
}

/// An executing (or canceling) goal: publish feedback, then end it with
/// exactly one of [`succeed`](Self::succeed), [`abort`](Self::abort) or
/// [`canceled`](Self::canceled). Dropping it unfinished aborts the goal (or
/// cancels it, if a cancel was accepted) with a default result.
pub struct ServerGoalHandle<A: RosAction> {
    goal: A::Goal,
    stamp: Stamp,
    handle: Handle<A>,
}

impl<A: RosAction> fmt::Debug for ServerGoalHandle<A> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ServerGoalHandle")
            .field("id", &uuid_text(&self.handle.id))
            .field("status", &self.status())
            .finish()
    }
}

impl<A: RosAction> ServerGoalHandle<A> {
    /// The goal's id.
    pub fn id(&self) -> GoalId {
        self.handle.id
    }

    /// The goal.
    pub fn goal(&self) -> &A::Goal {
        &self.goal
    }

    /// When the server accepted it.
    pub fn stamp(&self) -> Stamp {
        self.stamp
    }

    /// The goal's state in the server's table.
    pub fn status(&self) -> GoalStatus {
        self.handle.core.status(&self.handle.id)
    }

    /// Whether a cancel of this goal was accepted: stop, then call
    /// [`canceled`](Self::canceled) (or succeed/abort if it finished anyway).
    pub fn is_cancel_requested(&self) -> bool {
        self.handle.is_cancel_requested()
    }

    /// Resolves when a cancel of this goal is accepted (at once if one was).
    /// Cancellation-safe: race it against the work with your runtime's
    /// `select!`.
    pub fn cancel_requested(&self) -> impl Future<Output = ()> + Send + '_ {
        let canceled = self.handle.canceled.clone();
        async move {
            // Nothing is ever sent: the sender is dropped when a cancel is
            // accepted (or the goal ends), which ends the wait.
            let _ = canceled.recv_async().await;
        }
    }

    /// Publish `feedback` on the action's feedback topic, tagged with this
    /// goal's id.
    pub fn publish_feedback(&self, feedback: A::Feedback) -> Result<PublishOutcome, ActionError> {
        let message = A::feedback_message(self.handle.id, feedback);
        Ok(self.handle.core.feedback.publish(&message).wait()?)
    }

    /// End the goal successfully with `result`.
    pub fn succeed(mut self, result: A::Result) -> Result<(), ActionError> {
        self.handle.finish(GoalEvent::Succeed, result)
    }

    /// End the goal as failed, with `result`.
    pub fn abort(mut self, result: A::Result) -> Result<(), ActionError> {
        self.handle.finish(GoalEvent::Abort, result)
    }

    /// End the goal as canceled, with `result`. Only a goal whose cancel was
    /// accepted ([`is_cancel_requested`](Self::is_cancel_requested)) can be
    /// canceled; any other is aborted with `result` instead, and this returns
    /// [`ActionError::InvalidTransition`].
    pub fn canceled(mut self, result: A::Result) -> Result<(), ActionError> {
        if self.handle.is_cancel_requested() {
            return self.handle.finish(GoalEvent::Canceled, result);
        }
        let refused = ActionError::InvalidTransition {
            from: self.status(),
            event: GoalEvent::Canceled,
        };
        self.handle.finish(GoalEvent::Abort, result)?;
        Err(refused)
    }
}

/// A goal id as rclcpp prints UUIDs (lowercase hex, hyphenated 8-4-4-4-12).
pub(crate) fn uuid_text(id: &GoalId) -> String {
    uuid::Uuid::from_bytes(*id).hyphenated().to_string()
}
