//! Primal-dual interior-point NLP solver (paper Sec. III), independent of vehicles.
//!
//! Problem definition ([`nlp`]), linear algebra ([`kkt`]), algorithm ([`solver`],
//! [`barrier`], [`residuals`]), settings ([`settings`]) and results ([`info`]) are kept
//! apart; every buffer lives in the [`workspace`], allocated once.

pub mod barrier;
pub mod info;
pub mod kkt;
pub mod nlp;
pub mod residuals;
pub mod settings;
pub mod solver;
pub mod vector;
pub mod workspace;

pub use info::{IterLog, PhaseTimes, SolveInfo, Status, StepKind};
pub use nlp::{Nlp, NlpDims};
pub use settings::{BarrierRule, Globalization, Settings};
pub use solver::{SetupError, Solver};
