//! The tracker process: simulates the plant in real time (RK4 at a fixed step), tracks the
//! latest valid trajectory (feed-forward + feedback), publishes the vehicle state at a
//! fixed rate, flags a stale plan and brakes to a stop, and reports tracking errors. With
//! `--lockstep` it runs on simulated time instead and waits for each plan (`crate::lockstep`).
//!
//! Each run draws its own run id, stamps it on every state it publishes and follows only
//! plans made from its own states ([`crate::tracker::Ownership`]); other valid plans are counted as foreign.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use planner::model::{iu, ix};

use crate::clock::monotonic_ns;
use crate::controller::{Actuator, Controller};
use crate::elog;
use crate::estimator::Estimator;
use crate::kinds::KindCounts;
use crate::mismatch::Mismatch;
use crate::msg::{new_run_id, Trajectory, VehicleState, FLAG_RUNNING, FLAG_STALE, FLAG_STOPPED};
use crate::plant::car::Car;
use crate::road::Scenario;
use crate::services::{ipc_err, publish_state, wait_events, IpcError, Services, Svc};
use crate::shutdown::StdinWatch;
use crate::stats::Latency;
use crate::tracker::{brake_to_stop, Gains};

mod inbox;
mod laps;
mod lockstep;
mod outcome;
mod start;

use inbox::Inbox;
pub use laps::RunLog;
use outcome::outcome;
pub use start::initial_state;

/// Command-line options of `tracker_proc`.
// clap prints these doc comments as the --help text, which would show the escapes of
// the unit brackets verbatim: the brackets stay as they are, and rustdoc keeps them as text.
#[allow(rustdoc::broken_intra_doc_links)]
#[derive(clap::Args, Debug, Clone)]
pub struct TrackerArgs {
    /// Scenario file (a closed road, or an obstacle file with --segment).
    #[arg(long, default_value = "config/scenarios/oval.toml")]
    pub scenario: PathBuf,
    /// The road options (--track, --track-profile, --segment, ...).
    #[command(flatten)]
    pub road: crate::road::RoadArgs,
    /// Road s where the car starts [m].
    #[arg(long, default_value_t = 0.0)]
    pub start_s: f64,
    /// Laps to drive when --distance-m is 0.
    #[arg(long, default_value_t = 1)]
    pub laps: usize,
    /// Lane margin of the planner's window [m] (for the free-start solve of the start state).
    #[arg(long, default_value_t = 0.5)]
    pub lane_margin_m: f64,
    /// Write the driven trace (driven.csv) and the plans taken (plans.csv) into this folder.
    #[arg(long)]
    pub trace_dir: Option<PathBuf>,
    /// Vehicle file (the planner's model; the controller is designed on it).
    #[arg(long, default_value = "config/vehicles/lc500.toml")]
    pub vehicle: PathBuf,
    /// Vehicle file of the simulated car (default: --vehicle); never shown to the planner.
    #[arg(long)]
    pub plant_vehicle: Option<PathBuf>,
    /// Plant mismatch: none, default (config/mismatch/default.toml) or a TOML file.
    #[arg(long, default_value = "none")]
    pub mismatch: String,
    /// Seed of the measurement noise.
    #[arg(long, default_value_t = 1)]
    pub noise_seed: u64,
    /// Time constant of the state estimator [ms] (the feedback and the planner get the
    /// filtered state; crate::estimator). 0: the raw measurement.
    #[arg(long, default_value_t = 20.0)]
    pub estimator_tau_ms: f64,
    /// Solver settings file (read for the road id only).
    #[arg(long, default_value = "config/solver.toml")]
    pub solver: PathBuf,
    /// iceoryx2 service-name prefix (unique per closed loop).
    #[arg(long, default_value = crate::services::DEFAULT_PREFIX)]
    pub service_prefix: String,
    /// Distance to drive before stopping [m] (0: --laps laps).
    #[arg(long, default_value_t = 0.0)]
    pub distance_m: f64,
    /// Simulated time after which to stop regardless [s].
    #[arg(long, default_value_t = 60.0)]
    pub duration_s: f64,
    /// Start speed [m/s]: straight-line cruise at --start-s in the lane centre (default:
    /// the scenario's fixed initial state, else --free-start, else 15 m/s).
    #[arg(long)]
    pub v0: Option<f64>,
    /// Start at node 0 of a free-start solve at --start-s (a flying start) unless --v0 is
    /// given or the scenario fixes the initial state.
    #[arg(long)]
    pub free_start: bool,
    /// Grip scale of the planner's plans (its `--friction-scale`): the free-start solve
    /// plans with it, so the car starts at the pace the planner itself chooses. The
    /// controller and the plant do not use it.
    #[arg(long, default_value_t = 1.0)]
    pub friction_scale: f64,
    /// Plant integration step [s].
    #[arg(long, default_value_t = 0.00025)]
    pub plant_dt_s: f64,
    /// Controller period [s] (1 kHz).
    #[arg(long, default_value_t = 0.001)]
    pub control_dt_s: f64,
    /// State publish period [s].
    #[arg(long, default_value_t = 0.01)]
    pub publish_dt_s: f64,
    /// A plan older than this (wall clock since it arrived) is stale [s].
    #[arg(long, default_value_t = 1.0)]
    pub stale_after_s: f64,
    /// Give up when no first plan arrives within this time [s].
    #[arg(long, default_value_t = 120.0)]
    pub first_plan_timeout_s: f64,
    /// Simulated seconds per wall-clock second (1: real time).
    #[arg(long, default_value_t = 1.0)]
    pub time_scale: f64,
    /// Stop when stdin reaches EOF.
    #[arg(long)]
    pub exit_on_stdin_eof: bool,
    /// After stopping on a stale plan, keep publishing for this long before exiting [s].
    #[arg(long, default_value_t = 0.5)]
    pub linger_s: f64,
    /// Lockstep with the planner (`crate::lockstep`): flag one state per planning period
    /// of simulated time, wait for its answer, and drive the plan from c n ms after its
    /// state (n its iterations, c --lockstep-ms-per-iter); the simulation runs as fast as
    /// the plans come, not on the wall clock, and a run repeats bit for bit.
    #[arg(long)]
    pub lockstep: bool,
    /// The planner's rate in lockstep [Hz] (its --rate-hz).
    #[arg(long, default_value_t = 10.0)]
    pub rate_hz: f64,
    /// Modelled time of one solver iteration in lockstep [ms] (the planner's
    /// --lockstep-ms-per-iter).
    #[arg(long, default_value_t = crate::lockstep::MS_PER_ITER)]
    pub lockstep_ms_per_iter: f64,
}

/// Why the tracker process failed.
#[derive(Debug, thiserror::Error)]
pub enum TrackerProcError {
    /// Bad files or options.
    #[error("{0}")]
    Setup(String),
    /// Shared-memory communication failed.
    #[error(transparent)]
    Ipc(#[from] IpcError),
    /// No plan arrived in time.
    #[error("no valid trajectory within {0} s")]
    NoPlan(f64),
}

/// Running tracking statistics.
#[derive(Debug, Default, Clone, Copy)]
struct Track {
    n: u64,
    sum_e2: f64,
    max_e: f64,
    /// Car's s where the largest lateral error occurred \[m\].
    max_e_s: f64,
    sum_cross2: f64,
    max_cross: f64,
    max_beta: f64,
    max_dpsi: f64,
    max_v: f64,
    e_lo: f64,
    e_hi: f64,
}

/// Refuses options that would hang or panic the process, naming the first bad one.
fn check_args(args: &TrackerArgs) -> Result<(), TrackerProcError> {
    // plant_dt >= 1e-6 s keeps the substeps per control step (control_dt <= 0.01) at most
    // 10^4; a finite first-plan timeout keeps the wait for the first plan bounded. The
    // first failed check names its option.
    let checks = [
        (
            "--plant-dt-s",
            args.plant_dt_s,
            args.plant_dt_s >= 1e-6 && args.plant_dt_s <= args.control_dt_s,
            "must lie in [1e-6, --control-dt-s]",
        ),
        (
            "--control-dt-s",
            args.control_dt_s,
            args.control_dt_s <= 0.01 && args.control_dt_s <= args.publish_dt_s,
            "must lie in [--plant-dt-s, min(0.01, --publish-dt-s)]",
        ),
        (
            "--publish-dt-s",
            args.publish_dt_s,
            args.publish_dt_s <= 10.0,
            "must lie in [--control-dt-s, 10]",
        ),
        (
            "--first-plan-timeout-s",
            args.first_plan_timeout_s,
            args.first_plan_timeout_s > 0.0 && args.first_plan_timeout_s.is_finite(),
            "must be finite and > 0",
        ),
        (
            "--stale-after-s",
            args.stale_after_s,
            args.stale_after_s > 0.0 && args.stale_after_s.is_finite(),
            "must be finite and > 0",
        ),
        (
            "--estimator-tau-ms",
            args.estimator_tau_ms,
            (0.0..=1000.0).contains(&args.estimator_tau_ms),
            "must lie in [0, 1000]",
        ),
        (
            "--time-scale",
            args.time_scale,
            (1e-3..=1e3).contains(&args.time_scale),
            "must lie in [1e-3, 1e3]",
        ),
        (
            "--duration-s",
            args.duration_s,
            args.duration_s > 0.0 && args.duration_s.is_finite(),
            "must be finite and > 0",
        ),
        (
            "--distance-m",
            args.distance_m,
            args.distance_m >= 0.0 && args.distance_m.is_finite(),
            "must be finite and >= 0",
        ),
        (
            "--v0",
            args.v0.unwrap_or(10.0),
            args.v0.is_none_or(|v| v > 3.0 && v.is_finite()),
            "must be finite and > 3 m/s",
        ),
        (
            "--friction-scale",
            args.friction_scale,
            planner::model::GRIP_SCALES.contains(&args.friction_scale),
            "must lie in [0.5, 1]",
        ),
        (
            "--start-s",
            args.start_s,
            args.start_s.is_finite() && args.start_s >= 0.0,
            "must be finite and >= 0",
        ),
        (
            "--laps",
            args.laps as f64,
            (1..=100).contains(&args.laps),
            "must lie in [1, 100]",
        ),
    ];
    match checks.iter().find(|c| !c.2) {
        Some((name, value, _, expected)) => Err(TrackerProcError::Setup(format!(
            "{name} = {value}: {expected}"
        ))),
        None => {
            crate::services::check_prefix(&args.service_prefix).map_err(TrackerProcError::Setup)
        }
    }
}

/// The shared-memory ports of the tracker process and its stop signals. The ports come
/// before the services in field order, so they are dropped first.
struct Ports {
    publisher: Publisher<Svc, VehicleState, ()>,
    notifier: Notifier<Svc>,
    sub: Subscriber<Svc, Trajectory, ()>,
    listener: Listener<Svc>,
    stdin: StdinWatch,
    svc: Services,
}

impl Ports {
    fn open(args: &TrackerArgs) -> Result<Self, IpcError> {
        let svc = Services::open(&args.service_prefix, "tracker")?;
        let publisher = svc.state_publisher()?;
        let notifier = svc.state_notifier()?;
        let sub = svc.traj_subscriber()?;
        let listener = svc.traj_listener()?;
        let stdin = if args.exit_on_stdin_eof {
            StdinWatch::start()
        } else {
            StdinWatch::disabled()
        };
        Ok(Self {
            publisher,
            notifier,
            sub,
            listener,
            stdin,
            svc,
        })
    }
}

/// The tracker process's loop state: the scenario and step sizes, the plant, the active
/// plan, the stale/stopped state and the statistics of the final report.
struct TrackerLoop {
    sc: Scenario,
    /// Gains of the stop without a plan: among obstacles the emergency stop
    /// ([`Gains::emergency_stop`]), else the comfort stop of a stale plan.
    stop_gains: Gains,
    distance: f64,
    substeps: usize,
    plant_dt: f64,
    publish_dt: f64,
    car: Car,
    /// Filters the measured state.
    estimator: Estimator,
    /// The last estimated state (what the feedback used and what is published).
    measured: [f64; planner::model::NX],
    controller: Controller,
    mismatch: Mismatch,
    plan: Box<Trajectory>,
    have_plan: bool,
    inbox: Inbox,
    plans_not_converged: u64,
    /// Plans driven, by kind.
    kinds: KindCounts,
    last_plan_at: Instant,
    stats: Track,
    ever_stale: bool,
    stale: bool,
    stale_at_s: f64,
    stopped_at: Option<Instant>,
    e_hold: f64,
    sim_start: Option<Instant>,
    /// The drive's log (laps, margins, obstacles, trace).
    log: RunLog,
    /// How the start state was chosen.
    start: &'static str,
    /// Braking to a stop in the lane because the planner found no feasible plan (obstacle
    /// roads: a non-converged plan is never followed there); latched.
    no_feasible_plan: bool,
    /// Simulated time when the active plan was taken \[s\] (lockstep's stale clock).
    last_plan_t: f64,
    /// The state seq of the last own plan or notice received (lockstep waits for it).
    answered_seq: u64,
    /// Lockstep's schedule and the plan waiting for its arrival time (`None`: real time).
    lockstep: Option<lockstep::Schedule>,
}

impl TrackerLoop {
    /// Checks the options, loads the files and derives the step sizes.
    fn setup(args: &TrackerArgs) -> Result<Self, TrackerProcError> {
        check_args(args)?;
        let sc = Scenario::load_with(&args.scenario, &args.road, &args.vehicle, &args.solver)
            .map_err(|e| TrackerProcError::Setup(e.to_string()))?;
        let distance = if args.distance_m > 0.0 {
            args.distance_m
        } else {
            args.laps as f64 * sc.road.lap()
        };
        let (x0, start) = initial_state(
            &sc,
            args.start_s,
            (args.v0, args.free_start, args.friction_scale),
            args.lane_margin_m,
        )
        .map_err(TrackerProcError::Setup)?;
        let log = RunLog::new(&sc.road, args.start_s, args.laps, args.duration_s);
        let substeps = (args.control_dt_s / args.plant_dt_s).round().max(1.0) as usize;
        let plant_dt = args.control_dt_s / substeps as f64;
        let per_publish = (args.publish_dt_s / args.control_dt_s).round().max(1.0) as usize;
        let publish_dt = per_publish as f64 * args.control_dt_s;
        let mismatch = Mismatch::from_arg(&args.mismatch)
            .map_err(|e| TrackerProcError::Setup(e.to_string()))?;
        let plant_params = match &args.plant_vehicle {
            Some(path) => planner::config::load_vehicle(path)
                .map_err(|e| TrackerProcError::Setup(e.to_string()))?,
            None => sc.spec.vehicle,
        };
        let mut car = Car::new(
            &plant_params,
            &mismatch,
            x0,
            args.control_dt_s,
            args.noise_seed,
        );
        let measured = car.measure();
        let estimator = Estimator::new(
            sc.spec.vehicle,
            args.estimator_tau_ms * 1e-3,
            args.control_dt_s,
        );
        // The tracker knows its actuators' latency (not the vehicle's mismatch): the
        // feed-forward looks ahead by the transport delay plus the steering lag.
        let preview =
            car.delay_steps() as f64 * args.control_dt_s + mismatch.actuator.steering_lag_s;
        let actuator = Actuator {
            steering_lag_s: mismatch.actuator.steering_lag_s,
            delay_steps: car.delay_steps(),
        };
        let stop_gains = if sc.road.obstacles().is_empty() {
            Gains::default()
        } else {
            Gains::default().emergency_stop(&sc.spec.vehicle)
        };
        let controller = Controller::new(&sc.spec.vehicle, args.control_dt_s, preview, actuator)
            .map_err(TrackerProcError::Setup)?;
        Ok(Self {
            sc,
            stop_gains,
            distance,
            substeps,
            plant_dt,
            publish_dt,
            car,
            estimator,
            measured,
            controller,
            mismatch,
            plan: Box::new(Trajectory {
                ds: 1.0,
                ..Trajectory::zeroed()
            }),
            have_plan: false,
            inbox: Inbox::new(new_run_id()),
            plans_not_converged: 0,
            kinds: KindCounts::default(),
            last_plan_at: Instant::now(),
            stats: Track::default(),
            ever_stale: false,
            stale: false,
            stale_at_s: f64::NAN,
            stopped_at: None,
            e_hold: x0[ix::E],
            sim_start: None,
            log,
            start,
            no_feasible_plan: false,
            last_plan_t: 0.0,
            answered_seq: 0,
            lockstep: lockstep::Schedule::from_args(args).map_err(TrackerProcError::Setup)?,
        })
    }

    /// Takes every queued plan: a valid own plan becomes the active one, whatever its kind
    /// (the planner sends only what it judges drivable: a converged plan, a best iterate
    /// within its violation threshold, or its previous plan shifted to the car).
    fn receive(&mut self, ports: &Ports) -> Result<(), IpcError> {
        while let Some(sample) = ports.sub.receive().map_err(ipc_err("receive trajectory"))? {
            let m: &Trajectory = sample.payload();
            if !self
                .inbox
                .accept(m, self.sc.id, self.sc.ds(), monotonic_ns())
            {
                continue;
            }
            self.answered_seq = self.answered_seq.max(m.from_state_seq);
            if m.is_no_plan() {
                self.notice(m);
                continue;
            }
            self.log.plan(m, self.car.plant.x[ix::S]);
            if !matches!(m.status, 0 | 1) {
                self.plans_not_converged += 1;
            }
            if self.no_feasible_plan {
                // The car is committed to its stop: later plans are logged, not driven.
                continue;
            }
            self.kinds.count_code(m.kind);
            let running = self.sim_start.is_some();
            match self.lockstep.as_mut() {
                // In lockstep a plan arrives after its modelled solve time.
                Some(ls) if running => ls.stage(m, self.car.plant.x[ix::T]),
                _ => {
                    *self.plan = *m;
                    self.took_plan();
                }
            }
            if !running {
                self.sim_start = Some(Instant::now());
                elog!(
                    "tracker: first plan {} ({} iterations); running",
                    m.seq,
                    m.iterations
                );
            }
        }
        Ok(())
    }

    /// Marks the plan in `self.plan` as just taken: fresh, and the end of a stale period.
    fn took_plan(&mut self) {
        self.have_plan = true;
        self.last_plan_at = Instant::now();
        self.last_plan_t = self.car.plant.x[ix::T];
        if self.stale && !self.car.plant.stopped {
            elog!(
                "tracker: fresh plan {} after stale period; resuming",
                self.plan.seq
            );
            self.stale = false;
        }
    }

    /// Takes a notice that the planner's cycle had nothing drivable. The tracker holds the
    /// plan it has until the plan is stale. Among obstacles, with no plan yet, the drive
    /// ends in an emergency stop: the car is moving at its start state, so the drive starts
    /// braking to a stop in its lane and does not resume. Once the car is driving (or among
    /// obstacles) the notice is logged with the plans, so the figures mark its cycle; a
    /// closed road's notices before the first plan come from start-up solves of a car that
    /// is still waiting.
    fn notice(&mut self, m: &Trajectory) {
        let among_obstacles = !self.sc.road.obstacles().is_empty();
        if self.sim_start.is_some() || among_obstacles {
            self.log.plan(m, self.car.plant.x[ix::S]);
        }
        if !among_obstacles || self.have_plan || self.no_feasible_plan {
            return;
        }
        elog!(
            "tracker: no drivable plan (the planner's cycle ended {}, violation {:.2e}); braking to a stop in the lane",
            crate::msg::status_name(m.status).unwrap_or("?"),
            m.max_violation
        );
        self.no_feasible_plan = true;
        self.e_hold = self.measured[ix::E];
        self.sim_start.get_or_insert_with(Instant::now);
    }

    /// Advances the simulation to the wall clock `now` (bounded: at most 1 s of sim per
    /// pass), tracking the active plan or braking to a stop once it is stale.
    fn advance(&mut self, args: &TrackerArgs, now: Instant) {
        let Some(t0) = self.sim_start else { return };
        let age_s = now.duration_since(self.last_plan_at).as_secs_f64();
        self.check_stale(args, age_s);
        self.step_to(args, now.duration_since(t0).as_secs_f64() * args.time_scale);
    }

    /// Flags the plan stale once it is `age_s` old, past --stale-after-s: from then on the
    /// car brakes to a stop.
    fn check_stale(&mut self, args: &TrackerArgs, age_s: f64) {
        if self.stale || !self.have_plan || age_s <= args.stale_after_s {
            return;
        }
        self.stale = true;
        self.ever_stale = true;
        self.stale_at_s = self.car.plant.x[ix::T];
        self.e_hold = self.measured[ix::E];
        elog!(
            "tracker: plan {} is stale (no new plan for {:.2} s); braking to a stop",
            self.plan.seq,
            args.stale_after_s
        );
    }

    /// Steps the simulation to simulated time `target_t` (at most 1 s per call), tracking
    /// the active plan or braking to a stop without one.
    fn step_to(&mut self, args: &TrackerArgs, target_t: f64) {
        let params = self.sc.spec.vehicle;
        let road = &self.sc.road;
        let car = &mut self.car;
        let stats = &mut self.stats;
        let max_steps = (1.0 / args.control_dt_s) as usize;
        let mut steps = 0;
        while car.plant.x[ix::T] + 0.5 * args.control_dt_s < target_t && steps < max_steps {
            steps += 1;
            // The feedback sees the estimated state; the statistics the true one.
            let y = car.measure();
            let y = self.estimator.update(
                &y,
                car.measured_controls(),
                road,
                (self.substeps, self.plant_dt),
            );
            self.measured = y;
            let control = if self.stale || self.no_feasible_plan {
                None
            } else {
                self.controller.control(&self.plan, &y)
            };
            let mut e_plan = f64::NAN;
            let u = match control {
                Some((u, r)) => {
                    e_plan = r.x[ix::E];
                    let err = crate::tracker::errors(&car.plant.x, &r);
                    stats.n += 1;
                    stats.sum_e2 += err.e * err.e;
                    if err.e.abs() > stats.max_e {
                        stats.max_e = err.e.abs();
                        stats.max_e_s = car.plant.x[ix::S];
                    }
                    stats.sum_cross2 += err.cross * err.cross;
                    stats.max_cross = stats.max_cross.max(err.cross.abs());
                    stats.max_beta = stats.max_beta.max(err.beta.abs());
                    stats.max_dpsi = stats.max_dpsi.max(err.dpsi.abs());
                    stats.max_v = stats.max_v.max(err.v.abs());
                    self.e_hold = r.x[ix::E];
                    u
                }
                None => brake_to_stop(
                    &params,
                    &self.stop_gains,
                    &self.controller,
                    &y,
                    road,
                    self.e_hold,
                ),
            };
            self.controller.applied(u[iu::DELTA]);
            car.drive(u, road, self.substeps, self.plant_dt);
            self.log.step(&car.plant.x, road, e_plan);
            stats.e_lo = stats.e_lo.min(car.plant.x[ix::E]);
            stats.e_hi = stats.e_hi.max(car.plant.x[ix::E]);
        }
    }

    /// Publishes the plant state with its flags (running, stale, stopped, and `extra`);
    /// returns the message sent.
    fn publish(
        &mut self,
        ports: &Ports,
        now: Instant,
        extra: u32,
    ) -> Result<VehicleState, IpcError> {
        let mut flags = extra;
        if self.sim_start.is_some() {
            flags |= FLAG_RUNNING;
        }
        if self.stale {
            flags |= FLAG_STALE;
        }
        if self.car.plant.stopped {
            flags |= FLAG_STOPPED;
            if self.stopped_at.is_none() {
                self.stopped_at = Some(now);
                elog!("tracker: stopped at s = {:.1} m", self.car.plant.x[ix::S]);
            }
        }
        let seq = self.inbox.own.next_seq();
        let msg = VehicleState::new(self.sc.id, seq, flags, self.measured)
            .with_run_id(self.inbox.own.run_id());
        publish_state(&ports.publisher, &ports.notifier, msg)?;
        Ok(msg)
    }

    /// Why the run ends after the pass at `now`, if it does.
    fn end_reason(&self, args: &TrackerArgs, now: Instant) -> Option<&'static str> {
        if self.car.plant.x[ix::S] >= args.start_s + self.distance {
            return Some("distance reached");
        }
        if self.car.plant.x[ix::T] >= args.duration_s {
            return Some("duration reached");
        }
        if self.log.left_track() {
            return Some("left the track");
        }
        if let Some(at) = self.stopped_at {
            if now.duration_since(at).as_secs_f64() >= args.linger_s {
                return Some("stopped");
            }
        }
        None
    }

    /// Logs the outcome and returns the summary as JSON.
    fn report(&self, args: &TrackerArgs, end_reason: &str) -> serde_json::Value {
        let (plant, stats, inbox, road) =
            (&self.car.plant, &self.stats, &self.inbox, &self.sc.road);
        let rms_of = |sum: f64| {
            if stats.n > 0 {
                (sum / stats.n as f64).sqrt()
            } else {
                0.0
            }
        };
        let rms = rms_of(stats.sum_e2);
        let log = self.log.json();
        let lane_kept = log["lane_kept"].as_bool().unwrap_or(false);
        let driven = plant.x[ix::S] - args.start_s;
        elog!(
            "tracker: {end_reason}: {:.1} m in {:.2} s, {} plans ({} foreign ignored), max |e - e_plan| {:.3} m, rms {:.3} m, lane [{:.2}, {:.2}] m{}",
            plant.x[ix::S],
            plant.x[ix::T],
            inbox.plans,
            inbox.foreign.total(),
            stats.max_e,
            rms,
            stats.e_lo,
            stats.e_hi,
            if lane_kept { "" } else { " LEFT THE LANE" }
        );
        let us = |l: &Latency, q: f64| l.quantile_ns(q) as f64 * 1e-3;
        let stale_at_s = self.stale_at_s;
        let mut obj = serde_json::json!({
            "process": "tracker",
            "end_reason": end_reason,
            "laps_or_distance_m": driven,
            "laps": driven / road.lap(),
            "sim_time_s": plant.x[ix::T],
            "plans_received": inbox.plans,
            "no_plan_notices_received": inbox.notices,
            "plans_rejected": inbox.rejected,
            "plans_foreign": inbox.foreign.total(),
            "plans_foreign_by_reason": {
                "run_id": inbox.foreign.run_id,
                "state_seq": inbox.foreign.state_seq,
            },
            "run_id": format!("{:#018x}", inbox.own.run_id()),
            "plans_not_converged": self.plans_not_converged,
            "max_lateral_error_m": stats.max_e,
            "max_lateral_error_at_s_m": stats.max_e_s,
            "rms_lateral_error_m": rms,
            "max_cross_track_error_m": stats.max_cross,
            "rms_cross_track_error_m": rms_of(stats.sum_cross2),
            "max_sideslip_error_rad": stats.max_beta,
            "max_heading_error_rad": stats.max_dpsi,
            "max_speed_error_mps": stats.max_v,
            "e_min_reached_m": stats.e_lo,
            "e_max_reached_m": stats.e_hi,
            "lane_kept": lane_kept,
            "stale": self.ever_stale,
            "stale_at_sim_s": if stale_at_s.is_finite() { serde_json::json!(stale_at_s) } else { serde_json::Value::Null },
            "stopped": plant.stopped,
            "final_speed_mps": plant.x[ix::V],
            "plan_latency_ms_p50": us(&inbox.plan_lat, 0.5) * 1e-3,
            "plan_latency_ms_p99": us(&inbox.plan_lat, 0.99) * 1e-3,
            "ipc_latency_us_p50": us(&inbox.ipc_lat, 0.5),
            "ipc_latency_us_p99": us(&inbox.ipc_lat, 0.99),
            "ipc_latency_samples": inbox.ipc_lat.count(),
        });
        crate::mismatch::add_to_report(
            &mut obj,
            &args.mismatch,
            &self.mismatch,
            args.plant_vehicle.as_deref(),
            args.noise_seed,
            self.controller.preview_s(),
        );
        self.kinds.add_json(&mut obj);
        obj["lockstep"] = self
            .lockstep
            .as_ref()
            .map_or(serde_json::Value::Null, lockstep::Schedule::json);
        obj
    }
}

/// Runs the tracker process until done; returns its summary as JSON.
pub fn run(args: &TrackerArgs) -> Result<serde_json::Value, TrackerProcError> {
    let mut tl = TrackerLoop::setup(args)?;
    let ports = Ports::open(args)?;
    let started = Instant::now();
    elog!(
        "tracker: up (prefix {}, road {:#018x}, run id {:#018x}, plant dt {} s, control {} s, publish {} s, distance {:.1} m)",
        args.service_prefix,
        tl.sc.id,
        tl.inbox.own.run_id(),
        tl.plant_dt,
        args.control_dt_s,
        tl.publish_dt,
        tl.distance
    );
    let end_reason = if tl.lockstep.is_some() {
        lockstep::run(&mut tl, args, &ports)?
    } else {
        real_time(&mut tl, args, &ports, started)?
    };
    let mut report = tl.report(args, end_reason);
    laps::finish_report(&mut report, &tl.log, outcome(&tl, end_reason), tl.start);
    report["no_feasible_plan_braking"] = tl.no_feasible_plan.into();
    if let Some(dir) = &args.trace_dir {
        if let Err(e) = tl.log.write(dir) {
            elog!("tracker: --trace-dir: {e}");
        }
    }
    Ok(report)
}

/// The real-time loop: steps the simulation to the wall clock, publishes the state every
/// publish period and takes each plan as it comes; returns why the drive ended.
fn real_time(
    tl: &mut TrackerLoop,
    args: &TrackerArgs,
    ports: &Ports,
    started: Instant,
) -> Result<&'static str, TrackerProcError> {
    let mut next_pub = started;
    loop {
        if ports.stdin.closed() || ports.svc.termination_requested() {
            return Ok("stop requested");
        }
        let wait = next_pub
            .saturating_duration_since(Instant::now())
            .clamp(Duration::from_micros(100), Duration::from_millis(100));
        if let Err(e) = wait_events(&ports.listener, wait) {
            if ports.svc.termination_requested() {
                return Ok("stop requested");
            }
            return Err(e.into());
        }
        tl.receive(ports)?;
        let now = Instant::now();
        if tl.sim_start.is_none()
            && now.duration_since(started).as_secs_f64() > args.first_plan_timeout_s
        {
            return Err(TrackerProcError::NoPlan(args.first_plan_timeout_s));
        }
        if now < next_pub {
            continue;
        }
        tl.advance(args, now);
        tl.publish(ports, now, 0)?;
        next_pub += Duration::from_secs_f64(tl.publish_dt / args.time_scale);
        if next_pub < now {
            next_pub = now;
        }
        if let Some(reason) = tl.end_reason(args, now) {
            return Ok(reason);
        }
    }
}
