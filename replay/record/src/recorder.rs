//! [`Recorder`]: a bounded queue to an MCAP writer thread. Recording never blocks the
//! caller; when the queue is full the record is dropped and counted.
//!
//! Two ways in: [`Recorder::record`] moves a boxed record (it allocates; for callers off
//! the real-time path), and a pooled recorder ([`Recorder::create_pooled`]) lends
//! preallocated [`PlanRecord`]s: the caller takes a free one ([`Recorder::slot`]), copies
//! the plan into it in place and queues it ([`Recorder::record_plan`]); the writer thread
//! returns it to the pool once written. Neither the queue (a fixed ring of pointers) nor
//! the pool allocates after creation, so a pooled recording cycle allocates nothing.
//!
//! The writer thread ([`crate::writer::PlanWriter`]) closes the chunk after every output
//! and when a chunk has been open for [`crate::CHUNK_PERIOD`], so a crash loses at most the
//! open chunk.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, RecvTimeoutError, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Instant;

use crate::msg::{PlanInput, PlanOutput, PlanRecord, PlanWarmStart, WARM_GUESS};
use crate::reader::Recording;
use crate::writer::PlanWriter;

/// Name of the MCAP metadata record the recorder writes when it finishes.
pub const METADATA_NAME: &str = "plan_recorder";

/// One message for the recorder (boxed: the queue moves pointers, not 10 KB structs).
#[derive(Debug, Clone, PartialEq)]
pub enum Record {
    /// What a solve acted on.
    Input(Box<PlanInput>),
    /// What it produced.
    Output(Box<PlanOutput>),
    /// Where a warm-started solve started.
    Warm(Box<PlanWarmStart>),
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
    /// The MCAP writer failed (an I/O failure shows the operating system's reason).
    #[error("{path}: MCAP write failed: {}", mcap_reason(source))]
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
    /// The finished file could not be moved into place.
    #[error("{path}: cannot rename {from} to it: {source}")]
    Rename {
        /// The destination.
        path: PathBuf,
        /// The temporary file.
        from: PathBuf,
        /// Why.
        source: std::io::Error,
    },
}

/// The reason of an MCAP failure: the operating system's for an I/O error (e.g. "No space
/// left on device (os error 28)"), else the MCAP error's own.
fn mcap_reason(e: &mcap::McapError) -> String {
    match e {
        mcap::McapError::Io(io) => io.to_string(),
        e => e.to_string(),
    }
}

/// Where a recording to `path` is written until it closes cleanly: `path` with `.partial`
/// appended, in the same folder. [`Recorder::finish`] renames it to `path`; a recording
/// whose process died is found under this name, and [`Recording::read`] (and `replay
/// recover`) reads what it holds.
pub fn partial_path(path: &Path) -> PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(".partial");
    PathBuf::from(name)
}

/// Counts of a finished recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RecordStats {
    /// Inputs written.
    pub inputs: u64,
    /// Outputs written.
    pub outputs: u64,
    /// Warm starts written.
    pub warm_starts: u64,
    /// Records dropped because the queue was full, no pooled slot was free, or the writer
    /// had failed (a pooled plan counts as two records, three when warm-started).
    pub dropped: u64,
}

/// What travels to the writer thread.
enum Job {
    One(Record),
    Plan(Box<PlanRecord>),
}

impl Job {
    fn records(&self) -> u64 {
        match self {
            Job::One(_) => 1,
            Job::Plan(p) => plan_records(p),
        }
    }
}

/// Messages of one pooled plan: input and output, and the warm start when there is one.
fn plan_records(p: &PlanRecord) -> u64 {
    if p.input.guess == WARM_GUESS {
        3
    } else {
        2
    }
}

/// The free slots of a pooled recorder.
#[derive(Debug)]
struct Pool {
    /// Returns a slot that could not be queued.
    back: SyncSender<Box<PlanRecord>>,
    /// Free slots (a mutex so the recorder stays `Sync`; only the recording thread locks it).
    free: Mutex<Receiver<Box<PlanRecord>>>,
}

/// Records planner inputs and outputs to an MCAP file from any thread without blocking.
#[derive(Debug)]
pub struct Recorder {
    tx: Option<SyncSender<Job>>,
    pool: Option<Pool>,
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

impl Recorder {
    /// Creates the file under its [`partial_path`] (errors surface here) and starts the
    /// writer thread with a queue of `capacity` records; a clean finish renames the file to
    /// `path`.
    pub fn create(path: &Path, capacity: usize) -> Result<Self, RecordError> {
        Self::start(path, capacity, None)
    }

    /// Like [`Recorder::create`], with a pool of `slots` copies of `template` (the queue
    /// holds as many), each with the template's capacities: give its vectors and strings
    /// the capacity a plan needs, and filling a slot allocates nothing.
    pub fn create_pooled(
        path: &Path,
        template: &PlanRecord,
        slots: usize,
    ) -> Result<Self, RecordError> {
        if slots == 0 {
            return Err(RecordError::Capacity);
        }
        let (back, free) = sync_channel(slots);
        for _ in 0..slots {
            // The channel holds `slots`: these never fail.
            let _ = back.try_send(Box::new(template.clone_with_capacity()));
        }
        let pool = Pool {
            back,
            free: Mutex::new(free),
        };
        Self::start(path, slots, Some(pool))
    }

    fn start(path: &Path, capacity: usize, pool: Option<Pool>) -> Result<Self, RecordError> {
        if capacity == 0 {
            return Err(RecordError::Capacity);
        }
        let writer = PlanWriter::create(&partial_path(path))?;
        let (tx, rx) = sync_channel(capacity);
        let dropped = Arc::new(AtomicU64::new(0));
        let thread_dropped = Arc::clone(&dropped);
        let back = pool.as_ref().map(|p| p.back.clone());
        let thread = std::thread::Builder::new()
            .name("plan-recorder".into())
            .spawn(move || write_loop(writer, rx, back, &thread_dropped, capacity))
            .map_err(|e| RecordError::Thread {
                path: path.to_path_buf(),
                what: e.to_string(),
            })?;
        Ok(Self {
            tx: Some(tx),
            pool,
            thread: Some(thread),
            dropped,
            path: path.to_path_buf(),
        })
    }

    /// Queues a record without blocking; false (and one more drop) when the queue is full.
    pub fn record(&self, record: Record) -> bool {
        let sent = match &self.tx {
            Some(tx) => tx.try_send(Job::One(record)).is_ok(),
            None => false,
        };
        if !sent {
            self.dropped.fetch_add(1, Ordering::Relaxed);
        }
        sent
    }

    /// A free slot of the pool to fill in place (allocates nothing), or None when every
    /// slot is queued or the recorder has no pool: that plan is dropped and counted as two
    /// records.
    pub fn slot(&self) -> Option<Box<PlanRecord>> {
        let slot = self
            .pool
            .as_ref()
            .and_then(|p| p.free.lock().ok()?.try_recv().ok());
        if slot.is_none() {
            self.dropped.fetch_add(2, Ordering::Relaxed);
        }
        slot
    }

    /// Queues a filled slot without blocking; false (two more drops, the slot back in the
    /// pool) when the queue is full.
    pub fn record_plan(&self, slot: Box<PlanRecord>) -> bool {
        let Some(tx) = &self.tx else {
            self.dropped.fetch_add(2, Ordering::Relaxed);
            return false;
        };
        match tx.try_send(Job::Plan(slot)) {
            Ok(()) => true,
            Err(TrySendError::Full(job) | TrySendError::Disconnected(job)) => {
                self.dropped.fetch_add(job.records(), Ordering::Relaxed);
                if let (Job::Plan(slot), Some(pool)) = (job, &self.pool) {
                    let _ = pool.back.try_send(slot);
                }
                false
            }
        }
    }

    /// Records dropped so far.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }

    /// Drains the queue, writes the summary, closes the file and renames it from its
    /// [`partial_path`] to its name. A recording that fails stays under the partial name
    /// with every chunk it closed (readable like the file of a crashed recorder).
    pub fn finish(mut self) -> Result<RecordStats, RecordError> {
        self.shutdown()
    }

    fn shutdown(&mut self) -> Result<RecordStats, RecordError> {
        drop(self.tx.take());
        let stats = match self.thread.take() {
            Some(t) => t.join().map_err(|_| RecordError::Thread {
                path: self.path.clone(),
                what: "writer thread panicked".into(),
            })??,
            None => {
                return Err(RecordError::Thread {
                    path: self.path.clone(),
                    what: "already finished".into(),
                })
            }
        };
        let partial = partial_path(&self.path);
        std::fs::rename(&partial, &self.path).map_err(|source| RecordError::Rename {
            path: self.path.clone(),
            from: partial,
            source,
        })?;
        Ok(stats)
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

/// Writes one job; closes the chunk after every output.
fn write_job(w: &mut PlanWriter, job: &Job) -> mcap::McapResult<()> {
    match job {
        Job::One(Record::Input(m)) => w.write_input(m),
        Job::One(Record::Warm(m)) => w.write_warm(m),
        Job::One(Record::Output(m)) => {
            w.write_output(m)?;
            w.close_chunk()
        }
        Job::Plan(p) => {
            w.write_input(&p.input)?;
            if p.input.guess == WARM_GUESS {
                w.write_warm(&p.warm)?;
            }
            w.write_output(&p.output)?;
            w.close_chunk()
        }
    }
}

/// The next job, closing the open chunk when its period ends first; None when the
/// queue is closed and empty.
fn next_job(
    w: &mut PlanWriter,
    rx: &Receiver<Job>,
    failed: &mut Option<mcap::McapError>,
) -> Option<Job> {
    loop {
        let Some(deadline) = w.chunk_deadline() else {
            return rx.recv().ok();
        };
        match rx.recv_timeout(deadline.saturating_duration_since(Instant::now())) {
            Ok(job) => return Some(job),
            Err(RecvTimeoutError::Timeout) => {
                if let Err(e) = w.close_chunk() {
                    failed.get_or_insert(e);
                }
            }
            Err(RecvTimeoutError::Disconnected) => return None,
        }
    }
}

fn write_loop(
    mut w: PlanWriter,
    rx: Receiver<Job>,
    back: Option<SyncSender<Box<PlanRecord>>>,
    dropped: &AtomicU64,
    capacity: usize,
) -> Result<RecordStats, RecordError> {
    let mut failed = None;
    while let Some(job) = next_job(&mut w, &rx, &mut failed) {
        if failed.is_some() {
            dropped.fetch_add(job.records(), Ordering::Relaxed);
        } else {
            let before = w.messages();
            let mut result = write_job(&mut w, &job);
            if result.is_ok() && w.chunk_deadline().is_some_and(|d| Instant::now() >= d) {
                result = w.close_chunk();
            }
            if let Err(e) = result {
                let written = w.messages() - before;
                dropped.fetch_add(job.records() - written, Ordering::Relaxed);
                failed = Some(e);
            }
        }
        if let (Job::Plan(slot), Some(back)) = (job, &back) {
            let _ = back.try_send(slot);
        }
    }
    let path = w.path().to_path_buf();
    let mcap_err = |source| RecordError::Mcap { path, source };
    if let Some(e) = failed {
        return Err(mcap_err(e));
    }
    let stats = RecordStats {
        inputs: w.inputs,
        outputs: w.outputs,
        warm_starts: w.warm_starts,
        dropped: dropped.load(Ordering::Relaxed),
    };
    let metadata = BTreeMap::from([
        ("inputs".to_string(), stats.inputs.to_string()),
        ("outputs".to_string(), stats.outputs.to_string()),
        ("warm_starts".to_string(), stats.warm_starts.to_string()),
        ("dropped".to_string(), stats.dropped.to_string()),
        ("queue_capacity".to_string(), capacity.to_string()),
    ]);
    w.finish(METADATA_NAME, metadata).map_err(mcap_err)?;
    Ok(stats)
}

/// Writes the inputs, warm starts and outputs of `rec` to a cleanly closed file at `path`,
/// in log-time order (each warm start after its input, one chunk per output, like the
/// recorder), keeping the recorder's metadata and
/// noting the bytes a recovery dropped. The file is written beside `path` under a
/// temporary name, synced, and renamed over `path`, so `path` is never half written.
pub fn write_recording(rec: &Recording, path: &Path) -> Result<RecordStats, RecordError> {
    let name = path
        .file_name()
        .map_or_else(|| "recording".into(), |n| n.to_string_lossy().into_owned());
    let tmp = path.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
    let result = write_clean(rec, &tmp);
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
        return result;
    }
    std::fs::rename(&tmp, path).map_err(|source| {
        let _ = std::fs::remove_file(&tmp);
        RecordError::Rename {
            path: path.to_path_buf(),
            from: tmp.clone(),
            source,
        }
    })?;
    result
}

fn write_clean(rec: &Recording, path: &Path) -> Result<RecordStats, RecordError> {
    let mut w = PlanWriter::create(path)?;
    let mcap_err = |source| RecordError::Mcap {
        path: path.to_path_buf(),
        source,
    };
    let (mut i, mut o) = (0, 0);
    while i < rec.inputs.len() || o < rec.outputs.len() {
        let input_first = match (rec.inputs.get(i), rec.outputs.get(o)) {
            (Some(a), Some(b)) => a.stamp_ns <= b.stamp_ns,
            (a, _) => a.is_some(),
        };
        if input_first {
            let input = &rec.inputs[i];
            w.write_input(input).map_err(mcap_err)?;
            for warm in rec.warm_starts.iter().filter(|m| m.seq == input.seq) {
                w.write_warm(warm).map_err(mcap_err)?;
            }
            i += 1;
        } else {
            w.write_output(&rec.outputs[o]).map_err(mcap_err)?;
            w.close_chunk().map_err(mcap_err)?;
            o += 1;
        }
    }
    let stats = RecordStats {
        inputs: w.inputs,
        outputs: w.outputs,
        warm_starts: w.warm_starts,
        dropped: rec.dropped().unwrap_or(0),
    };
    let mut metadata = rec.recorder.clone();
    metadata.insert("inputs".into(), stats.inputs.to_string());
    metadata.insert("outputs".into(), stats.outputs.to_string());
    metadata.insert("warm_starts".into(), stats.warm_starts.to_string());
    if let Some(r) = &rec.recovery {
        metadata.insert(
            "recovered_dropped_bytes".into(),
            r.dropped_bytes.to_string(),
        );
    }
    w.finish(METADATA_NAME, metadata).map_err(mcap_err)?;
    Ok(stats)
}

// The recorder can be shared by reference between threads.
const _: fn() = || {
    fn is<T: Send + Sync>() {}
    is::<Recorder>();
};
