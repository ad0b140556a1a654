//! How a file ends: closed cleanly (footer and closing magic), cut short (a prefix of a
//! valid file, as a killed writer leaves it), or damaged at its tail.
//!
//! An MCAP file is the 8-byte magic, then records framed as an opcode byte, a
//! little-endian u64 body length and the body. Walking that framing finds the first record
//! that does not fit in the file: everything before it is complete records (which the
//! reader then validates, CRCs included), and the file was cut at its start. A cut is told
//! from damage by what the incomplete record still shows: its opcode must be a defined
//! one, and a chunk's length must agree with the sizes in its own header (both are written
//! together when the chunk closes). A chunk whose length is still the writer's placeholder
//! (all ones) is the chunk a writer that seeks back to patch its header had open.

use mcap::records::op;
use mcap::MAGIC;

/// Where a file ends.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Tail {
    /// Footer and closing magic present (or the framing is not recognised at all): read
    /// the whole file strictly.
    Whole,
    /// The file is a valid prefix cut at byte `at`: read the records before it.
    Cut {
        /// Bytes of complete records.
        at: usize,
        /// What the file ends inside, for people.
        ends: String,
    },
    /// The last record cannot be the start of a valid record.
    Damaged {
        /// Its offset.
        at: usize,
        /// What is wrong.
        problem: String,
    },
}

/// Length of an opcode plus a record length.
const FRAME: usize = 9;

/// Longest compression name a chunk header can carry here.
const MAX_COMPRESSION_NAME: usize = 64;

fn record_name(opcode: u8) -> Option<&'static str> {
    Some(match opcode {
        op::HEADER => "header",
        op::FOOTER => "footer",
        op::SCHEMA => "schema",
        op::CHANNEL => "channel",
        op::MESSAGE => "message",
        op::CHUNK => "chunk",
        op::MESSAGE_INDEX => "message index",
        op::CHUNK_INDEX => "chunk index",
        op::ATTACHMENT => "attachment",
        op::ATTACHMENT_INDEX => "attachment index",
        op::STATISTICS => "statistics",
        op::METADATA => "metadata",
        op::METADATA_INDEX => "metadata index",
        op::SUMMARY_OFFSET => "summary offset",
        op::DATA_END => "data end",
        0x80..=0xff => "private",
        _ => return None,
    })
}

fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?))
}

fn u64_at(b: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(b.get(at..at + 8)?.try_into().ok()?))
}

/// A chunk body (as far as present) whose header contradicts the record length `len`:
/// start and end time, uncompressed size (3 x u64), CRC (u32), compression name (u32
/// length + bytes), compressed size (u64), then the compressed records.
fn chunk_mismatch(body: &[u8], len: u64) -> Option<String> {
    let name_len = u32_at(body, 28)? as usize;
    if name_len > MAX_COMPRESSION_NAME {
        return Some(format!("chunk header names a {name_len}-byte compression"));
    }
    let compressed = u64_at(body, 32 + name_len)?;
    let expected = (40 + name_len as u64).checked_add(compressed);
    (expected != Some(len)).then(|| {
        format!("chunk length {len} disagrees with its header's compressed size {compressed}")
    })
}

/// Finds where `data` ends (see the module documentation).
pub(crate) fn scan(data: &[u8]) -> Tail {
    if data.len() < MAGIC.len() {
        return if MAGIC.starts_with(data) {
            Tail::Cut {
                at: 0,
                ends: "inside the opening magic".into(),
            }
        } else {
            Tail::Whole
        };
    }
    if &data[..MAGIC.len()] != MAGIC {
        return Tail::Whole;
    }
    let mut at = MAGIC.len();
    loop {
        let rest = &data[at..];
        let Some(&opcode) = rest.first() else {
            return Tail::Cut {
                at,
                ends: "after a complete record, without the summary and footer".into(),
            };
        };
        let Some(name) = record_name(opcode) else {
            return Tail::Damaged {
                at,
                problem: format!("undefined record opcode {opcode:#04x}"),
            };
        };
        let Some(len) = u64_at(rest, 1) else {
            return Tail::Cut {
                at,
                ends: format!("inside the length of a {name} record at byte {at}"),
            };
        };
        let fits = len
            .checked_add(FRAME as u64)
            .filter(|n| *n <= rest.len() as u64);
        if let Some(n) = fits {
            let end = at + n as usize;
            if opcode == op::FOOTER {
                let after = &data[end..];
                return if after.len() < MAGIC.len() && MAGIC.starts_with(after) {
                    Tail::Cut {
                        at: end,
                        ends: "inside the closing magic".into(),
                    }
                } else {
                    Tail::Whole
                };
            }
            at = end;
            continue;
        }
        if opcode == op::CHUNK && len == u64::MAX {
            return Tail::Cut {
                at,
                ends: format!(
                    "inside the chunk the writer had open at byte {at} (its header is still the placeholder)"
                ),
            };
        }
        if opcode == op::CHUNK {
            if let Some(problem) = chunk_mismatch(&rest[FRAME..], len) {
                return Tail::Damaged { at, problem };
            }
        }
        return Tail::Cut {
            at,
            ends: format!(
                "inside a {name} record at byte {at} ({} of {} bytes present)",
                rest.len(),
                len.saturating_add(FRAME as u64)
            ),
        };
    }
}
