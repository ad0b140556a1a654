//! Robustness studies of the paper's Sec. VI-B/VI-C, as library code behind
//! `trajopt study ...`: [`segments`] (Tables II and III, Fig. 5: ten race segments from the
//! equilibrium and the zero guess) and [`barrier`] (Table IV: the oval with every barrier
//! rule). Each study returns plain serializable rows; printing and plotting are separate
//! functions so the CLI stays thin.

pub mod barrier;
pub mod figures;
pub mod segments;

use crate::config::ConfigError;
use crate::plan::PlanError;
use crate::plot::PlotError;

/// Why a study could not run (bad input files, planner setup, figures).
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// A configuration file (scenario, vehicle, solver, track) is unusable.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A planner could not be built.
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// A figure could not be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// A file of the study (segment list, reference table) is malformed.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// `--repeat` must be at least 1.
    #[error("repeat must be at least 1")]
    Repeat,
}

/// Median of the samples (mean of the two middle ones for an even count); NaN when empty.
pub fn median(samples: &mut [f64]) -> f64 {
    if samples.is_empty() {
        return f64::NAN;
    }
    samples.sort_by(f64::total_cmp);
    let n = samples.len();
    if n % 2 == 1 {
        samples[n / 2]
    } else {
        0.5 * (samples[n / 2 - 1] + samples[n / 2])
    }
}

/// The optimality error of one logged iteration: max(inf_pr, scaled inf_du, scaled
/// complementarity), the quantity of the paper's Fig. 5.
pub fn optimality_error(l: &crate::ip::IterLog) -> f64 {
    l.inf_pr.max(l.inf_du).max(l.compl)
}
