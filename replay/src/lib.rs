//! Replay of planner recordings (issue 5): re-solve every recorded input with the recorded
//! configuration on a pinned core, check the outputs are bit-identical, and report latency
//! and jitter from an HDR histogram ([`run`]); summarise a file ([`info`]); record a 10 Hz
//! replanning drive along the oval ([`oval`]); draw the latency figure ([`plot`]).
//!
//! The recording format and the [`plan_record::Recorder`] live in `plan_record`
//! (`replay/record`), which does not depend on the planner, so the planner's own `trajopt`
//! binary can record too without a dependency cycle.

pub mod info;
pub mod oval;
pub mod plot;
pub mod run;
pub mod stats;

/// The horizon every shipped scenario uses (the planner is compiled for N = 100).
pub const N: usize = 100;
