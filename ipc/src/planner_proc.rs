//! The planner process: waits on vehicle-state events, replans from the latest valid state
//! at a fixed rate over the road ahead, and publishes each trajectory written in place
//! into a loaned shared-memory sample. Each plan names the state it starts from by the
//! publisher's run id and the state's seq ([`LastPlanned`]), so a restarted tracker's
//! states are planned even when their seqs repeat its predecessor's. With `--lockstep` it
//! plans from each state the tracker flags, under iteration caps (`crate::lockstep`).
//!
//! Allocation: receiving, validating, sampling the road window, the domain check, shifting
//! the warm start, writing and sending the sample allocate nothing, and
//! [`planner::plan::Planner::replan`] updates the problem in place and solves without
//! allocating (`planner/tests/solve_alloc.rs`). Recording (`--record`) copies each plan
//! into a preallocated slot of the recorder's pool ([`CycleRecorder`]) and allocates
//! nothing either (`ipc/tests/hot_path_alloc.rs`); only logging a refused or failed state
//! allocates.

use std::time::{Duration, Instant};

use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use plan_record::now_ns;
use planner::guess::GuessKind;
use planner::ip::{MuMatch, SolveInfo};
use planner::model::{ix, VehicleParams, NU, NX};
use planner::plan::{shift_plan, Planner, ReplanGuess, WarmOptions};

use crate::clock::{monotonic_ns, thread_cpu_ns};
use crate::elog;
use crate::msg::{RunId, Trajectory, VehicleState, FLAG_PLAN_NOW, HORIZON_N};
use crate::road::{RoadWindow, Scenario, StartRamp};
use crate::services::{ipc_err, wait_events, IpcError, Services, Svc};
use crate::shutdown::StdinWatch;
use crate::stats::Latency;

mod args;
pub mod budget;
mod end_speed;
mod intake;
mod lockstep;
pub mod publish_policy;
mod record;
mod relaxed;
mod report;
mod send;
mod soft_lane;
pub use args::{PlannerArgs, ARREST_LATERAL_ACCEL_MPS2, MARGIN_FLOOR_M, MARGIN_RAMP_M};
pub use intake::{LastPlanned, Rejected};
pub use record::{CycleRecorder, WarmRecord};

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

/// What one planning cycle needs, allocated once.
struct Cycle {
    planner: Planner<HORIZON_N>,
    road: RoadWindow,
    guess_x: Vec<[f64; NX]>,
    guess_u: Vec<[f64; NU]>,
    /// The warm start's source (the last successful solve, [`Planner::warm_source`]):
    /// its origin s and the publisher run of the state it started from.
    src_origin: f64,
    src_run: Option<RunId>,
    /// The relaxed problem (`None`: never relaxed) and whether this cycle solves it.
    relaxed: Option<relaxed::Relaxed>,
    relaxed_now: bool,
}

impl Cycle {
    /// Builds the guess from the last successful solution shifted by `shift` metres
    /// ([`shift_plan`]; allocates nothing). False when no solve has succeeded yet.
    fn shifted_guess(&mut self, shift: f64, x0: &[f64; NX], ds: f64) -> bool {
        let Some((xs, us)) = self.planner.warm_source() else {
            return false;
        };
        shift_plan(xs, us, ds, shift, x0, &mut self.guess_x, &mut self.guess_u);
        true
    }

    /// Switches the planner to the relaxed problem's saturation bound and grip or back (the
    /// lane margin comes with the road window); the bounds are recomputed only on a switch.
    fn set_relaxed(&mut self, relaxed: bool) {
        if relaxed == self.relaxed_now {
            return;
        }
        self.relaxed_now = relaxed;
        let Some(r) = &self.relaxed else { return };
        let limits = r.limits[usize::from(relaxed)];
        if let Err(e) = self.planner.set_limits(limits) {
            elog!("planner: cannot set the limits {limits:?}: {e}");
        }
    }
}

/// The least time a cycle's solve is given [s]: a cycle that spent its budget before the
/// solve still runs the solver's start, which ends `time_limit` at once with the start
/// as its best iterate (so the cycle sends the previous plan shifted or the notice).
const MIN_SOLVE_S: f64 = 1e-6;

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

/// The shared-memory ports of the planner process and its stop signals. The ports come
/// before the services in field order, so they are dropped first.
struct Ports {
    sub: Subscriber<Svc, VehicleState, ()>,
    listener: Listener<Svc>,
    publisher: Publisher<Svc, Trajectory, ()>,
    notifier: Notifier<Svc>,
    stdin: StdinWatch,
    svc: Services,
}

impl Ports {
    fn open(args: &PlannerArgs) -> Result<Self, IpcError> {
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
        Ok(Self {
            sub,
            listener,
            publisher,
            notifier,
            stdin,
            svc,
        })
    }
}

/// How a cycle's solve started.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Start {
    /// From the cold guess.
    Cold,
    /// Warm, from the previous plan moved `shift` metres (the planner's warm buffers and
    /// `Cycle::guess_x` hold where it started); `fell_back` when the warm solve stalled and
    /// the plan comes from the cold guess inside the same caps; `opts` as it ran (recorded
    /// with it).
    Warm {
        shift: f64,
        fell_back: bool,
        opts: WarmOptions,
    },
}

impl Start {
    /// The plan comes from the warm solve (not from its fall-back).
    fn warm_started(self) -> bool {
        matches!(
            self,
            Start::Warm {
                fell_back: false,
                ..
            }
        )
    }
}

/// What one planning cycle solved: the solve's outcome (`None`: the replan failed) and the
/// state it planned from. The planner holds the solution ([`Planner::states`],
/// [`Planner::controls`]).
struct Solved {
    info: Option<SolveInfo>,
    /// How the solve started.
    start: Start,
    /// The start state as planned from (re-referenced and nudged into the bounds).
    x0: [f64; NX],
    /// Track s of the measured state: the plan's origin.
    s_track: f64,
    /// Wall clock when the cycle started [ns since the epoch] (the record's input stamp).
    stamp_in: u64,
    /// When the cycle started (the cycle latency runs to the send).
    t0: Instant,
    /// The planner thread's CPU time when the cycle started \[ns\] ([`thread_cpu_ns`]).
    cpu_t0_ns: u64,
    /// Seconds from the cycle's start to the end of the solve.
    solve_time_s: f64,
}

/// The planner process's loop state: the scenario, what a cycle needs, and the counters
/// of the final report.
struct PlannerLoop {
    sc: Scenario,
    ds: f64,
    v_min: f64,
    v_max: f64,
    /// The lane margin's start ramp of a nominal plan (a relaxed plan changes its margin).
    ramp: StartRamp,
    /// Soft lane margin from each edge \[m\] (`--soft-lane-m`; used when the spec's soft
    /// lane is on).
    soft_margin: f64,
    /// Speed envelope for the plans' last node (`--end-speed-envelope`; `None`: off).
    envelope: Option<end_speed::EndSpeed>,
    warm_start: bool,
    /// How a warm-started replan runs (its cold fall-back is the guess of every cold solve).
    warm_opts: WarmOptions,
    /// Warm iteration cap of a cycle after one whose solve did not succeed
    /// (`--warm-max-iter-after-failure`, at most `warm_opts.max_iter`).
    warm_cap_after_failure: usize,
    /// The last cycle's solve did not succeed: its warm source is a cycle older.
    last_failed: bool,
    /// Warm-started solves that ran under `warm_cap_after_failure`.
    capped_after_failure: u64,
    recorder: Option<CycleRecorder>,
    cy: Cycle,
    policy: publish_policy::Policy,
    /// Solve budgets \[ms\]: steady, and until the first plan is sent.
    budget_ms: f64,
    first_budget_ms: f64,
    /// Lockstep's iteration caps (`None`: real time, wall-clock budgets).
    lockstep: Option<lockstep::Caps>,
    /// Cycles that solved (the recording's seq).
    cycles: u64,
    /// Cycle time of the first plan sent (start-up budget) \[ms\].
    first_cycle_ms: f64,
    latest: Option<VehicleState>,
    planned: LastPlanned,
    rejected: Rejected,
    /// Valid states outside the planner's domain (see `InitialDomain`), not planned.
    outside: u64,
    states_received: u64,
    published: u64,
    /// True once the start-up budget has ended (see `send::record_cycle_time`).
    startup_over: bool,
    warm: u64,
    cold: u64,
    failed: u64,
    cycle_lat: Latency,
    /// Steady cycles that ended past the budget plus [`send::OVERRUN_ALLOWANCE_MS`].
    past_budget: u64,
    /// Those of them whose own CPU time stayed within it: the planner thread waited for a
    /// CPU (the machine's stall, not the cycle's work).
    past_budget_off_cpu: u64,
    state_ipc_lat: Latency,
}

/// Checks the numeric options; the error names the first one out of its range.
fn check_args(args: &PlannerArgs) -> Result<(), PlannerProcError> {
    if MuMatch::parse(&args.warm_mu, args.warm_mu_factor).is_none() {
        return Err(PlannerProcError::Setup(format!(
            "--warm-mu-factor {}: must be finite and > 0",
            args.warm_mu_factor
        )));
    }
    if !(args.rate_hz > 0.0 && args.rate_hz <= 1000.0) {
        return Err(PlannerProcError::Setup(
            "--rate-hz must be in (0, 1000]".into(),
        ));
    }
    if args.lane_margin_m.is_nan() || args.lane_margin_m < 0.0 {
        return Err(PlannerProcError::Setup(
            "--lane-margin-m must be >= 0".into(),
        ));
    }
    if let Some(k) = args.warm_max_iter.filter(|k| !(1..=100_000).contains(k)) {
        return Err(PlannerProcError::Setup(format!(
            "--warm-max-iter {k} must lie in 1..=100000"
        )));
    }
    if !(1..=100_000).contains(&args.warm_max_iter_after_failure) {
        return Err(PlannerProcError::Setup(format!(
            "--warm-max-iter-after-failure {} must lie in 1..=100000",
            args.warm_max_iter_after_failure
        )));
    }
    if !(0.0..=0.9).contains(&args.min_path_scale) {
        return Err(PlannerProcError::Setup(format!(
            "--min-path-scale {} must lie in [0, 0.9]",
            args.min_path_scale
        )));
    }
    if args.relaxed_margin_m.is_nan() || args.relaxed_margin_m < 0.0 {
        return Err(PlannerProcError::Setup(format!(
            "--relaxed-margin-m {}: must be >= 0",
            args.relaxed_margin_m
        )));
    }
    if !(args.margin_ramp_m >= 0.0 && args.margin_ramp_m <= 250.0) {
        return Err(PlannerProcError::Setup(format!(
            "--margin-ramp-m {}: must be in [0, 250]",
            args.margin_ramp_m
        )));
    }
    if !(args.margin_floor_m >= -2.0 && args.margin_floor_m <= 10.0) {
        return Err(PlannerProcError::Setup(format!(
            "--margin-floor-m {}: must be in [-2, 10]",
            args.margin_floor_m
        )));
    }
    if !(0.0..=1.0).contains(&args.relaxed_saturation) {
        return Err(PlannerProcError::Setup(format!(
            "--relaxed-saturation {}: must be in [0, 1]",
            args.relaxed_saturation
        )));
    }
    if !planner::model::GRIP_SCALES.contains(&args.friction_scale) {
        return Err(PlannerProcError::Setup(format!(
            "--friction-scale {}: must be in [0.5, 1]",
            args.friction_scale
        )));
    }
    if !planner::model::GRIP_SCALES.contains(&args.relaxed_grip()) {
        return Err(PlannerProcError::Setup(format!(
            "--relaxed-friction-scale {}: must be in [0.5, 1]",
            args.relaxed_grip()
        )));
    }
    Ok(())
}

impl PlannerLoop {
    /// Loads the scenario with the planner's own limits (its grip, the saturation rows at
    /// the last node, the soft lane, the road frame's smallest path scale) and checks the
    /// lane margin against the road; also returns the vehicle of a relaxed plan.
    fn scenario(args: &PlannerArgs) -> Result<(Scenario, VehicleParams), PlannerProcError> {
        let mut sc = Scenario::load_with(&args.scenario, &args.road, &args.vehicle, &args.solver)
            .map_err(|e| PlannerProcError::Setup(e.to_string()))?;
        let mut relaxed_vehicle = sc.spec.vehicle;
        relaxed_vehicle.eps_sat = args.relaxed_saturation;
        relaxed_vehicle.scale_grip(args.relaxed_grip());
        sc.spec.vehicle.scale_grip(args.friction_scale);
        sc.spec.saturation_at_end = args.saturation_at_end == "on";
        soft_lane::setup(&mut sc, args)?;
        sc.road = sc.road.clone().with_min_path_scale(args.min_path_scale);
        sc.road.check_margin(args.lane_margin_m).map_err(|e| {
            PlannerProcError::Setup(format!(
                "--lane-margin-m on {}: {e}",
                args.road.road_file(&args.scenario).display()
            ))
        })?;
        Ok((sc, relaxed_vehicle))
    }

    /// Checks the options, loads the files and allocates the planner and the recorder.
    fn setup(args: &PlannerArgs) -> Result<Self, PlannerProcError> {
        check_args(args)?;
        let (budget_ms, first_budget_ms) = budget::budgets_ms(args)?;
        let cold_guess = GuessKind::parse(&args.cold_guess).unwrap_or(GuessKind::Equilibrium);
        crate::services::check_prefix(&args.service_prefix).map_err(PlannerProcError::Setup)?;
        let (sc, relaxed_vehicle) = Self::scenario(args)?;
        // Among obstacles the car is already moving at the scenario's start: the first
        // cycle answers within the steady budget like every other (a plan, or the notice
        // that there is none), instead of the start-up budget of a car waiting to start.
        let first_budget_ms = if sc.road.obstacles().is_empty() {
            first_budget_ms
        } else {
            budget_ms
        };
        let mut settings = sc.settings;
        settings.max_time_s = budget_ms * 1e-3;
        let ds = sc.ds();
        let (v_min, v_max) = (sc.spec.v_min, sc.spec.v_max);
        let envelope = end_speed::setup(&sc, args);
        let lockstep =
            lockstep::Caps::from_args(args, (budget_ms, first_budget_ms), settings.max_iter)?;
        // The steady settings are recorded; the first solves run under the start-up caps.
        let (recorded_settings, startup_settings) = match &lockstep {
            Some(caps) => (caps.apply(settings, false), caps.apply(settings, true)),
            None => {
                let startup = planner::ip::Settings {
                    max_time_s: first_budget_ms * 1e-3,
                    ..settings
                };
                (settings, startup)
            }
        };
        let planner = Planner::<HORIZON_N>::new(sc.spec.clone(), startup_settings)
            .map_err(|e| PlannerProcError::Setup(e.to_string()))?;
        let dims = (
            planner.solver().workspace().n,
            planner.solver().workspace().m,
        );
        let (relaxed, relaxed_spec) = relaxed::setup(args, &sc, &relaxed_vehicle);
        let recorder = match &args.record {
            Some(path) => Some(
                CycleRecorder::create(
                    path,
                    (&sc.spec, relaxed_spec.as_ref()),
                    &recorded_settings,
                    cold_guess,
                    dims,
                )
                .map_err(|e| {
                    PlannerProcError::Setup(format!("--record {}: {e}", path.display()))
                })?,
            ),
            None => None,
        };
        let cy = Cycle {
            planner,
            road: RoadWindow::default(),
            guess_x: vec![[0.0; NX]; HORIZON_N + 1],
            guess_u: vec![[0.0; NU]; HORIZON_N],
            src_origin: 0.0,
            src_run: None,
            relaxed,
            relaxed_now: false,
        };
        Ok(Self {
            sc,
            ds,
            v_min,
            v_max,
            ramp: StartRamp {
                margin: args.lane_margin_m,
                length_m: args.margin_ramp_m,
                arrest_accel: ARREST_LATERAL_ACCEL_MPS2,
                floor_m: args.margin_floor_m,
            },
            soft_margin: args.soft_lane_m,
            envelope,
            warm_start: args.warm_start == "on",
            warm_opts: WarmOptions {
                cold: cold_guess,
                // `check_args` has checked the rule.
                mu_match: MuMatch::parse(&args.warm_mu, args.warm_mu_factor)
                    .unwrap_or(MuMatch::DEFAULT),
                max_iter: args.warm_max_iter.unwrap_or(usize::MAX),
                ..WarmOptions::default()
            },
            warm_cap_after_failure: args.warm_max_iter_after_failure,
            last_failed: false,
            capped_after_failure: 0,
            recorder,
            cy,
            policy: publish_policy::Policy::default(),
            budget_ms,
            first_budget_ms,
            lockstep,
            cycles: 0,
            first_cycle_ms: 0.0,
            latest: None,
            planned: LastPlanned::default(),
            rejected: Rejected::default(),
            outside: 0,
            states_received: 0,
            published: 0,
            startup_over: false,
            warm: 0,
            cold: 0,
            failed: 0,
            cycle_lat: Latency::new(),
            past_budget: 0,
            past_budget_off_cpu: 0,
            state_ipc_lat: Latency::new(),
        })
    }

    /// Takes every queued vehicle state: keeps the latest valid one, counts and logs the
    /// invalid ones.
    fn receive(&mut self, ports: &Ports) -> Result<(), IpcError> {
        while let Some(sample) = ports
            .sub
            .receive()
            .map_err(ipc_err("receive vehicle state"))?
        {
            let m: &VehicleState = sample.payload();
            self.states_received += 1;
            match m.validate(self.sc.id) {
                Ok(()) => {
                    self.state_ipc_lat
                        .record_ns(monotonic_ns().saturating_sub(m.stamp_ns));
                    self.latest = Some(*m);
                }
                Err(e) => {
                    self.rejected.count(&e);
                    let n = self.rejected.total();
                    if n <= 10 || n.is_multiple_of(1000) {
                        elog!(
                            "planner: dropped vehicle state seq {} ({n} dropped so far): {e}",
                            m.seq
                        );
                    }
                }
            }
        }
        Ok(())
    }

    /// Plans from `state`: samples the road window, nudges the start state into the
    /// bounds, checks the domain and solves (warm, then from the equilibrium; the relaxed
    /// problem after a cycle without a plan of its own). `None` when
    /// nothing was planned (a state outside the domain); otherwise what was solved,
    /// converged or not (`info` is `None` when the replan failed).
    fn plan_cycle(&mut self, state: &VehicleState) -> Option<Solved> {
        let stamp_in = now_ns();
        let t0 = Instant::now();
        let cpu_t0_ns = thread_cpu_ns();
        let s_track = state.x[ix::S];
        let relaxed = self.cy.relaxed.as_ref().is_some_and(|r| r.active());
        self.cy.set_relaxed(relaxed);
        let x0 = self.start_state(state)?;
        self.budget_from(t0);
        let (info, start) = match self.solve(state, x0, s_track) {
            Some((info, start)) => (Some(info), start),
            None => (None, Start::Cold),
        };
        if info.as_ref().is_some_and(|i| !i.status.is_success()) {
            self.failed += 1;
        }
        // A successful solve is the next warm start's source (`Planner::warm_source`).
        if info.as_ref().is_some_and(|i| i.status.is_success()) {
            self.cy.src_origin = s_track;
            self.cy.src_run = Some(state.run_id);
        }
        self.planned.mark(state);
        let solve_time_s = t0.elapsed().as_secs_f64();
        Some(Solved {
            info,
            start,
            x0,
            s_track,
            stamp_in,
            t0,
            cpu_t0_ns,
            solve_time_s,
        })
    }

    /// Gives this cycle's solve what is left of the cycle's budget (the start-up budget
    /// until the first plan is out) after the work since `t0`, the cycle's start: the
    /// budget bounds the cycle, not only the solve, so time lost before the solve (the
    /// road window, the warm start's shift, or the machine) comes out of the solve.
    /// Allocates nothing.
    fn budget_from(&mut self, t0: Instant) {
        if let Some(caps) = self.lockstep {
            let settings = caps.apply(*self.cy.planner.solver().settings(), !self.startup_over);
            if let Err(e) = self.cy.planner.solver_mut().set_settings(settings) {
                elog!("planner: cannot set the cycle's iteration cap: {e}");
            }
            return;
        }
        let budget_ms = if self.startup_over {
            self.budget_ms
        } else {
            self.first_budget_ms
        };
        let left_s = budget_ms * 1e-3 - t0.elapsed().as_secs_f64();
        let mut settings = *self.cy.planner.solver().settings();
        settings.max_time_s = left_s.max(MIN_SOLVE_S);
        if let Err(e) = self.cy.planner.solver_mut().set_settings(settings) {
            elog!("planner: cannot set the cycle's budget: {e}");
        }
    }

    /// Samples the road window at `state` and returns the start state to plan from:
    /// `state` re-referenced and nudged into the bounds. `None` (counted, logged and
    /// marked as planned) when it lies outside the planner's domain.
    fn start_state(&mut self, state: &VehicleState) -> Option<[f64; NX]> {
        let cy = &mut self.cy;
        let e_dot = state.x[ix::V] * state.x[ix::DPSI].sin();
        let margin = match &cy.relaxed {
            Some(r) if cy.relaxed_now => r.margin,
            _ => self.ramp.margin,
        };
        let ramp = StartRamp {
            margin,
            ..self.ramp
        };
        self.sc.road.window_from(
            state.x[ix::S],
            (state.x[ix::E], e_dot),
            self.ds,
            &ramp,
            &mut cy.road,
        );
        soft_lane::update(cy, &self.sc, state, (self.ds, self.soft_margin));
        if let Some(env) = &self.envelope {
            end_speed::update(cy, env, state, self.ds);
        }
        // Plan from the measured state, re-referenced to s = t = 0, nudged into the bounds
        // the OCP enforces so a slightly-out state stays plannable.
        let mut x0 = state.x;
        x0[ix::S] = 0.0;
        x0[ix::T] = 0.0;
        x0[ix::V] = nudge_into(x0[ix::V], self.v_min, self.v_max);
        x0[ix::E] = nudge_into(x0[ix::E], cy.road.e_min[0], cy.road.e_max[0]);
        let vehicle = &self.sc.spec.vehicle;
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
            self.outside += 1;
            if self.outside <= 10 || self.outside.is_multiple_of(1000) {
                elog!(
                    "planner: not planning from vehicle state seq {} ({} so far): {e}",
                    state.seq,
                    self.outside
                );
            }
            self.planned.mark(state);
            return None;
        }
        Some(x0)
    }

    /// Solves from `x0` over the sampled window: warm-started from the last successful
    /// plan when that is sound (even after failed cycles: a cold start on a track takes
    /// several times a warm one's iterations), else from the cold guess. Returns the
    /// solve's outcome and how it started; `None` (logged, counted, marked as planned) when
    /// the cold replan fails.
    fn solve(
        &mut self,
        state: &VehicleState,
        x0: [f64; NX],
        s_track: f64,
    ) -> Option<(SolveInfo, Start)> {
        let ds = self.ds;
        let cy = &mut self.cy;
        let shift = s_track - cy.src_origin;
        // A warm start shifts the last good plan, which belongs to the same publisher run
        // only.
        let sound = self.warm_start
            && cy.src_run == Some(state.run_id)
            && shift >= 0.0
            && shift < 0.5 * HORIZON_N as f64 * ds;
        if sound && cy.shifted_guess(shift, &x0, ds) {
            // Primal and dual, falling back to the equilibrium inside the same caps. After a
            // failed cycle the warm source is older and the warm solve more likely to stall
            // for the whole budget, so its cap may be tighter.
            let tightened = self
                .warm_opts
                .capped_after_failure(self.warm_cap_after_failure)
                .filter(|_| self.last_failed);
            self.capped_after_failure += u64::from(tightened.is_some());
            let opts = tightened.unwrap_or(self.warm_opts);
            let r = cy.planner.replan_warm(
                &cy.road.kappa,
                &cy.road.e_min,
                &cy.road.e_max,
                x0,
                (&cy.guess_x, &cy.guess_u),
                shift,
                opts,
            );
            match r {
                Ok(r) => {
                    self.last_failed = !r.info.status.is_success();
                    let fell_back = r.fell_back;
                    if fell_back {
                        self.cold += 1;
                    } else {
                        self.warm += 1;
                    }
                    let start = Start::Warm {
                        shift,
                        fell_back,
                        opts,
                    };
                    return Some((r.info, start));
                }
                Err(e) => elog!("planner: warm replan failed: {e}"),
            }
        }
        self.cold += 1;
        match cy.planner.replan(
            &cy.road.kappa,
            &cy.road.e_min,
            &cy.road.e_max,
            x0,
            ReplanGuess::cold(self.warm_opts.cold),
        ) {
            Ok(i) => {
                self.last_failed = !i.status.is_success();
                Some((i, Start::Cold))
            }
            Err(e) => {
                self.last_failed = true;
                elog!("planner: replan failed: {e}");
                self.failed += 1;
                self.planned.mark(state);
                None
            }
        }
    }

    /// Records the plan just published (after publishing; copies into a preallocated
    /// slot), with where it started when it went through the warm path.
    fn record(&mut self, solved: &Solved) {
        let Some(info) = &solved.info else { return };
        let Some(rec) = &self.recorder else {
            return;
        };
        let cy = &self.cy;
        let warm = match solved.start {
            Start::Warm { shift, opts, .. } => Some(WarmRecord {
                shift,
                opts,
                guess: (&cy.guess_x, &cy.guess_u),
                duals: cy.planner.warm_duals(),
            }),
            Start::Cold => None,
        };
        rec.record(
            (self.cycles, solved.stamp_in),
            (&cy.road, cy.relaxed_now),
            solved.x0,
            info,
            (cy.planner.states(), cy.planner.controls()),
            warm,
        );
    }

    /// Logs, in one line, the worst-case cycle time the caps allow on this machine
    /// ([`budget::measure`]).
    fn log_worst_case(&self, args: &PlannerArgs) {
        let settings = *self.cy.planner.solver().settings();
        match budget::measure(&self.sc, settings, self.ramp.margin, 15.0) {
            Ok(o) => elog!(
                "planner: worst-case cycle {:.1} ms = budget {:.1} ms + overshoot {:.2} ms (one factorization {:.2} ms with its solves {:.2} ms and two evaluations of {:.2} ms, measured on the first window), period {:.1} ms; first plan budget {:.0} ms",
                self.budget_ms + o.total_ms(),
                self.budget_ms,
                o.total_ms(),
                o.factorization_ms,
                o.solves_ms,
                o.evaluation_ms,
                1e3 / args.rate_hz,
                self.first_budget_ms
            ),
            Err(e) => elog!(
                "planner: budget {:.1} ms; worst-case cycle not measured: {e}",
                self.budget_ms
            ),
        }
    }
}

/// Runs the planner process until stopped; returns its summary as JSON.
pub fn run(args: &PlannerArgs) -> Result<serde_json::Value, PlannerProcError> {
    let mut pl = PlannerLoop::setup(args)?;
    let ports = Ports::open(args)?;
    let period = Duration::from_secs_f64(1.0 / args.rate_hz);
    let started = Instant::now();
    let mut next_tick = started;
    elog!(
        "planner: up (prefix {}, road {:#018x}, {:.1} Hz, ds {} m)",
        args.service_prefix,
        pl.sc.id,
        args.rate_hz,
        pl.ds
    );
    pl.log_worst_case(args);
    loop {
        if ports.stdin.closed() || ports.svc.termination_requested() {
            break;
        }
        if args.max_runtime_s > 0.0 && started.elapsed().as_secs_f64() > args.max_runtime_s {
            break;
        }
        let now = Instant::now();
        // In lockstep a flagged state's event wakes the planner; nothing is due before.
        let wait = if pl.lockstep.is_some() {
            Duration::from_millis(100)
        } else {
            next_tick
                .saturating_duration_since(now)
                .clamp(Duration::from_millis(1), Duration::from_millis(100))
        };
        if let Err(e) = wait_events(&ports.listener, wait) {
            if ports.svc.termination_requested() {
                break;
            }
            return Err(e.into());
        }
        pl.receive(&ports)?;
        let Some(state) = pl.latest else { continue };
        if pl.planned.is_planned(&state) {
            continue;
        }
        // In lockstep the tracker flags the states to plan from and waits; else the
        // planner plans from the latest state on its own clock.
        if pl.lockstep.is_some() {
            if state.flags & FLAG_PLAN_NOW == 0 {
                continue;
            }
        } else if Instant::now() < next_tick {
            continue;
        } else {
            next_tick = (next_tick + period).max(Instant::now());
        }
        let Some(solved) = pl.plan_cycle(&state) else {
            if pl.lockstep.is_some() {
                pl.decline(&ports, &state)?;
            }
            continue;
        };
        pl.send(&ports, &state, &solved)?;
        pl.record(&solved);
        pl.cycles += 1;
    }
    pl.report(args)
}
