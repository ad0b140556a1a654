//! Crash safety: a recorder killed mid-recording leaves a file whose complete chunks (one
//! per plan) `replay info`, `replay run` and `replay recover` read; a file cut at any byte
//! is recovered up to its last complete chunk; damage before the cut stays an error.

mod common;

use std::collections::BTreeMap;
use std::io::Cursor;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use plan_record::{ReadError, Recording};

/// Top-level records of an MCAP file: (opcode, start, end).
fn records(b: &[u8]) -> Vec<(u8, usize, usize)> {
    let mut out = Vec::new();
    let mut at = 8;
    while at + 9 <= b.len() {
        let len = u64::from_le_bytes(b[at + 1..at + 9].try_into().unwrap()) as usize;
        out.push((b[at], at, at + 9 + len));
        at += 9 + len;
    }
    out
}

const CHUNK: u8 = 0x06;
const METADATA: u8 = 0x0C;

fn replay(args: &[&str], file: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_replay"))
        .args(args)
        .arg(file)
        .output()
        .unwrap()
}

#[test]
fn every_cut_point_recovers_exactly_the_plans_whose_chunk_is_complete() {
    let d = common::temp_dir("cuts");
    let f = d.join("four.mcap");
    common::record(&f, 4);
    let b = std::fs::read(&f).unwrap();
    let full = Recording::from_bytes(&b).unwrap();
    assert!(full.complete());
    assert_eq!(full.inputs.len(), 4);
    let recs = records(&b);
    let chunk_ends: Vec<usize> = recs.iter().filter(|r| r.0 == CHUNK).map(|r| r.2).collect();
    // The schemas and channels, then one chunk per plan.
    assert_eq!(chunk_ends.len(), 5, "{recs:?}");
    let metadata_end = recs.iter().find(|r| r.0 == METADATA).unwrap().2;
    let mut cuts = vec![1, 5, 8, 9, 20, b.len() - 1, b.len() - 8, b.len() - 9];
    for &(_, start, end) in &recs {
        cuts.extend([
            start,
            start + 1,
            start + 9,
            start + 40,
            (start + end) / 2,
            end - 1,
        ]);
    }
    cuts.retain(|c| (1..b.len()).contains(c));
    for cut in cuts {
        let r = Recording::from_bytes(&b[..cut]).unwrap_or_else(|e| panic!("cut {cut}: {e}"));
        let rec = r.recovery.as_ref().expect("a cut file is not complete");
        assert_eq!(rec.dropped_bytes, (cut - rec.kept_bytes as usize) as u64);
        let plans = chunk_ends
            .iter()
            .filter(|e| **e <= cut)
            .count()
            .saturating_sub(1);
        assert_eq!(r.inputs[..], full.inputs[..plans], "cut {cut}: {rec}");
        assert_eq!(r.outputs[..], full.outputs[..plans], "cut {cut}: {rec}");
        let closed_metadata = cut >= metadata_end;
        assert_eq!(r.dropped().is_some(), closed_metadata, "cut {cut}");
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_file_cut_inside_a_chunk_reads_as_truncated_not_as_a_length_error() {
    let b = common::valid_bytes();
    let r = Recording::from_bytes(&b[..141]).unwrap();
    let rec = r.recovery.unwrap();
    assert!(rec.ends.contains("inside a chunk record"), "{rec}");
    assert!(!rec.to_string().contains("exceeds"), "{rec}");
    // A writer that patches its chunk headers on close leaves the open chunk's header as
    // the placeholder (length all ones).
    let mut w = mcap::WriteOptions::new()
        .compression(None)
        .create(Cursor::new(Vec::new()))
        .unwrap();
    let s = w.add_schema("s", "ros2msg", b"uint8 x\n").unwrap();
    let ch = w.add_channel(s, "/t", "cdr", &BTreeMap::new()).unwrap();
    let header = mcap::records::MessageHeader {
        channel_id: ch,
        sequence: 0,
        log_time: 1,
        publish_time: 1,
    };
    w.write_to_known_channel(&header, &[0, 1, 0, 0, 7]).unwrap();
    let open = w.into_inner().into_inner();
    let r = Recording::from_bytes(&open).unwrap();
    let rec = r.recovery.unwrap();
    assert!(rec.ends.contains("placeholder"), "{rec}");
    assert_eq!(
        rec.dropped_bytes as usize,
        open.len() - rec.kept_bytes as usize
    );
}

#[test]
fn damage_before_the_cut_or_in_the_cut_record_stays_an_error() {
    let d = common::temp_dir("damage");
    let f = d.join("three.mcap");
    common::record(&f, 3);
    let b = std::fs::read(&f).unwrap();
    let chunks: Vec<(u8, usize, usize)> =
        records(&b).into_iter().filter(|r| r.0 == CHUNK).collect();
    let (_, start, end) = chunks[2];
    let cut = chunks[3].1 + 100;
    // A flipped bit inside a complete chunk of a cut file: its CRC fails.
    let mut c = b[..cut].to_vec();
    c[(start + end) / 2] ^= 0x10;
    let e = Recording::from_bytes(&c).unwrap_err();
    assert!(e.to_string().contains("CRC"), "{e}");
    // The cut chunk's length disagrees with its own header: not a truncation.
    let mut c = b[..cut].to_vec();
    let at = chunks[3].1;
    let len = u64::from_le_bytes(c[at + 1..at + 9].try_into().unwrap());
    c[at + 1..at + 9].copy_from_slice(&(len + 1000).to_le_bytes());
    let e = Recording::from_bytes(&c).unwrap_err();
    assert!(matches!(e, ReadError::Damaged { .. }), "{e}");
    assert!(e.to_string().contains("disagrees"), "{e}");
    let _ = std::fs::remove_dir_all(&d);
}

/// `replay record-oval` killed with SIGKILL once it has written a few plans: the file,
/// under its partial name (nothing under the final name), holds every plan it had written,
/// which replays bit-identically; `info`, `run` and `recover` all read it, with a warning
/// and a `recovered` JSON field.
#[test]
fn a_recorder_killed_mid_recording_leaves_a_partial_file_that_replays() {
    let d = common::temp_dir("killed");
    let out = d.join("killed.mcap");
    let f = plan_record::partial_path(&out);
    let config = common::repo().join("config");
    let mut child = Command::new(env!("CARGO_BIN_EXE_replay"))
        .args(["record-oval", "--plans", "90", "--out"])
        .arg(&out)
        .arg("--scenario")
        .arg(config.join("scenarios/oval.toml"))
        .arg("--vehicle")
        .arg(config.join("vehicles/lc500.toml"))
        .arg("--solver")
        .arg(config.join("solver.toml"))
        .stderr(Stdio::null())
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    let written = loop {
        assert!(t0.elapsed() < Duration::from_secs(300), "no plans recorded");
        assert!(
            child.try_wait().unwrap().is_none(),
            "finished before the kill"
        );
        let n = Recording::read(&f).map_or(0, |r| r.outputs.len());
        if n >= 4 {
            break n;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        !out.exists(),
        "a killed recording has no file under the final name"
    );

    let rec = Recording::read(&f).unwrap();
    let recovery = rec
        .recovery
        .clone()
        .expect("a killed recorder leaves no footer");
    assert!(
        rec.outputs.len() >= written,
        "{} < {written}",
        rec.outputs.len()
    );
    assert_eq!(rec.inputs.len(), rec.outputs.len(), "one chunk per plan");

    let out = replay(&["info", "--json"], &f);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("warning") && err.contains("not closed cleanly"),
        "{err}"
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["inputs"], rec.inputs.len());
    assert_eq!(v["recovered"]["complete"], false);
    assert_eq!(v["recovered"]["dropped_bytes"], recovery.dropped_bytes);

    let out = replay(&["run", "--json", "--budget-ms", "10000"], &f);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("not closed cleanly"), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["identical"], rec.outputs.len(), "{v}");
    assert_eq!(v["different"], 0, "{v}");
    assert_eq!(v["recovered"]["complete"], false, "{v}");

    let clean = d.join("clean.mcap");
    let out = Command::new(env!("CARGO_BIN_EXE_replay"))
        .arg("recover")
        .arg(&f)
        .arg(&clean)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let back = Recording::read(&clean).unwrap();
    assert!(back.complete());
    assert_eq!(back.inputs, rec.inputs);
    assert_eq!(back.outputs, rec.outputs);
    assert_eq!(
        back.recorder.get("recovered_dropped_bytes"),
        Some(&recovery.dropped_bytes.to_string())
    );
    let out = replay(&["info"], &clean);
    assert!(out.status.success());
    assert!(!String::from_utf8_lossy(&out.stderr).contains("warning"));
    // Nothing but the clean file is left beside it.
    let names: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
    let _ = std::fs::remove_dir_all(&d);
}

/// The schemas reach the (partial) file when the recorder starts, an input whose output
/// never comes is on disk once its chunk has been open for the chunk period, and a clean
/// finish renames the file to its final name.
#[test]
fn an_open_chunk_reaches_the_file_within_the_chunk_period() {
    use plan_record::{Record, Recorder, CHUNK_PERIOD};
    let d = common::temp_dir("period");
    let done_path = d.join("period.mcap");
    let f = plan_record::partial_path(&done_path);
    let input = Recording::from_bytes(common::valid_bytes()).unwrap().inputs[0].clone();
    let r = Recorder::create(&done_path, 4).unwrap();
    assert!(!done_path.exists());
    let started = Recording::read(&f).unwrap();
    assert_eq!((started.channels.len(), started.inputs.len()), (3, 0));
    assert!(!started.complete());
    assert!(r.record(Record::Input(Box::new(input.clone()))));
    std::thread::sleep(CHUNK_PERIOD + Duration::from_millis(500));
    let open = Recording::read(&f).unwrap();
    assert_eq!(open.inputs, std::slice::from_ref(&input));
    let stats = r.finish().unwrap();
    assert_eq!((stats.inputs, stats.outputs, stats.dropped), (1, 0, 0));
    assert!(!f.exists(), "the partial file is renamed on finish");
    let done = Recording::read(&done_path).unwrap();
    assert!(done.complete());
    assert_eq!(done.inputs, [input]);
    let _ = std::fs::remove_dir_all(&d);
}
