//! Reproducible studies of the paper, each a library function behind a `trajopt study`
//! subcommand; each returns plain serializable rows, printing and plotting are separate so
//! the CLI stays thin:
//! - [`integrators`] (Sec. IV and VI-A: the nine integrators against the Gauss-Legendre
//!   3-stage ground truth, Table I and Fig. 4a) and [`stiffness`] (Sec. IV, eq. 7 and
//!   Fig. 3), drawn by [`figures`];
//! - [`segments`] (Sec. VI-B, Table II, Fig. 5: ten race segments from the
//!   equilibrium and the zero guess), drawn by [`segment_figures`], and [`barrier`]
//!   (Sec. VI-C, Table IV: the oval with every barrier rule);
//! - [`paper`]: all of them as one report next to the paper's published numbers.

pub mod barrier;
pub mod figures;
pub mod integrators;
pub mod paper;
pub mod segment_figures;
pub mod segments;
pub mod stiffness;

use crate::config::ConfigError;
use crate::guess::GuessError;
use crate::ip::SetupError;
use crate::ocp::TranscriptionError;
use crate::plan::PlanError;
use crate::plot::PlotError;

/// Why a study could not run (a solve that ends with a failure status is not an error:
/// it is reported with its status).
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// A configuration file (scenario, vehicle, solver, track) is unusable.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A planner could not be built.
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// The OCP data does not fit the transcription.
    #[error(transparent)]
    Transcription(#[from] TranscriptionError),
    /// The solver could not be set up.
    #[error(transparent)]
    Setup(#[from] SetupError),
    /// The equilibrium guess failed.
    #[error(transparent)]
    Guess(#[from] GuessError),
    /// A figure could not be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// An integrator name that is not one of [`integrators::Integrator::ALL`].
    #[error("unknown integrator {name:?}; known: {known}")]
    UnknownIntegrator {
        /// The given name.
        name: String,
        /// Comma-separated known names.
        known: String,
    },
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
    /// A study parameter is out of range.
    #[error("invalid study input: {0}")]
    Invalid(String),
}

/// The optimality error of one logged iteration: max(inf_pr, scaled inf_du, scaled
/// complementarity), the quantity of the paper's Fig. 5.
pub fn optimality_error(l: &crate::ip::IterLog) -> f64 {
    l.inf_pr.max(l.inf_du).max(l.compl)
}
