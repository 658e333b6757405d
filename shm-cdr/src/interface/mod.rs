//! Services and actions: the type identities rosidl gives them, beside the
//! message types ([`RosMessage`](crate::RosMessage)) they are made of.
//!
//! A service `pkg/srv/Name` is three messages (`Name_Request`, `Name_Response`,
//! `Name_Event`); an action `pkg/action/Name` is its goal, result and feedback plus
//! two services (`Name_SendGoal`, `Name_GetResult`) and `Name_FeedbackMessage`.
//! Their RIHS01 hashes cover all of these, as rosidl's do. Implementations are
//! generated from `.srv`/`.action` files by shm-codegen.

mod action;
mod service;

pub use action::{compute_action_hash, GoalId, RequestOf, ResponseOf, RosAction, Stamp};
pub use service::{compute_service_hash, RosService};
