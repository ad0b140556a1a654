//! [`Recording`]: reads a whole MCAP file into memory and validates everything (magic,
//! record lengths, chunk / data-section / summary CRCs, schemas of the planner channels,
//! every CDR payload). Any damage is an error naming where it is; nothing panics.
//!
//! A file cut short (a writer killed or a machine that lost power) is read up to its last
//! complete record ([`crate::tail`] finds the cut): every complete chunk is recovered, CRCs
//! checked, and [`Recording::recovery`] says how many bytes were dropped.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use mcap::records::Record as McapRecord;
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};

use crate::cdr::{decode_input, decode_output, decode_warm, DecodeError};
use crate::msg::{PlanInput, PlanOutput, PlanWarmStart};
use crate::recorder::METADATA_NAME;
use crate::schema::*;
use crate::tail::{scan, Tail};

/// Largest recording [`Recording::read`] loads \[bytes\].
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// Cap on reader events (records plus read requests), so a hostile file cannot loop it.
const MAX_EVENTS: usize = 100_000_000;

/// Why a recording could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The file could not be read.
    #[error("{path}: cannot read: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The file is larger than [`MAX_FILE_BYTES`].
    #[error("{size} bytes is larger than the {MAX_FILE_BYTES}-byte limit")]
    TooLarge {
        /// Its size.
        size: u64,
    },
    /// The file has no bytes.
    #[error("empty file (0 bytes): not an MCAP recording")]
    Empty,
    /// The MCAP structure is damaged (truncated, bad magic, CRC mismatch, bad record).
    #[error("invalid MCAP (failed after reading {offset} of {size} bytes): {source}")]
    Mcap {
        /// Bytes handed to the parser when it failed.
        offset: usize,
        /// File size.
        size: usize,
        /// The parser's error.
        source: mcap::McapError,
    },
    /// The file ends inside a record that cannot be the start of a valid one.
    #[error("damaged MCAP (record at byte {offset} of {size}): {problem}")]
    Damaged {
        /// Offset of the record.
        offset: usize,
        /// File size.
        size: usize,
        /// What is wrong.
        problem: String,
    },
    /// Two records define the same schema or channel id differently.
    #[error("{what} id {id} is defined twice with different contents")]
    Conflict {
        /// `schema` or `channel`.
        what: &'static str,
        /// The id.
        id: u16,
    },
    /// A channel names a schema id that was not defined before it.
    #[error("channel {topic} refers to unknown schema id {schema_id}")]
    UnknownSchema {
        /// Channel topic.
        topic: String,
        /// The missing id.
        schema_id: u16,
    },
    /// A message refers to a channel id that was not defined before it.
    #[error("message {index} refers to unknown channel id {channel_id}")]
    UnknownChannel {
        /// Message number in the file (from 0).
        index: u64,
        /// The missing id.
        channel_id: u16,
    },
    /// A planner channel carries a different schema or encoding.
    #[error("channel {topic}: found {found}, expected {expected}")]
    WrongSchema {
        /// Channel topic.
        topic: String,
        /// What the file says (name, schema encoding, message encoding).
        found: String,
        /// What this reader understands.
        expected: String,
    },
    /// A planner message could not be decoded.
    #[error("{topic} message {index} (log time {log_time} ns): {source}")]
    Decode {
        /// Channel topic.
        topic: &'static str,
        /// Message number on that topic (from 0).
        index: u64,
        /// Its log time.
        log_time: u64,
        /// What is wrong in the payload.
        source: DecodeError,
    },
}

/// One channel of a recording.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelInfo {
    /// Channel id.
    pub id: u16,
    /// Topic.
    pub topic: String,
    /// Schema name ("" when schemaless).
    pub schema: String,
    /// Schema encoding.
    pub schema_encoding: String,
    /// Message encoding.
    pub message_encoding: String,
    /// Messages on it.
    pub messages: u64,
}

/// A decoded, validated recording.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Recording {
    /// Planner inputs, in file order.
    pub inputs: Vec<PlanInput>,
    /// Planner outputs, in file order.
    pub outputs: Vec<PlanOutput>,
    /// Warm starts of the warm-started inputs, in file order.
    pub warm_starts: Vec<PlanWarmStart>,
    /// Every channel, by id.
    pub channels: Vec<ChannelInfo>,
    /// Earliest message log time \[ns\].
    pub start_ns: Option<u64>,
    /// Latest message log time \[ns\].
    pub end_ns: Option<u64>,
    /// The recorder's closing metadata (counts and drops), if present.
    pub recorder: BTreeMap<String, String>,
    /// File size \[bytes\].
    pub bytes: u64,
    /// What was recovered of a file that was not closed cleanly (None: closed cleanly).
    pub recovery: Option<Recovery>,
}

/// What a read kept of a file that was not closed cleanly (a crashed or killed writer).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Recovery {
    /// Bytes read: the magic, the header and every complete record before the cut.
    pub kept_bytes: u64,
    /// Bytes after them, dropped: the incomplete record the file ends inside.
    pub dropped_bytes: u64,
    /// Where the file ends, for people.
    pub ends: String,
}

impl std::fmt::Display for Recovery {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "not closed cleanly: the file ends {}; recovered every complete chunk ({} bytes), dropped {} bytes",
            self.ends, self.kept_bytes, self.dropped_bytes
        )
    }
}

#[derive(PartialEq)]
struct SchemaDef {
    name: String,
    encoding: String,
    /// The schema text (a planner channel's must be the one this crate writes).
    text: Vec<u8>,
}

/// Decodes records into a [`Recording`] as the MCAP reader emits them.
#[derive(Default)]
struct Decoder {
    rec: Recording,
    schemas: BTreeMap<u16, SchemaDef>,
    channels: BTreeMap<u16, ChannelInfo>,
    messages: u64,
}

impl Decoder {
    fn record(&mut self, record: McapRecord<'_>) -> Result<(), ReadError> {
        match record {
            McapRecord::Schema { header, data } => {
                let def = SchemaDef {
                    name: header.name,
                    encoding: header.encoding,
                    text: data.into_owned(),
                };
                match self.schemas.get(&header.id) {
                    Some(old) if *old != def => {
                        return Err(ReadError::Conflict {
                            what: "schema",
                            id: header.id,
                        })
                    }
                    Some(_) => {}
                    None => {
                        self.schemas.insert(header.id, def);
                    }
                }
            }
            McapRecord::Channel(c) => self.channel(c)?,
            McapRecord::Message { header, data } => self.message(&header, &data)?,
            McapRecord::Metadata(m) if m.name == METADATA_NAME => {
                self.rec.recorder = m.metadata;
            }
            _ => {}
        }
        Ok(())
    }

    fn channel(&mut self, c: mcap::records::Channel) -> Result<(), ReadError> {
        let (schema, schema_encoding, text) = if c.schema_id == 0 {
            (String::new(), String::new(), &[][..])
        } else {
            let s = self
                .schemas
                .get(&c.schema_id)
                .ok_or_else(|| ReadError::UnknownSchema {
                    topic: c.topic.clone(),
                    schema_id: c.schema_id,
                })?;
            (s.name.clone(), s.encoding.clone(), &s.text[..])
        };
        let info = ChannelInfo {
            id: c.id,
            topic: c.topic,
            schema,
            schema_encoding,
            message_encoding: c.message_encoding,
            messages: 0,
        };
        check_planner_channel(&info, text)?;
        match self.channels.get(&c.id) {
            Some(old)
                if old.topic != info.topic
                    || old.schema != info.schema
                    || old.message_encoding != info.message_encoding =>
            {
                return Err(ReadError::Conflict {
                    what: "channel",
                    id: c.id,
                })
            }
            Some(_) => {}
            None => {
                self.channels.insert(c.id, info);
            }
        }
        Ok(())
    }

    fn message(
        &mut self,
        header: &mcap::records::MessageHeader,
        payload: &[u8],
    ) -> Result<(), ReadError> {
        let ch = self
            .channels
            .get_mut(&header.channel_id)
            .ok_or(ReadError::UnknownChannel {
                index: self.messages,
                channel_id: header.channel_id,
            })?;
        let index = ch.messages;
        ch.messages += 1;
        self.messages += 1;
        let rec = &mut self.rec;
        let t = header.log_time;
        rec.start_ns = Some(rec.start_ns.map_or(t, |s| s.min(t)));
        rec.end_ns = Some(rec.end_ns.map_or(t, |e| e.max(t)));
        let decode_err = |topic, source| ReadError::Decode {
            topic,
            index,
            log_time: t,
            source,
        };
        if ch.topic == INPUT_TOPIC {
            let m = decode_input(payload).map_err(|e| decode_err(INPUT_TOPIC, e))?;
            rec.inputs.push(m);
        } else if ch.topic == OUTPUT_TOPIC {
            let m = decode_output(payload).map_err(|e| decode_err(OUTPUT_TOPIC, e))?;
            rec.outputs.push(m);
        } else if ch.topic == WARM_TOPIC {
            let m = decode_warm(payload).map_err(|e| decode_err(WARM_TOPIC, e))?;
            rec.warm_starts.push(m);
        }
        Ok(())
    }

    fn done(mut self, recovery: Option<Recovery>) -> Recording {
        self.rec.channels = self.channels.into_values().collect();
        self.rec.recovery = recovery;
        self.rec
    }
}

impl Recording {
    /// Reads and validates a file, recovering a cut one (see [`Recording::from_bytes`]).
    pub fn read(path: &Path) -> Result<Self, ReadError> {
        let io = |source| ReadError::Io {
            path: path.to_path_buf(),
            source,
        };
        let size = std::fs::metadata(path).map_err(io)?.len();
        if size > MAX_FILE_BYTES {
            return Err(ReadError::TooLarge { size });
        }
        let data = std::fs::read(path).map_err(io)?;
        Self::from_bytes(&data)
    }

    /// Validates and decodes an in-memory file. A file cut short (no summary or footer, or
    /// an incomplete last record, as a killed writer leaves it) gives every complete
    /// record before the cut and a [`Recovery`] saying what was dropped; any other damage
    /// is an error.
    pub fn from_bytes(data: &[u8]) -> Result<Self, ReadError> {
        if data.is_empty() {
            return Err(ReadError::Empty);
        }
        if data.len() as u64 > MAX_FILE_BYTES {
            return Err(ReadError::TooLarge {
                size: data.len() as u64,
            });
        }
        match scan(data) {
            Tail::Whole => decode(data, data.len(), None),
            Tail::Cut { at, ends } => {
                let recovery = Recovery {
                    kept_bytes: at as u64,
                    dropped_bytes: (data.len() - at) as u64,
                    ends,
                };
                decode(data, at, Some(recovery))
            }
            Tail::Damaged { at, problem } => Err(ReadError::Damaged {
                offset: at,
                size: data.len(),
                problem,
            }),
        }
    }

    /// True when the file was closed cleanly (nothing was recovered or dropped).
    pub fn complete(&self) -> bool {
        self.recovery.is_none()
    }

    /// Time between the first and the last message \[s\].
    pub fn duration_s(&self) -> f64 {
        match (self.start_ns, self.end_ns) {
            (Some(a), Some(b)) => b.saturating_sub(a) as f64 * 1e-9,
            _ => 0.0,
        }
    }

    /// The warm start recorded for input `seq`.
    pub fn warm_start(&self, seq: u64) -> Option<&PlanWarmStart> {
        self.warm_starts.iter().find(|w| w.seq == seq)
    }

    /// Records the recorder dropped, if it wrote its closing metadata.
    pub fn dropped(&self) -> Option<u64> {
        self.recorder.get("dropped").and_then(|v| v.parse().ok())
    }
}

/// Runs the MCAP reader over `data[..end]` (all CRCs checked) and decodes what it emits.
/// Without a `recovery`, `end` is the file's size and running out of bytes is an error;
/// with one, `end` is a record boundary and the read stops there.
fn decode(data: &[u8], end: usize, recovery: Option<Recovery>) -> Result<Recording, ReadError> {
    let options = LinearReaderOptions::default()
        .with_emit_chunks(false)
        .with_prevalidate_chunk_crcs(true)
        .with_validate_data_section_crc(true)
        .with_validate_summary_section_crc(true)
        .with_check_finishes_after_end_magic(true)
        .with_record_length_limit(data.len());
    let mut reader = LinearReader::new_with_options(options);
    let mut dec = Decoder::default();
    dec.rec.bytes = data.len() as u64;
    let mut fed = 0usize;
    let mcap_err = |fed: usize, source| ReadError::Mcap {
        offset: fed,
        size: data.len(),
        source,
    };
    for _ in 0..MAX_EVENTS {
        let Some(event) = reader.next_event() else {
            return Ok(dec.done(recovery));
        };
        match event.map_err(|e| mcap_err(fed, e))? {
            LinearReadEvent::ReadRequest(_) if fed == end && recovery.is_some() => {
                return Ok(dec.done(recovery));
            }
            LinearReadEvent::ReadRequest(n) => {
                let k = n.min(end - fed);
                reader.insert(k).copy_from_slice(&data[fed..fed + k]);
                reader.notify_read(k);
                fed += k;
            }
            LinearReadEvent::Record { data: body, opcode } => {
                let record = mcap::parse_record(opcode, body).map_err(|e| mcap_err(fed, e))?;
                dec.record(record)?;
            }
        }
    }
    Err(mcap_err(fed, mcap::McapError::UnexpectedEof))
}

/// The planner topics must carry exactly the schema this crate writes: name, encodings
/// and text (an older layout under the same name could otherwise decode into wrong fields
/// when its sizes happen to match).
fn check_planner_channel(c: &ChannelInfo, text: &[u8]) -> Result<(), ReadError> {
    let (expected, expected_text) = match c.topic.as_str() {
        INPUT_TOPIC => (PLAN_INPUT_NAME, PLAN_INPUT_MSG),
        OUTPUT_TOPIC => (PLAN_OUTPUT_NAME, PLAN_OUTPUT_MSG),
        WARM_TOPIC => (PLAN_WARM_NAME, PLAN_WARM_MSG),
        _ => return Ok(()),
    };
    if c.schema != expected
        || c.schema_encoding != SCHEMA_ENCODING
        || c.message_encoding != MESSAGE_ENCODING
    {
        return Err(ReadError::WrongSchema {
            topic: c.topic.clone(),
            found: format!(
                "schema `{}` ({}) with {} messages",
                c.schema, c.schema_encoding, c.message_encoding
            ),
            expected: format!(
                "schema `{expected}` ({SCHEMA_ENCODING}) with {MESSAGE_ENCODING} messages"
            ),
        });
    }
    if text != expected_text.as_bytes() {
        return Err(ReadError::WrongSchema {
            topic: c.topic.clone(),
            found: format!(
                "schema `{expected}` with a different definition ({} bytes)",
                text.len()
            ),
            expected: format!(
                "this build's definition of `{expected}` ({} bytes)",
                expected_text.len()
            ),
        });
    }
    Ok(())
}
