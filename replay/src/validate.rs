//! The checks `replay run` and `replay info` share, so both judge a file alike: every seq
//! unique per topic, every input a problem inside the model's domain
//! ([`planner::record::problem_from`], which ends in [`planner::ocp::OcpSpec::check`]) with
//! the replayed horizon and, when warm-started, with its warm start recorded; and the
//! outputs that match no input (which no replay can verify).

use std::collections::HashSet;

use plan_record::Recording;
use planner::record::{problem_from, warm_from, RecordedStart};

use crate::run::ReplayError;
use crate::N;

/// What validation found short of an error.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Validated {
    /// Seqs of recorded outputs with no input of the same seq, ascending: nothing can be
    /// replayed to verify them.
    pub orphan_outputs: Vec<u64>,
}

/// Checks a recording: no two inputs and no two outputs share a seq, and every input
/// describes a problem inside the model's domain with N = [`N`] intervals. The first bad
/// input is an error naming its seq and field.
pub fn validate(rec: &Recording) -> Result<Validated, ReplayError> {
    let mut inputs: HashSet<u64> = HashSet::with_capacity(rec.inputs.len());
    for i in &rec.inputs {
        if !inputs.insert(i.seq) {
            return Err(ReplayError::DuplicateSeq {
                what: "inputs",
                seq: i.seq,
            });
        }
    }
    let mut outputs: HashSet<u64> = HashSet::with_capacity(rec.outputs.len());
    for o in &rec.outputs {
        if !outputs.insert(o.seq) {
            return Err(ReplayError::DuplicateSeq {
                what: "outputs",
                seq: o.seq,
            });
        }
    }
    for input in &rec.inputs {
        let (spec, _, start) = problem_from(input)?;
        if spec.n_intervals != N {
            return Err(ReplayError::Horizon {
                seq: input.seq,
                n: spec.n_intervals,
            });
        }
        if start == RecordedStart::Warm {
            let w = rec
                .warm_start(input.seq)
                .ok_or(ReplayError::MissingWarmStart { seq: input.seq })?;
            warm_from(w)?;
        }
    }
    let mut orphan_outputs: Vec<u64> = outputs.difference(&inputs).copied().collect();
    orphan_outputs.sort_unstable();
    Ok(Validated { orphan_outputs })
}

/// The line that reports outputs without an input (empty when there are none).
pub fn orphan_line(orphans: &[u64]) -> String {
    if orphans.is_empty() {
        return String::new();
    }
    let list: Vec<String> = orphans.iter().take(10).map(u64::to_string).collect();
    let more = if orphans.len() > 10 { ", ..." } else { "" };
    format!(
        "{} recorded output(s) match no input and cannot be verified: seq {}{more}\n",
        orphans.len(),
        list.join(", ")
    )
}
