//! The tracker process: simulates the plant in real time (RK4 at a fixed step), tracks the
//! latest valid trajectory (feed-forward + feedback), publishes the vehicle state at a
//! fixed rate, flags a stale plan and brakes to a stop, and reports tracking errors.
//!
//! Each run draws its own run id, stamps it on every state it publishes and follows only
//! plans made from its own states ([`Ownership`]); other valid plans are counted as foreign.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use planner::model::ix;

use crate::clock::monotonic_ns;
use crate::msg::{
    new_run_id, RoadId, RunId, Trajectory, VehicleState, FLAG_RUNNING, FLAG_STALE, FLAG_STOPPED,
};
use crate::plant::Plant;
use crate::road::Scenario;
use crate::services::{ipc_err, publish_state, wait_events, IpcError, Services};
use crate::shutdown::StdinWatch;
use crate::stats::Latency;
use crate::tracker::{brake_to_stop, reference, track, ForeignPlans, Gains, Ownership};

/// Command-line options of `tracker_proc`.
#[derive(clap::Args, Debug, Clone)]
pub struct TrackerArgs {
    /// Scenario file (a closed road).
    #[arg(long, default_value = "config/scenarios/oval.toml")]
    pub scenario: PathBuf,
    /// Vehicle file.
    #[arg(long, default_value = "config/vehicles/lc500.toml")]
    pub vehicle: PathBuf,
    /// Solver settings file (read for the road id only).
    #[arg(long, default_value = "config/solver.toml")]
    pub solver: PathBuf,
    /// iceoryx2 service-name prefix (unique per closed loop).
    #[arg(long, default_value = crate::services::DEFAULT_PREFIX)]
    pub service_prefix: String,
    /// Distance to drive before stopping [m] (0: one lap).
    #[arg(long, default_value_t = 0.0)]
    pub distance_m: f64,
    /// Simulated time after which to stop regardless [s].
    #[arg(long, default_value_t = 60.0)]
    pub duration_s: f64,
    /// Start speed [m/s] (straight-line cruise at s = 0, lane centre).
    #[arg(long, default_value_t = 15.0)]
    pub v0: f64,
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
            args.v0,
            args.v0 > 3.0 && args.v0.is_finite(),
            "must be finite and > 3 m/s",
        ),
    ];
    match checks.iter().find(|c| !c.2) {
        Some((name, value, _, expected)) => Err(TrackerProcError::Setup(format!(
            "{name} = {value}: {expected}"
        ))),
        None => Ok(()),
    }
}

/// Receives plans: drops invalid ones, refuses foreign ones ([`Ownership`]) and counts
/// both; times the run's own plans.
struct Inbox {
    own: Ownership,
    /// Own valid plans.
    plans: u64,
    /// Invalid plans.
    rejected: u64,
    foreign: ForeignPlans,
    ipc_lat: Latency,
    plan_lat: Latency,
}

impl Inbox {
    fn new(run_id: RunId) -> Self {
        Self {
            own: Ownership::new(run_id),
            plans: 0,
            rejected: 0,
            foreign: ForeignPlans::default(),
            ipc_lat: Latency::new(),
            plan_lat: Latency::new(),
        }
    }

    /// True when `m` is a valid plan of this run (received at `now_ns`); logs the first
    /// invalid and foreign ones. Allocates nothing unless it logs.
    fn accept(&mut self, m: &Trajectory, road: RoadId, ds: f64, now_ns: u64) -> bool {
        if let Err(e) = m.validate_for(road, ds) {
            self.rejected += 1;
            if self.rejected <= 10 {
                eprintln!("tracker: dropped trajectory seq {}: {e}", m.seq);
            }
            return false;
        }
        // A valid plan made from another run's state is never followed.
        if let Err(f) = self.own.check(m) {
            self.foreign.count(&f);
            let n = self.foreign.total();
            if n <= 10 || n.is_multiple_of(1000) {
                eprintln!(
                    "tracker: ignored foreign trajectory seq {} ({n} so far): {f}",
                    m.seq
                );
            }
            return false;
        }
        self.ipc_lat.record_ns(now_ns.saturating_sub(m.stamp_ns));
        self.plan_lat
            .record_ns(now_ns.saturating_sub(m.from_state_stamp_ns));
        self.plans += 1;
        true
    }
}

/// Runs the tracker process until done; returns its summary as JSON.
pub fn run(args: &TrackerArgs) -> Result<serde_json::Value, TrackerProcError> {
    check_args(args)?;
    let sc = Scenario::load(&args.scenario, &args.vehicle, &args.solver)
        .map_err(|e| TrackerProcError::Setup(e.to_string()))?;
    let road = &sc.road;
    let params = sc.spec.vehicle;
    let gains = Gains::default();
    let distance = if args.distance_m > 0.0 {
        args.distance_m
    } else {
        road.lap()
    };
    let substeps = (args.control_dt_s / args.plant_dt_s).round().max(1.0) as usize;
    let plant_dt = args.control_dt_s / substeps as f64;
    let per_publish = (args.publish_dt_s / args.control_dt_s).round().max(1.0) as usize;
    let publish_dt = per_publish as f64 * args.control_dt_s;

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

    let mut plant = Plant::cruise(params, args.v0);
    let mut plan: Box<Trajectory> = Box::new(Trajectory {
        ds: 1.0,
        ..Trajectory::zeroed()
    });
    let mut have_plan = false;
    let mut inbox = Inbox::new(new_run_id());
    let mut plans_not_converged = 0u64;
    let mut last_plan_at = Instant::now();
    let mut stats = Track::default();
    let mut ever_stale = false;
    let mut stale = false;
    let mut stale_at_s = f64::NAN;
    let mut stopped_at: Option<Instant> = None;
    let mut e_hold = 0.0;

    let started = Instant::now();
    let mut sim_start: Option<Instant> = None;
    let mut next_pub = started;
    eprintln!(
        "tracker: up (prefix {}, road {:#018x}, run id {:#018x}, plant dt {plant_dt} s, control {} s, publish {publish_dt} s, distance {distance:.1} m)",
        args.service_prefix,
        sc.id,
        inbox.own.run_id(),
        args.control_dt_s
    );
    let end_reason;
    loop {
        if stdin.closed() || svc.termination_requested() {
            end_reason = "stop requested";
            break;
        }
        let wait = next_pub
            .saturating_duration_since(Instant::now())
            .clamp(Duration::from_micros(100), Duration::from_millis(100));
        if let Err(e) = wait_events(&listener, wait) {
            if svc.termination_requested() {
                end_reason = "stop requested";
                break;
            }
            return Err(e.into());
        }
        while let Some(sample) = sub.receive().map_err(ipc_err("receive trajectory"))? {
            let m: &Trajectory = sample.payload();
            if !inbox.accept(m, sc.id, sc.ds(), monotonic_ns()) {
                continue;
            }
            let converged = matches!(m.status, 0 | 1);
            // A non-converged best iterate replaces the active plan only when that
            // plan no longer covers the car (or there is none yet).
            let covered = have_plan && reference(&plan, plant.x[ix::S] - plan.s_origin).is_some();
            if !converged {
                plans_not_converged += 1;
                if covered && !stale {
                    continue;
                }
            }
            *plan = *m;
            have_plan = true;
            last_plan_at = Instant::now();
            if stale && !plant.stopped {
                eprintln!("tracker: fresh plan {} after stale period; resuming", m.seq);
                stale = false;
            }
            if sim_start.is_none() {
                sim_start = Some(Instant::now());
                eprintln!(
                    "tracker: first plan {} ({} iterations); running",
                    m.seq, m.iterations
                );
            }
        }
        let now = Instant::now();
        if sim_start.is_none()
            && now.duration_since(started).as_secs_f64() > args.first_plan_timeout_s
        {
            return Err(TrackerProcError::NoPlan(args.first_plan_timeout_s));
        }
        if now < next_pub {
            continue;
        }
        // Advance the simulation to the wall clock (bounded: at most 1 s of sim per pass).
        if let Some(t0) = sim_start {
            if !stale
                && have_plan
                && now.duration_since(last_plan_at).as_secs_f64() > args.stale_after_s
            {
                stale = true;
                ever_stale = true;
                stale_at_s = plant.x[ix::T];
                e_hold = plant.x[ix::E];
                eprintln!(
                    "tracker: plan {} is stale (no new plan for {:.2} s); braking to a stop",
                    plan.seq, args.stale_after_s
                );
            }
            let target_t = now.duration_since(t0).as_secs_f64() * args.time_scale;
            let max_steps = (1.0 / args.control_dt_s) as usize;
            let mut steps = 0;
            while plant.x[ix::T] + 0.5 * args.control_dt_s < target_t && steps < max_steps {
                steps += 1;
                let s_local = plant.x[ix::S] - plan.s_origin;
                let r = if stale {
                    None
                } else {
                    reference(&plan, s_local)
                };
                let u = match r {
                    Some(r) => {
                        let (u, err) = track(&params, &gains, &plant.x, &r);
                        stats.n += 1;
                        stats.sum_e2 += err.e * err.e;
                        stats.max_e = stats.max_e.max(err.e.abs());
                        stats.max_beta = stats.max_beta.max(err.beta.abs());
                        stats.max_dpsi = stats.max_dpsi.max(err.dpsi.abs());
                        stats.max_v = stats.max_v.max(err.v.abs());
                        e_hold = r.x[ix::E];
                        u
                    }
                    None => brake_to_stop(&params, &gains, &plant.x, road, e_hold),
                };
                for _ in 0..substeps {
                    plant.step(u, road, plant_dt);
                }
                stats.e_lo = stats.e_lo.min(plant.x[ix::E]);
                stats.e_hi = stats.e_hi.max(plant.x[ix::E]);
            }
        }
        let mut flags = 0;
        if sim_start.is_some() {
            flags |= FLAG_RUNNING;
        }
        if stale {
            flags |= FLAG_STALE;
        }
        if plant.stopped {
            flags |= FLAG_STOPPED;
            if stopped_at.is_none() {
                stopped_at = Some(now);
                eprintln!("tracker: stopped at s = {:.1} m", plant.x[ix::S]);
            }
        }
        let seq = inbox.own.next_seq();
        publish_state(
            &publisher,
            &notifier,
            VehicleState::new(sc.id, seq, flags, plant.x).with_run_id(inbox.own.run_id()),
        )?;
        next_pub += Duration::from_secs_f64(publish_dt / args.time_scale);
        if next_pub < now {
            next_pub = now;
        }
        if plant.x[ix::S] >= distance {
            end_reason = "distance reached";
            break;
        }
        if plant.x[ix::T] >= args.duration_s {
            end_reason = "duration reached";
            break;
        }
        if let Some(at) = stopped_at {
            if now.duration_since(at).as_secs_f64() >= args.linger_s {
                end_reason = "stopped";
                break;
            }
        }
    }
    let rms = if stats.n > 0 {
        (stats.sum_e2 / stats.n as f64).sqrt()
    } else {
        0.0
    };
    let lane_kept = stats.e_lo >= road.e_min() && stats.e_hi <= road.e_max();
    eprintln!(
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
    Ok(serde_json::json!({
        "process": "tracker",
        "end_reason": end_reason,
        "laps_or_distance_m": plant.x[ix::S],
        "laps": plant.x[ix::S] / road.lap(),
        "sim_time_s": plant.x[ix::T],
        "plans_received": inbox.plans,
        "plans_rejected": inbox.rejected,
        "plans_foreign": inbox.foreign.total(),
        "plans_foreign_by_reason": {
            "run_id": inbox.foreign.run_id,
            "state_seq": inbox.foreign.state_seq,
        },
        "run_id": format!("{:#018x}", inbox.own.run_id()),
        "plans_not_converged": plans_not_converged,
        "max_lateral_error_m": stats.max_e,
        "rms_lateral_error_m": rms,
        "max_sideslip_error_rad": stats.max_beta,
        "max_heading_error_rad": stats.max_dpsi,
        "max_speed_error_mps": stats.max_v,
        "e_min_reached_m": stats.e_lo,
        "e_max_reached_m": stats.e_hi,
        "lane_kept": lane_kept,
        "stale": ever_stale,
        "stale_at_sim_s": if stale_at_s.is_finite() { serde_json::json!(stale_at_s) } else { serde_json::Value::Null },
        "stopped": plant.stopped,
        "final_speed_mps": plant.x[ix::V],
        "plan_latency_ms_p50": us(&inbox.plan_lat, 0.5) * 1e-3,
        "plan_latency_ms_p99": us(&inbox.plan_lat, 0.99) * 1e-3,
        "ipc_latency_us_p50": us(&inbox.ipc_lat, 0.5),
        "ipc_latency_us_p99": us(&inbox.ipc_lat, 0.99),
        "ipc_latency_samples": inbox.ipc_lat.count(),
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{status_code, MSG_VERSION};
    use planner::ip::Status;

    /// A valid plan on road 7 (grid 2.5 m) made from state `seq` of run `run_id`.
    fn plan(run_id: RunId, seq: u64) -> Box<Trajectory> {
        let x = [0.0, 15.0, 0.0, 15.0, 0.0, 0.0, 0.0, 3.0, 1.0];
        let mut p = Box::new(Trajectory::zeroed());
        p.version = MSG_VERSION;
        p.status = status_code(Status::Optimal);
        p.road_id = 7;
        p.ds = 2.5;
        p.x_from = x;
        p.x = [x; crate::msg::HORIZON_N + 1];
        p.from_run_id = run_id;
        p.from_state_seq = seq;
        p
    }

    #[test]
    fn the_inbox_takes_own_plans_and_counts_foreign_and_invalid_ones() {
        let mut inbox = Inbox::new(0xabc);
        inbox.own.next_seq();
        inbox.own.next_seq();
        // Own plans from states 1 and 2.
        assert!(inbox.accept(&plan(0xabc, 1), 7, 2.5, 10));
        assert!(inbox.accept(&plan(0xabc, 2), 7, 2.5, 10));
        // A predecessor's plan, and an own-run plan from a state not yet published.
        assert!(!inbox.accept(&plan(0xdef, 2), 7, 2.5, 10));
        assert!(!inbox.accept(&plan(0xabc, 3), 7, 2.5, 10));
        // An invalid plan is rejected, not foreign.
        assert!(!inbox.accept(&plan(0xabc, 1), 8, 2.5, 10));
        assert_eq!(inbox.plans, 2);
        assert_eq!(inbox.rejected, 1);
        assert_eq!(
            inbox.foreign,
            ForeignPlans {
                run_id: 1,
                state_seq: 1
            }
        );
        assert_eq!(inbox.ipc_lat.count(), 2);
    }
}
