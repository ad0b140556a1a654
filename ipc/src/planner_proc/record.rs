//! The `--record` part of the planner cycle: a pooled MCAP recorder with one preallocated
//! slot per queued plan.

use std::path::Path;

use plan_record::{
    config_hash, now_ns, PlanOutput, PlanRecord, PlanWarmStart, RecordError, RecordStats, Recorder,
    VEHICLE_LEN, WARM_GUESS,
};
use planner::guess::GuessKind;
use planner::ip::{Settings, SolveInfo};
use planner::model::{NU, NX};
use planner::ocp::{InitialState, OcpSpec};
use planner::plan::{WarmDuals, WarmOptions};
use planner::record::{settings_to_array, vehicle_to_array};

use crate::msg::HORIZON_N;
use crate::road::RoadWindow;

/// Where a warm-started plan started: the shift, the options, the shifted primal guess and
/// the shifted multipliers ([`planner::plan::Planner::warm_duals`]).
#[derive(Debug, Clone, Copy)]
pub struct WarmRecord<'a> {
    /// How far the window moved since the previous plan \[m\].
    pub shift: f64,
    /// The options of the warm replan.
    pub opts: WarmOptions,
    /// The primal guess: N + 1 states, N controls.
    pub guess: (&'a [[f64; NX]], &'a [[f64; NU]]),
    /// The multipliers it started from.
    pub duals: WarmDuals<'a>,
}

/// The `--record` part of the planner cycle: each plan is copied into a preallocated slot
/// of a pooled [`Recorder`] and queued for its writer thread, which closes an MCAP chunk
/// per plan (allocates nothing and never blocks; a plan that finds no free slot or a full
/// queue is dropped and counted). A warm-started plan is recorded with where it started
/// (guess `warm` and a warm-start message), so it replays bit for bit on its own.
#[derive(Debug)]
pub struct CycleRecorder {
    rec: Recorder,
    /// The guess name of a cold plan.
    cold: GuessKind,
    /// The vehicle as recorded and the configuration hash of the nominal problem and of
    /// the relaxed one (they differ in the saturation bound only).
    vehicles: [([f64; VEHICLE_LEN], u64); 2],
}

impl CycleRecorder {
    /// Preallocated plans: 12.8 s of plans at 10 Hz can wait for a slow disk.
    pub const SLOTS: usize = 128;

    /// Creates the file; every slot starts as the record of `spec` solved with `settings`
    /// from the cold guess `guess`, with room for a road of the planner's horizon and for
    /// the warm start of a planner with `(n, m)` variables and rows. A relaxed plan is
    /// recorded with the vehicle of `relaxed` (default: `spec`'s).
    pub fn create(
        path: &Path,
        (spec, relaxed): (&OcpSpec, Option<&OcpSpec>),
        settings: &Settings,
        guess: GuessKind,
        (n, m): (usize, usize),
    ) -> Result<Self, RecordError> {
        let settings_arr = settings_to_array(settings);
        let recorded = |sp: &OcpSpec| {
            let v = vehicle_to_array(&sp.vehicle);
            (v, config_hash(&v, &settings_arr))
        };
        let vehicles = [recorded(spec), recorded(relaxed.unwrap_or(spec))];
        let mut input = planner::record::plan_input(spec, settings, guess, 0, 0);
        let road = [
            &mut input.kappa,
            &mut input.e_min,
            &mut input.e_max,
            &mut input.soft_e_min,
            &mut input.soft_e_max,
        ];
        for v in road {
            v.reserve(HORIZON_N + 1);
        }
        input.guess.reserve(WARM_GUESS.len());
        let template = PlanRecord {
            input,
            output: PlanOutput::with_capacity(HORIZON_N),
            warm: PlanWarmStart::with_capacity(HORIZON_N, n, m),
        };
        Ok(Self {
            rec: Recorder::create_pooled(path, &template, Self::SLOTS)?,
            cold: guess,
            vehicles,
        })
    }

    /// Records one plan: the road window and start state it solved from, whether it solved
    /// the relaxed problem (and where a warm-started solve started) and what it produced.
    /// False when it was dropped.
    pub fn record(
        &self,
        (seq, stamp_in): (u64, u64),
        (road, relaxed): (&RoadWindow, bool),
        x0: [f64; NX],
        info: &SolveInfo,
        (states, controls): (&[[f64; NX]], &[[f64; NU]]),
        warm: Option<WarmRecord<'_>>,
    ) -> bool {
        let Some(mut slot) = self.rec.slot() else {
            return false;
        };
        planner::record::update_input(
            &mut slot.input,
            seq,
            stamp_in,
            (road.slices(), road.v_end_max),
            InitialState::Fixed(x0),
        );
        (slot.input.vehicle, slot.input.config_hash) = self.vehicles[usize::from(relaxed)];
        slot.input.guess.clear();
        match warm {
            Some(w) => {
                slot.input.guess.push_str(WARM_GUESS);
                planner::record::write_warm(
                    &mut slot.warm,
                    (seq, stamp_in, w.shift),
                    &w.opts,
                    w.guess,
                    w.duals,
                );
            }
            None => slot.input.guess.push_str(self.cold.name()),
        }
        planner::record::write_output(&mut slot.output, seq, now_ns(), info, states, controls);
        self.rec.record_plan(slot)
    }

    /// Drains the queue and closes the file.
    pub fn finish(self) -> Result<RecordStats, RecordError> {
        self.rec.finish()
    }
}
