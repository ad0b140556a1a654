//! `trajopt study stiffness`: [`planner::study::stiffness`] along the implicit-Euler
//! optimum of the scenario (paper Sec. IV, Fig. 3).

use planner::guess::GuessKind;
use planner::ip::SolveInfo;
use planner::ocp::OcpSpec;
use planner::plan::Planner;
use planner::study::stiffness::StiffnessStudy;
use planner::HORIZON;

use super::{figure_written, study_inputs};
use crate::args::StudyFiles;
use crate::out::{errln, outln};

#[derive(clap::Args, Debug)]
pub struct StiffnessArgs {
    #[command(flatten)]
    files: StudyFiles,
}

/// Solves the scenario, analyses the stiffness along the optimum, draws the figure and
/// prints the summary (stderr with `--json`, followed by the JSON object on stdout).
pub fn run(a: StiffnessArgs) -> Result<(), String> {
    let (spec, settings) = study_inputs(&a.files)?;
    let mut planner = Planner::<HORIZON>::new(spec, settings).map_err(|e| e.to_string())?;
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
    let figure = figure_written(
        planner::study::figures::plot_stiffness(&study, &title, &png),
        &png,
    )?;
    let t_final = planner.states()[HORIZON][planner::model::ix::T];
    let summary = summary(&study, &spec, &info, t_final);
    if a.files.json {
        errln!("{summary}");
        let mut v = serde_json::to_value(&study).map_err(|e| e.to_string())?;
        v["scenario"] = serde_json::json!(spec.name);
        v["steering_slew_weight"] = serde_json::json!(spec.steering_slew_weight);
        v["status"] = serde_json::json!(info.status.name());
        v["iterations"] = serde_json::json!(info.iterations);
        v["figure"] = serde_json::json!(figure);
        outln!("{v}");
    } else {
        outln!("{summary}");
        outln!("  wrote {figure}");
    }
    Ok(())
}

/// The human summary: the peak ratio and where, the dominant states, the node count above
/// the stiffness threshold 1e3, and the same for the vehicle dynamics alone.
fn summary(study: &StiffnessStudy, spec: &OcpSpec, info: &SolveInfo, t_final: f64) -> String {
    let node0 = study.nodes.first().and_then(|n| n.ratio);
    let dominant: Vec<String> = planner::model::STATE_NAMES
        .iter()
        .zip(study.dominant_counts)
        .filter(|(_, c)| *c > 0)
        .map(|(n, c)| format!("{n} {c}"))
        .collect();
    let fmt = |v: Option<f64>| v.map_or("none".to_string(), |r| format!("{r:.1}"));
    format!(
        "stiffness ({} Jacobian d(dx/ds)/dx) along the {} optimum ({}): solve {}, t_N {:.4} s\n  \
         peak stiffness ratio {} at node {} (s = {:.1} m), fastest mode dominated by {} (slowest by {})\n  \
         nodes above 1e3: {} of {}; node 0 (free initial state) ratio {}\n  \
         dominant state of the fastest mode (nodes 1..N): {}\n  \
         vehicle dynamics only (r, V, beta, V_wr, dFz): peak ratio {} at node {}, dominated by {}",
        study.jacobian,
        spec.name,
        planner::ocp::objective::label(spec.steering_slew_weight),
        info.status.name(),
        t_final,
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
    )
}
