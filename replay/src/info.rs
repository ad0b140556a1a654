//! `replay info`: what a recording holds.

use plan_record::{ChannelInfo, Recording, Recovery};
use serde::Serialize;

/// Summary of a recording.
#[derive(Debug, Clone, Serialize)]
pub struct Info {
    /// File size \[bytes\].
    pub bytes: u64,
    /// Channels with message counts.
    pub channels: Vec<ChannelSummary>,
    /// Planner inputs.
    pub inputs: usize,
    /// Planner outputs.
    pub outputs: usize,
    /// Time between first and last message \[s\].
    pub duration_s: f64,
    /// First message log time \[ns\].
    pub start_ns: Option<u64>,
    /// Last message log time \[ns\].
    pub end_ns: Option<u64>,
    /// Records the recorder dropped (None: no recorder metadata).
    pub dropped: Option<u64>,
    /// Scenarios of the inputs, in order of first appearance.
    pub scenarios: Vec<String>,
    /// What was recovered of a file that was not closed cleanly (None: closed cleanly).
    pub recovered: Option<Recovered>,
    /// Seqs of recorded outputs that match no input ([`crate::validate`] fills it).
    pub orphan_outputs: Vec<u64>,
}

/// What a read recovered of a file that was not closed cleanly (a killed recorder).
#[derive(Debug, Clone, Serialize)]
pub struct Recovered {
    /// Always false: the file lacks its end (summary, footer, or part of a record).
    pub complete: bool,
    /// Bytes of complete records read.
    pub kept_bytes: u64,
    /// Bytes dropped at the end (the incomplete record).
    pub dropped_bytes: u64,
    /// Where the file ends.
    pub ends: String,
}

impl From<&Recovery> for Recovered {
    fn from(r: &Recovery) -> Self {
        Self {
            complete: false,
            kept_bytes: r.kept_bytes,
            dropped_bytes: r.dropped_bytes,
            ends: r.ends.clone(),
        }
    }
}

/// One channel.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelSummary {
    /// Channel id.
    pub id: u16,
    /// Topic.
    pub topic: String,
    /// Schema name and encoding.
    pub schema: String,
    /// Message encoding.
    pub encoding: String,
    /// Messages.
    pub messages: u64,
}

/// Summarises a recording.
pub fn info(rec: &Recording) -> Info {
    let mut scenarios: Vec<String> = Vec::new();
    for i in &rec.inputs {
        if !scenarios.contains(&i.scenario) && scenarios.len() < 20 {
            scenarios.push(i.scenario.clone());
        }
    }
    Info {
        bytes: rec.bytes,
        channels: rec
            .channels
            .iter()
            .map(|c: &ChannelInfo| ChannelSummary {
                id: c.id,
                topic: c.topic.clone(),
                schema: format!("{} ({})", c.schema, c.schema_encoding),
                encoding: c.message_encoding.clone(),
                messages: c.messages,
            })
            .collect(),
        inputs: rec.inputs.len(),
        outputs: rec.outputs.len(),
        duration_s: rec.duration_s(),
        start_ns: rec.start_ns,
        end_ns: rec.end_ns,
        dropped: rec.dropped(),
        scenarios,
        recovered: rec.recovery.as_ref().map(Recovered::from),
        orphan_outputs: Vec::new(),
    }
}

impl std::fmt::Display for Info {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{} bytes, {} inputs, {} outputs, duration {:.3} s, dropped {}",
            self.bytes,
            self.inputs,
            self.outputs,
            self.duration_s,
            self.dropped
                .map_or("unknown".to_string(), |d| d.to_string())
        )?;
        for c in &self.channels {
            writeln!(
                f,
                "  channel {} {}: {} messages, schema {}, encoding {}",
                c.id, c.topic, c.messages, c.schema, c.encoding
            )?;
        }
        if let Some(r) = &self.recovered {
            writeln!(
                f,
                "  not closed cleanly: ends {}; {} bytes recovered, {} dropped",
                r.ends, r.kept_bytes, r.dropped_bytes
            )?;
        }
        if !self.scenarios.is_empty() {
            writeln!(f, "  scenarios: {}", self.scenarios.join(", "))?;
        }
        write!(f, "{}", crate::validate::orphan_line(&self.orphan_outputs))
    }
}
