//! `trajopt solve`: one scenario solved `--repeat` times, in named steps: load the inputs
//! (files plus command-line overrides), build the planner and the recorder, run the
//! repeats, take the medians, write the CSV and figures, report (text and JSON).

use std::path::PathBuf;

use plan_record::{now_ns, PlanInput, Record, Recorder};
use planner::config::{load_scenario_layout, load_solver, load_vehicle, Layout};
use planner::guess::GuessKind;
use planner::ip::{Settings, SolveInfo};
use planner::ocp::OcpSpec;
use planner::plan::Planner;
use planner::stats::median;
use planner::trajectory::Trajectory;
use planner::HORIZON;

use crate::args::{budget_ms_arg, slew_weight_arg, BarrierArg, GuessArg, KktArg, OnOff};
use crate::out::{errln, outln};
use crate::paths::{resolve, solver_file};

#[derive(clap::Args, Debug)]
pub struct SolveArgs {
    /// Scenario file (paths inside resolve against its data root).
    #[arg(long, default_value = "config/scenarios/oval.toml")]
    scenario: PathBuf,
    /// Segment or scenario name inside a multi-entry file (e.g. S01, critical).
    #[arg(long)]
    segment: Option<String>,
    #[command(flatten)]
    stretch: crate::track::StretchArgs,
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
    /// Wall-clock budget of each solve in milliseconds (overrides the solver file's max_time_s): a
    /// solve that spends it ends `time_limit` with its best iterate.
    #[arg(long, value_name = "B", value_parser = budget_ms_arg)]
    budget_ms: Option<f64>,
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

/// What a solve acts on: the files loaded and the command-line overrides applied.
struct Inputs {
    spec: OcpSpec,
    layout: Layout,
    settings: Settings,
    solver_path: PathBuf,
    guess: GuessKind,
}

/// The measurements of the repeats: the total and per-phase times of every solve, in ms,
/// and the last solve's report.
struct Repeats {
    /// Total solve time of each repeat.
    times: Vec<f64>,
    /// Per phase over the repeats: evaluation, factorization, solve, line search.
    phases: [Vec<f64>; 4],
    /// The last solve's report.
    info: SolveInfo,
}

/// Solves the scenario `--repeat` times, writes the outputs and prints the report.
pub fn run(args: SolveArgs) -> Result<(), String> {
    if args.repeat == 0 {
        return Err("--repeat must be at least 1".into());
    }
    let inputs = load_inputs(&args)?;
    let layout = inputs.layout.clone();
    let saturation = inputs.spec.enforce_tire_saturation;
    let slew = inputs.spec.steering_slew_weight;
    let settings = inputs.settings;
    let input = planner::record::plan_input(&inputs.spec, &settings, inputs.guess, 0, 0);
    let mut planner = Planner::<HORIZON>::new(inputs.spec, settings).map_err(|e| e.to_string())?;
    let recorder = match &args.record {
        // Room for every record: a CLI run drops nothing (the queue stays bounded).
        Some(path) => {
            Some(Recorder::create(path, (2 * args.repeat).min(4096)).map_err(|e| e.to_string())?)
        }
        None => None,
    };
    let mut repeats = run_repeats(
        &mut planner,
        inputs.guess,
        &input,
        recorder.as_ref(),
        args.repeat,
    )?;
    let recording = finish_recording(recorder, &args.record)?;
    if args.log {
        print_log(&planner);
    }
    // Medians of the repeats, the total's being `solve_ms`; the phase medians need not add
    // up to it. Sorts `times` for `solve_ms_all`.
    let solve_ms = median(&mut repeats.times);
    let phase_medians = repeats.phases.each_mut().map(|v| median(v));
    let mut traj = planner.trajectory();
    layout.clone().apply(&mut traj);
    let name = planner.spec().name.clone();
    let x = planner.solver().x().to_vec();
    let worst = planner.worst_rows(&x, 5);
    let files = if args.no_output {
        Vec::new()
    } else {
        let mut files = write_outputs(&args.out_dir, &name, &traj)?;
        if let Some(track) = &layout.track {
            files.push(crate::track::draw_plan(track, &traj, &args.out_dir)?);
        }
        files
    };
    let report = Report {
        args: &args,
        name,
        info: &repeats.info,
        solve_ms,
        times: &repeats.times,
        phase_medians,
        traj: &traj,
        worst,
        guess: inputs.guess,
        settings: &settings,
        solver_path: &inputs.solver_path,
        saturation,
        slew,
        files: files.iter().map(|f| f.display().to_string()).collect(),
        recording,
    };
    report.print(&planner)
}

/// Loads the vehicle, scenario and solver files and applies the command-line overrides;
/// the scenario must have the horizon this build solves.
fn load_inputs(args: &SolveArgs) -> Result<Inputs, String> {
    let vehicle = load_vehicle(&resolve(&args.vehicle)).map_err(|e| e.to_string())?;
    let (mut spec, layout) = match args.stretch.load(vehicle)? {
        Some(stretch) => stretch,
        None => load_scenario_layout(
            &resolve(&args.scenario),
            args.segment.as_deref(),
            vehicle,
            Some(HORIZON),
        )
        .map_err(|e| e.to_string())?,
    };
    if let Some(sat) = args.tire_saturation {
        spec.enforce_tire_saturation = matches!(sat, OnOff::On);
    }
    if let Some(w) = args.steering_slew_weight {
        spec.steering_slew_weight = w;
    }
    let solver_path = solver_file(&args.solver, spec.steering_slew_weight);
    let mut settings = load_solver(&solver_path).map_err(|e| e.to_string())?;
    if let Some(k) = args.kkt {
        settings.kkt = k.kind();
    }
    if let Some(b) = args.barrier {
        settings.barrier = b.rule();
    }
    if let Some(t) = args.threads {
        settings.threads = usize::from(t);
    }
    if let Some(ms) = args.budget_ms {
        settings.max_time_s = 1e-3 * ms;
    }
    if spec.n_intervals != HORIZON {
        return Err(format!(
            "scenario has n_intervals = {}; this build solves N = {HORIZON}",
            spec.n_intervals
        ));
    }
    Ok(Inputs {
        spec,
        layout,
        settings,
        solver_path,
        guess: args.guess.kind(),
    })
}

/// Solves `repeat` times from `guess`, timing each solve and its phases; with a recorder,
/// records each solve's input (`input` with the solve's sequence number and stamp) and
/// output.
fn run_repeats(
    planner: &mut Planner<HORIZON>,
    guess: GuessKind,
    input: &PlanInput,
    recorder: Option<&Recorder>,
    repeat: usize,
) -> Result<Repeats, String> {
    let mut times = Vec::with_capacity(repeat);
    let mut phases: [Vec<f64>; 4] = std::array::from_fn(|_| Vec::with_capacity(repeat));
    let mut info: Option<SolveInfo> = None;
    for seq in 0..repeat as u64 {
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
        if let Some(rec) = recorder {
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
    Ok(Repeats {
        times,
        phases,
        info,
    })
}

/// Closes the recording and describes it for the JSON report (Null without `--record`).
fn finish_recording(
    recorder: Option<Recorder>,
    path: &Option<PathBuf>,
) -> Result<serde_json::Value, String> {
    let (Some(rec), Some(path)) = (recorder, path) else {
        return Ok(serde_json::Value::Null);
    };
    let stats = rec.finish().map_err(|e| e.to_string())?;
    if stats.dropped > 0 {
        errln!(
            "trajopt: warning: recorder dropped {} records",
            stats.dropped
        );
    }
    Ok(serde_json::json!({
        "file": path.display().to_string(),
        "inputs": stats.inputs,
        "outputs": stats.outputs,
        "dropped": stats.dropped,
    }))
}

/// Prints the solver's iteration log of the last solve to stderr.
fn print_log(planner: &Planner<HORIZON>) {
    errln!("{}", planner::ip::IterLog::HEADER);
    for l in planner.solver().log() {
        errln!("{}", l.row());
    }
}

/// Writes `<name>.csv`, `<name>.png` and `<name>_footprint.png` to `out_dir`, each
/// atomically (complete or not at all); returns the files written. A file that cannot be
/// written is an error naming it.
fn write_outputs(
    out_dir: &std::path::Path,
    name: &str,
    traj: &Trajectory,
) -> Result<Vec<PathBuf>, String> {
    std::fs::create_dir_all(out_dir)
        .map_err(|e| format!("{}: cannot create: {e}", out_dir.display()))?;
    let csv = out_dir.join(format!("{name}.csv"));
    traj.write_csv(&csv).map_err(|e| e.to_string())?;
    let png = out_dir.join(format!("{name}.png"));
    planner::plot::plot_trajectory(traj, &png).map_err(|e| format!("figure: {e}"))?;
    let foot = out_dir.join(format!("{name}_footprint.png"));
    planner::plot::plot_footprint(traj, &foot).map_err(|e| format!("footprint figure: {e}"))?;
    Ok(vec![csv, png, foot])
}

/// Everything the report of a solve shows.
struct Report<'a> {
    args: &'a SolveArgs,
    name: String,
    /// The last solve's report.
    info: &'a SolveInfo,
    /// Median total solve time, in ms.
    solve_ms: f64,
    /// Every repeat's total solve time, in ms, sorted.
    times: &'a [f64],
    /// Median time of each phase, in ms: evaluation, factorization, solve, line search.
    phase_medians: [f64; 4],
    traj: &'a Trajectory,
    worst: Vec<(String, f64)>,
    guess: GuessKind,
    settings: &'a Settings,
    solver_path: &'a std::path::Path,
    saturation: bool,
    slew: f64,
    files: Vec<String>,
    recording: serde_json::Value,
}

impl Report<'_> {
    /// Prints the summary (to stderr with `--json`, followed by the JSON object on stdout;
    /// else to stdout with the worst rows of a failed solve, the files and the recording).
    fn print(&self, planner: &Planner<HORIZON>) -> Result<(), String> {
        let summary = self.summary(planner);
        if self.args.json {
            errln!("{summary}");
            outln!("{}", self.json(planner));
            return Ok(());
        }
        outln!("{summary}");
        if !self.info.status.is_success() {
            outln!("  largest violations (scaled NLP units):");
            for (row, v) in &self.worst {
                outln!("    {v:.3e}  {row}");
            }
        }
        for f in &self.files {
            outln!("  wrote {f}");
        }
        if let Some(path) = &self.args.record {
            outln!("  recorded {} ({})", path.display(), self.recording);
        }
        Ok(())
    }

    /// The three-line human summary.
    fn summary(&self, planner: &Planner<HORIZON>) -> String {
        let (info, traj, settings) = (self.info, self.traj, self.settings);
        let [ev, fa, so, ls] = self.phase_medians;
        format!(
            "{name}: status {status}, {it} iterations, solve {solve_ms:.2} ms (median of {rep}), \
             t_final {tf:.4} s, max violation {mv:.2e} (initial {iv:.2e}, {sv:.2e} pushed into the bounds), max |beta| {mb:.3} rad\n  \
             guess {guess} (V {v:.2} m/s), integrator implicit_euler, barrier {barrier}, kkt {kkt}, \
             tire saturation {sat}, {objective}\n  \
             time (medians of {rep}): evaluation {ev:.2} ms, factorization {fa:.2} ms, solve {so:.2} ms, line search {ls:.2} ms; \
             {nf} factorizations (max {mf} per iteration, cap {cap}), {fb} fallback steps",
            name = self.name,
            status = info.status.name(),
            it = info.iterations,
            solve_ms = self.solve_ms,
            rep = self.args.repeat,
            tf = traj.t_final(),
            mv = info.max_violation,
            iv = info.initial_violation,
            sv = info.start_violation,
            mb = traj.max_abs_beta(),
            guess = self.guess.name(),
            v = planner.equilibrium().x[planner::model::ix::V],
            barrier = settings.barrier.name(),
            kkt = planner.solver().kkt().name(),
            sat = if self.saturation { "on" } else { "off" },
            objective = planner::ocp::objective::label(self.slew),
            nf = info.factorizations,
            mf = info.max_factorizations_per_iter,
            cap = settings.max_refactorizations,
            fb = info.fallback_steps,
        )
    }

    /// The JSON object of `--json`.
    fn json(&self, planner: &Planner<HORIZON>) -> serde_json::Value {
        let (info, traj, settings) = (self.info, self.traj, self.settings);
        let [ev, fa, so, ls] = self.phase_medians;
        serde_json::json!({
            "scenario": self.name,
            "status": info.status.name(),
            "iterations": info.iterations,
            "solve_ms": self.solve_ms,
            "solve_ms_all": self.times,
            "t_final": traj.t_final(),
            "objective": info.objective,
            "max_violation": info.max_violation,
            "best_iterate": info.best_iterate,
            "best_iteration": info.best_iteration,
            "initial_violation": info.initial_violation,
            "start_violation": info.start_violation,
            "max_abs_beta_rad": traj.max_abs_beta(),
            "guess": self.guess.name(),
            "integrator": "implicit_euler",
            "barrier": settings.barrier.name(),
            "solver_file": self.solver_path.display().to_string(),
            "kkt": planner.solver().kkt().name(),
            "threads": settings.threads,
            "tire_saturation": self.saturation,
            "steering_slew_weight": self.slew,
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
                "evaluation": ev,
                "factorization": fa,
                "solve": so,
                "line_search": ls,
                "total": self.solve_ms,
            },
            "equilibrium": planner.equilibrium(),
            "worst_rows": self.worst.iter().map(|(r, v)| serde_json::json!({"row": r, "violation": v})).collect::<Vec<_>>(),
            "files": self.files,
            "recording": self.recording,
        })
    }
}
