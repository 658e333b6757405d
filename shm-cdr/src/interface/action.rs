//! [`RosAction`]: an action type's goal, result, feedback and the services and
//! message built from them.

use crate::describe::{Field, FieldType, TypeDescription, TypeRegistry};
use crate::interface::RosService;
use crate::{DecodeOwned, RosMessage, RosType};

/// A ROS 2 action type, e.g. `example_interfaces/action/Fibonacci`.
///
/// Implementations are generated from `.action` files (shm-codegen). The wire
/// protocol uses [`SendGoal`](Self::SendGoal) and [`GetResult`](Self::GetResult)
/// as services and [`FeedbackMessage`](Self::FeedbackMessage) on the feedback
/// topic.
pub trait RosAction: 'static {
    /// `pkg/action/Name`.
    const TYPE_NAME: &'static str;

    /// `pkg::action::dds_::Name_`.
    const DDS_TYPE_NAME: &'static str;

    /// The goal (`Name_Goal`).
    type Goal: RosMessage + DecodeOwned;

    /// The result (`Name_Result`).
    type Result: RosMessage + DecodeOwned;

    /// The feedback (`Name_Feedback`).
    type Feedback: RosMessage + DecodeOwned;

    /// `Name_SendGoal`: request `{goal_id, goal}`, response `{accepted, stamp}`.
    type SendGoal: RosService;

    /// `Name_GetResult`: request `{goal_id}`, response `{status, result}`.
    type GetResult: RosService;

    /// `Name_FeedbackMessage`: `{goal_id, feedback}`.
    type FeedbackMessage: RosMessage + DecodeOwned;

    /// The type's own description, as rosidl hashes it.
    const FIELDS: &'static [Field] = &[
        Field {
            name: "goal",
            field_type: FieldType::nested(<Self::Goal as RosMessage>::TYPE_NAME),
        },
        Field {
            name: "result",
            field_type: FieldType::nested(<Self::Result as RosMessage>::TYPE_NAME),
        },
        Field {
            name: "feedback",
            field_type: FieldType::nested(<Self::Feedback as RosMessage>::TYPE_NAME),
        },
        Field {
            name: "send_goal_service",
            field_type: FieldType::nested(<Self::SendGoal as RosService>::TYPE_NAME),
        },
        Field {
            name: "get_result_service",
            field_type: FieldType::nested(<Self::GetResult as RosService>::TYPE_NAME),
        },
        Field {
            name: "feedback_message",
            field_type: FieldType::nested(<Self::FeedbackMessage as RosMessage>::TYPE_NAME),
        },
    ];

    /// The REP 2011 hash of the action, equal to rosidl's (generated code caches
    /// it).
    fn type_hash() -> &'static str;

    /// Register this action's description and every type it references.
    fn register_types(registry: &mut TypeRegistry) {
        let own = TypeDescription {
            type_name: Self::TYPE_NAME,
            fields: Self::FIELDS,
        };
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
    super::composite_type_hash(
        TypeDescription {
            type_name: A::TYPE_NAME,
            fields: A::FIELDS,
        },
        A::register_types,
    )
}
