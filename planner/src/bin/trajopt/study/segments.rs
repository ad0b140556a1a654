//! `trajopt study segments`: [`planner::study::segments`] (paper Table II,
//! Fig. 5).

use std::path::PathBuf;

use planner::config::{load_solver, load_vehicle};
use planner::study::{segment_figures, segments};

use crate::args::{BarrierArg, StudyCommon};
use crate::out::{err, out, outln};
use crate::paths::{resolve, solver_file};

#[derive(clap::Args, Debug)]
pub struct StudySegmentsArgs {
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

/// Runs the study, prints both halves of Table II (stderr with `--json`), writes the convergence
/// and path figures.
pub fn run(args: StudySegmentsArgs) -> Result<(), String> {
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
        err!("{tables}");
        let mut v = serde_json::to_value(&study).map_err(|e| e.to_string())?;
        v["figures"] = serde_json::json!(figures_out);
        outln!("{v}");
    } else {
        out!("{tables}");
        for f in &figures_out {
            outln!("wrote {f}");
        }
    }
    Ok(())
}
