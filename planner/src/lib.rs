//! Math core of the reference-free minimum-time trajectory planner.
//!
//! Data flows one way: [`config`] (files) → [`track`] (road ahead) → [`ocp`] (the NLP of
//! paper eq. 3) → [`ip`] (interior-point solver) → trajectory. [`model`] holds the
//! single-track vehicle model of paper eq. (1); [`guess`] the equilibrium initial guess
//! of paper Sec. V.
#![deny(missing_docs)]
// Numerical kernels index several parallel arrays at once; iterators would obscure them.
#![allow(clippy::needless_range_loop)]

pub mod config;
pub mod cpu;
pub mod elementary;
pub mod guess;
pub mod ip;
pub mod model;
pub mod ocp;
pub mod plan;
pub mod plot;
pub mod record;
pub mod study;
pub mod track;
pub mod trajectory;
pub mod worker;

/// Number of intervals N of the planning horizon (paper: N = 100 over about 250 m). The
/// planner process, the recordings, the studies and the command line all plan with it.
pub const HORIZON: usize = 100;
