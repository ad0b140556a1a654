//! The `--record` part of the planner cycle: a pooled MCAP recorder with one preallocated
//! slot per queued plan.

use std::path::Path;

use plan_record::{now_ns, PlanOutput, PlanRecord, RecordError, RecordStats, Recorder};
use planner::guess::GuessKind;
use planner::ip::{Settings, SolveInfo};
use planner::model::{NU, NX};
use planner::ocp::{InitialState, OcpSpec};

use crate::msg::HORIZON_N;
use crate::road::RoadWindow;

/// The `--record` part of the planner cycle: each equilibrium-started plan is copied into a
/// preallocated slot of a pooled [`Recorder`] and queued for its writer thread, which
/// closes an MCAP chunk per plan (allocates nothing and never blocks; a plan that finds no
/// free slot or a full queue is dropped and counted).
#[derive(Debug)]
pub struct CycleRecorder {
    rec: Recorder,
    /// Warm-started plans (a recording cannot hold the guess).
    not_recorded: u64,
}

impl CycleRecorder {
    /// Preallocated plans: 12.8 s of plans at 10 Hz can wait for a slow disk.
    pub const SLOTS: usize = 128;

    /// Creates the file; every slot starts as the record of `spec` solved with `settings`
    /// from the cold guess `guess`, with room for a road of the planner's horizon.
    pub fn create(
        path: &Path,
        spec: &OcpSpec,
        settings: &Settings,
        guess: GuessKind,
    ) -> Result<Self, RecordError> {
        let mut input = planner::record::plan_input(spec, settings, guess, 0, 0);
        for v in [&mut input.kappa, &mut input.e_min, &mut input.e_max] {
            v.reserve(HORIZON_N + 1);
        }
        let template = PlanRecord {
            input,
            output: PlanOutput::with_capacity(HORIZON_N),
        };
        Ok(Self {
            rec: Recorder::create_pooled(path, &template, Self::SLOTS)?,
            not_recorded: 0,
        })
    }

    /// Records one equilibrium-started plan: the road window and start state it solved
    /// from and what it produced. False when it was dropped.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        seq: u64,
        stamp_in: u64,
        road: &RoadWindow,
        x0: [f64; NX],
        info: &SolveInfo,
        states: &[[f64; NX]],
        controls: &[[f64; NU]],
    ) -> bool {
        let Some(mut slot) = self.rec.slot() else {
            return false;
        };
        planner::record::update_input(
            &mut slot.input,
            seq,
            stamp_in,
            [&road.kappa, &road.e_min, &road.e_max],
            InitialState::Fixed(x0),
        );
        planner::record::write_output(&mut slot.output, seq, now_ns(), info, states, controls);
        self.rec.record_plan(slot)
    }

    /// Counts a warm-started plan, which is not recorded.
    pub fn skip_warm_started(&mut self) {
        self.not_recorded += 1;
    }

    /// Warm-started plans not recorded.
    pub fn not_recorded(&self) -> u64 {
        self.not_recorded
    }

    /// Drains the queue and closes the file.
    pub fn finish(self) -> Result<RecordStats, RecordError> {
        self.rec.finish()
    }
}
