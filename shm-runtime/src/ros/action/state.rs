//! rcl_action's goal state machine (`goal_state_machine.c`, Kilted 10.1.x).

/// A goal's status, with `action_msgs/msg/GoalStatus`'s codes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(i8)]
pub enum GoalStatus {
    /// `STATUS_UNKNOWN` (0): the server does not know the goal (never accepted,
    /// or its result expired).
    Unknown = 0,
    /// `STATUS_ACCEPTED` (1): accepted, not yet executing.
    Accepted = 1,
    /// `STATUS_EXECUTING` (2).
    Executing = 2,
    /// `STATUS_CANCELING` (3): a cancel was accepted; the server is winding it
    /// down.
    Canceling = 3,
    /// `STATUS_SUCCEEDED` (4), terminal.
    Succeeded = 4,
    /// `STATUS_CANCELED` (5), terminal.
    Canceled = 5,
    /// `STATUS_ABORTED` (6), terminal.
    Aborted = 6,
}

impl GoalStatus {
    /// The status of wire code `code`; codes outside 0..=6 are `Unknown`.
    pub fn from_code(code: i8) -> Self {
        match code {
            1 => Self::Accepted,
            2 => Self::Executing,
            3 => Self::Canceling,
            4 => Self::Succeeded,
            5 => Self::Canceled,
            6 => Self::Aborted,
            _ => Self::Unknown,
        }
    }

    /// The wire code.
    pub fn code(self) -> i8 {
        self as i8
    }

    /// Succeeded, canceled or aborted: the goal has its result.
    pub fn is_terminal(self) -> bool {
        matches!(self, Self::Succeeded | Self::Canceled | Self::Aborted)
    }

    /// Accepted or executing: a cancel request may move it to canceling
    /// (`rcl_action_goal_handle_is_cancelable`).
    pub fn is_cancelable(self) -> bool {
        matches!(self, Self::Accepted | Self::Executing)
    }
}

/// What happens to a goal (rcl_action's `rcl_action_goal_event_t`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum GoalEvent {
    /// Start executing an accepted goal.
    Execute,
    /// A cancel request for the goal was accepted.
    CancelGoal,
    /// The goal finished successfully.
    Succeed,
    /// The goal failed.
    Abort,
    /// The goal stopped because it was asked to.
    Canceled,
}

impl GoalEvent {
    /// Every event, in rcl_action's order.
    pub const ALL: [Self; 5] = [
        Self::Execute,
        Self::CancelGoal,
        Self::Succeed,
        Self::Abort,
        Self::Canceled,
    ];
}

/// The state `event` moves a goal in state `from` to, or `None` where
/// rcl_action's transition map has no entry (the event is refused):
///
/// | from | execute | cancel_goal | succeed | abort | canceled |
/// |---|---|---|---|---|---|
/// | accepted | executing | canceling | | | |
/// | executing | | canceling | succeeded | aborted | |
/// | canceling | | | succeeded | aborted | canceled |
///
/// Terminal and unknown states take no event.
pub fn transition(from: GoalStatus, event: GoalEvent) -> Option<GoalStatus> {
    use GoalEvent as E;
    use GoalStatus as S;
    Some(match (from, event) {
        (S::Accepted, E::Execute) => S::Executing,
        (S::Accepted | S::Executing, E::CancelGoal) => S::Canceling,
        (S::Executing | S::Canceling, E::Succeed) => S::Succeeded,
        (S::Executing | S::Canceling, E::Abort) => S::Aborted,
        (S::Canceling, E::Canceled) => S::Canceled,
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_trip_and_out_of_range_is_unknown() {
        for code in 0..=6 {
            assert_eq!(GoalStatus::from_code(code).code(), code);
        }
        assert_eq!(GoalStatus::from_code(7), GoalStatus::Unknown);
        assert_eq!(GoalStatus::from_code(-1), GoalStatus::Unknown);
    }

    #[test]
    fn terminal_states_take_no_event() {
        for from in [
            GoalStatus::Unknown,
            GoalStatus::Succeeded,
            GoalStatus::Canceled,
            GoalStatus::Aborted,
        ] {
            for event in GoalEvent::ALL {
                assert_eq!(transition(from, event), None, "{from:?} {event:?}");
            }
        }
    }

    #[test]
    fn every_path_from_accepted_ends_terminal() {
        // Walk every sequence of events: each reachable state either takes an
        // event or is terminal, and nothing leads back to accepted.
        let mut frontier = vec![GoalStatus::Accepted];
        let mut seen = std::collections::HashSet::new();
        while let Some(state) = frontier.pop() {
            if !seen.insert(state) {
                continue;
            }
            let next: Vec<_> = GoalEvent::ALL
                .iter()
                .filter_map(|&e| transition(state, e))
                .collect();
            assert_eq!(next.is_empty(), state.is_terminal(), "{state:?}");
            assert!(!next.contains(&GoalStatus::Accepted));
            frontier.extend(next);
        }
        assert_eq!(seen.len(), 6, "every state but unknown is reachable");
    }
}
