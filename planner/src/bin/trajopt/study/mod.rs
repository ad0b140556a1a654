//! `trajopt study`: the reproducible studies of the paper, one module per study, each a
//! thin front end of the library's [`planner::study`] (load the files, run, print the
//! table, draw the figures, emit one JSON object with `--json`).

mod barrier;
mod integrators;
mod paper;
mod segments;
mod stiffness;

use clap::Subcommand;
use planner::config::{load_scenario_for_horizon, load_solver, load_vehicle};
use planner::ip::Settings;
use planner::ocp::OcpSpec;
use planner::HORIZON;

use crate::args::StudyFiles;
use crate::paths::{resolve, solver_file};

#[derive(Subcommand, Debug)]
pub enum StudyCommand {
    /// The nine integrators vs the Gauss-Legendre 3 ground truth (paper Table I, Fig. 4a).
    Integrators(integrators::IntegratorsArgs),
    /// Stiffness ratio and participation factors along the optimal oval (paper Fig. 3).
    Stiffness(stiffness::StiffnessArgs),
    /// Segments S01-S10 from the equilibrium and the zero guess (Table II; Fig. 5).
    Segments(segments::StudySegmentsArgs),
    /// The oval with each of the six barrier rules (Table IV).
    Barrier(barrier::StudyBarrierArgs),
    /// Every table and figure of the paper next to its published numbers, as one report.
    Paper(paper::StudyPaperArgs),
}

/// Runs the study `command` names.
pub fn run(command: StudyCommand) -> Result<(), String> {
    match command {
        StudyCommand::Integrators(a) => integrators::run(a),
        StudyCommand::Stiffness(a) => stiffness::run(a),
        StudyCommand::Segments(a) => segments::run(a),
        StudyCommand::Barrier(a) => barrier::run(a),
        StudyCommand::Paper(a) => paper::run(a),
    }
}

/// Loads the vehicle, scenario and solver settings of a single-scenario study and creates
/// its output folder.
fn study_inputs(f: &StudyFiles) -> Result<(OcpSpec, Settings), String> {
    let vehicle = load_vehicle(&resolve(&f.vehicle)).map_err(|e| e.to_string())?;
    let mut spec =
        load_scenario_for_horizon(&resolve(&f.scenario), None, vehicle, planner::HORIZON)
            .map_err(|e| e.to_string())?;
    spec.steering_slew_weight = f.objective.slew();
    if spec.n_intervals != HORIZON {
        return Err(format!(
            "scenario has n_intervals = {}; this build solves N = {HORIZON}",
            spec.n_intervals
        ));
    }
    let settings = load_solver(&solver_file(&f.solver, spec.steering_slew_weight))
        .map_err(|e| e.to_string())?;
    std::fs::create_dir_all(&f.out_dir)
        .map_err(|e| format!("{}: cannot create: {e}", f.out_dir.display()))?;
    Ok((spec, settings))
}

/// Path of a figure that was written, or the error naming the figure that could not be
/// drawn or written (a study's figure is one of its outputs: its failure fails the study).
fn figure_written<E: std::fmt::Display>(
    drawn: Result<(), E>,
    png: &std::path::Path,
) -> Result<String, String> {
    match drawn {
        Ok(()) => Ok(png.display().to_string()),
        Err(e) => Err(format!("figure {}: {e}", png.display())),
    }
}
