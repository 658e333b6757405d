//! The calling side: three service clients and two subscribers, and a table
//! of the goals this client sent, which routes their feedback and status.

use std::collections::HashMap;
use std::fmt;
use std::future::{Future, IntoFuture};
use std::pin::Pin;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use shm_cdr::interface::RosAction;
use shm_cdr::msgs::action_msgs::msg as wire;
use shm_cdr::msgs::action_msgs::srv::{CancelGoal, CancelGoal_Request, CancelGoal_Response};
use zenoh::{Resolvable, Wait};

use super::server::uuid_text;
use super::state::GoalStatus;
use super::{part_name, ActionError, GoalId, Stamp};
use crate::rmw::Qos;
use crate::ros::service::{ServiceClient, NO_TIMEOUT};
use crate::ros::type_description::TypeUse;
use crate::{CallbackSubscriber, RosNode, RosSample};

/// How long `send_goal` and `cancel` wait for the server by default (Zenoh's
/// query timeout, as rmw_zenoh_cpp's clients).
const DEFAULT_TIMEOUT: Duration = Duration::from_secs(10);

/// Builder of an [`ActionClient`]; resolve with `.wait()` or `.await`.
#[must_use = "resolve the builder with .wait() or .await"]
pub struct ActionClientBuilder<'a, A: RosAction> {
    pub(crate) node: &'a RosNode,
    pub(crate) name: String,
    timeout: Duration,
    action: std::marker::PhantomData<fn() -> A>,
}

impl<'a, A: RosAction> ActionClientBuilder<'a, A> {
    pub(crate) fn new(node: &'a RosNode, name: &str) -> Self {
        Self {
            node,
            name: name.to_owned(),
            timeout: DEFAULT_TIMEOUT,
            action: std::marker::PhantomData,
        }
    }

    /// How long `send_goal` and `cancel` wait for the server's answer (10 s by
    /// default). A result is awaited for as long as the goal runs, unless
    /// [`ResultBuilder::timeout`] says otherwise.
    pub fn timeout(mut self, timeout: Duration) -> Self {
        self.timeout = timeout.min(NO_TIMEOUT);
        self
    }

    fn build(self) -> zenoh::Result<ActionClient<A>> {
        let node = self.node;
        let name = node.resolve_topic_name(&self.name)?;
        let type_use = node.register_type(A::type_hash(), A::full_description);
        let send_goal = node
            .declare_client::<A::SendGoal>(&part_name(&name, "send_goal"))
            .timeout(self.timeout)
            .wait()?;
        let cancel_goal = node
            .declare_client::<CancelGoal>(&part_name(&name, "cancel_goal"))
            .timeout(self.timeout)
            .wait()?;
        // rmw_zenoh_cpp's get_result has no timeout: it lasts as long as the goal.
        let get_result = node
            .declare_client::<A::GetResult>(&part_name(&name, "get_result"))
            .timeout(NO_TIMEOUT)
            .wait()?;
        let goals: Arc<Goals<A>> = Arc::new(Goals {
            table: Mutex::new(HashMap::new()),
        });
        let for_feedback = goals.clone();
        let feedback = node
            .declare_subscriber::<A::FeedbackMessage>(&part_name(&name, "feedback"))
            .callback_inline(move |sample: RosSample| for_feedback.feedback(&sample))
            .wait()?;
        let for_status = goals.clone();
        let status = node
            .declare_subscriber_with_qos::<wire::GoalStatusArray>(
                &part_name(&name, "status"),
                Qos::transient_local(1),
            )
            .callback_inline(move |sample: RosSample| for_status.status(&sample))
            .wait()?;
        // The server went away: goals waiting for feedback stop waiting (a
        // result call then fails with `NoReply`).
        let for_loss = goals.clone();
        get_result.on_matching_change(move |matching| {
            if !matching {
                for_loss.server_gone();
            }
        })?;
        Ok(ActionClient {
            inner: Arc::new(Inner {
                name,
                send_goal,
                cancel_goal,
                get_result,
                goals,
                _feedback: feedback,
                _status: status,
                _type_use: type_use,
            }),
        })
    }
}

impl<A: RosAction> Resolvable for ActionClientBuilder<'_, A> {
    type To = zenoh::Result<ActionClient<A>>;
}

impl<A: RosAction> Wait for ActionClientBuilder<'_, A> {
    fn wait(self) -> Self::To {
        self.build()
    }
}

impl<A: RosAction> IntoFuture for ActionClientBuilder<'_, A> {
    type Output = zenoh::Result<ActionClient<A>>;
    type IntoFuture = std::future::Ready<Self::Output>;
    fn into_future(self) -> Self::IntoFuture {
        std::future::ready(self.build())
    }
}

/// What the client knows of one goal it sent.
struct Tracked<A: RosAction> {
    /// Until the goal finishes (or the server goes away).
    feedback: Option<flume::Sender<A::Feedback>>,
    status: GoalStatus,
}

/// The goals this client sent, by id.
struct Goals<A: RosAction> {
    table: Mutex<HashMap<GoalId, Tracked<A>>>,
}

impl<A: RosAction> Goals<A> {
    fn table(&self) -> MutexGuard<'_, HashMap<GoalId, Tracked<A>>> {
        // Every change under the lock is one assignment: a panic elsewhere
        // cannot leave it half-done.
        self.table.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// A feedback message: to its goal's queue if the goal is one of ours.
    fn feedback(&self, sample: &RosSample) {
        let message = match sample.decode::<A::FeedbackMessage>() {
            Ok(message) => message,
            Err(e) => {
                tracing::warn!(key_expr = sample.key_expr(), "action feedback dropped: {e}");
                return;
            }
        };
        let (id, feedback) = A::feedback_message_parts(message);
        if let Some(sender) = self.table().get(&id).and_then(|t| t.feedback.as_ref()) {
            let _ = sender.send(feedback);
        }
    }

    /// A status array: update our goals; a finished goal's feedback ends.
    fn status(&self, sample: &RosSample) {
        let array = match sample.decode::<wire::GoalStatusArray>() {
            Ok(array) => array,
            Err(e) => {
                tracing::warn!(key_expr = sample.key_expr(), "action status dropped: {e}");
                return;
            }
        };
        let mut table = self.table();
        for entry in &array.status_list {
            if let Some(tracked) = table.get_mut(&entry.goal_info.goal_id.uuid) {
                tracked.status = GoalStatus::from_code(entry.status);
                if tracked.status.is_terminal() {
                    tracked.feedback = None;
                }
            }
        }
    }

    /// The server went away: every goal it had not finished is unknown now
    /// (nobody holds its state or result), and its feedback ends.
    fn server_gone(&self) {
        for tracked in self.table().values_mut() {
            tracked.feedback = None;
            if !tracked.status.is_terminal() {
                tracked.status = GoalStatus::Unknown;
            }
        }
    }

    fn finished(&self, id: &GoalId, status: GoalStatus) {
        if let Some(tracked) = self.table().get_mut(id) {
            tracked.status = status;
            tracked.feedback = None;
        }
    }
}

struct Inner<A: RosAction> {
    name: String,
    send_goal: ServiceClient<A::SendGoal>,
    cancel_goal: ServiceClient<CancelGoal>,
    get_result: ServiceClient<A::GetResult>,
    goals: Arc<Goals<A>>,
    _feedback: CallbackSubscriber<A::FeedbackMessage>,
    _status: CallbackSubscriber<wire::GoalStatusArray>,
    _type_use: TypeUse,
}

/// An action client: send goals, then follow each through its
/// [`ClientGoalHandle`]. Cheap to clone (clones share the client); undeclared
/// when the last clone and goal handle are dropped.
pub struct ActionClient<A: RosAction> {
    inner: Arc<Inner<A>>,
}

impl<A: RosAction> Clone for ActionClient<A> {
    fn clone(&self) -> Self {
        Self {
            inner: self.inner.clone(),
        }
    }
}

impl<A: RosAction> fmt::Debug for ActionClient<A> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ActionClient")
            .field("name", &self.inner.name)
            .finish()
    }
}

impl<A: RosAction> ActionClient<A> {
    /// Send `goal`; resolve with `.wait()` or `.await` into its handle, or
    /// [`ActionError::Rejected`].
    pub fn send_goal(&self, goal: A::Goal) -> SendGoalBuilder<'_, A> {
        SendGoalBuilder {
            client: self,
            goal,
            id: None,
        }
    }

    /// Ask the server to cancel goal `id` (sent by this client or any other).
    pub fn cancel_goal(&self, id: GoalId) -> CancelBuilder<'_, A> {
        CancelBuilder {
            client: self,
            id,
            cut_off: Stamp::default(),
        }
    }

    /// Ask the server to cancel every goal it has (from any client).
    pub fn cancel_all(&self) -> CancelBuilder<'_, A> {
        CancelBuilder {
            client: self,
            id: [0; 16],
            cut_off: Stamp::default(),
        }
    }

    /// Ask the server to cancel every goal it accepted at or before `stamp`.
    pub fn cancel_before(&self, stamp: Stamp) -> CancelBuilder<'_, A> {
        CancelBuilder {
            client: self,
            id: [0; 16],
            cut_off: stamp,
        }
    }

    /// Whether the action's three services have a server now.
    pub fn is_server_available(&self) -> bool {
        self.inner.send_goal.is_service_available()
            && self.inner.cancel_goal.is_service_available()
            && self.inner.get_result.is_service_available()
    }

    /// Wait until the action's three services have a server, or `timeout`
    /// passes; returns whether they do.
    pub fn wait_for_server(&self, timeout: Duration) -> bool {
        let deadline = std::time::Instant::now() + timeout;
        let left = || deadline.saturating_duration_since(std::time::Instant::now());
        self.inner.send_goal.wait_for_service(left())
            && self.inner.cancel_goal.wait_for_service(left())
            && self.inner.get_result.wait_for_service(left())
    }

    /// Resolves once the action's three services have a server.
    /// Cancellation-safe; bound it with your runtime's timeout.
    pub async fn server_available(&self) -> zenoh::Result<()> {
        self.inner.send_goal.service_available().await?;
        self.inner.cancel_goal.service_available().await?;
        self.inner.get_result.service_available().await
    }

    /// The action's fully qualified name.
    pub fn name(&self) -> &str {
        &self.inner.name
    }

    fn track(&self, id: GoalId) -> Option<flume::Receiver<A::Feedback>> {
        let mut table = self.inner.goals.table();
        if table.contains_key(&id) {
            return None;
        }
        let (sender, receiver) = flume::unbounded();
        table.insert(
            id,
            Tracked {
                feedback: Some(sender),
                status: GoalStatus::Unknown,
            },
        );
        Some(receiver)
    }

    fn untrack(&self, id: &GoalId) {
        self.inner.goals.table().remove(id);
    }

    /// The handle of a goal the server answered `response` to.
    fn accepted(
        &self,
        id: GoalId,
        feedback: flume::Receiver<A::Feedback>,
        response: &shm_cdr::interface::ResponseOf<A::SendGoal>,
    ) -> Result<ClientGoalHandle<A>, ActionError> {
        let (accepted, stamp) = A::send_goal_response_parts(response);
        if !accepted {
            self.untrack(&id);
            return Err(ActionError::Rejected);
        }
        if let Some(tracked) = self.inner.goals.table().get_mut(&id) {
            if tracked.status == GoalStatus::Unknown {
                tracked.status = GoalStatus::Accepted;
            }
        }
        Ok(ClientGoalHandle {
            client: self.clone(),
            id,
            stamp,
            feedback,
        })
    }
}

/// A goal to send; resolve with `.wait()` or `.await`.
#[must_use = "resolve the goal with .wait() or .await"]
pub struct SendGoalBuilder<'c, A: RosAction> {
    client: &'c ActionClient<A>,
    goal: A::Goal,
    id: Option<GoalId>,
}

impl<'c, A: RosAction> SendGoalBuilder<'c, A> {
    /// Send the goal with this id instead of a fresh random (version 4) UUID.
    /// An id the client already follows is refused as a rejection.
    pub fn goal_id(mut self, id: GoalId) -> Self {
        self.id = Some(id);
        self
    }

    /// Register the goal and build its request.
    #[allow(clippy::type_complexity)]
    fn prepare(
        self,
    ) -> Result<
        (
            &'c ActionClient<A>,
            GoalId,
            flume::Receiver<A::Feedback>,
            shm_cdr::interface::RequestOf<A::SendGoal>,
        ),
        ActionError,
    > {
        let id = self.id.unwrap_or_else(|| *uuid::Uuid::new_v4().as_bytes());
        // Feedback may arrive before the answer: the goal is followed first.
        let feedback = self.client.track(id).ok_or(ActionError::Rejected)?;
        Ok((
            self.client,
            id,
            feedback,
            A::send_goal_request(id, self.goal),
        ))
    }
}

impl<A: RosAction> Resolvable for SendGoalBuilder<'_, A> {
    type To = Result<ClientGoalHandle<A>, ActionError>;
}

impl<A: RosAction> Wait for SendGoalBuilder<'_, A> {
    fn wait(self) -> Self::To {
        let (client, id, feedback, request) = self.prepare()?;
        match client.inner.send_goal.call(&request).wait() {
            Ok(response) => client.accepted(id, feedback, &response),
            Err(e) => {
                client.untrack(&id);
                Err(e.into())
            }
        }
    }
}

impl<'c, A: RosAction> IntoFuture for SendGoalBuilder<'c, A> {
    type Output = Result<ClientGoalHandle<A>, ActionError>;
    type IntoFuture = Pin<Box<dyn Future<Output = Self::Output> + Send + 'c>>;

    fn into_future(self) -> Self::IntoFuture {
        let prepared = self.prepare();
        Box::pin(async move {
            let (client, id, feedback, request) = prepared?;
            // The call encodes the request before its first await.
            let call = client.inner.send_goal.call(&request).into_future();
            match call.await {
                Ok(response) => client.accepted(id, feedback, &response),
                Err(e) => {
                    client.untrack(&id);
                    Err(e.into())
                }
            }
        })
    }
}

/// The server's answer to a cancel request.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CancelResponse {
    /// `action_msgs/srv/CancelGoal` `ERROR_NONE` (0), `ERROR_REJECTED` (1),
    /// `ERROR_UNKNOWN_GOAL_ID` (2) or `ERROR_GOAL_TERMINATED` (3).
    pub return_code: i8,
    /// The goals now canceling, with the stamps they were accepted at.
    pub goals_canceling: Vec<(GoalId, Stamp)>,
}

impl CancelResponse {
    /// Whether the server is canceling at least one goal.
    pub fn is_accepted(&self) -> bool {
        self.return_code == CancelGoal_Response::ERROR_NONE && !self.goals_canceling.is_empty()
    }

    fn from_wire(response: CancelGoal_Response) -> Self {
        Self {
            return_code: response.return_code,
            goals_canceling: response
                .goals_canceling
                .iter()
                .map(|info| {
                    let stamp = Stamp {
                        sec: info.stamp.sec,
                        nanosec: info.stamp.nanosec,
                    };
                    (info.goal_id.uuid, stamp)
                })
                .collect(),
        }
    }
}

/// A cancel request; resolve with `.wait()` or `.await`.
#[must_use = "resolve the cancel request with .wait() or .await"]
pub struct CancelBuilder<'c, A: RosAction> {
    client: &'c ActionClient<A>,
    id: GoalId,
    cut_off: Stamp,
}

impl<A: RosAction> CancelBuilder<'_, A> {
    fn request(&self) -> CancelGoal_Request {
        let mut request = CancelGoal_Request::default();
        request.goal_info.goal_id.uuid = self.id;
        request.goal_info.stamp.sec = self.cut_off.sec;
        request.goal_info.stamp.nanosec = self.cut_off.nanosec;
        request
    }
}

impl<A: RosAction> Resolvable for CancelBuilder<'_, A> {
    type To = Result<CancelResponse, ActionError>;
}

impl<A: RosAction> Wait for CancelBuilder<'_, A> {
    fn wait(self) -> Self::To {
        let request = self.request();
        let response = self.client.inner.cancel_goal.call(&request).wait()?;
        Ok(CancelResponse::from_wire(response))
    }
}

impl<'c, A: RosAction> IntoFuture for CancelBuilder<'c, A> {
    type Output = Result<CancelResponse, ActionError>;
    type IntoFuture = Pin<Box<dyn Future<Output = Self::Output> + Send + 'c>>;

    fn into_future(self) -> Self::IntoFuture {
        let request = self.request();
        let client = self.client;
        Box::pin(async move {
            let response = client.inner.cancel_goal.call(&request).await?;
            Ok(CancelResponse::from_wire(response))
        })
    }
}

/// How a goal ended, and its result.
#[derive(Debug, Clone, PartialEq)]
pub struct GoalResult<R> {
    /// Succeeded, canceled or aborted; `Unknown` if the server does not know
    /// the goal (its result expired).
    pub status: GoalStatus,
    /// The result (the type's default when the status is `Unknown`).
    pub result: R,
}

/// A goal the server accepted: its feedback, its status, its result, and
/// cancel. Not following it any more (dropping the handle) does not cancel
/// it.
pub struct ClientGoalHandle<A: RosAction> {
    client: ActionClient<A>,
    id: GoalId,
    stamp: Stamp,
    feedback: flume::Receiver<A::Feedback>,
}

impl<A: RosAction> fmt::Debug for ClientGoalHandle<A> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ClientGoalHandle")
            .field("id", &uuid_text(&self.id))
            .field("stamp", &self.stamp)
            .field("status", &self.status())
            .finish()
    }
}

impl<A: RosAction> Drop for ClientGoalHandle<A> {
    fn drop(&mut self) {
        self.client.untrack(&self.id);
    }
}

impl<A: RosAction> ClientGoalHandle<A> {
    /// The goal's id.
    pub fn id(&self) -> GoalId {
        self.id
    }

    /// When the server accepted the goal.
    pub fn stamp(&self) -> Stamp {
        self.stamp
    }

    /// The goal's status as the server last published it (`Accepted` until
    /// the first status array arrives); [`GoalStatus::Unknown`] once the
    /// server went away before the goal finished.
    pub fn status(&self) -> GoalStatus {
        self.client
            .inner
            .goals
            .table()
            .get(&self.id)
            .map_or(GoalStatus::Unknown, |t| t.status)
    }

    /// The next feedback, waiting for it; `None` once the goal finished (or
    /// the server went away) and every feedback before that was taken.
    /// Feedback waits in an unbounded queue until taken.
    pub fn recv_feedback(&self) -> Option<A::Feedback> {
        self.feedback.recv().ok()
    }

    /// The next feedback, waiting at most `timeout`; `Ok(None)` on timeout,
    /// `Err` once the goal finished and every feedback was taken.
    pub fn recv_feedback_timeout(
        &self,
        timeout: Duration,
    ) -> Result<Option<A::Feedback>, FeedbackEnded> {
        match self.feedback.recv_timeout(timeout) {
            Ok(feedback) => Ok(Some(feedback)),
            Err(flume::RecvTimeoutError::Timeout) => Ok(None),
            Err(flume::RecvTimeoutError::Disconnected) => Err(FeedbackEnded),
        }
    }

    /// The next feedback if one waits.
    pub fn try_recv_feedback(&self) -> Option<A::Feedback> {
        self.feedback.try_recv().ok()
    }

    /// The next feedback, asynchronously; `None` once the goal finished and
    /// every feedback was taken. Cancellation-safe.
    pub async fn recv_feedback_async(&self) -> Option<A::Feedback> {
        self.feedback.recv_async().await.ok()
    }

    /// The goal's result; resolve with `.wait()` or `.await`. The call stays
    /// open as long as the goal runs (rmw_zenoh_cpp's get_result has no
    /// timeout), and fails at once if the server goes away.
    pub fn result(&self) -> ResultBuilder<'_, A> {
        ResultBuilder {
            handle: self,
            timeout: NO_TIMEOUT,
        }
    }

    /// Ask the server to cancel this goal; resolve with `.wait()` or
    /// `.await`.
    pub fn cancel(&self) -> CancelBuilder<'_, A> {
        CancelBuilder {
            client: &self.client,
            id: self.id,
            cut_off: Stamp::default(),
        }
    }
}

/// The goal finished (or its server went away) and its feedback queue is
/// empty.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FeedbackEnded;

impl fmt::Display for FeedbackEnded {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("the goal's feedback ended: it finished or its server went away")
    }
}

impl std::error::Error for FeedbackEnded {}

/// A pending `get_result`; resolve with `.wait()` or `.await`.
#[must_use = "resolve the result request with .wait() or .await"]
pub struct ResultBuilder<'h, A: RosAction> {
    handle: &'h ClientGoalHandle<A>,
    timeout: Duration,
}

impl<A: RosAction> ResultBuilder<'_, A> {
    /// Give up after `timeout` ([`CallError::Timeout`](crate::ros::service::CallError::Timeout)).
    pub fn timeout(mut self, timeout: Duration) -> Self {
        self.timeout = timeout.min(NO_TIMEOUT);
        self
    }

    fn finish(
        handle: &ClientGoalHandle<A>,
        response: Result<
            shm_cdr::interface::ResponseOf<A::GetResult>,
            crate::ros::service::CallError,
        >,
    ) -> Result<GoalResult<A::Result>, ActionError> {
        let response = match response {
            Ok(response) => response,
            Err(error) => {
                if matches!(error, crate::ros::service::CallError::NoReply) {
                    // The server went away with the goal: nobody knows it now.
                    handle
                        .client
                        .inner
                        .goals
                        .finished(&handle.id, GoalStatus::Unknown);
                }
                return Err(error.into());
            }
        };
        let (status, result) = A::get_result_response_parts(response);
        let status = GoalStatus::from_code(status);
        handle.client.inner.goals.finished(&handle.id, status);
        Ok(GoalResult { status, result })
    }
}

impl<A: RosAction> Resolvable for ResultBuilder<'_, A> {
    type To = Result<GoalResult<A::Result>, ActionError>;
}

impl<A: RosAction> Wait for ResultBuilder<'_, A> {
    fn wait(self) -> Self::To {
        let request = A::get_result_request(self.handle.id);
        let inner = &self.handle.client.inner;
        let response = inner.get_result.call(&request).timeout(self.timeout).wait();
        Self::finish(self.handle, response)
    }
}

impl<'h, A: RosAction> IntoFuture for ResultBuilder<'h, A> {
    type Output = Result<GoalResult<A::Result>, ActionError>;
    type IntoFuture = Pin<Box<dyn Future<Output = Self::Output> + Send + 'h>>;

    fn into_future(self) -> Self::IntoFuture {
        let handle = self.handle;
        let timeout = self.timeout;
        Box::pin(async move {
            let request = A::get_result_request(handle.id);
            let call = handle
                .client
                .inner
                .get_result
                .call(&request)
                .timeout(timeout)
                .into_future();
            Self::finish(handle, call.await)
        })
    }
}
