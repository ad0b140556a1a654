//! `trajopt`: command-line front end of the planner.
//!
//! `trajopt solve` solves one scenario (the oval by default) from the equilibrium or zero
//! guess, prints a summary (stderr with `--json`, whose single JSON object goes to stdout),
//! and writes the trajectory as CSV and a PNG figure; `--record FILE.mcap` records every
//! solve's input and output for `replay`. Exit code 0 when the solve ran, whatever its
//! status; 2 on bad input.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};
use plan_record::{now_ns, Record, Recorder};
use planner::config::{load_scenario, load_solver, load_vehicle};
use planner::guess::GuessKind;
use planner::ip::kkt::KktBackendKind;
use planner::ip::{BarrierRule, SolveInfo};
use planner::plan::Planner;

/// The horizon every shipped scenario uses (paper: N = 100).
const N: usize = 100;

#[derive(Parser, Debug)]
#[command(
    name = "trajopt",
    version,
    about = "Reference-free minimum-time trajectory optimizer"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Solve one scenario (default: the oval) and write CSV + PNG.
    Solve(SolveArgs),
    /// Compute and print the equilibrium initial guess of a vehicle (paper eq. 8).
    Guess(GuessArgs),
    /// Run the planner and tracker processes (ipc crate) in closed loop and summarise.
    ClosedLoop(ClosedLoopArgs),
    /// Reproduce a study of the paper (tables + PNG; `--json` for one JSON object).
    #[command(subcommand)]
    Study(StudyCommand),
}

#[derive(Subcommand, Debug)]
enum StudyCommand {
    /// The nine integrators vs the Gauss-Legendre 3 ground truth (paper Table I, Fig. 4a).
    Integrators(IntegratorsArgs),
    /// Stiffness ratio and participation factors along the optimal oval (paper Fig. 3).
    Stiffness(StiffnessArgs),
    /// Segments S01-S10 from the equilibrium and the zero guess (Tables II, III; Fig. 5).
    Segments(StudySegmentsArgs),
    /// The oval with each of the six barrier rules (Table IV).
    Barrier(StudyBarrierArgs),
}

#[derive(clap::Args, Debug)]
struct StudyFiles {
    /// Scenario file.
    #[arg(long, default_value = "config/scenarios/oval.toml")]
    scenario: PathBuf,
    /// Vehicle file.
    #[arg(long, default_value = "config/vehicles/lc500.toml")]
    vehicle: PathBuf,
    /// Solver settings file (default: the shipped one for the objective solved,
    /// config/solver_min_time.toml for the pure minimum time, else config/solver.toml).
    #[arg(long)]
    solver: Option<PathBuf>,
    /// Print exactly one JSON object on stdout (the table goes to stderr).
    #[arg(long)]
    json: bool,
    /// Folder for the PNG.
    #[arg(long, default_value = "out")]
    out_dir: PathBuf,
    #[command(flatten)]
    objective: StudyObjective,
}

/// The objective a study solves.
#[derive(clap::Args, Debug)]
struct StudyObjective {
    /// Weight [1/s] of the objective's steering-slew term. Studies reproduce the paper, so
    /// they solve its pure minimum time (0) unless this is given (1: the shipped scenarios').
    #[arg(long, value_parser = slew_weight_arg)]
    steering_slew_weight: Option<f64>,
}

#[derive(clap::Args, Debug)]
struct StudyCommon {
    /// Vehicle file.
    #[arg(long, default_value = "config/vehicles/lc500.toml")]
    vehicle: PathBuf,
    /// Solver settings file (default: the shipped one for the objective solved,
    /// config/solver_min_time.toml for the pure minimum time, else config/solver.toml).
    #[arg(long)]
    solver: Option<PathBuf>,
    /// Solves per run; the median time is reported.
    #[arg(long, default_value_t = 10)]
    repeat: usize,
    /// Print exactly one JSON object on stdout (tables go to stderr).
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    objective: StudyObjective,
}

#[derive(clap::Args, Debug)]
struct IntegratorsArgs {
    #[command(flatten)]
    files: StudyFiles,
    /// Solves per integrator (the median time is reported).
    #[arg(long, default_value_t = 10)]
    repeat: usize,
    /// Comma-separated subset (default: all nine); the reference always runs.
    #[arg(long, value_delimiter = ',')]
    integrators: Vec<String>,
    /// Ground truth of the NRMSE (the paper's: gauss_legendre3; others only for quick checks).
    #[arg(long, default_value = "gauss_legendre3")]
    reference: String,
    /// Wall-clock cap per solve [s] (overrides the solver file: the oracle-derivative
    /// schemes are not real-time).
    #[arg(long, default_value_t = 120.0)]
    max_time_s: f64,
}

#[derive(clap::Args, Debug)]
struct StiffnessArgs {
    #[command(flatten)]
    files: StudyFiles,
}

#[derive(clap::Args, Debug)]
struct StudySegmentsArgs {
    /// Multi-segment scenario file.
    #[arg(long, default_value = "config/scenarios/segments.toml")]
    scenario: PathBuf,
    /// Barrier parameter rule (overrides the solver file).
    #[arg(long, value_enum)]
    barrier: Option<BarrierArg>,
    /// Folder for the PNG figures.
    #[arg(long, default_value = "out")]
    out_dir: PathBuf,
    /// Do not write the figures.
    #[arg(long)]
    no_output: bool,
    #[command(flatten)]
    common: StudyCommon,
}

#[derive(clap::Args, Debug)]
struct StudyBarrierArgs {
    /// Scenario file.
    #[arg(long, default_value = "config/scenarios/oval.toml")]
    scenario: PathBuf,
    /// Segment or scenario name inside a multi-entry file.
    #[arg(long)]
    segment: Option<String>,
    #[command(flatten)]
    common: StudyCommon,
}

#[derive(clap::Args, Debug)]
struct ClosedLoopArgs {
    /// Scenario file (a closed road such as the oval).
    #[arg(long, default_value = "config/scenarios/oval.toml")]
    scenario: PathBuf,
    /// Vehicle file.
    #[arg(long, default_value = "config/vehicles/lc500.toml")]
    vehicle: PathBuf,
    /// Solver settings file.
    #[arg(long, default_value = "config/solver.toml")]
    solver: PathBuf,
    /// Distance to drive [m] (0: one lap).
    #[arg(long, default_value_t = 0.0)]
    distance_m: f64,
    /// Simulated-time cap [s].
    #[arg(long, default_value_t = 60.0)]
    duration_s: f64,
    /// Replanning rate [Hz].
    #[arg(long, default_value_t = 10.0)]
    rate_hz: f64,
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
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum OnOff {
    On,
    Off,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum GuessArg {
    Equilibrium,
    Zero,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum BarrierArg {
    Monotone,
    Adaptive,
    Probing,
    Loqo,
    Fullmpc,
    Dampmpc,
}

impl BarrierArg {
    fn rule(self) -> BarrierRule {
        match self {
            BarrierArg::Monotone => BarrierRule::Monotone,
            BarrierArg::Dampmpc => BarrierRule::Dampmpc,
            BarrierArg::Fullmpc => BarrierRule::Fullmpc,
            BarrierArg::Loqo => BarrierRule::Loqo,
            BarrierArg::Adaptive => BarrierRule::Adaptive,
            BarrierArg::Probing => BarrierRule::Probing,
        }
    }
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum KktArg {
    Sparse,
    Riccati,
    Auto,
}

#[derive(clap::Args, Debug)]
struct SolveArgs {
    /// Scenario file (paths inside resolve against its data root).
    #[arg(long, default_value = "config/scenarios/oval.toml")]
    scenario: PathBuf,
    /// Segment or scenario name inside a multi-entry file (e.g. S01, critical).
    #[arg(long)]
    segment: Option<String>,
    /// Vehicle file.
    #[arg(long, default_value = "config/vehicles/lc500.toml")]
    vehicle: PathBuf,
    /// Solver settings file (default: the shipped one for the objective solved,
    /// config/solver_min_time.toml for the pure minimum time, else config/solver.toml).
    #[arg(long)]
    solver: Option<PathBuf>,
    /// Initial guess.
    #[arg(long, value_enum, default_value = "equilibrium")]
    guess: GuessArg,
    /// Barrier parameter rule (overrides the solver file).
    #[arg(long, value_enum)]
    barrier: Option<BarrierArg>,
    /// Tire saturation constraints (overrides the scenario).
    #[arg(long, value_enum)]
    tire_saturation: Option<OnOff>,
    /// Weight [1/s] of the objective's steering-slew term (overrides the scenario; 0 is the
    /// paper's pure minimum time).
    #[arg(long, value_parser = slew_weight_arg)]
    steering_slew_weight: Option<f64>,
    /// KKT backend (overrides the solver file).
    #[arg(long, value_enum)]
    kkt: Option<KktArg>,
    /// Threads of a solve: 1, or 2 to pipeline the Riccati factorization over a helper
    /// thread (overrides the solver file; same results).
    #[arg(long, value_parser = clap::value_parser!(u8).range(1..=2))]
    threads: Option<u8>,
    /// Solve K times and report the median solve_ms.
    #[arg(long, default_value_t = 1)]
    repeat: usize,
    /// Print exactly one JSON object on stdout (summary goes to stderr).
    #[arg(long)]
    json: bool,
    /// Folder for the CSV and PNG outputs.
    #[arg(long, default_value = "out")]
    out_dir: PathBuf,
    /// Do not write the CSV and PNG files.
    #[arg(long)]
    no_output: bool,
    /// Print the solver's iteration log (last solve) to stderr.
    #[arg(long)]
    log: bool,
    /// Record every solve's input and output to this MCAP file (`replay run FILE` replays it).
    #[arg(long, value_name = "FILE.mcap")]
    record: Option<PathBuf>,
}

#[derive(clap::Args, Debug)]
struct GuessArgs {
    /// Vehicle file.
    #[arg(long, default_value = "config/vehicles/lc500.toml")]
    vehicle: PathBuf,
    /// Speed bounds and start speed [m/s].
    #[arg(long, default_value_t = 5.0)]
    v_min: f64,
    /// Upper speed bound [m/s].
    #[arg(long, default_value_t = 40.0)]
    v_max: f64,
    /// Start speed of the least-squares problem [m/s].
    #[arg(long, default_value_t = planner::plan::DEFAULT_GUESS_SPEED)]
    v_start: f64,
    /// JSON output.
    #[arg(long)]
    json: bool,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // No subcommand: solve the built-in default scenario (the oval).
    let command = match cli.command {
        Some(c) => c,
        None => match Cli::parse_from(["trajopt", "solve"]).command {
            Some(c) => c,
            None => return ExitCode::from(2),
        },
    };
    let result = match command {
        Command::Solve(args) => solve(args),
        Command::Guess(args) => guess(args),
        Command::ClosedLoop(args) => closed_loop(args),
        Command::Study(StudyCommand::Integrators(a)) => study_integrators(a),
        Command::Study(StudyCommand::Stiffness(a)) => study_stiffness(a),
        Command::Study(StudyCommand::Segments(args)) => study_segments(args),
        Command::Study(StudyCommand::Barrier(args)) => study_barrier(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(msg) => {
            eprintln!("trajopt: error: {msg}");
            ExitCode::from(2)
        }
    }
}

/// A default path relative to the working directory, or else to the repository this
/// binary was built from (so `trajopt` works from any folder of a clone).
fn resolve(path: &Path) -> PathBuf {
    if path.exists() || path.is_absolute() {
        return path.to_path_buf();
    }
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path);
    if repo.exists() {
        repo
    } else {
        path.to_path_buf()
    }
}

impl StudyObjective {
    /// The studies' steering-slew weight: the paper's pure minimum time unless given.
    fn slew(&self) -> f64 {
        self.steering_slew_weight.unwrap_or(0.0)
    }
}

/// The solver file given, or the shipped one tuned for the objective's steering-slew weight
/// ([`planner::config::shipped_solver_file`]), resolved.
fn solver_file(given: &Option<PathBuf>, steering_slew_weight: f64) -> PathBuf {
    match given {
        Some(p) => resolve(p),
        None => resolve(
            &Path::new("config").join(planner::config::shipped_solver_file(steering_slew_weight)),
        ),
    }
}

/// `--steering-slew-weight`: a number in [0, MAX_STEERING_SLEW_WEIGHT].
fn slew_weight_arg(v: &str) -> Result<f64, String> {
    let max = planner::ocp::MAX_STEERING_SLEW_WEIGHT;
    match v.parse::<f64>() {
        Ok(w) if (0.0..=max).contains(&w) => Ok(w),
        _ => Err(format!("`{v}` is not a weight in [0, {max}] 1/s")),
    }
}

fn solve(args: SolveArgs) -> Result<(), String> {
    if args.repeat == 0 {
        return Err("--repeat must be at least 1".into());
    }
    let vehicle = load_vehicle(&resolve(&args.vehicle)).map_err(|e| e.to_string())?;
    let mut spec = load_scenario(&resolve(&args.scenario), args.segment.as_deref(), vehicle)
        .map_err(|e| e.to_string())?;
    if let Some(sat) = args.tire_saturation {
        spec.enforce_tire_saturation = matches!(sat, OnOff::On);
    }
    if let Some(w) = args.steering_slew_weight {
        spec.steering_slew_weight = w;
    }
    let solver_path = solver_file(&args.solver, spec.steering_slew_weight);
    let mut settings = load_solver(&solver_path).map_err(|e| e.to_string())?;
    if let Some(k) = args.kkt {
        settings.kkt = match k {
            KktArg::Sparse => KktBackendKind::Sparse,
            KktArg::Riccati => KktBackendKind::Riccati,
            KktArg::Auto => KktBackendKind::Auto,
        };
    }
    if let Some(b) = args.barrier {
        settings.barrier = b.rule();
    }
    if let Some(t) = args.threads {
        settings.threads = usize::from(t);
    }
    let guess = match args.guess {
        GuessArg::Equilibrium => GuessKind::Equilibrium,
        GuessArg::Zero => GuessKind::Zero,
    };
    if spec.n_intervals != N {
        return Err(format!(
            "scenario has n_intervals = {}; this build solves N = {N}",
            spec.n_intervals
        ));
    }
    let saturation = spec.enforce_tire_saturation;
    let slew = spec.steering_slew_weight;
    let input = planner::record::plan_input(&spec, &settings, guess, 0, 0);
    let mut planner = Planner::<N>::new(spec, settings).map_err(|e| e.to_string())?;
    let recorder = match &args.record {
        // Room for every record: a CLI run drops nothing (the queue stays bounded).
        Some(path) => {
            Some(Recorder::create(path, (2 * args.repeat).min(4096)).map_err(|e| e.to_string())?)
        }
        None => None,
    };

    let mut times = Vec::with_capacity(args.repeat);
    // Per phase over the repeats: evaluation, factorization, solve, line search (ms).
    let mut phases: [Vec<f64>; 4] = std::array::from_fn(|_| Vec::with_capacity(args.repeat));
    let mut info: Option<SolveInfo> = None;
    for seq in 0..args.repeat as u64 {
        let stamp = now_ns();
        let i = planner.solve(guess);
        times.push(i.times.total * 1e3);
        let t = &i.times;
        for (v, x) in phases
            .iter_mut()
            .zip([t.evaluation, t.factorization, t.solve, t.line_search])
        {
            v.push(x * 1e3);
        }
        if let Some(rec) = &recorder {
            let mut inp = input.clone();
            inp.seq = seq;
            inp.stamp_ns = stamp;
            rec.record(Record::Input(Box::new(inp)));
            let out = planner::record::plan_output(
                seq,
                now_ns(),
                &i,
                planner.states(),
                planner.controls(),
            );
            rec.record(Record::Output(Box::new(out)));
        }
        info = Some(i);
    }
    let Some(info) = info else {
        return Err("no solve ran".into());
    };
    let recording = match (recorder, &args.record) {
        (Some(rec), Some(path)) => {
            let stats = rec.finish().map_err(|e| e.to_string())?;
            if stats.dropped > 0 {
                eprintln!(
                    "trajopt: warning: recorder dropped {} records",
                    stats.dropped
                );
            }
            serde_json::json!({
                "file": path.display().to_string(),
                "inputs": stats.inputs,
                "outputs": stats.outputs,
                "dropped": stats.dropped,
            })
        }
        _ => serde_json::Value::Null,
    };
    if args.log {
        eprintln!("iter  objective      inf_pr    inf_du    compl     mu        alpha     delta_w  nf bt step");
        for l in planner.solver().log() {
            eprintln!(
                "{:4} {:13.6e} {:9.2e} {:9.2e} {:9.2e} {:9.2e} {:9.2e} {:8.1e} {:2} {:2} {}",
                l.iter,
                l.objective,
                l.inf_pr,
                l.inf_du,
                l.compl,
                l.mu,
                l.alpha,
                l.delta_w,
                l.factorizations,
                l.backtracks,
                l.step.name()
            );
        }
    }
    // Medians (the upper one for an even count), the total's being `solve_ms`; the phase
    // medians need not add up to it.
    let median = |v: &[f64]| {
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        s[s.len() / 2]
    };
    let solve_ms = median(&times);
    let [ev_med, fa_med, so_med, ls_med] = phases.each_ref().map(|v| median(v));
    times.sort_by(f64::total_cmp);
    let traj = planner.trajectory();
    let name = planner.spec().name.clone();
    let worst = worst_rows(&mut planner, 5);

    let mut files = Vec::new();
    if !args.no_output {
        std::fs::create_dir_all(&args.out_dir)
            .map_err(|e| format!("{}: cannot create: {e}", args.out_dir.display()))?;
        let csv = args.out_dir.join(format!("{name}.csv"));
        traj.write_csv(&csv)
            .map_err(|e| format!("{}: cannot write: {e}", csv.display()))?;
        files.push(csv);
        let png = args.out_dir.join(format!("{name}.png"));
        match planner::plot::plot_trajectory(&traj, &png) {
            Ok(()) => files.push(png),
            Err(e) => eprintln!("trajopt: warning: figure not written: {e}"),
        }
        let foot = args.out_dir.join(format!("{name}_footprint.png"));
        match planner::plot::plot_footprint(&traj, &foot) {
            Ok(()) => files.push(foot),
            Err(e) => eprintln!("trajopt: warning: footprint figure not written: {e}"),
        }
    }

    let eq = planner.equilibrium();
    let summary = format!(
        "{name}: status {status}, {it} iterations, solve {solve_ms:.2} ms (median of {rep}), \
         t_final {tf:.4} s, max violation {mv:.2e} (initial {iv:.2e}, {sv:.2e} pushed into the bounds), max |beta| {mb:.3} rad\n  \
         guess {guess} (V {v:.2} m/s), integrator implicit_euler, barrier {barrier}, kkt {kkt}, \
         tire saturation {sat}, {objective}\n  \
         time (medians of {rep}): evaluation {ev:.2} ms, factorization {fa:.2} ms, solve {so:.2} ms, line search {ls:.2} ms; \
         {nf} factorizations (max {mf} per iteration, cap {cap}), {fb} fallback steps",
        status = info.status.name(),
        it = info.iterations,
        rep = args.repeat,
        tf = traj.t_final(),
        mv = info.max_violation,
        iv = info.initial_violation,
        sv = info.start_violation,
        mb = traj.max_abs_beta(),
        guess = guess.name(),
        v = eq.x[planner::model::ix::V],
        barrier = settings.barrier.name(),
        kkt = planner.solver().kkt().name(),
        sat = if saturation { "on" } else { "off" },
        objective = planner::ocp::objective::label(slew),
        ev = ev_med,
        fa = fa_med,
        so = so_med,
        ls = ls_med,
        nf = info.factorizations,
        mf = info.max_factorizations_per_iter,
        cap = settings.max_refactorizations,
        fb = info.fallback_steps,
    );
    let files_txt: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
    if args.json {
        eprintln!("{summary}");
        let obj = serde_json::json!({
            "scenario": name,
            "status": info.status.name(),
            "iterations": info.iterations,
            "solve_ms": solve_ms,
            "solve_ms_all": times,
            "t_final": traj.t_final(),
            "objective": info.objective,
            "max_violation": info.max_violation,
            "initial_violation": info.initial_violation,
            "start_violation": info.start_violation,
            "max_abs_beta_rad": traj.max_abs_beta(),
            "guess": guess.name(),
            "integrator": "implicit_euler",
            "barrier": settings.barrier.name(),
            "solver_file": solver_path.display().to_string(),
            "kkt": planner.solver().kkt().name(),
            "threads": settings.threads,
            "tire_saturation": saturation,
            "steering_slew_weight": slew,
            "dual_inf": info.dual_inf,
            "compl": info.compl,
            "factorizations": info.factorizations,
            "max_factorizations_per_iter": info.max_factorizations_per_iter,
            "max_refactorizations": settings.max_refactorizations,
            "fallback_steps": info.fallback_steps,
            "evaluations": info.evaluations,
            "times_ms": {
                "evaluation": info.times.evaluation * 1e3,
                "factorization": info.times.factorization * 1e3,
                "solve": info.times.solve * 1e3,
                "line_search": info.times.line_search * 1e3,
                "total": info.times.total * 1e3,
            },
            "times_ms_median": {
                "evaluation": ev_med,
                "factorization": fa_med,
                "solve": so_med,
                "line_search": ls_med,
                "total": solve_ms,
            },
            "equilibrium": eq,
            "worst_rows": worst.iter().map(|(r, v)| serde_json::json!({"row": r, "violation": v})).collect::<Vec<_>>(),
            "files": files_txt,
            "recording": recording,
        });
        println!("{obj}");
    } else {
        println!("{summary}");
        if !info.status.is_success() {
            println!("  largest violations (scaled NLP units):");
            for (row, v) in &worst {
                println!("    {v:.3e}  {row}");
            }
        }
        for f in &files_txt {
            println!("  wrote {f}");
        }
        if let Some(path) = &args.record {
            println!("  recorded {} ({recording})", path.display());
        }
    }
    Ok(())
}

/// Loads the vehicle, scenario and solver settings of a study.
fn study_inputs(f: &StudyFiles) -> Result<(planner::ocp::OcpSpec, planner::ip::Settings), String> {
    let vehicle = load_vehicle(&resolve(&f.vehicle)).map_err(|e| e.to_string())?;
    let mut spec =
        load_scenario(&resolve(&f.scenario), None, vehicle).map_err(|e| e.to_string())?;
    spec.steering_slew_weight = f.objective.slew();
    if spec.n_intervals != N {
        return Err(format!(
            "scenario has n_intervals = {}; this build solves N = {N}",
            spec.n_intervals
        ));
    }
    let settings = load_solver(&solver_file(&f.solver, spec.steering_slew_weight))
        .map_err(|e| e.to_string())?;
    std::fs::create_dir_all(&f.out_dir)
        .map_err(|e| format!("{}: cannot create: {e}", f.out_dir.display()))?;
    Ok((spec, settings))
}

/// `trajopt study integrators`: [`planner::study::integrators`].
fn study_integrators(a: IntegratorsArgs) -> Result<(), String> {
    use planner::study::integrators::{run_study, Integrator, StudyConfig};
    if a.repeat == 0 || a.max_time_s.is_nan() || a.max_time_s <= 0.0 {
        return Err("need --repeat >= 1 and --max-time-s > 0".into());
    }
    let integrators = if a.integrators.is_empty() {
        // Table I: the nine integrators (the reference is appended by the study).
        Integrator::ALL
            .into_iter()
            .filter(|i| *i != Integrator::REFERENCE)
            .collect()
    } else {
        a.integrators
            .iter()
            .map(|n| Integrator::from_name(n.trim()))
            .collect::<Result<_, _>>()
            .map_err(|e| e.to_string())?
    };
    let reference = Integrator::from_name(a.reference.trim()).map_err(|e| e.to_string())?;
    let (spec, mut settings) = study_inputs(&a.files)?;
    settings.max_time_s = a.max_time_s;
    let config = StudyConfig {
        repeat: a.repeat,
        integrators,
        reference,
    };
    let study = run_study::<N>(&spec, &settings, &config, |r| {
        eprintln!(
            "  {}: {} in {} iterations, median {:.1} ms",
            r.integrator.name(),
            r.status,
            r.iterations,
            r.median_ms
        )
    })
    .map_err(|e| e.to_string())?;
    let png = a
        .files
        .out_dir
        .join(format!("{}_integrators.png", spec.name));
    let figure = match planner::study::figures::plot_integrator_study(&study, &png) {
        Ok(()) => Some(png.display().to_string()),
        Err(e) => {
            eprintln!("trajopt: warning: figure not written: {e}");
            None
        }
    };
    let table = format!(
        "{}{}\n",
        study.table(),
        planner::ocp::objective::label(spec.steering_slew_weight)
    );
    if a.files.json {
        eprint!("{table}");
        let mut v = serde_json::to_value(&study).map_err(|e| e.to_string())?;
        v["figure"] = serde_json::json!(figure);
        v["steering_slew_weight"] = serde_json::json!(spec.steering_slew_weight);
        println!("{v}");
    } else {
        print!("{table}");
        if let Some(f) = figure {
            println!("  wrote {f}");
        }
    }
    Ok(())
}

/// `trajopt study stiffness`: [`planner::study::stiffness`] along the implicit-Euler
/// optimum of the scenario.
fn study_stiffness(a: StiffnessArgs) -> Result<(), String> {
    let (spec, settings) = study_inputs(&a.files)?;
    let mut planner = Planner::<N>::new(spec, settings).map_err(|e| e.to_string())?;
    let info = planner.solve(GuessKind::Equilibrium);
    let spec = planner.spec().clone();
    let study = planner::study::stiffness::analyze(
        &spec.vehicle,
        planner.states(),
        planner.controls(),
        &spec.kappa,
        spec.ds(),
    )
    .map_err(|e| e.to_string())?;
    let png = a.files.out_dir.join(format!("{}_stiffness.png", spec.name));
    let title = format!(
        "{}: stiffness along the implicit-Euler optimum ({}), dx/ds Jacobian",
        spec.name,
        info.status.name()
    );
    let figure = match planner::study::figures::plot_stiffness(&study, &title, &png) {
        Ok(()) => Some(png.display().to_string()),
        Err(e) => {
            eprintln!("trajopt: warning: figure not written: {e}");
            None
        }
    };
    let node0 = study.nodes.first().and_then(|n| n.ratio);
    let dominant: Vec<String> = planner::model::STATE_NAMES
        .iter()
        .zip(study.dominant_counts)
        .filter(|(_, c)| *c > 0)
        .map(|(n, c)| format!("{n} {c}"))
        .collect();
    let fmt = |v: Option<f64>| v.map_or("none".to_string(), |r| format!("{r:.1}"));
    let summary = format!(
        "stiffness ({} Jacobian d(dx/ds)/dx) along the {} optimum ({}): solve {}, t_N {:.4} s\n  \
         peak stiffness ratio {} at node {} (s = {:.1} m), fastest mode dominated by {} (slowest by {})\n  \
         nodes above 1e3: {} of {}; node 0 (free initial state) ratio {}\n  \
         dominant state of the fastest mode (nodes 1..N): {}\n  \
         vehicle dynamics only (r, V, beta, V_wr, dFz): peak ratio {} at node {}, dominated by {}",
        study.jacobian,
        spec.name,
        planner::ocp::objective::label(spec.steering_slew_weight),
        info.status.name(),
        planner.states()[N][planner::model::ix::T],
        fmt(study.peak_ratio),
        study.peak_node.map_or("-".to_string(), |k| k.to_string()),
        study.peak_node.map_or(f64::NAN, |k| study.nodes[k].s),
        study.peak_dominant_state.unwrap_or("-"),
        study.peak_slowest_state.unwrap_or("-"),
        study.nodes_above_1e3,
        study.nodes.len().saturating_sub(1),
        fmt(node0),
        dominant.join(", "),
        fmt(study.dynamic_peak_ratio),
        study
            .dynamic_peak_node
            .map_or("-".to_string(), |k| k.to_string()),
        study.dynamic_peak_dominant_state.unwrap_or("-"),
    );
    if a.files.json {
        eprintln!("{summary}");
        let mut v = serde_json::to_value(&study).map_err(|e| e.to_string())?;
        v["scenario"] = serde_json::json!(spec.name);
        v["steering_slew_weight"] = serde_json::json!(spec.steering_slew_weight);
        v["status"] = serde_json::json!(info.status.name());
        v["iterations"] = serde_json::json!(info.iterations);
        v["figure"] = serde_json::json!(figure);
        println!("{v}");
    } else {
        println!("{summary}");
        if let Some(f) = figure {
            println!("  wrote {f}");
        }
    }
    Ok(())
}

/// The `count` constraint rows with the largest violation at the returned point, named
/// (e.g. `defect[V]@0`): where an infeasible problem concentrates its violation.
fn worst_rows(planner: &mut Planner<N>, count: usize) -> Vec<(String, f64)> {
    use planner::ip::Nlp;
    let x = planner.solver().x().to_vec();
    let nlp = planner.nlp();
    let d = nlp.dims();
    let (mut xl, mut xu) = (vec![0.0; d.n], vec![0.0; d.n]);
    let (mut gl, mut gu, mut g) = (vec![0.0; d.m], vec![0.0; d.m], vec![0.0; d.m]);
    nlp.bounds(&mut xl, &mut xu, &mut gl, &mut gu);
    nlp.eval_g(&x, &mut g);
    let mut rows: Vec<(usize, f64)> = (0..d.m)
        .map(|i| (i, (gl[i] - g[i]).max(g[i] - gu[i]).max(0.0)))
        .filter(|(_, v)| *v > 0.0)
        .collect();
    rows.sort_by(|a, b| b.1.total_cmp(&a.1));
    rows.truncate(count);
    rows.into_iter()
        .map(|(i, v)| (nlp.row_name(i), v))
        .collect()
}

fn guess(args: GuessArgs) -> Result<(), String> {
    let vehicle = load_vehicle(&resolve(&args.vehicle)).map_err(|e| e.to_string())?;
    if !(args.v_min > 0.0 && args.v_max > args.v_min && args.v_start.is_finite()) {
        return Err("need 0 < v_min < v_max and a finite v_start".into());
    }
    let eq = planner::guess::equilibrium(&vehicle, args.v_min, args.v_max, args.v_start)
        .map_err(|e| e.to_string())?;
    if args.json {
        println!("{}", serde_json::json!(eq));
    } else {
        let n = planner::model::STATE_NAMES;
        let c = planner::model::CONTROL_NAMES;
        println!(
            "equilibrium guess ({}, {} iterations, cost {:.2e}):",
            eq.status, eq.iterations, eq.cost
        );
        for (name, v) in n.iter().zip(&eq.x).take(5) {
            println!("  {name:>6} = {v:.6}");
        }
        for (name, v) in c.iter().zip(&eq.u) {
            println!("  {name:>6} = {v:.6}");
        }
    }
    Ok(())
}

/// Kills a child on drop unless it was waited for (no orphans on error paths).
struct ChildGuard(Option<std::process::Child>);

impl Drop for ChildGuard {
    fn drop(&mut self) {
        if let Some(c) = self.0.as_mut() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// Waits for a child up to `limit`; kills it on timeout. Returns (exit ok, stdout).
fn wait_child(
    guard: &mut ChildGuard,
    limit: std::time::Duration,
) -> Result<(bool, String), String> {
    use std::io::Read;
    let Some(mut child) = guard.0.take() else {
        return Err("child already reaped".into());
    };
    let start = std::time::Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(status)) => {
                let mut out = String::new();
                if let Some(mut so) = child.stdout.take() {
                    let _ = so.read_to_string(&mut out);
                }
                return Ok((status.success(), out));
            }
            Ok(None) if start.elapsed() < limit => {
                std::thread::sleep(std::time::Duration::from_millis(50))
            }
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

fn last_json(out: &str) -> serde_json::Value {
    out.lines()
        .rev()
        .find_map(|l| serde_json::from_str(l).ok())
        .unwrap_or(serde_json::Value::Null)
}

fn closed_loop(args: ClosedLoopArgs) -> Result<(), String> {
    use std::process::{Command as Proc, Stdio};
    if !(args.duration_s > 0.0 && args.duration_s <= 3600.0 && args.distance_m >= 0.0) {
        return Err("need 0 < --duration-s <= 3600 and --distance-m >= 0".into());
    }
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
    let (planner_exe, tracker_exe) = (exe("planner_proc")?, exe("tracker_proc")?);
    let prefix = args.service_prefix.clone().unwrap_or_else(|| {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos());
        format!("trajopt-{}-{nanos}", std::process::id())
    });
    let files = |c: &mut Proc| {
        c.arg("--scenario")
            .arg(resolve(&args.scenario))
            .arg("--vehicle")
            .arg(resolve(&args.vehicle))
            .arg("--solver")
            .arg(resolve(&args.solver))
            .arg("--service-prefix")
            .arg(&prefix)
            .arg("--exit-on-stdin-eof")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit());
    };
    let mut pc = Proc::new(&planner_exe);
    files(&mut pc);
    pc.arg("--rate-hz").arg(args.rate_hz.to_string());
    if let Some(path) = &args.record {
        pc.arg("--record").arg(path);
    }
    let mut planner = ChildGuard(Some(
        pc.spawn()
            .map_err(|e| format!("{}: {e}", planner_exe.display()))?,
    ));
    let mut tc = Proc::new(&tracker_exe);
    files(&mut tc);
    tc.arg("--duration-s")
        .arg(args.duration_s.to_string())
        .arg("--distance-m")
        .arg(args.distance_m.to_string());
    let mut tracker = ChildGuard(Some(
        tc.spawn()
            .map_err(|e| format!("{}: {e}", tracker_exe.display()))?,
    ));
    // Simulated time runs at wall-clock speed; the first plan may take a while on a loaded machine.
    let limit = std::time::Duration::from_secs_f64(args.duration_s + 180.0);
    let (tracker_ok, tracker_out) = wait_child(&mut tracker, limit)?;
    // Stop the planner by closing its stdin.
    if let Some(c) = planner.0.as_mut() {
        drop(c.stdin.take());
    }
    let (planner_ok, planner_out) = wait_child(&mut planner, std::time::Duration::from_secs(30))?;
    let t = last_json(&tracker_out);
    let p = last_json(&planner_out);
    if !tracker_ok || t.is_null() {
        return Err("tracker_proc failed (see its log above)".into());
    }
    if !planner_ok || p.is_null() {
        return Err("planner_proc failed (see its log above)".into());
    }
    let f = |k: &str| t.get(k).cloned().unwrap_or(serde_json::Value::Null);
    let obj = serde_json::json!({
        "scenario": resolve(&args.scenario).display().to_string(),
        "service_prefix": prefix,
        "laps_or_distance_m": f("laps_or_distance_m"),
        "laps": f("laps"),
        "plans_received": f("plans_received"),
        "max_lateral_error_m": f("max_lateral_error_m"),
        "rms_lateral_error_m": f("rms_lateral_error_m"),
        "max_sideslip_error_rad": f("max_sideslip_error_rad"),
        "lane_kept": f("lane_kept"),
        "plan_latency_ms_p50": f("plan_latency_ms_p50"),
        "plan_latency_ms_p99": f("plan_latency_ms_p99"),
        "ipc_latency_us_p50": f("ipc_latency_us_p50"),
        "ipc_latency_us_p99": f("ipc_latency_us_p99"),
        "tracker": t,
        "planner": p,
    });
    let summary = format!(
        "closed loop: {:.1} m ({:.2} laps), {} plans, lateral error vs plan max {:.3} m rms {:.3} m, \
         max sideslip error {:.3} rad, lane kept {}; plan latency p50 {:.1} ms p99 {:.1} ms; \
         IPC latency p50 {:.1} us p99 {:.1} us",
        obj["laps_or_distance_m"].as_f64().unwrap_or(f64::NAN),
        obj["laps"].as_f64().unwrap_or(f64::NAN),
        obj["plans_received"],
        obj["max_lateral_error_m"].as_f64().unwrap_or(f64::NAN),
        obj["rms_lateral_error_m"].as_f64().unwrap_or(f64::NAN),
        obj["max_sideslip_error_rad"].as_f64().unwrap_or(f64::NAN),
        obj["lane_kept"],
        obj["plan_latency_ms_p50"].as_f64().unwrap_or(f64::NAN),
        obj["plan_latency_ms_p99"].as_f64().unwrap_or(f64::NAN),
        obj["ipc_latency_us_p50"].as_f64().unwrap_or(f64::NAN),
        obj["ipc_latency_us_p99"].as_f64().unwrap_or(f64::NAN),
    );
    if args.json {
        eprintln!("{summary}");
        println!("{obj}");
    } else {
        println!("{summary}");
    }
    Ok(())
}

/// `trajopt study segments`: runs [`planner::study::segments`], prints Tables II and III
/// (stderr with `--json`), writes the convergence and path figures.
fn study_segments(args: StudySegmentsArgs) -> Result<(), String> {
    use planner::study::{segment_figures, segments};
    let c = &args.common;
    let vehicle = load_vehicle(&resolve(&c.vehicle)).map_err(|e| e.to_string())?;
    let mut settings =
        load_solver(&solver_file(&c.solver, c.objective.slew())).map_err(|e| e.to_string())?;
    if let Some(b) = args.barrier {
        settings.barrier = b.rule();
    }
    let scenario = resolve(&args.scenario);
    let study = segments::run(&scenario, &vehicle, settings, c.repeat, c.objective.slew())
        .map_err(|e| e.to_string())?;
    let tables = format!(
        "{}\n{}",
        segments::table(&study, "equilibrium"),
        segments::table(&study, "zero")
    );
    let mut figures_out = Vec::new();
    if !args.no_output {
        std::fs::create_dir_all(&args.out_dir)
            .map_err(|e| format!("{}: {e}", args.out_dir.display()))?;
        let conv = args.out_dir.join("segments_convergence.png");
        segment_figures::plot_convergence(&study, &conv).map_err(|e| e.to_string())?;
        let paths = args.out_dir.join("segments_paths.png");
        segment_figures::plot_paths(&scenario, &study, &paths).map_err(|e| e.to_string())?;
        figures_out.push(conv.display().to_string());
        figures_out.push(paths.display().to_string());
    }
    if c.json {
        eprint!("{tables}");
        let mut v = serde_json::to_value(&study).map_err(|e| e.to_string())?;
        v["figures"] = serde_json::json!(figures_out);
        println!("{v}");
    } else {
        print!("{tables}");
        for f in &figures_out {
            println!("wrote {f}");
        }
    }
    Ok(())
}

/// `trajopt study barrier`: runs [`planner::study::barrier`] and prints Table IV (stderr
/// with `--json`).
fn study_barrier(args: StudyBarrierArgs) -> Result<(), String> {
    use planner::study::barrier;
    let c = &args.common;
    let vehicle = load_vehicle(&resolve(&c.vehicle)).map_err(|e| e.to_string())?;
    let settings =
        load_solver(&solver_file(&c.solver, c.objective.slew())).map_err(|e| e.to_string())?;
    let runs = barrier::run(
        &resolve(&args.scenario),
        args.segment.as_deref(),
        &vehicle,
        settings,
        c.repeat,
        c.objective.slew(),
    )
    .map_err(|e| e.to_string())?;
    let table = barrier::table(
        &runs,
        c.repeat,
        settings.max_refactorizations,
        c.objective.slew(),
    );
    if c.json {
        eprint!("{table}");
        let v = serde_json::json!({
            "scenario": args.scenario.display().to_string(),
            "repeat": c.repeat,
            "max_refactorizations": settings.max_refactorizations,
            "steering_slew_weight": c.objective.slew(),
            "runs": runs,
        });
        println!("{v}");
    } else {
        print!("{table}");
    }
    Ok(())
}
