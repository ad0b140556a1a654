//! Replay of planner recordings: re-solve every recorded input with the recorded
//! configuration on a pinned core, check the outputs are bit-identical, and report latency
//! and jitter from an HDR histogram ([`run`]); summarise a file ([`info`]); record a 10 Hz
//! replanning drive along the oval ([`oval`]); replay under a time or iteration budget
//! and say what the car would have been sent ([`budget`]); draw the latency figure ([`plot`]). Both
//! `run` and `info` judge a file by the same checks ([`validate`]).
//!
//! The recording format and the [`plan_record::Recorder`] live in `plan_record`
//! (`replay/record`), which does not depend on the planner, so the planner's own `trajopt`
//! binary can record too without a dependency cycle.

pub mod budget;
pub mod info;
pub mod oval;
pub mod plan_log;
pub mod plot;
pub mod run;
pub mod stats;
pub mod validate;

/// The horizon every recording is replayed with: the planner's [`planner::HORIZON`].
pub const N: usize = planner::HORIZON;
