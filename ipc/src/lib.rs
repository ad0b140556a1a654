//! Inter-process messages and the planner/tracker processes.
//!
//! [`msg`] holds the `#[repr(C)]` zero-copy messages; [`services`] opens the iceoryx2
//! services both processes share; [`road`] samples the closed road ahead; [`plant`]
//! simulates the full vehicle model in time; [`tracker`] is the feed-forward + feedback
//! controller of the simple feedback kind, [`controller`] the feed-forward plus LQR one
//! ([`lqr`]: its gains), fed the state [`estimator`] filters; [`mismatch`] makes the plant differ from
//! the planner's model; [`planner_proc`] and [`tracker_proc`] are the two process loops;
//! [`lockstep`] runs the two on simulated time alone; [`stats`] collects latencies; [`kinds`] counts plans by kind; [`out`] writes the
//! standard streams without panicking
//! on a closed pipe.
#![deny(missing_docs)]
#![allow(clippy::needless_range_loop)]

pub mod clock;
pub mod controller;
pub mod estimator;
pub mod kinds;
pub mod lockstep;
pub mod lqr;
pub mod mismatch;
pub mod msg;
pub mod out;
pub mod planner_proc;
pub mod plant;
pub mod road;
pub mod services;
pub mod shutdown;
pub mod stats;
pub mod tracker;
pub mod tracker_proc;
