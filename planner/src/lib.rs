//! Math core of the reference-free minimum-time trajectory planner.
//!
//! Data flows one way: [`config`] (files) → [`track`] (road ahead) → [`ocp`] (the NLP of
//! paper eq. 3) → [`ip`] (interior-point solver) → trajectory. [`model`] holds the
//! single-track vehicle model of paper eq. (1); [`guess`] the equilibrium initial guess
//! of paper Sec. V.
//!
//! # Cargo features
//!
//! The solver core (everything above, plus [`plan`], [`record`], [`stats`]) needs neither
//! a command-line parser nor a plotting library; two features add them:
//! - `plot`: the PNG figures of a trajectory (`plot`, with the `plotters` dependency);
//! - `cli` (default; enables `plot`): the reproducible studies of the paper (`study`) and
//!   the `trajopt` executable (with the `clap` dependency).
//!
//! Crates that only solve (the planner process, the benchmarks) depend on this one with
//! `default-features = false`.
#![deny(missing_docs)]
// Numerical kernels index several parallel arrays at once; iterators would obscure them.
#![allow(clippy::needless_range_loop)]

pub mod config;
pub mod cpu;
pub mod elementary;
pub mod guess;
pub mod io;
pub mod ip;
pub mod model;
pub mod ocp;
pub mod plan;
#[cfg(feature = "plot")]
pub mod plot;
#[cfg(feature = "plot")]
pub mod plot_track;
pub mod progress;
pub mod record;
pub mod stats;
#[cfg(feature = "cli")]
pub mod study;
pub mod track;
pub mod trajectory;
pub mod worker;

/// Number of intervals N of the planning horizon (paper: N = 100 over about 250 m). The
/// planner process, the recordings, the studies and the command line all plan with it.
pub const HORIZON: usize = 100;
