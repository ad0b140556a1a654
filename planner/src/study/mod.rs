//! Reproducible studies of the paper, each a library function the `trajopt study`
//! subcommands call: [`integrators`] (Sec. IV and VI-A: the nine integrators against the
//! Gauss-Legendre 3-stage ground truth, Table I and Fig. 4a) and [`stiffness`] (Sec. IV,
//! eq. 7 and Fig. 3). [`figures`] draws their PNGs.

pub mod figures;
pub mod integrators;
pub mod stiffness;

use crate::guess::GuessError;
use crate::ip::SetupError;
use crate::ocp::TranscriptionError;
use crate::plot::PlotError;

/// Why a study could not run (a solve that ends with a failure status is not an error:
/// it is reported with its status).
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
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
    /// A study parameter is out of range.
    #[error("invalid study input: {0}")]
    Invalid(String),
}
