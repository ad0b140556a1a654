//! Primal-dual interior-point NLP solver (paper Sec. III), independent of vehicles.

pub mod nlp;

pub use nlp::{Nlp, NlpDims};
