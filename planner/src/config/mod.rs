//! Configuration files (vehicle, scenarios, track index): serde types and validation.
//!
//! The data root (`config/` in the repository) holds `vehicles/`, `scenarios/` and
//! `tracks/`; paths written inside scenario files resolve against it ([`data_root_of`]).
//! Every failure is a [`ConfigError`] naming the file and the field or, for a track file,
//! the CSV line ([`crate::track::TrackFileError`]).

mod error;
mod fields;
pub mod paths;
mod scenario;
mod solver;
mod tracks;
mod vehicle;

pub use error::ConfigError;
pub use scenario::{
    data_root_of, list_selections, load_scenario, load_scenario_for_horizon, load_stretch, Stretch,
};
pub use solver::{load_solver, shipped_solver_file, SOLVER_FILE, SOLVER_FILE_MIN_TIME};
pub use tracks::{load_track_index, Direction, TrackInfo};
pub use vehicle::load_vehicle;
