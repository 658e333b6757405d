//! [`RosAction`]: an action type's goal, result, feedback and the services and
//! message built from them.

use crate::describe::{
    Field, FieldType, FullDescription, TypeDescription, TypeRegistry, TypeSource,
};
use crate::interface::RosService;
use crate::{DecodeOwned, RosMessage, RosType};

/// A goal's id: the 16 bytes of its `unique_identifier_msgs/UUID`.
pub type GoalId = [u8; 16];

/// A `builtin_interfaces/Time` as the action protocol carries it: when a goal
/// was accepted, or the cut-off of a cancel request.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Stamp {
    /// Seconds since the epoch.
    pub sec: i32,
    /// Nanoseconds within the second (below 1e9).
    pub nanosec: u32,
}

impl Stamp {
    /// The stamp of `nanoseconds` since the epoch (saturating at `i32::MAX`
    /// seconds, as rcl's conversion does not go beyond 2038 either).
    pub fn from_nanos(nanoseconds: i64) -> Self {
        let sec = nanoseconds.div_euclid(1_000_000_000);
        Self {
            sec: sec.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32,
            nanosec: nanoseconds.rem_euclid(1_000_000_000) as u32,
        }
    }

    /// Nanoseconds since the epoch, as rcl_action compares stamps.
    pub fn as_nanos(self) -> i64 {
        i64::from(self.sec) * 1_000_000_000 + i64::from(self.nanosec)
    }
}

/// `S::Request` of a service type `S`.
pub type RequestOf<S> = <S as RosService>::Request;

/// `S::Response` of a service type `S`.
pub type ResponseOf<S> = <S as RosService>::Response;

/// A ROS 2 action type, e.g. `example_interfaces/action/Fibonacci`.
///
/// Implementations are generated from `.action` files (shm-codegen). The wire
/// protocol uses [`SendGoal`](Self::SendGoal) and [`GetResult`](Self::GetResult)
/// as services and [`FeedbackMessage`](Self::FeedbackMessage) on the feedback
/// topic; the functions below build and take apart those messages, so an
/// action client or server is generic over the action. A hand-written
/// implementation must keep rosidl's field order (`goal_id` first, then the
/// goal; `accepted`, `stamp`; `status`, `result`; `goal_id`, `feedback`) or the
/// type hash and the wire bytes will not match real ROS 2.
pub trait RosAction: 'static {
    // Messages cross threads: Zenoh's callbacks, the application's workers.
    /// `pkg/action/Name`.
    const TYPE_NAME: &'static str;

    /// `pkg::action::dds_::Name_`.
    const DDS_TYPE_NAME: &'static str;

    /// The goal (`Name_Goal`).
    type Goal: RosMessage + DecodeOwned + Send + Sync;

    /// The result (`Name_Result`). `Default` is what `get_result` answers for
    /// a goal the server does not know (status `UNKNOWN`), and `Clone` lets a
    /// server answer every client that asks for the same goal's result.
    type Result: RosMessage + DecodeOwned + Default + Clone + Send + Sync;

    /// The feedback (`Name_Feedback`).
    type Feedback: RosMessage + DecodeOwned + Send + Sync;

    /// `Name_SendGoal`: request `{goal_id, goal}`, response `{accepted, stamp}`.
    type SendGoal: RosService;

    /// `Name_GetResult`: request `{goal_id}`, response `{status, result}`.
    type GetResult: RosService;

    /// `Name_FeedbackMessage`: `{goal_id, feedback}`.
    type FeedbackMessage: RosMessage + DecodeOwned + Send + Sync;

    /// `SendGoal`'s request: `{goal_id, goal}`.
    fn send_goal_request(goal_id: GoalId, goal: Self::Goal) -> RequestOf<Self::SendGoal>;

    /// The goal id and goal of a `SendGoal` request.
    fn send_goal_request_parts(request: RequestOf<Self::SendGoal>) -> (GoalId, Self::Goal);

    /// `SendGoal`'s response: `{accepted, stamp}`.
    fn send_goal_response(accepted: bool, stamp: Stamp) -> ResponseOf<Self::SendGoal>;

    /// Whether a `SendGoal` response accepts the goal, and its stamp.
    fn send_goal_response_parts(response: &ResponseOf<Self::SendGoal>) -> (bool, Stamp);

    /// `GetResult`'s request: `{goal_id}`.
    fn get_result_request(goal_id: GoalId) -> RequestOf<Self::GetResult>;

    /// The goal id of a `GetResult` request.
    fn get_result_request_goal_id(request: &RequestOf<Self::GetResult>) -> GoalId;

    /// `GetResult`'s response: `{status, result}` (`status` is an
    /// `action_msgs/GoalStatus` code).
    fn get_result_response(status: i8, result: Self::Result) -> ResponseOf<Self::GetResult>;

    /// The status code and result of a `GetResult` response.
    fn get_result_response_parts(response: ResponseOf<Self::GetResult>) -> (i8, Self::Result);

    /// The feedback topic's message: `{goal_id, feedback}`.
    fn feedback_message(goal_id: GoalId, feedback: Self::Feedback) -> Self::FeedbackMessage;

    /// The goal id and feedback of a feedback message.
    fn feedback_message_parts(message: Self::FeedbackMessage) -> (GoalId, Self::Feedback);

    /// The `.action` file the type was generated from
    /// ([`TypeSource::NONE`] for a hand-written implementation).
    const SOURCE: TypeSource = TypeSource::NONE;

    /// The type's own description, as rosidl hashes it.
    const FIELDS: &'static [Field] = &[
        Field::new(
            "goal",
            FieldType::nested(<Self::Goal as RosMessage>::TYPE_NAME),
        ),
        Field::new(
            "result",
            FieldType::nested(<Self::Result as RosMessage>::TYPE_NAME),
        ),
        Field::new(
            "feedback",
            FieldType::nested(<Self::Feedback as RosMessage>::TYPE_NAME),
        ),
        Field::new(
            "send_goal_service",
            FieldType::nested(<Self::SendGoal as RosService>::TYPE_NAME),
        ),
        Field::new(
            "get_result_service",
            FieldType::nested(<Self::GetResult as RosService>::TYPE_NAME),
        ),
        Field::new(
            "feedback_message",
            FieldType::nested(<Self::FeedbackMessage as RosMessage>::TYPE_NAME),
        ),
    ];

    /// The REP 2011 hash of the action, equal to rosidl's (generated code caches
    /// it).
    fn type_hash() -> &'static str;

    /// Register this action's description and every type it references.
    /// The type's own description (referenced types excluded).
    fn type_description() -> TypeDescription {
        TypeDescription::new(Self::TYPE_NAME, Self::FIELDS, Self::SOURCE)
    }

    /// The action's description with every type it references, as its
    /// type-description service reply carries it.
    fn full_description() -> FullDescription
    where
        Self: Sized,
    {
        FullDescription::collect(Self::type_description(), Self::register_types)
    }

    /// Register this action's description and every type it references.
    fn register_types(registry: &mut TypeRegistry) {
        let own = Self::type_description();
        if registry.insert(own) {
            <Self::Goal as RosType>::register_types(registry);
            <Self::Result as RosType>::register_types(registry);
            <Self::Feedback as RosType>::register_types(registry);
            <Self::SendGoal as RosService>::register_types(registry);
            <Self::GetResult as RosService>::register_types(registry);
            <Self::FeedbackMessage as RosType>::register_types(registry);
        }
    }
}

/// Compute the RIHS01 hash of action `A` (what generated `type_hash` caches).
pub fn compute_action_hash<A: RosAction>() -> String {
    FullDescription::collect(A::type_description(), A::register_types).type_hash()
}
