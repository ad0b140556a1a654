//! What the planner process keeps about the vehicle states it takes in: the states it
//! refused, by reason, and the last one it planned from.

use crate::msg::{Invalid, RunId, VehicleState};

/// Counters of dropped states, by reason.
#[derive(Debug, Clone, Copy, Default)]
pub struct Rejected {
    /// Unknown version.
    pub version: u64,
    /// Other road.
    pub road: u64,
    /// NaN or infinite values.
    pub non_finite: u64,
    /// Out of physical range.
    pub range: u64,
}

impl Rejected {
    /// Counts one refused state under its reason.
    pub(super) fn count(&mut self, e: &Invalid) {
        match e {
            Invalid::Version { .. } => self.version += 1,
            Invalid::Road { .. } => self.road += 1,
            Invalid::NonFinite { .. } | Invalid::NodeNonFinite { .. } => self.non_finite += 1,
            Invalid::Range { .. }
            | Invalid::NodeRange { .. }
            | Invalid::Status(_)
            | Invalid::Kind(_) => self.range += 1,
        }
    }

    /// Total dropped.
    pub fn total(&self) -> u64 {
        self.version + self.road + self.non_finite + self.range
    }
}

/// The state the planner last planned from (or declined to plan from), keyed by the
/// publisher's run id and the state's seq: seqs start over with every publisher run, so the
/// seq alone would take a restarted tracker's state for one already planned.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LastPlanned {
    key: Option<(RunId, u64)>,
    switches: u64,
}

impl LastPlanned {
    /// True when `state` (same run id and seq) was the last one planned from.
    pub fn is_planned(&self, state: &VehicleState) -> bool {
        self.key == Some((state.run_id, state.seq))
    }

    /// True when the last state planned from came from `state`'s publisher run.
    pub fn same_run(&self, state: &VehicleState) -> bool {
        self.key.is_some_and(|(run, _)| run == state.run_id)
    }

    /// Records `state` as planned from.
    pub fn mark(&mut self, state: &VehicleState) {
        if self.key.map(|(run, _)| run) != Some(state.run_id) {
            self.switches += 1;
        }
        self.key = Some((state.run_id, state.seq));
    }

    /// How often the planned state's run id changed (the first run counts once): 2 after a
    /// tracker restart.
    pub fn run_switches(&self) -> u64 {
        self.switches
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(run_id: RunId, seq: u64) -> VehicleState {
        VehicleState::new(7, seq, 0, [0.0, 15.0, 0.0, 15.0, 0.0, 0.0, 0.0, 3.0, 1.0])
            .with_run_id(run_id)
    }

    #[test]
    fn the_last_planned_state_is_not_planned_again() {
        let mut last = LastPlanned::default();
        assert!(!last.is_planned(&state(1, 5)));
        last.mark(&state(1, 5));
        assert!(last.is_planned(&state(1, 5)));
        assert!(!last.is_planned(&state(1, 6)));
        assert!(last.same_run(&state(1, 6)));
        assert_eq!(last.run_switches(), 1);
    }

    #[test]
    fn a_second_publisher_reusing_seq_values_gets_planned() {
        let mut last = LastPlanned::default();
        for seq in 1..=3 {
            last.mark(&state(1, seq));
        }
        // A restarted tracker (new run id) publishes seq 3 again: a new state.
        assert!(!last.is_planned(&state(2, 3)));
        assert!(!last.same_run(&state(2, 3)));
        last.mark(&state(2, 3));
        assert!(last.is_planned(&state(2, 3)));
        // Its predecessor's seq 3 is now a different state as well.
        assert!(!last.is_planned(&state(1, 3)));
        assert_eq!(last.run_switches(), 2);
    }
}
