//! `trajopt closed-loop`: starts `planner_proc` and `tracker_proc` (ipc crate) on one
//! iceoryx2 service prefix, waits for the tracker to finish the drive, stops the planner by
//! closing its stdin, and summarises both processes' final JSON lines, with the laps, the
//! figures and the reference lap time ([`summary`]).

mod figures;
mod road;
mod summary;
mod trace;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::out::{errln, outln};
use crate::paths::resolve;

#[allow(rustdoc::broken_intra_doc_links)] // clap prints these docs as --help: unit brackets stay unescaped
#[derive(clap::Args, Debug)]
pub struct ClosedLoopArgs {
    /// Scenario file (a closed road such as the oval, or an obstacle file with --segment).
    #[arg(long, default_value = "config/scenarios/oval.toml")]
    scenario: PathBuf,
    /// Vehicle file.
    #[arg(long, default_value = "config/vehicles/lc500.toml")]
    vehicle: PathBuf,
    /// Solver settings file.
    #[arg(long, default_value = "config/solver.toml")]
    solver: PathBuf,
    /// Distance to drive [m] (0: --laps laps).
    #[arg(long, default_value_t = 0.0)]
    distance_m: f64,
    /// Simulated-time cap [s] (default: 60 s plus 1 s per 15 m of the laps).
    #[arg(long)]
    duration_s: Option<f64>,
    /// Replanning rate [Hz].
    #[arg(long, default_value_t = 10.0)]
    rate_hz: f64,
    /// Run the two processes in lockstep on simulated time (`ipc::lockstep`,
    /// docs/closed-loop.md): the tracker waits for each plan, each solve is bounded by
    /// --budget-ms / --lockstep-ms-per-iter iterations and its plan is driven that many
    /// modelled milliseconds after its state. The run repeats bit for bit on any machine
    /// and takes as long as its solves, not as the lap.
    #[arg(long)]
    lockstep: bool,
    /// Modelled time of one solver iteration in lockstep [ms] (default: the processes'
    /// own, 0.6).
    #[arg(long, requires = "lockstep")]
    lockstep_ms_per_iter: Option<f64>,
    /// iceoryx2 service prefix (default: unique per run).
    #[arg(long)]
    service_prefix: Option<String>,
    /// Folder holding planner_proc and tracker_proc (default: next to this executable).
    #[arg(long)]
    bin_dir: Option<PathBuf>,
    /// Print exactly one JSON object on stdout (summary goes to stderr).
    #[arg(long)]
    json: bool,
    /// Record the planner's inputs and outputs to this MCAP file (`planner_proc --record`).
    #[arg(long)]
    record: Option<PathBuf>,
    /// Vehicle file of the simulated car (tracker only; default: --vehicle).
    #[arg(long)]
    plant_vehicle: Option<PathBuf>,
    /// Plant mismatch (tracker only): none, default or a TOML file.
    #[arg(long, default_value = "none")]
    mismatch: String,
    /// Seed of the measurement noise (tracker only).
    #[arg(long, default_value_t = 1)]
    noise_seed: u64,
    /// Time constant of the tracker's state estimator [ms] (`tracker_proc
    /// --estimator-tau-ms`; 0: the raw measurement).
    #[arg(long, default_value_t = 20.0)]
    estimator_tau_ms: f64,
    /// Budget of one planning cycle's solve [ms] (`planner_proc --budget-ms`; default 80 %
    /// of the period).
    #[arg(long)]
    budget_ms: Option<f64>,
    /// Fraction of the vehicle file's friction and brake torques the plans use
    /// (`planner_proc --friction-scale`; the plant keeps its own).
    #[arg(long, default_value_t = 1.0)]
    friction_scale: f64,
    /// Guess of a cold solve: equilibrium or road_speed (`planner_proc --cold-guess`).
    #[arg(long, default_value = "equilibrium", value_parser = ["equilibrium", "road_speed"])]
    cold_guess: String,
    /// Warm-start each plan from the previous one, shifted to the car (`planner_proc
    /// --warm-start`; docs/solver.md); `off` starts every plan from the cold guess.
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    warm_start: String,
    /// Tire saturation rows at each plan's last node too (`planner_proc
    /// --saturation-at-end`; docs/modelling.md).
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    saturation_at_end: String,
    /// How a warm start's first barrier parameter is matched to the shifted point:
    /// geometric or mean (`planner_proc --warm-mu`).
    #[arg(long, default_value = "geometric", value_parser = ["geometric", "mean"])]
    warm_mu: String,
    /// Multiple of the geometric mean for `--warm-mu geometric` (`planner_proc
    /// --warm-mu-factor`).
    #[arg(long, default_value_t = 30.0)]
    warm_mu_factor: f64,
    /// Iterations a warm-started solve may take before it falls back to the cold guess
    /// (`planner_proc --warm-max-iter`; default: the solver's cap).
    #[arg(long, value_name = "K")]
    warm_max_iter: Option<usize>,
    /// Iterations a warm-started solve may take after a cycle whose solve did not succeed
    /// (`planner_proc --warm-max-iter-after-failure`).
    #[arg(long, value_name = "K", default_value_t = 40)]
    warm_max_iter_after_failure: usize,
    /// Lane margin of a relaxed plan [m] (`planner_proc --relaxed-margin-m`): after a
    /// cycle without a plan of its own, the next cycles on a closed road plan with the tire
    /// saturation bound `--relaxed-saturation`, the grip `--relaxed-friction-scale` and this
    /// margin.
    #[arg(long, default_value_t = 0.6)]
    relaxed_margin_m: f64,
    /// Distance over which a plan's lane margin ramps in from the car's own distance inside
    /// an edge [m] (`planner_proc --margin-ramp-m`; default 20).
    #[arg(long)]
    margin_ramp_m: Option<f64>,
    /// Smallest arc-length scale 1 - kappa e of the road frame a plan may use
    /// (`planner_proc --min-path-scale`; 0: the lane edges only).
    #[arg(long, default_value_t = 0.0)]
    min_path_scale: f64,
    /// Closest to an edge that ramp starts for a car moving toward the edge [m]
    /// (`planner_proc --margin-floor-m`; default 0.3; negative: past the edge).
    #[arg(long, allow_hyphen_values = true)]
    margin_floor_m: Option<f64>,
    /// Soft lane margin from each edge of a closed road [m] (`planner_proc
    /// --soft-lane-m`; default 1.9 on a track, else 0: none): a penalty in the objective,
    /// not a bound.
    #[arg(long)]
    soft_lane_m: Option<f64>,
    /// Weight of the soft lane's penalty [s/m^2] (`planner_proc --soft-lane-weight`;
    /// default 10).
    #[arg(long)]
    soft_lane_weight: Option<f64>,
    /// Bound each plan's end speed by the speed from which the car can still brake for the
    /// curves past the window (`planner_proc --end-speed-envelope`; default on on a track,
    /// else off).
    #[arg(long, value_parser = ["on", "off"])]
    end_speed_envelope: Option<String>,
    /// Tire saturation bound of a relaxed plan (`planner_proc --relaxed-saturation`).
    #[arg(long, default_value_t = 0.05)]
    relaxed_saturation: f64,
    /// Fraction of the vehicle file's friction and brake torques a relaxed plan uses
    /// (`planner_proc --relaxed-friction-scale`; 0.5 to 1, at least `--friction-scale`;
    /// default: `--friction-scale`).
    #[arg(long)]
    relaxed_friction_scale: Option<f64>,
    /// Relaxed cycles in a row with their own plan before the nominal problem resumes
    /// (`planner_proc --relaxed-cycles`; 0: never relax).
    #[arg(long, default_value_t = 10)]
    relaxed_cycles: u32,
    /// Keep the tracker's driven trace and plan log (driven.csv, plans.csv) in this folder
    /// (default: a temporary folder removed after the run).
    #[arg(long)]
    trace_dir: Option<PathBuf>,
    #[command(flatten)]
    road: road::RoadOpts,
}

/// Soft lane margin of the plans on a track when not given \[m\] (docs/closed-loop.md).
const TRACK_SOFT_LANE_M: f64 = 1.9;

impl ClosedLoopArgs {
    /// The soft lane margin of the plans \[m\]: as given, else [`TRACK_SOFT_LANE_M`] on a
    /// track and none on a scenario road.
    pub fn soft_lane(&self) -> f64 {
        self.soft_lane_m.unwrap_or(if self.on_track() {
            TRACK_SOFT_LANE_M
        } else {
            0.0
        })
    }

    /// Whether the plans' end speed is bounded by the road's speed envelope: as given,
    /// else on a track only.
    pub fn end_speed_envelope(&self) -> &str {
        match self.end_speed_envelope.as_deref() {
            Some(v) => v,
            None if self.on_track() => "on",
            None => "off",
        }
    }

    /// True when the road is a track (`--track` or `--track-profile`).
    fn on_track(&self) -> bool {
        self.road.track.is_some() || self.road.track_profile.is_some()
    }

    /// The simulated-time cap: as given, else 60 s plus 1 s per 15 m of the drive.
    fn duration(&self, lap_m: f64) -> f64 {
        self.duration_s.unwrap_or_else(|| {
            let drive = if self.distance_m > 0.0 {
                self.distance_m
            } else {
                self.road.laps as f64 * lap_m
            };
            60.0 + drive / 15.0
        })
    }
}

/// Kills a child on drop unless it was waited for (no orphans on error paths).
struct ChildGuard(Option<Child>);

impl Drop for ChildGuard {
    fn drop(&mut self) {
        if let Some(c) = self.0.as_mut() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// Waits for a child up to `limit`; kills it on timeout. Returns (exit ok, stdout).
fn wait_child(guard: &mut ChildGuard, limit: Duration) -> Result<(bool, String), String> {
    wait_child_beside(guard, None, limit)
}

/// [`wait_child`], and gives up at once when `partner` exits first with a failure (the
/// planner refused its options or files: the tracker would otherwise wait out its
/// first-plan timeout for a plan that never comes).
fn wait_child_beside(
    guard: &mut ChildGuard,
    mut partner: Option<&mut ChildGuard>,
    limit: Duration,
) -> Result<(bool, String), String> {
    use std::io::Read;
    let Some(mut child) = guard.0.take() else {
        return Err("child already reaped".into());
    };
    let start = Instant::now();
    loop {
        let partner_failed = partner
            .as_mut()
            .and_then(|p| p.0.as_mut())
            .and_then(|c| c.try_wait().ok().flatten())
            .is_some_and(|status| !status.success());
        if partner_failed {
            let _ = child.kill();
            let _ = child.wait();
            return Err("planner_proc failed (see its log above)".into());
        }
        match child.try_wait() {
            Ok(Some(status)) => {
                let mut out = String::new();
                if let Some(mut so) = child.stdout.take() {
                    let _ = so.read_to_string(&mut out);
                }
                return Ok((status.success(), out));
            }
            Ok(None) if start.elapsed() < limit => std::thread::sleep(Duration::from_millis(50)),
            Ok(None) => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!(
                    "timed out after {:.0} s; killed",
                    limit.as_secs_f64()
                ));
            }
            Err(e) => return Err(e.to_string()),
        }
    }
}

/// The last line of `out` that parses as JSON (Null when none does).
fn last_json(out: &str) -> serde_json::Value {
    out.lines()
        .rev()
        .find_map(|l| serde_json::from_str(l).ok())
        .unwrap_or(serde_json::Value::Null)
}

/// The paths of `planner_proc` and `tracker_proc` in `--bin-dir`, or else next to this
/// executable.
fn executables(args: &ClosedLoopArgs) -> Result<(PathBuf, PathBuf), String> {
    let bin_dir = match args.bin_dir.clone() {
        Some(d) => d,
        None => std::env::current_exe()
            .ok()
            .and_then(|p| p.parent().map(Path::to_path_buf))
            .ok_or("cannot locate this executable's folder; pass --bin-dir")?,
    };
    let exe = |name: &str| -> Result<PathBuf, String> {
        let p = bin_dir.join(name);
        if p.is_file() {
            Ok(p)
        } else {
            Err(format!(
                "{} not found (build it with `cargo build -p ipc --bins` in the same profile, or pass --bin-dir)",
                p.display()
            ))
        }
    };
    Ok((exe("planner_proc")?, exe("tracker_proc")?))
}

/// Starts the planner, then the tracker, both on the input files and service `prefix`.
fn spawn_pair(
    args: &ClosedLoopArgs,
    (planner_exe, tracker_exe): &(PathBuf, PathBuf),
    prefix: &str,
    (duration_s, trace_dir): (f64, &Path),
) -> Result<(ChildGuard, ChildGuard), String> {
    let files = |c: &mut Command| {
        c.arg("--scenario")
            .arg(resolve(&args.scenario))
            .arg("--vehicle")
            .arg(resolve(&args.vehicle))
            .arg("--solver")
            .arg(resolve(&args.solver))
            .arg("--service-prefix")
            .arg(prefix)
            .arg("--exit-on-stdin-eof")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit());
        args.road.pass(c);
        c.arg("--rate-hz").arg(args.rate_hz.to_string());
        if args.lockstep {
            c.arg("--lockstep");
        }
        if let Some(ms) = args.lockstep_ms_per_iter {
            c.arg("--lockstep-ms-per-iter").arg(ms.to_string());
        }
    };
    let mut pc = Command::new(planner_exe);
    files(&mut pc);
    planner_options(args, &mut pc);
    let planner = ChildGuard(Some(
        pc.spawn()
            .map_err(|e| format!("{}: {e}", planner_exe.display()))?,
    ));
    let mut tc = Command::new(tracker_exe);
    files(&mut tc);
    tracker_options(args, (duration_s, trace_dir), &mut tc);
    let tracker = ChildGuard(Some(
        tc.spawn()
            .map_err(|e| format!("{}: {e}", tracker_exe.display()))?,
    ));
    Ok((planner, tracker))
}

/// The planner's own options (`planner_proc`): its budget, lane, warm start and grip.
fn planner_options(args: &ClosedLoopArgs, pc: &mut Command) {
    if let Some(path) = &args.record {
        pc.arg("--record").arg(path);
    }
    if let Some(ms) = args.budget_ms {
        pc.arg("--budget-ms").arg(ms.to_string());
    }
    if let Some(m) = args.margin_ramp_m {
        pc.arg("--margin-ramp-m").arg(m.to_string());
    }
    if let Some(m) = args.margin_floor_m {
        // One token: a negative floor would otherwise read as an option.
        pc.arg(format!("--margin-floor-m={m}"));
    }
    // Any value but the default 0 goes on, so that planner_proc refuses a bad one.
    let soft = args.soft_lane();
    if soft != 0.0 {
        pc.arg("--soft-lane-m").arg(soft.to_string());
    }
    if let Some(w) = args.soft_lane_weight {
        pc.arg("--soft-lane-weight").arg(w.to_string());
    }
    if let Some(k) = args.warm_max_iter {
        pc.arg("--warm-max-iter").arg(k.to_string());
    }
    pc.arg("--warm-max-iter-after-failure")
        .arg(args.warm_max_iter_after_failure.to_string());
    pc.arg("--end-speed-envelope")
        .arg(args.end_speed_envelope())
        .arg("--warm-start")
        .arg(&args.warm_start)
        .arg("--saturation-at-end")
        .arg(&args.saturation_at_end)
        .arg("--cold-guess")
        .arg(&args.cold_guess)
        .arg("--warm-mu")
        .arg(&args.warm_mu)
        .arg("--warm-mu-factor")
        .arg(args.warm_mu_factor.to_string())
        .arg("--friction-scale")
        .arg(args.friction_scale.to_string())
        .arg("--relaxed-margin-m")
        .arg(args.relaxed_margin_m.to_string())
        .arg("--min-path-scale")
        .arg(args.min_path_scale.to_string())
        .arg("--relaxed-cycles")
        .arg(args.relaxed_cycles.to_string())
        .arg("--relaxed-saturation")
        .arg(args.relaxed_saturation.to_string());
    if let Some(f) = args.relaxed_friction_scale {
        pc.arg("--relaxed-friction-scale").arg(f.to_string());
    }
}

/// The tracker's own options (`tracker_proc`): the run's length, its start and the
/// plant, which the planner never sees.
fn tracker_options(args: &ClosedLoopArgs, (duration_s, trace_dir): (f64, &Path), tc: &mut Command) {
    tc.arg("--duration-s")
        .arg(duration_s.to_string())
        .arg("--distance-m")
        .arg(args.distance_m.to_string())
        .arg("--laps")
        .arg(args.road.laps.to_string())
        .arg("--start-s")
        .arg(args.road.start_s.to_string())
        .arg("--trace-dir")
        .arg(trace_dir);
    // A flying start (free-start solve) on a track; a scenario road starts from its own
    // fixed initial state, else at the tracker's cruise speed.
    let on_track = args.road.track.is_some() || args.road.track_profile.is_some();
    match args.road.initial_speed_mps {
        Some(v) => {
            tc.arg("--v0").arg(v.to_string());
        }
        None if on_track => {
            tc.arg("--free-start")
                .arg("--friction-scale")
                .arg(args.friction_scale.to_string());
        }
        None => {}
    }
    // The plant's settings go to the tracker only: the planner never sees them.
    tc.arg("--mismatch")
        .arg(mismatch_arg(&args.mismatch))
        .arg("--noise-seed")
        .arg(args.noise_seed.to_string())
        .arg("--estimator-tau-ms")
        .arg(args.estimator_tau_ms.to_string());
    if let Some(path) = &args.plant_vehicle {
        tc.arg("--plant-vehicle").arg(resolve(path));
    }
}

/// `none` and `default` as they are; a file path resolved like the other input files.
fn mismatch_arg(m: &str) -> std::ffi::OsString {
    match m {
        "none" | "default" => m.into(),
        path => resolve(Path::new(path)).into_os_string(),
    }
}

/// Runs the closed loop and prints its summary (one JSON object with `--json`).
pub fn run(args: ClosedLoopArgs) -> Result<(), String> {
    // The road is read here first, so a bad file is refused before anything starts.
    let map = road::road_map(&args.road, &args.scenario, &args.vehicle)?;
    let duration_s = args.duration(map.length);
    if !(duration_s > 0.0 && duration_s <= 3600.0 && args.distance_m >= 0.0) {
        return Err("need 0 < --duration-s <= 3600 and --distance-m >= 0".into());
    }
    let exes = executables(&args)?;
    let prefix = args.service_prefix.clone().unwrap_or_else(|| {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos());
        format!("trajopt-{}-{nanos}", std::process::id())
    });
    let (trace_dir, _cleanup) = match &args.trace_dir {
        Some(dir) => (resolve(dir), None),
        None => {
            let dir = std::env::temp_dir().join(format!("{prefix}-trace"));
            (dir.clone(), Some(summary::RemoveOnDrop(dir)))
        }
    };
    let (mut planner, mut tracker) = spawn_pair(&args, &exes, &prefix, (duration_s, &trace_dir))?;
    // Simulated time runs at wall-clock speed; the first plan may take a while on a loaded machine.
    let limit = Duration::from_secs_f64(duration_s + 180.0);
    planner::progress::begin(0, "closed loop: driving");
    let waited = wait_child_beside(&mut tracker, Some(&mut planner), limit);
    planner::progress::end();
    let (tracker_ok, tracker_out) = waited?;
    // Stop the planner by closing its stdin.
    if let Some(c) = planner.0.as_mut() {
        drop(c.stdin.take());
    }
    let (planner_ok, planner_out) = wait_child(&mut planner, Duration::from_secs(30))?;
    let t = last_json(&tracker_out);
    let p = last_json(&planner_out);
    if !tracker_ok || t.is_null() {
        return Err("tracker_proc failed (see its log above)".into());
    }
    if !planner_ok || p.is_null() {
        return Err("planner_proc failed (see its log above)".into());
    }
    let mut obj = summary_json(&args, &prefix, t, p);
    summary::extend(&args, &map, &trace_dir, &mut obj);
    let summary = format!("{}\n{}", summary_text(&obj), summary::text(&obj));
    if args.json {
        errln!("{summary}");
        outln!("{obj}");
    } else {
        outln!("{summary}");
    }
    Ok(())
}

/// The JSON summary: the tracker's figures of merit at the top level, both processes'
/// final reports in full under `tracker` and `planner`.
fn summary_json(
    args: &ClosedLoopArgs,
    prefix: &str,
    t: serde_json::Value,
    p: serde_json::Value,
) -> serde_json::Value {
    let f = |k: &str| t.get(k).cloned().unwrap_or(serde_json::Value::Null);
    serde_json::json!({
        "scenario": resolve(&args.scenario).display().to_string(),
        "service_prefix": prefix,
        "laps_or_distance_m": f("laps_or_distance_m"),
        "laps": f("laps"),
        "plans_received": f("plans_received"),
        "max_lateral_error_m": f("max_lateral_error_m"),
        "rms_lateral_error_m": f("rms_lateral_error_m"),
        "max_cross_track_error_m": f("max_cross_track_error_m"),
        "max_lateral_error_at_s_m": f("max_lateral_error_at_s_m"),
        "rms_cross_track_error_m": f("rms_cross_track_error_m"),
        "max_sideslip_error_rad": f("max_sideslip_error_rad"),
        "lane_kept": f("lane_kept"),
        "mismatch": f("mismatch"),
        "plan_latency_ms_p50": f("plan_latency_ms_p50"),
        "plan_latency_ms_p99": f("plan_latency_ms_p99"),
        "ipc_latency_us_p50": f("ipc_latency_us_p50"),
        "ipc_latency_us_p99": f("ipc_latency_us_p99"),
        "plans_converged": f("plans_converged"),
        "plans_best_iterate": f("plans_best_iterate"),
        "plans_previous_shifted": f("plans_previous_shifted"),
        "budget_ms": p.get("budget_ms").cloned().unwrap_or(serde_json::Value::Null),
        "clock": if args.lockstep { "lockstep" } else { "real_time" },
        "lockstep": p.get("lockstep").cloned().unwrap_or(serde_json::Value::Null),
        "tracker": t,
        "planner": p,
    })
}

/// The one-line human summary of [`summary_json`]'s object.
fn summary_text(obj: &serde_json::Value) -> String {
    format!(
        "closed loop: {:.1} m ({:.2} laps), {} plans, lateral error vs plan max {:.3} m rms {:.3} m \
         (across the path max {:.3} m), max sideslip error {:.3} rad, lane kept {}; plan latency p50 {:.1} ms p99 {:.1} ms; \
         IPC latency p50 {:.1} us p99 {:.1} us; budget {} ms, plans driven: {} converged, \
         {} best iterates, {} previous shifted",
        obj["laps_or_distance_m"].as_f64().unwrap_or(f64::NAN),
        obj["laps"].as_f64().unwrap_or(f64::NAN),
        obj["plans_received"],
        obj["max_lateral_error_m"].as_f64().unwrap_or(f64::NAN),
        obj["rms_lateral_error_m"].as_f64().unwrap_or(f64::NAN),
        obj["max_cross_track_error_m"].as_f64().unwrap_or(f64::NAN),
        obj["max_sideslip_error_rad"].as_f64().unwrap_or(f64::NAN),
        obj["lane_kept"],
        obj["plan_latency_ms_p50"].as_f64().unwrap_or(f64::NAN),
        obj["plan_latency_ms_p99"].as_f64().unwrap_or(f64::NAN),
        obj["ipc_latency_us_p50"].as_f64().unwrap_or(f64::NAN),
        obj["ipc_latency_us_p99"].as_f64().unwrap_or(f64::NAN),
        obj["budget_ms"],
        obj["plans_converged"],
        obj["plans_best_iterate"],
        obj["plans_previous_shifted"],
    )
}
