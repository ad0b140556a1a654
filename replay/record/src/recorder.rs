//! [`Recorder`]: a bounded queue to an MCAP writer thread. Recording never blocks the
//! caller; when the queue is full the record is dropped and counted.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender, TrySendError};
use std::sync::Arc;
use std::thread::JoinHandle;

use mcap::records::{MessageHeader, Metadata};
use mcap::{WriteOptions, Writer};

use crate::cdr::{encode_input, encode_output, Encoder};
use crate::msg::{PlanInput, PlanOutput};
use crate::schema::*;

/// Name of the MCAP metadata record the recorder writes when it finishes.
pub const METADATA_NAME: &str = "plan_recorder";

/// One message for the recorder (boxed: the queue moves pointers, not 10 KB structs).
#[derive(Debug, Clone, PartialEq)]
pub enum Record {
    /// What a solve acted on.
    Input(Box<PlanInput>),
    /// What it produced.
    Output(Box<PlanOutput>),
}

/// Why a recording could not be written.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The file could not be created.
    #[error("{path}: cannot create: {source}")]
    Create {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The MCAP writer failed.
    #[error("{path}: MCAP write failed: {source}")]
    Mcap {
        /// The file.
        path: PathBuf,
        /// Why.
        source: mcap::McapError,
    },
    /// The queue capacity is zero.
    #[error("recorder queue capacity must be at least 1")]
    Capacity,
    /// The writer thread could not be started or panicked.
    #[error("{path}: recorder thread failed: {what}")]
    Thread {
        /// The file.
        path: PathBuf,
        /// What happened.
        what: String,
    },
}

/// Counts of a finished recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RecordStats {
    /// Inputs written.
    pub inputs: u64,
    /// Outputs written.
    pub outputs: u64,
    /// Records dropped because the queue was full (or the writer had failed).
    pub dropped: u64,
}

/// Records planner inputs and outputs to an MCAP file from any thread without blocking.
#[derive(Debug)]
pub struct Recorder {
    tx: Option<SyncSender<Record>>,
    thread: Option<JoinHandle<Result<RecordStats, RecordError>>>,
    dropped: Arc<AtomicU64>,
    path: PathBuf,
}

/// Nanoseconds since the Unix epoch (0 if the clock is before it).
pub fn now_ns() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

struct Channels {
    input: u16,
    output: u16,
}

fn open(path: &Path) -> Result<(Writer<BufWriter<File>>, Channels), RecordError> {
    let mcap_err = |source| RecordError::Mcap {
        path: path.to_path_buf(),
        source,
    };
    let file = File::create(path).map_err(|source| RecordError::Create {
        path: path.to_path_buf(),
        source,
    })?;
    let mut w = WriteOptions::new()
        .compression(None)
        .profile("")
        .create(BufWriter::new(file))
        .map_err(mcap_err)?;
    let si = w
        .add_schema(PLAN_INPUT_NAME, SCHEMA_ENCODING, PLAN_INPUT_MSG.as_bytes())
        .map_err(mcap_err)?;
    let so = w
        .add_schema(
            PLAN_OUTPUT_NAME,
            SCHEMA_ENCODING,
            PLAN_OUTPUT_MSG.as_bytes(),
        )
        .map_err(mcap_err)?;
    let input = w
        .add_channel(si, INPUT_TOPIC, MESSAGE_ENCODING, &BTreeMap::new())
        .map_err(mcap_err)?;
    let output = w
        .add_channel(so, OUTPUT_TOPIC, MESSAGE_ENCODING, &BTreeMap::new())
        .map_err(mcap_err)?;
    Ok((w, Channels { input, output }))
}

impl Recorder {
    /// Creates the file (errors surface here) and starts the writer thread with a queue of
    /// `capacity` records.
    pub fn create(path: &Path, capacity: usize) -> Result<Self, RecordError> {
        if capacity == 0 {
            return Err(RecordError::Capacity);
        }
        let (writer, channels) = open(path)?;
        let (tx, rx) = sync_channel(capacity);
        let dropped = Arc::new(AtomicU64::new(0));
        let thread_dropped = Arc::clone(&dropped);
        let thread_path = path.to_path_buf();
        let thread = std::thread::Builder::new()
            .name("plan-recorder".into())
            .spawn(move || {
                write_loop(
                    writer,
                    channels,
                    rx,
                    &thread_dropped,
                    capacity,
                    &thread_path,
                )
            })
            .map_err(|e| RecordError::Thread {
                path: path.to_path_buf(),
                what: e.to_string(),
            })?;
        Ok(Self {
            tx: Some(tx),
            thread: Some(thread),
            dropped,
            path: path.to_path_buf(),
        })
    }

    /// Queues a record without blocking; false (and one more drop) when the queue is full.
    pub fn record(&self, record: Record) -> bool {
        let sent = match &self.tx {
            Some(tx) => match tx.try_send(record) {
                Ok(()) => true,
                Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => false,
            },
            None => false,
        };
        if !sent {
            self.dropped.fetch_add(1, Ordering::Relaxed);
        }
        sent
    }

    /// Records dropped so far.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }

    /// Drains the queue, writes the summary and closes the file.
    pub fn finish(mut self) -> Result<RecordStats, RecordError> {
        self.shutdown()
    }

    fn shutdown(&mut self) -> Result<RecordStats, RecordError> {
        drop(self.tx.take());
        match self.thread.take() {
            Some(t) => t.join().map_err(|_| RecordError::Thread {
                path: self.path.clone(),
                what: "writer thread panicked".into(),
            })?,
            None => Err(RecordError::Thread {
                path: self.path.clone(),
                what: "already finished".into(),
            }),
        }
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        if self.thread.is_some() {
            // Best effort: a recorder dropped without finish() still closes a valid file.
            let _ = self.shutdown();
        }
    }
}

fn write_loop(
    mut w: Writer<BufWriter<File>>,
    ch: Channels,
    rx: Receiver<Record>,
    dropped: &AtomicU64,
    capacity: usize,
    path: &Path,
) -> Result<RecordStats, RecordError> {
    let mcap_err = |source| RecordError::Mcap {
        path: path.to_path_buf(),
        source,
    };
    let mut enc = Encoder::default();
    let (mut inputs, mut outputs) = (0u64, 0u64);
    let mut failed = None;
    for record in rx.iter() {
        if failed.is_some() {
            dropped.fetch_add(1, Ordering::Relaxed);
            continue;
        }
        let (channel_id, seq, stamp) = match &record {
            Record::Input(m) => {
                encode_input(&mut enc, m);
                (ch.input, m.seq, m.stamp_ns)
            }
            Record::Output(m) => {
                encode_output(&mut enc, m);
                (ch.output, m.seq, m.stamp_ns)
            }
        };
        let header = MessageHeader {
            channel_id,
            sequence: seq as u32,
            log_time: stamp,
            publish_time: stamp,
        };
        match w.write_to_known_channel(&header, enc.bytes()) {
            Ok(()) => match record {
                Record::Input(_) => inputs += 1,
                Record::Output(_) => outputs += 1,
            },
            Err(e) => {
                dropped.fetch_add(1, Ordering::Relaxed);
                failed = Some(e);
            }
        }
    }
    if let Some(e) = failed {
        return Err(mcap_err(e));
    }
    let stats = RecordStats {
        inputs,
        outputs,
        dropped: dropped.load(Ordering::Relaxed),
    };
    let metadata = Metadata {
        name: METADATA_NAME.into(),
        metadata: BTreeMap::from([
            ("inputs".to_string(), inputs.to_string()),
            ("outputs".to_string(), outputs.to_string()),
            ("dropped".to_string(), stats.dropped.to_string()),
            ("queue_capacity".to_string(), capacity.to_string()),
        ]),
    };
    w.write_metadata(&metadata).map_err(mcap_err)?;
    w.finish().map_err(mcap_err)?;
    Ok(stats)
}
