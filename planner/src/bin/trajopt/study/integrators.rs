//! `trajopt study integrators`: [`planner::study::integrators`] (paper Table I, Fig. 4a).

use planner::study::integrators::{run_study, Integrator, StudyConfig};
use planner::HORIZON;

use super::{figure_written, study_inputs};
use crate::args::StudyFiles;
use crate::out::{err, errln, out, outln};

#[allow(rustdoc::broken_intra_doc_links)] // clap prints these docs as --help: unit brackets stay unescaped
#[derive(clap::Args, Debug)]
pub struct IntegratorsArgs {
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

/// The integrators `--integrators` names, or Table I's nine (the study appends the
/// reference).
fn selected(a: &IntegratorsArgs) -> Result<Vec<Integrator>, String> {
    if a.integrators.is_empty() {
        return Ok(Integrator::ALL
            .into_iter()
            .filter(|i| *i != Integrator::REFERENCE)
            .collect());
    }
    a.integrators
        .iter()
        .map(|n| Integrator::from_name(n.trim()))
        .collect::<Result<_, _>>()
        .map_err(|e| e.to_string())
}

/// Runs the study with a progress line per integrator on stderr, prints the table (stderr
/// with `--json`), draws the accuracy-versus-time figure.
pub fn run(a: IntegratorsArgs) -> Result<(), String> {
    if a.repeat == 0 || a.max_time_s.is_nan() || a.max_time_s <= 0.0 {
        return Err("need --repeat >= 1 and --max-time-s > 0".into());
    }
    let integrators = selected(&a)?;
    let reference = Integrator::from_name(a.reference.trim()).map_err(|e| e.to_string())?;
    let (spec, mut settings) = study_inputs(&a.files)?;
    settings.max_time_s = a.max_time_s;
    let config = StudyConfig {
        repeat: a.repeat,
        integrators,
        reference,
    };
    let study = run_study::<HORIZON>(&spec, &settings, &config, |r| {
        errln!(
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
    let figure = figure_written(
        planner::study::figures::plot_integrator_study(&study, &png),
        &png,
    )?;
    let table = format!(
        "{}{}\n",
        study.table(),
        planner::ocp::objective::label(spec.steering_slew_weight)
    );
    if a.files.json {
        err!("{table}");
        let mut v = serde_json::to_value(&study).map_err(|e| e.to_string())?;
        v["figure"] = serde_json::json!(figure);
        v["steering_slew_weight"] = serde_json::json!(spec.steering_slew_weight);
        outln!("{v}");
    } else {
        out!("{table}");
        outln!("  wrote {figure}");
    }
    Ok(())
}
