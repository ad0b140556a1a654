//! [`PlanWriter`]: the MCAP file of a recording, written so that a crash of the writing
//! process loses at most the chunk it has open.
//!
//! Each chunk is built in memory (the MCAP writer's buffered chunk mode) and reaches the
//! file in one piece when it closes, followed by its message indexes, and the file is then
//! flushed to the operating system; at most once per [`SYNC_PERIOD`] it is also synced to
//! the disk. The file on disk is therefore always the magic, the header and a sequence of
//! complete chunks, possibly followed by the beginning of the next one: a prefix the
//! reader ([`crate::Recording`]) recovers. A clean finish appends the summary and footer.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use mcap::records::{MessageHeader, Metadata};
use mcap::write::NoSeek;
use mcap::{McapResult, WriteOptions, Writer};

use crate::cdr::{encode_input, encode_output, encode_warm, Encoder};
use crate::msg::{PlanInput, PlanOutput, PlanWarmStart};
use crate::recorder::RecordError;
use crate::schema::*;

/// Longest time a chunk stays open: a chunk closes after each plan's output, or when it has
/// been open this long, whichever comes first.
pub const CHUNK_PERIOD: Duration = Duration::from_secs(1);

/// Largest chunk \[bytes\] (uncompressed): a longer one closes at the next message.
pub const CHUNK_BYTES: u64 = 1 << 20;

/// Shortest time between two syncs of the file to the disk (flushes to the operating system
/// happen at every chunk close).
pub const SYNC_PERIOD: Duration = Duration::from_secs(1);

/// The file under the MCAP writer: flushing hands the buffered bytes to the operating
/// system and, when the last sync is [`SYNC_PERIOD`] old, syncs the data to the disk.
struct Sink {
    file: BufWriter<File>,
    last_sync: Instant,
}

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.file.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()?;
        if self.last_sync.elapsed() >= SYNC_PERIOD {
            self.file.get_ref().sync_data()?;
            self.last_sync = Instant::now();
        }
        Ok(())
    }
}

/// Writes planner inputs, warm starts and outputs as CDR messages on their three
/// channels, one chunk at a time.
pub(crate) struct PlanWriter {
    w: Writer<NoSeek<Sink>>,
    input: u16,
    output: u16,
    warm: u16,
    enc: Encoder,
    path: PathBuf,
    /// When the open chunk received its first message (None: no chunk open).
    opened: Option<Instant>,
    /// Inputs written.
    pub inputs: u64,
    /// Outputs written.
    pub outputs: u64,
    /// Warm starts written.
    pub warm_starts: u64,
}

impl PlanWriter {
    /// Creates the file and writes the header, the schemas and the channels as a first
    /// closed chunk, flushed, so even a recording killed before its first plan reads back.
    pub fn create(path: &Path) -> Result<Self, RecordError> {
        let file = File::create(path).map_err(|source| RecordError::Create {
            path: path.to_path_buf(),
            source,
        })?;
        let sink = Sink {
            file: BufWriter::new(file),
            last_sync: Instant::now(),
        };
        let mcap_err = |source| RecordError::Mcap {
            path: path.to_path_buf(),
            source,
        };
        let mut w = WriteOptions::new()
            .compression(None)
            .profile(PROFILE)
            .chunk_size(Some(CHUNK_BYTES))
            .disable_seeking(true)
            .create(NoSeek::new(sink))
            .map_err(mcap_err)?;
        let [input, output, warm] = add_channels(&mut w).map_err(mcap_err)?;
        w.flush().map_err(mcap_err)?;
        Ok(Self {
            w,
            input,
            output,
            warm,
            enc: Encoder::default(),
            path: path.to_path_buf(),
            opened: None,
            inputs: 0,
            outputs: 0,
            warm_starts: 0,
        })
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// When the open chunk must close (None: no chunk open).
    pub fn chunk_deadline(&self) -> Option<Instant> {
        self.opened.map(|t| t + CHUNK_PERIOD)
    }

    /// Writes an input into the open chunk (opening one if needed).
    pub fn write_input(&mut self, m: &PlanInput) -> McapResult<()> {
        encode_input(&mut self.enc, m);
        self.write(self.input, m.seq, m.stamp_ns)?;
        self.inputs += 1;
        Ok(())
    }

    /// Writes an output into the open chunk (opening one if needed).
    pub fn write_output(&mut self, m: &PlanOutput) -> McapResult<()> {
        encode_output(&mut self.enc, m);
        self.write(self.output, m.seq, m.stamp_ns)?;
        self.outputs += 1;
        Ok(())
    }

    /// Writes a warm start into the open chunk (opening one if needed).
    pub fn write_warm(&mut self, m: &PlanWarmStart) -> McapResult<()> {
        encode_warm(&mut self.enc, m);
        self.write(self.warm, m.seq, m.stamp_ns)?;
        self.warm_starts += 1;
        Ok(())
    }

    /// Messages written on all channels.
    pub fn messages(&self) -> u64 {
        self.inputs + self.outputs + self.warm_starts
    }

    fn write(&mut self, channel_id: u16, seq: u64, stamp: u64) -> McapResult<()> {
        let header = MessageHeader {
            channel_id,
            sequence: seq as u32,
            log_time: stamp,
            publish_time: stamp,
        };
        self.w.write_to_known_channel(&header, self.enc.bytes())?;
        self.opened.get_or_insert_with(Instant::now);
        Ok(())
    }

    /// Closes the open chunk (if any) and flushes the file to the operating system.
    pub fn close_chunk(&mut self) -> McapResult<()> {
        if self.opened.take().is_some() {
            self.w.flush()?;
        }
        Ok(())
    }

    /// Closes the open chunk, writes `metadata` under `name`, the summary and the footer,
    /// and syncs the file to the disk.
    pub fn finish(mut self, name: &str, metadata: BTreeMap<String, String>) -> McapResult<()> {
        self.close_chunk()?;
        self.w.write_metadata(&Metadata {
            name: name.into(),
            metadata,
        })?;
        self.w.finish()?;
        let mut sink = self.w.into_inner().into_inner();
        sink.file.flush()?;
        sink.file.get_ref().sync_all()?;
        Ok(())
    }
}

/// The input, output and warm-start channels with their schemas.
fn add_channels(w: &mut Writer<NoSeek<Sink>>) -> McapResult<[u16; 3]> {
    let mut ids = [0; 3];
    for (id, (name, text, topic)) in ids.iter_mut().zip([
        (PLAN_INPUT_NAME, PLAN_INPUT_MSG, INPUT_TOPIC),
        (PLAN_OUTPUT_NAME, PLAN_OUTPUT_MSG, OUTPUT_TOPIC),
        (PLAN_WARM_NAME, PLAN_WARM_MSG, WARM_TOPIC),
    ]) {
        let schema = w.add_schema(name, SCHEMA_ENCODING, text.as_bytes())?;
        *id = w.add_channel(schema, topic, MESSAGE_ENCODING, &BTreeMap::new())?;
    }
    Ok(ids)
}
