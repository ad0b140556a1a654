//! `replay`: replay planner recordings (MCAP) for determinism, latency and jitter.
//!
//! `replay run FILE` re-solves every recorded input on a pinned core; `replay info FILE`
//! summarises a file; `replay record-oval` records a 10 Hz replanning drive on the oval;
//! `replay recover IN OUT` rewrites what a file cut short holds as a clean file. A file
//! cut short (a killed recorder) is read up to its last complete chunk, with a warning.
//! Exit code 0 on success, 1 when a replayed output differs from the recorded one or a
//! recorded output matches no input, 2 on bad input (unreadable or damaged file, an input
//! outside the model's domain or a repeated seq, bad options); `info` makes the same
//! checks as `run` short of solving.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use plan_record::Recording;
use planner::config::paths::resolve_path;
use planner::guess::GuessKind;
use planner::{err, errln, out, outln};
use replay::oval::{record_oval, OvalOptions};
use replay::run::{run, RunOptions};

#[derive(Parser, Debug)]
#[command(name = "replay", version, about = "Replay planner recordings (MCAP)")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Re-solve every recorded input: determinism, latency, jitter, deadline misses.
    Run {
        /// The recording.
        file: PathBuf,
        /// Time budget of every solve [ms], also the deadline (default: the recorded
        /// settings' budget, and a 100 ms deadline).
        #[arg(long)]
        budget_ms: Option<f64>,
        /// Iteration budget of every solve (default: the recorded settings' max_iter).
        #[arg(long)]
        max_iter: Option<usize>,
        /// Core to pin the solver thread to (default: the last core).
        #[arg(long)]
        core: Option<usize>,
        /// Initial guess of every solve: equilibrium, zero or road_speed (default: the
        /// recorded one; another guess is compared with no recorded output).
        #[arg(long, value_parser = ["equilibrium", "zero", "road_speed"])]
        guess: Option<String>,
        /// Print exactly one JSON object on stdout.
        #[arg(long)]
        json: bool,
        /// Also include every plan in the JSON.
        #[arg(long)]
        per_plan: bool,
        /// Write a latency figure (PNG).
        #[arg(long, value_name = "OUT.png")]
        plot: Option<PathBuf>,
        /// Log the solve of input SEQ: its iterations and the constraint rows violated
        /// most at its start and end (after the summary; `plan_log` in the JSON).
        #[arg(long, value_name = "SEQ")]
        log_plan: Option<u64>,
        /// Re-derive each warm start's primal guess from the recorded plan it shifts, with
        /// this build's shift (to measure a change to the shift on a recording; a guess
        /// other than the recorded one is compared with no recorded output).
        #[arg(long)]
        reshift: bool,
        /// Iterations each warm-started solve may take before it falls back to its cold
        /// start, within the solve's caps (default: the recorded one; to measure a warm
        /// cap on a recording; a cap other than the recorded one is compared with no
        /// recorded output).
        #[arg(long, value_name = "K")]
        warm_max_iter: Option<usize>,
        /// Iterations a warm-started solve may take after a replayed solve that did not
        /// succeed, as `planner_proc --warm-max-iter-after-failure` (plans it changes are
        /// compared with no recorded output).
        #[arg(long, value_name = "K")]
        warm_max_iter_after_failure: Option<usize>,
    },
    /// Summarise a recording: channels, counts, duration, drops.
    Info {
        /// The recording.
        file: PathBuf,
        /// Print exactly one JSON object on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Write everything a (cut short) recording holds to a clean, closed file.
    Recover {
        /// The recording.
        input: PathBuf,
        /// The clean file (written beside it under a temporary name, then renamed).
        output: PathBuf,
    },
    /// Record a replanning drive along the oval (stand-in for the IPC planner process).
    RecordOval {
        /// Number of plans.
        #[arg(long, default_value_t = 100)]
        plans: usize,
        /// Replanning rate [Hz].
        #[arg(long, default_value_t = 10.0)]
        rate_hz: f64,
        /// Warm-start each plan from the previous one shifted by the arc length driven,
        /// primal and dual, as the planner process does (`off`: every plan from the
        /// equilibrium guess).
        #[arg(long, default_value = "on", value_parser = ["on", "off"])]
        warm_start: String,
        /// Tire saturation rows at each plan's last node too (as `planner_proc
        /// --saturation-at-end`).
        #[arg(long, default_value = "on", value_parser = ["on", "off"])]
        saturation_at_end: String,
        /// How a warm start's first barrier parameter is matched to the shifted point:
        /// geometric or mean (as `planner_proc --warm-mu`).
        #[arg(long, default_value = "geometric", value_parser = ["geometric", "mean"])]
        warm_mu: String,
        /// Multiple of the geometric mean for `--warm-mu geometric` (finite, > 0).
        #[arg(long, default_value_t = 30.0)]
        warm_mu_factor: f64,
        /// Guess of a cold plan (the first, and every plan with `--warm-start off`):
        /// equilibrium or road_speed (as `planner_proc --cold-guess`).
        #[arg(long, default_value = "equilibrium", value_parser = ["equilibrium", "road_speed"])]
        cold_guess: String,
        /// Output file.
        #[arg(long, default_value = "out/oval_drive.mcap")]
        out: PathBuf,
        /// Scenario file (the oval).
        #[arg(long, default_value = "config/scenarios/oval.toml")]
        scenario: PathBuf,
        /// Vehicle file.
        #[arg(long, default_value = "config/vehicles/lc500.toml")]
        vehicle: PathBuf,
        /// Solver settings file.
        #[arg(long, default_value = "config/solver.toml")]
        solver: PathBuf,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // A progress bar on stderr while replaying, only on a terminal and never with --json.
    planner::progress::install_terminal(std::env::args().any(|a| a == "--json"));
    match dispatch(cli.command) {
        Ok(code) => code,
        Err(msg) => {
            errln!("replay: error: {msg}");
            ExitCode::from(2)
        }
    }
}

/// Reads a recording; warns on stderr when it was not closed cleanly.
fn read(file: &Path) -> Result<Recording, String> {
    let rec = Recording::read(file).map_err(|e| format!("{}: {e}", file.display()))?;
    if let Some(r) = &rec.recovery {
        errln!("replay: warning: {}: {r}", file.display());
    }
    Ok(rec)
}

/// Prints `replay run`'s report as one JSON object (the text report on stderr); every plan
/// when `per_plan`, else only those that differ from the recording.
fn run_json(
    mut report: replay::run::RunReport,
    rec: &Recording,
    file: &Path,
    plot: Option<&Path>,
    per_plan: bool,
) -> Result<ExitCode, String> {
    err!("{report}");
    let differing: Vec<_> = report
        .per_plan
        .iter()
        .filter(|p| p.identical == Some(false))
        .cloned()
        .collect();
    let deterministic = report.deterministic;
    if !per_plan {
        report.per_plan = differing;
    }
    let mut v = serde_json::to_value(&report).map_err(|e| e.to_string())?;
    v["file"] = file.display().to_string().into();
    v["plot"] = plot.map(|p| p.display().to_string()).into();
    v["recorder_dropped"] = rec.dropped().into();
    outln!("{v}");
    Ok(exit(
        (deterministic || report.different == 0) && report.orphan_outputs.is_empty(),
    ))
}

fn dispatch(command: Command) -> Result<ExitCode, String> {
    match command {
        Command::Run {
            file,
            budget_ms,
            max_iter,
            core,
            guess,
            json,
            per_plan,
            plot,
            log_plan,
            reshift,
            warm_max_iter,
            warm_max_iter_after_failure,
        } => {
            let rec = read(&file)?;
            let opts = RunOptions {
                budget_ms: budget_ms.unwrap_or(100.0),
                budgets: replay::budget::Budgets {
                    budget_ms,
                    max_iter,
                },
                core,
                guess: guess.as_deref().and_then(GuessKind::parse),
                log_plan,
                reshift,
                warm_max_iter,
                warm_max_iter_after_failure,
            };
            let report = run(&rec, opts).map_err(|e| format!("{}: {e}", file.display()))?;
            if let Some(png) = &plot {
                replay::plot::plot_latency(&report, png).map_err(|e| e.to_string())?;
            }
            if json {
                return run_json(report, &rec, &file, plot.as_deref(), per_plan);
            }
            out!("{report}");
            if let Some(log) = &report.plan_log {
                out!("{log}");
            }
            if let Some(d) = rec.dropped().filter(|d| *d > 0) {
                outln!("recorder dropped {d} records while recording");
            }
            if let Some(png) = &plot {
                outln!("wrote {}", png.display());
            }
            Ok(exit(
                report.different == 0 && report.orphan_outputs.is_empty(),
            ))
        }
        Command::Info { file, json } => {
            let rec = read(&file)?;
            // The checks `run` makes before solving: both commands refuse the same files.
            let checked =
                replay::validate::validate(&rec).map_err(|e| format!("{}: {e}", file.display()))?;
            let mut info = replay::info::info(&rec);
            info.orphan_outputs = checked.orphan_outputs;
            if json {
                let mut v = serde_json::to_value(&info).map_err(|e| e.to_string())?;
                v["file"] = file.display().to_string().into();
                outln!("{v}");
            } else {
                out!("{}: {info}", file.display());
            }
            Ok(exit(info.orphan_outputs.is_empty()))
        }
        Command::Recover { input, output } => {
            let rec = read(&input)?;
            let stats = plan_record::write_recording(&rec, &output).map_err(|e| e.to_string())?;
            outln!(
                "wrote {} inputs and {} outputs from {} to {}",
                stats.inputs,
                stats.outputs,
                input.display(),
                output.display()
            );
            Ok(ExitCode::SUCCESS)
        }
        Command::RecordOval {
            plans,
            rate_hz,
            warm_start,
            saturation_at_end,
            warm_mu,
            warm_mu_factor,
            cold_guess,
            out,
            scenario,
            vehicle,
            solver,
        } => {
            if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)
                    .map_err(|e| format!("{}: cannot create: {e}", dir.display()))?;
            }
            let opts = OvalOptions {
                scenario: resolve_path(&scenario),
                vehicle: resolve_path(&vehicle),
                solver: resolve_path(&solver),
                plans,
                rate_hz,
                out: out.clone(),
                warm_start: warm_start == "on",
                saturation_at_end: saturation_at_end == "on",
                mu_match: planner::ip::MuMatch::parse(&warm_mu, warm_mu_factor).ok_or_else(
                    || format!("--warm-mu-factor {warm_mu_factor}: must be finite and > 0"),
                )?,
                cold_guess: planner::guess::GuessKind::parse(&cold_guess)
                    .ok_or_else(|| format!("--cold-guess {cold_guess}: unknown"))?,
            };
            let summary = record_oval(&opts, |i, ms, status| {
                errln!("plan {i:3}: {status} in {ms:.1} ms");
            })
            .map_err(|e| e.to_string())?;
            let ok = summary.statuses.iter().filter(|s| **s == "optimal").count();
            outln!(
                "recorded {} inputs and {} outputs to {} ({} dropped); {ok} of {plans} optimal",
                summary.stats.inputs,
                summary.stats.outputs,
                out.display(),
                summary.stats.dropped
            );
            Ok(ExitCode::SUCCESS)
        }
    }
}

fn exit(deterministic: bool) -> ExitCode {
    if deterministic {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}
