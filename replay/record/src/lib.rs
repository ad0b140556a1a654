//! Flight recorder of the planner: what each solve acted on ([`PlanInput`], and for a
//! warm-started solve where it started, [`PlanWarmStart`]) and what it produced
//! ([`PlanOutput`]), as plain structs, written to MCAP by a writer thread behind a
//! bounded queue ([`Recorder`]) and read back with full validation ([`Recording`]).
//!
//! Messages are CDR with `ros2msg` schemas ([`schema`]), so Foxglove decodes and plots them,
//! and every f64 is stored as its raw IEEE-754 bits, so replay reproduces inputs exactly.
//! This crate does not depend on the planner: any process (the `trajopt` CLI, the IPC
//! planner) can record, and `planner::record` converts between these structs and its types.
//!
//! Crash safety: the file is written one closed chunk at a time (after every plan, or
//! every [`CHUNK_PERIOD`]), so a writer killed mid-recording loses at most its open chunk,
//! and the reader recovers every complete chunk of a file cut short ([`Recovery`]). The file
//! is named [`partial_path`] until it closes cleanly, so a file under the final name is
//! always complete.

pub mod cdr;
mod msg;
mod reader;
mod recorder;
pub mod schema;
mod tail;
mod writer;

pub use msg::{
    config_hash, first_difference, PlanInput, PlanOutput, PlanRecord, PlanWarmStart, CONTROL_LEN,
    CONTROL_NAMES, SETTINGS_FIELDS, SETTINGS_LEN, STATE_LEN, STATE_NAMES, VEHICLE_FIELDS,
    VEHICLE_LEN, WARM_GUESS,
};
pub use reader::{ChannelInfo, ReadError, Recording, Recovery, MAX_FILE_BYTES};
pub use recorder::{
    now_ns, partial_path, write_recording, Record, RecordError, RecordStats, Recorder,
    METADATA_NAME,
};
pub use writer::{CHUNK_BYTES, CHUNK_PERIOD, SYNC_PERIOD};
