//! The planner process: waits on vehicle-state events, replans from the latest valid state
//! at a fixed rate over the road ahead, and publishes each trajectory written in place
//! into a loaned shared-memory sample.
//!
//! Allocation: receiving, validating, sampling the road window, the domain check, shifting
//! the warm start, writing and sending the sample allocate nothing, and
//! [`planner::plan::Planner::replan`] updates the problem in place and solves without
//! allocating (`planner/tests/solve_alloc.rs`). Only logging a refused or failed state and
//! recording (`--record`, which copies the input for the writer thread) allocate.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use plan_record::{now_ns, Record, Recorder};
use planner::guess::GuessKind;
use planner::ip::Status;
use planner::model::{ix, NU, NX};
use planner::ocp::InitialState;
use planner::plan::{Planner, ReplanGuess};

use crate::clock::monotonic_ns;
use crate::msg::{status_code, Invalid, VehicleState, HORIZON_N, MSG_VERSION};
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
    /// Record every equilibrium-started plan's input and output to this MCAP file (built and
    /// queued after the plan is published, outside the timed solve; `replay run` re-solves
    /// them). Warm-started plans are counted, not recorded (a recording cannot hold the guess).
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
    let recorder =
        match &args.record {
            // Room for ~7 minutes at 10 Hz; beyond that, records are dropped and counted.
            Some(path) => Some(Recorder::create(path, 8192).map_err(|e| {
                PlannerProcError::Setup(format!("--record {}: {e}", path.display()))
            })?),
            None => None,
        };
    let mut rec_spec = sc.spec.clone();
    let mut not_recorded = 0u64;
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
    let mut planned_seq: Option<u64> = None;
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
        if planned_seq == Some(state.seq) {
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
            planned_seq = Some(state.seq);
            continue;
        }
        let shift = s_track - cy.prev_origin;
        let sound = args.warm_start == "on"
            && cy.prev_ok
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
                        planned_seq = Some(state.seq);
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
        planned_seq = Some(state.seq);
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

        // ---- record (after publishing; allocates)
        if let Some(rec) = &recorder {
            if warm_started {
                not_recorded += 1;
            } else {
                rec_spec.kappa.clear();
                rec_spec.kappa.extend_from_slice(&cy.road.kappa);
                rec_spec.e_min.clear();
                rec_spec.e_min.extend_from_slice(&cy.road.e_min);
                rec_spec.e_max.clear();
                rec_spec.e_max.extend_from_slice(&cy.road.e_max);
                rec_spec.initial = InitialState::Fixed(x0);
                let seq = published - 1;
                let input = planner::record::plan_input(
                    &rec_spec,
                    &settings,
                    GuessKind::Equilibrium,
                    seq,
                    stamp_in,
                );
                rec.record(Record::Input(Box::new(input)));
                let output = planner::record::plan_output(
                    seq,
                    now_ns(),
                    &info,
                    cy.planner.states(),
                    cy.planner.controls(),
                );
                rec.record(Record::Output(Box::new(output)));
            }
        }
    }
    eprintln!(
        "planner: stopping after {published} plans ({warm} warm, {cold} equilibrium starts, {failed} not converged), {} states dropped, {outside} outside the planner's domain",
        rejected.total()
    );
    let recording = match (recorder, &args.record) {
        (Some(rec), Some(path)) => {
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
