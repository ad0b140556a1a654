//! `trajopt study barrier`: [`planner::study::barrier`] (paper Table IV).

use std::path::PathBuf;

use planner::config::{load_solver, load_vehicle};
use planner::study::barrier;

use crate::args::StudyCommon;
use crate::out::{err, out, outln};
use crate::paths::{resolve, solver_file};

#[derive(clap::Args, Debug)]
pub struct StudyBarrierArgs {
    /// Scenario file.
    #[arg(long, default_value = "config/scenarios/oval.toml")]
    scenario: PathBuf,
    /// Segment or scenario name inside a multi-entry file.
    #[arg(long)]
    segment: Option<String>,
    #[command(flatten)]
    common: StudyCommon,
}

/// Runs the study and prints Table IV (stderr with `--json`, followed by the JSON object
/// on stdout).
pub fn run(args: StudyBarrierArgs) -> Result<(), String> {
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
        err!("{table}");
        let v = serde_json::json!({
            "scenario": args.scenario.display().to_string(),
            "repeat": c.repeat,
            "max_refactorizations": settings.max_refactorizations,
            "steering_slew_weight": c.objective.slew(),
            "runs": runs,
        });
        outln!("{v}");
    } else {
        out!("{table}");
    }
    Ok(())
}
