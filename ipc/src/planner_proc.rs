//! The planner process: waits on vehicle-state events, replans from the latest valid state
//! at a fixed rate over the road ahead, and publishes each trajectory written in place
//! into a loaned shared-memory sample. Each plan names the state it starts from by the
//! publisher's run id and the state's seq ([`LastPlanned`]), so a restarted tracker's
//! states are planned even when their seqs repeat its predecessor's.
//!
//! Allocation: receiving, validating, sampling the road window, the domain check, shifting
//! the warm start, writing and sending the sample allocate nothing, and
//! [`planner::plan::Planner::replan`] updates the problem in place and solves without
//! allocating (`planner/tests/solve_alloc.rs`). Recording (`--record`) copies each plan
//! into a preallocated slot of the recorder's pool ([`CycleRecorder`]) and allocates
//! nothing either (`ipc/tests/hot_path_alloc.rs`); only logging a refused or failed state
//! allocates.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use plan_record::{now_ns, PlanOutput, PlanRecord, RecordError, RecordStats, Recorder};
use planner::guess::GuessKind;
use planner::ip::{Settings, SolveInfo, Status};
use planner::model::{ix, NU, NX};
use planner::ocp::{InitialState, OcpSpec};
use planner::plan::{Planner, ReplanGuess};

use crate::clock::monotonic_ns;
use crate::msg::{status_code, Invalid, RunId, VehicleState, HORIZON_N, MSG_VERSION};
use crate::road::{RoadWindow, Scenario};
use crate::services::{ipc_err, wait_events, IpcError, Services};
use crate::shutdown::StdinWatch;
use crate::stats::Latency;

/// Distance over which the lane margin ramps in from the lane edge [m].
pub const MARGIN_RAMP_M: f64 = 20.0;

/// Command-line options of `planner_proc`.
#[derive(clap::Args, Debug, Clone)]
pub struct PlannerArgs {
    /// Scenario file (a closed road).
    #[arg(long, default_value = "config/scenarios/oval.toml")]
    pub scenario: PathBuf,
    /// Vehicle file.
    #[arg(long, default_value = "config/vehicles/lc500.toml")]
    pub vehicle: PathBuf,
    /// Solver settings file.
    #[arg(long, default_value = "config/solver.toml")]
    pub solver: PathBuf,
    /// iceoryx2 service-name prefix (unique per closed loop).
    #[arg(long, default_value = crate::services::DEFAULT_PREFIX)]
    pub service_prefix: String,
    /// Replanning rate [Hz].
    #[arg(long, default_value_t = 10.0)]
    pub rate_hz: f64,
    /// Wall-clock cap of one solve [s] (overrides the solver file's max_time_s).
    #[arg(long, default_value_t = 1.0)]
    pub max_solve_s: f64,
    /// Lane margin the plan keeps from each edge [m] (room for tracking error).
    #[arg(long, default_value_t = 0.5)]
    pub lane_margin_m: f64,
    /// Warm-start from the previous plan shifted in s (off by default: every plan starts
    /// from the equilibrium guess, which converges more reliably in closed loop; see
    /// docs/performance.md).
    #[arg(long, default_value = "off", value_parser = ["on", "off"])]
    pub warm_start: String,
    /// Stop when stdin reaches EOF (used by `trajopt closed-loop`).
    #[arg(long)]
    pub exit_on_stdin_eof: bool,
    /// Stop after this many seconds (0: run until stopped).
    #[arg(long, default_value_t = 0.0)]
    pub max_runtime_s: f64,
    /// Record every equilibrium-started plan's input and output to this MCAP file (copied
    /// into a preallocated slot after the plan is published, outside the timed solve; one
    /// MCAP chunk per plan, so a killed planner loses at most the plan being written;
    /// `replay run` re-solves them). Warm-started plans are counted, not recorded (a
    /// recording cannot hold the guess).
    #[arg(long)]
    pub record: Option<PathBuf>,
}

/// Why the planner process failed.
#[derive(Debug, thiserror::Error)]
pub enum PlannerProcError {
    /// Bad files or options.
    #[error("{0}")]
    Setup(String),
    /// Shared-memory communication failed.
    #[error(transparent)]
    Ipc(#[from] IpcError),
}

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
    fn count(&mut self, e: &Invalid) {
        match e {
            Invalid::Version { .. } => self.version += 1,
            Invalid::Road { .. } => self.road += 1,
            Invalid::NonFinite { .. } | Invalid::NodeNonFinite { .. } => self.non_finite += 1,
            Invalid::Range { .. } | Invalid::NodeRange { .. } | Invalid::Status(_) => {
                self.range += 1
            }
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
    /// from the equilibrium guess, with room for a road of the planner's horizon.
    pub fn create(path: &Path, spec: &OcpSpec, settings: &Settings) -> Result<Self, RecordError> {
        let mut input = planner::record::plan_input(spec, settings, GuessKind::Equilibrium, 0, 0);
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

/// What one planning cycle needs, allocated once.
struct Cycle {
    planner: Planner<HORIZON_N>,
    road: RoadWindow,
    guess_x: Vec<[f64; NX]>,
    guess_u: Vec<[f64; NU]>,
    /// Previous plan: origin s and whether it is usable for a warm start.
    prev_origin: f64,
    prev_ok: bool,
}

/// Linear interpolation of the states of `xs` (grid ds) at local s, clamped to the horizon.
fn interp(xs: &[[f64; NX]], ds: f64, s: f64) -> [f64; NX] {
    let q = (s / ds).clamp(0.0, HORIZON_N as f64);
    let k = (q.floor() as usize).min(HORIZON_N - 1);
    let w = q - k as f64;
    let mut x = [0.0; NX];
    for i in 0..NX {
        x[i] = xs[k][i] + w * (xs[k + 1][i] - xs[k][i]);
    }
    x
}

impl Cycle {
    /// Builds the guess from the previous solution shifted by `shift` metres (allocates nothing).
    fn shifted_guess(&mut self, shift: f64, x0: &[f64; NX], ds: f64) {
        let xs = self.planner.states();
        let us = self.planner.controls();
        let t_shift = interp(xs, ds, shift)[ix::T];
        for k in 0..=HORIZON_N {
            let s = k as f64 * ds;
            let mut x = interp(xs, ds, s + shift);
            x[ix::S] = s;
            x[ix::T] = if s + shift <= HORIZON_N as f64 * ds {
                x[ix::T] - t_shift
            } else {
                // Beyond the old horizon: extend at the last node's pace.
                let last = &xs[HORIZON_N];
                last[ix::T] - t_shift + (s + shift - HORIZON_N as f64 * ds) / last[ix::V].max(1.0)
            };
            self.guess_x[k] = x;
        }
        self.guess_x[0] = *x0;
        for k in 0..HORIZON_N {
            let j = (((k as f64 * ds + shift) / ds).floor() as usize).min(HORIZON_N - 1);
            self.guess_u[k] = us[j];
        }
    }
}

/// `x` moved at least 1 mm (or m/s) inside [lo, hi]; the midpoint when the interval is
/// narrower than that (never panics, unlike `clamp` on crossed bounds).
fn nudge_into(x: f64, lo: f64, hi: f64) -> f64 {
    const IN: f64 = 1e-3;
    if hi - lo > 2.0 * IN {
        x.max(lo + IN).min(hi - IN)
    } else {
        0.5 * (lo + hi)
    }
}

/// Runs the planner process until stopped; returns its summary as JSON.
pub fn run(args: &PlannerArgs) -> Result<serde_json::Value, PlannerProcError> {
    if !(args.rate_hz > 0.0 && args.rate_hz <= 1000.0) {
        return Err(PlannerProcError::Setup(
            "--rate-hz must be in (0, 1000]".into(),
        ));
    }
    if !(args.max_solve_s > 0.0 && args.lane_margin_m >= 0.0) {
        return Err(PlannerProcError::Setup(
            "--max-solve-s must be > 0 and --lane-margin-m >= 0".into(),
        ));
    }
    let sc = Scenario::load(&args.scenario, &args.vehicle, &args.solver)
        .map_err(|e| PlannerProcError::Setup(e.to_string()))?;
    if 2.0 * args.lane_margin_m >= sc.road.e_max() - sc.road.e_min() {
        return Err(PlannerProcError::Setup(
            "--lane-margin-m leaves no lane".into(),
        ));
    }
    let mut settings = sc.settings;
    settings.max_time_s = args.max_solve_s;
    let ds = sc.ds();
    let (v_min, v_max) = (sc.spec.v_min, sc.spec.v_max);
    let mut recorder = match &args.record {
        Some(path) => Some(
            CycleRecorder::create(path, &sc.spec, &settings).map_err(|e| {
                PlannerProcError::Setup(format!("--record {}: {e}", path.display()))
            })?,
        ),
        None => None,
    };
    let planner = Planner::<HORIZON_N>::new(sc.spec.clone(), settings)
        .map_err(|e| PlannerProcError::Setup(e.to_string()))?;
    let mut cy = Cycle {
        planner,
        road: RoadWindow::default(),
        guess_x: vec![[0.0; NX]; HORIZON_N + 1],
        guess_u: vec![[0.0; NU]; HORIZON_N],
        prev_origin: 0.0,
        prev_ok: false,
    };

    let svc = Services::open(&args.service_prefix, "planner")?;
    let sub = svc.state_subscriber()?;
    let listener = svc.state_listener()?;
    let publisher = svc.traj_publisher()?;
    let notifier = svc.traj_notifier()?;
    let stdin = if args.exit_on_stdin_eof {
        StdinWatch::start()
    } else {
        StdinWatch::disabled()
    };

    let period = Duration::from_secs_f64(1.0 / args.rate_hz);
    let started = Instant::now();
    let mut next_tick = started;
    let mut latest: Option<VehicleState> = None;
    let mut planned = LastPlanned::default();
    let mut rejected = Rejected::default();
    // Valid states outside the planner's domain (see `InitialDomain`), not planned.
    let mut outside = 0u64;
    let mut states_received = 0u64;
    let mut published = 0u64;
    let (mut warm, mut cold, mut failed) = (0u64, 0u64, 0u64);
    let mut cycle_lat = Latency::new();
    let mut state_ipc_lat = Latency::new();
    let margin = args.lane_margin_m;

    eprintln!(
        "planner: up (prefix {}, road {:#018x}, {:.1} Hz, ds {ds} m)",
        args.service_prefix, sc.id, args.rate_hz
    );
    loop {
        if stdin.closed() || svc.termination_requested() {
            break;
        }
        if args.max_runtime_s > 0.0 && started.elapsed().as_secs_f64() > args.max_runtime_s {
            break;
        }
        let now = Instant::now();
        let wait = next_tick
            .saturating_duration_since(now)
            .clamp(Duration::from_millis(1), Duration::from_millis(100));
        if let Err(e) = wait_events(&listener, wait) {
            if svc.termination_requested() {
                break;
            }
            return Err(e.into());
        }
        while let Some(sample) = sub.receive().map_err(ipc_err("receive vehicle state"))? {
            let m: &VehicleState = sample.payload();
            states_received += 1;
            match m.validate(sc.id) {
                Ok(()) => {
                    state_ipc_lat.record_ns(monotonic_ns().saturating_sub(m.stamp_ns));
                    latest = Some(*m);
                }
                Err(e) => {
                    rejected.count(&e);
                    let n = rejected.total();
                    if n <= 10 || n % 1000 == 0 {
                        eprintln!(
                            "planner: dropped vehicle state seq {} ({n} dropped so far): {e}",
                            m.seq
                        );
                    }
                }
            }
        }
        if Instant::now() < next_tick {
            continue;
        }
        let Some(state) = latest else { continue };
        if planned.is_planned(&state) {
            continue;
        }
        next_tick = (next_tick + period).max(Instant::now());

        // ---- planning cycle
        let stamp_in = now_ns();
        let t0 = Instant::now();
        let s_track = state.x[ix::S];
        sc.road
            .window(s_track, ds, margin, MARGIN_RAMP_M, &mut cy.road);
        // Plan from the measured state, re-referenced to s = t = 0, nudged into the bounds
        // the OCP enforces so a slightly-out state stays plannable.
        let mut x0 = state.x;
        x0[ix::S] = 0.0;
        x0[ix::T] = 0.0;
        x0[ix::V] = nudge_into(x0[ix::V], v_min, v_max);
        x0[ix::E] = nudge_into(x0[ix::E], cy.road.e_min[0], cy.road.e_max[0]);
        let vehicle = &sc.spec.vehicle;
        x0[ix::VWR] = x0[ix::VWR].max(vehicle.v_wr_min + 1e-3);
        let w = vehicle.m * vehicle.g;
        x0[ix::DFZ] = nudge_into(x0[ix::DFZ], -w, w);
        // What no nudge can fix (heading across the road, yaw rate past the envelope) is
        // not planned: the solver would only spend its caps on it.
        if let Err(e) = cy
            .planner
            .spec()
            .initial_domain(&cy.road.kappa, &cy.road.e_min, &cy.road.e_max)
            .check(&x0)
        {
            outside += 1;
            if outside <= 10 || outside.is_multiple_of(1000) {
                eprintln!(
                    "planner: not planning from vehicle state seq {} ({outside} so far): {e}",
                    state.seq
                );
            }
            cy.prev_ok = false;
            planned.mark(&state);
            continue;
        }
        let shift = s_track - cy.prev_origin;
        // A warm start shifts the previous plan, which belongs to the same publisher run only.
        let sound = args.warm_start == "on"
            && cy.prev_ok
            && planned.same_run(&state)
            && shift >= 0.0
            && shift < 0.5 * HORIZON_N as f64 * ds;
        let mut info = None;
        if sound {
            cy.shifted_guess(shift, &x0, ds);
            let r = cy.planner.replan(
                &cy.road.kappa,
                &cy.road.e_min,
                &cy.road.e_max,
                x0,
                ReplanGuess::Warm(&cy.guess_x, &cy.guess_u),
            );
            match r {
                Ok(i) if i.status.is_success() => {
                    warm += 1;
                    info = Some((i, true));
                }
                Ok(_) => {}
                Err(e) => eprintln!("planner: warm replan failed: {e}"),
            }
        }
        let (info, warm_started) = match info {
            Some(v) => v,
            None => {
                cold += 1;
                match cy.planner.replan(
                    &cy.road.kappa,
                    &cy.road.e_min,
                    &cy.road.e_max,
                    x0,
                    ReplanGuess::Equilibrium,
                ) {
                    Ok(i) => (i, false),
                    Err(e) => {
                        eprintln!("planner: replan failed: {e}");
                        failed += 1;
                        cy.prev_ok = false;
                        planned.mark(&state);
                        continue;
                    }
                }
            }
        };
        if !info.status.is_success() {
            failed += 1;
            if failed <= 10 || failed % 100 == 0 {
                eprintln!(
                    "planner: plan {} ended {} after {} iterations; publishing the best iterate",
                    published,
                    info.status.name(),
                    info.iterations
                );
            }
        }
        cy.prev_ok = matches!(info.status, Status::Optimal | Status::Acceptable);
        cy.prev_origin = s_track;
        planned.mark(&state);
        let solve_time = t0.elapsed().as_secs_f64();

        // ---- write the plan in place into a loaned sample
        let mut sample = publisher
            .loan_uninit()
            .map_err(ipc_err("loan trajectory"))?;
        let p = sample.payload_mut().as_mut_ptr();
        let xs = cy.planner.states();
        let us = cy.planner.controls();
        // SAFETY: `p` points to a properly aligned, writable `Trajectory` in the loaned
        // shared-memory chunk; every field is written exactly once below (all are plain
        // `Copy` data), so the sample is fully initialised before `assume_init`.
        let sample = unsafe {
            use core::ptr::addr_of_mut;
            addr_of_mut!((*p).version).write(MSG_VERSION);
            addr_of_mut!((*p).status).write(status_code(info.status));
            addr_of_mut!((*p).seq).write(published);
            addr_of_mut!((*p).road_id).write(sc.id);
            addr_of_mut!((*p).from_run_id).write(state.run_id);
            addr_of_mut!((*p).from_state_seq).write(state.seq);
            addr_of_mut!((*p).from_state_stamp_ns).write(state.stamp_ns);
            addr_of_mut!((*p).iterations).write(info.iterations.min(u32::MAX as usize) as u32);
            addr_of_mut!((*p).warm_started).write(u32::from(warm_started));
            addr_of_mut!((*p).solve_time_s).write(solve_time);
            addr_of_mut!((*p).s_origin).write(s_track);
            addr_of_mut!((*p).t_origin).write(state.x[ix::T]);
            addr_of_mut!((*p).ds).write(ds);
            addr_of_mut!((*p).x_from).write(state.x);
            let px = addr_of_mut!((*p).x) as *mut [f64; NX];
            for k in 0..=HORIZON_N {
                px.add(k).write(xs[k]);
            }
            let pu = addr_of_mut!((*p).u) as *mut [f64; NU];
            for k in 0..HORIZON_N {
                pu.add(k).write(us[k]);
            }
            addr_of_mut!((*p).stamp_ns).write(monotonic_ns());
            sample.assume_init()
        };
        sample.send().map_err(ipc_err("send trajectory"))?;
        notifier.notify().map_err(ipc_err("notify trajectory"))?;
        published += 1;
        cycle_lat.record_ns(t0.elapsed().as_nanos() as u64);

        // ---- record (after publishing; copies into a preallocated slot)
        if let Some(rec) = &mut recorder {
            if warm_started {
                rec.skip_warm_started();
            } else {
                let xs = cy.planner.states();
                let us = cy.planner.controls();
                rec.record(published - 1, stamp_in, &cy.road, x0, &info, xs, us);
            }
        }
    }
    eprintln!(
        "planner: stopping after {published} plans ({warm} warm, {cold} equilibrium starts, {failed} not converged), {} states dropped, {outside} outside the planner's domain",
        rejected.total()
    );
    let recording = match (recorder, &args.record) {
        (Some(rec), Some(path)) => {
            let not_recorded = rec.not_recorded();
            let stats = rec.finish().map_err(|e| {
                PlannerProcError::Setup(format!("--record {}: {e}", path.display()))
            })?;
            serde_json::json!({
                "file": path.display().to_string(),
                "inputs": stats.inputs,
                "outputs": stats.outputs,
                "dropped": stats.dropped,
                "warm_started_not_recorded": not_recorded,
            })
        }
        _ => serde_json::Value::Null,
    };
    let ms = |l: &Latency, q: f64| l.quantile_ns(q) as f64 * 1e-6;
    Ok(serde_json::json!({
        "process": "planner",
        "plans_published": published,
        "warm_starts": warm,
        "equilibrium_starts": cold,
        "not_converged": failed,
        "states_received": states_received,
        "states_rejected": rejected.total(),
        "states_outside_domain": outside,
        "state_run_switches": planned.run_switches(),
        "states_rejected_by_reason": {
            "version": rejected.version,
            "road": rejected.road,
            "non_finite": rejected.non_finite,
            "range": rejected.range,
        },
        "cycle_ms_p50": ms(&cycle_lat, 0.5),
        "cycle_ms_p99": ms(&cycle_lat, 0.99),
        "cycle_ms_max": cycle_lat.max_ns() as f64 * 1e-6,
        "state_age_at_receive_us": state_ipc_lat.json_us(),
        "rate_hz": args.rate_hz,
        "recording": recording,
    }))
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
