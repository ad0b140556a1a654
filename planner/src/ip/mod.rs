//! Primal-dual interior-point NLP solver (paper Sec. III), independent of vehicles.
//!
//! Problem definition ([`nlp`]), linear algebra ([`kkt`], [`sparse`]), algorithm
//! ([`solver`], [`barrier`], [`residuals`]), settings ([`settings`]) and results ([`info`])
//! are kept apart; every buffer lives in the [`workspace`], allocated once.
//!
//! The modules depend on each other one way: [`sparse`] knows only slices; the
//! [`workspace`] holds the sparse patterns; the [`vector`] kernels work on the workspace;
//! [`residuals`] combines the sparse products and the vector kernels; [`barrier`] and the
//! [`solver`] use them all.

pub mod barrier;
pub mod info;
pub mod kkt;
pub mod nlp;
pub mod residuals;
pub mod settings;
pub mod solver;
pub mod sparse;
pub mod vector;
pub mod workspace;

pub use info::{IterLog, PhaseTimes, SolveInfo, Status, StepKind};
pub use nlp::{Nlp, NlpDims};
pub use settings::{BarrierRule, Globalization, Settings};
pub use solver::{MuMatch, SetupError, Solver, WarmStart};
