//! Inter-process messages and the planner/tracker processes.
//!
//! [`msg`] holds the `#[repr(C)]` zero-copy messages; [`services`] opens the iceoryx2
//! services both processes share; [`road`] samples the closed road ahead; [`plant`]
//! simulates the full vehicle model in time; [`tracker`] is the feed-forward + feedback
//! controller; [`planner_proc`] and [`tracker_proc`] are the two process loops;
//! [`stats`] collects latencies; [`kinds`] counts plans by kind; [`out`] writes the standard streams without panicking
//! on a closed pipe.
#![deny(missing_docs)]
#![allow(clippy::needless_range_loop)]

pub mod clock;
pub mod kinds;
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
