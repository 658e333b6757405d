//! The managed-node state machine, as rcl_lifecycle's default one: its
//! states, its 25 transitions in the order rcl registers them (which is the
//! order its services list them in), and what a step from one state to the
//! next looks like.

use shm_cdr::msgs::lifecycle_msgs::msg::{
    State as StateMsg, Transition as TransitionMsg, TransitionDescription,
};

/// A state of a managed node: the four primary states (and `Unknown`), and
/// the transition states a node passes through while its callbacks run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum State {
    /// Not yet set.
    Unknown,
    /// Just created, or cleaned up: nothing allocated.
    Unconfigured,
    /// Configured, not processing.
    Inactive,
    /// Processing: its lifecycle publishers publish.
    Active,
    /// Shut down; only destruction is left.
    Finalized,
    /// `on_configure` is running.
    Configuring,
    /// `on_cleanup` is running.
    CleaningUp,
    /// `on_shutdown` is running.
    ShuttingDown,
    /// `on_activate` is running.
    Activating,
    /// `on_deactivate` is running.
    Deactivating,
    /// `on_error` is running, after a callback returned
    /// [`CallbackReturn::Error`](super::CallbackReturn::Error).
    ErrorProcessing,
}

impl State {
    /// Every state, in the order rcl registers (and lists) them.
    pub const ALL: [State; 11] = [
        State::Unknown,
        State::Unconfigured,
        State::Inactive,
        State::Active,
        State::Finalized,
        State::Configuring,
        State::CleaningUp,
        State::ShuttingDown,
        State::Activating,
        State::Deactivating,
        State::ErrorProcessing,
    ];

    /// The id in `lifecycle_msgs/msg/State`.
    pub const fn id(self) -> u8 {
        match self {
            State::Unknown => StateMsg::PRIMARY_STATE_UNKNOWN,
            State::Unconfigured => StateMsg::PRIMARY_STATE_UNCONFIGURED,
            State::Inactive => StateMsg::PRIMARY_STATE_INACTIVE,
            State::Active => StateMsg::PRIMARY_STATE_ACTIVE,
            State::Finalized => StateMsg::PRIMARY_STATE_FINALIZED,
            State::Configuring => StateMsg::TRANSITION_STATE_CONFIGURING,
            State::CleaningUp => StateMsg::TRANSITION_STATE_CLEANINGUP,
            State::ShuttingDown => StateMsg::TRANSITION_STATE_SHUTTINGDOWN,
            State::Activating => StateMsg::TRANSITION_STATE_ACTIVATING,
            State::Deactivating => StateMsg::TRANSITION_STATE_DEACTIVATING,
            State::ErrorProcessing => StateMsg::TRANSITION_STATE_ERRORPROCESSING,
        }
    }

    /// The label rcl gives it (`"unconfigured"`, `"cleaningup"`, …).
    pub const fn label(self) -> &'static str {
        match self {
            State::Unknown => "unknown",
            State::Unconfigured => "unconfigured",
            State::Inactive => "inactive",
            State::Active => "active",
            State::Finalized => "finalized",
            State::Configuring => "configuring",
            State::CleaningUp => "cleaningup",
            State::ShuttingDown => "shuttingdown",
            State::Activating => "activating",
            State::Deactivating => "deactivating",
            State::ErrorProcessing => "errorprocessing",
        }
    }

    /// Whether this is a primary state (one a node rests in).
    pub const fn is_primary(self) -> bool {
        self.id() < 10
    }

    /// As `lifecycle_msgs/msg/State`.
    pub fn to_msg(self) -> StateMsg {
        StateMsg {
            id: self.id(),
            label: self.label().to_owned(),
        }
    }
}

impl std::fmt::Display for State {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.label())
    }
}

/// One transition of the state machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Step {
    /// Its id in `lifecycle_msgs/msg/Transition`.
    pub(crate) id: u8,
    pub(crate) label: &'static str,
    pub(crate) start: State,
    pub(crate) goal: State,
}

impl Step {
    pub(crate) fn to_msg(self) -> TransitionDescription {
        TransitionDescription {
            transition: TransitionMsg {
                id: self.id,
                label: self.label.to_owned(),
            },
            start_state: self.start.to_msg(),
            goal_state: self.goal.to_msg(),
        }
    }
}

const SUCCESS: &str = "transition_success";
const FAILURE: &str = "transition_failure";
const ERROR: &str = "transition_error";

const fn step(id: u8, label: &'static str, start: State, goal: State) -> Step {
    Step {
        id,
        label,
        start,
        goal,
    }
}

/// Every transition, in rcl's order.
pub(crate) const STEPS: [Step; 25] = {
    use State::*;
    type T = TransitionMsg;
    [
        step(
            T::TRANSITION_CONFIGURE,
            "configure",
            Unconfigured,
            Configuring,
        ),
        step(
            T::TRANSITION_ON_CONFIGURE_SUCCESS,
            SUCCESS,
            Configuring,
            Inactive,
        ),
        step(
            T::TRANSITION_ON_CONFIGURE_FAILURE,
            FAILURE,
            Configuring,
            Unconfigured,
        ),
        step(
            T::TRANSITION_ON_CONFIGURE_ERROR,
            ERROR,
            Configuring,
            ErrorProcessing,
        ),
        step(T::TRANSITION_CLEANUP, "cleanup", Inactive, CleaningUp),
        step(
            T::TRANSITION_ON_CLEANUP_SUCCESS,
            SUCCESS,
            CleaningUp,
            Unconfigured,
        ),
        step(
            T::TRANSITION_ON_CLEANUP_FAILURE,
            FAILURE,
            CleaningUp,
            Inactive,
        ),
        step(
            T::TRANSITION_ON_CLEANUP_ERROR,
            ERROR,
            CleaningUp,
            ErrorProcessing,
        ),
        step(T::TRANSITION_ACTIVATE, "activate", Inactive, Activating),
        step(
            T::TRANSITION_ON_ACTIVATE_SUCCESS,
            SUCCESS,
            Activating,
            Active,
        ),
        step(
            T::TRANSITION_ON_ACTIVATE_FAILURE,
            FAILURE,
            Activating,
            Inactive,
        ),
        step(
            T::TRANSITION_ON_ACTIVATE_ERROR,
            ERROR,
            Activating,
            ErrorProcessing,
        ),
        step(T::TRANSITION_DEACTIVATE, "deactivate", Active, Deactivating),
        step(
            T::TRANSITION_ON_DEACTIVATE_SUCCESS,
            SUCCESS,
            Deactivating,
            Inactive,
        ),
        step(
            T::TRANSITION_ON_DEACTIVATE_FAILURE,
            FAILURE,
            Deactivating,
            Active,
        ),
        step(
            T::TRANSITION_ON_DEACTIVATE_ERROR,
            ERROR,
            Deactivating,
            ErrorProcessing,
        ),
        step(
            T::TRANSITION_UNCONFIGURED_SHUTDOWN,
            "shutdown",
            Unconfigured,
            ShuttingDown,
        ),
        step(
            T::TRANSITION_INACTIVE_SHUTDOWN,
            "shutdown",
            Inactive,
            ShuttingDown,
        ),
        step(
            T::TRANSITION_ACTIVE_SHUTDOWN,
            "shutdown",
            Active,
            ShuttingDown,
        ),
        step(
            T::TRANSITION_ON_SHUTDOWN_SUCCESS,
            SUCCESS,
            ShuttingDown,
            Finalized,
        ),
        step(
            T::TRANSITION_ON_SHUTDOWN_FAILURE,
            FAILURE,
            ShuttingDown,
            Finalized,
        ),
        step(
            T::TRANSITION_ON_SHUTDOWN_ERROR,
            ERROR,
            ShuttingDown,
            ErrorProcessing,
        ),
        step(
            T::TRANSITION_ON_ERROR_SUCCESS,
            SUCCESS,
            ErrorProcessing,
            Unconfigured,
        ),
        step(
            T::TRANSITION_ON_ERROR_FAILURE,
            FAILURE,
            ErrorProcessing,
            Finalized,
        ),
        step(
            T::TRANSITION_ON_ERROR_ERROR,
            ERROR,
            ErrorProcessing,
            Finalized,
        ),
    ]
};

/// The transitions that leave `state`, in rcl's order.
pub(crate) fn from(state: State) -> impl Iterator<Item = Step> {
    STEPS.into_iter().filter(move |s| s.start == state)
}

/// The transition with `id` that leaves `state`.
pub(crate) fn by_id(state: State, id: u8) -> Option<Step> {
    from(state).find(|s| s.id == id)
}

/// The transition labelled `label` that leaves `state` (the first, as rcl
/// looks it up).
pub(crate) fn by_label(state: State, label: &str) -> Option<Step> {
    from(state).find(|s| s.label == label)
}

/// The label that ends a transition state with a callback's result.
pub(crate) fn result_label(result: super::CallbackReturn) -> &'static str {
    match result {
        super::CallbackReturn::Success => SUCCESS,
        super::CallbackReturn::Failure => FAILURE,
        super::CallbackReturn::Error => ERROR,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lifecycle::CallbackReturn;

    #[test]
    fn every_transition_state_ends_in_one_of_three_ways() {
        for state in State::ALL.into_iter().filter(|s| !s.is_primary()) {
            for result in [
                CallbackReturn::Success,
                CallbackReturn::Failure,
                CallbackReturn::Error,
            ] {
                let step = by_label(state, result_label(result));
                assert!(step.is_some(), "{state} has no {result:?} transition");
            }
        }
    }

    #[test]
    fn primary_states_offer_what_rcl_offers() {
        let labels = |s| from(s).map(|t| t.label).collect::<Vec<_>>();
        assert_eq!(labels(State::Unconfigured), ["configure", "shutdown"]);
        assert_eq!(labels(State::Inactive), ["cleanup", "activate", "shutdown"]);
        assert_eq!(labels(State::Active), ["deactivate", "shutdown"]);
        assert!(labels(State::Finalized).is_empty());
        assert_eq!(by_label(State::Active, "shutdown").map(|s| s.id), Some(7));
        assert_eq!(
            by_id(State::Unconfigured, TransitionMsg::TRANSITION_ACTIVATE),
            None
        );
    }
}
