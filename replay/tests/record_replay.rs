//! Record a drive, replay it: bit-identical outputs, a latency report, the CLI contract.

mod common;

use std::process::Command;

use plan_record::{PlanOutput, Record, Recorder, Recording};
use planner::record::{plan_input, problem_from, RecordedStart};
use replay::run::{run, RunOptions};

#[test]
fn recorded_drive_replays_bit_identically_with_a_latency_report() {
    let rec = Recording::from_bytes(common::valid_bytes()).unwrap();
    assert_eq!(rec.inputs.len(), 2);
    assert_eq!(rec.outputs.len(), 2);
    assert_eq!(rec.dropped(), Some(0));
    // 10 Hz clock: the second plan is logged 100 ms after the first.
    assert_eq!(rec.inputs[1].stamp_ns - rec.inputs[0].stamp_ns, 100_000_000);
    let report = run(&rec, RunOptions::default()).unwrap();
    assert!(report.deterministic, "{report}");
    assert_eq!(
        (report.identical, report.different, report.unverified),
        (2, 0, 0)
    );
    assert_eq!(report.latency.count, 2);
    let l = report.latency;
    assert!(
        l.p50_ms > 0.0 && l.p50_ms <= l.p99_ms && l.p99_ms <= l.max_ms,
        "{l:?}"
    );
    assert!((l.jitter_ms - (l.max_ms - l.p50_ms)).abs() < 1e-9);
    assert!(report.iterations[0] > 0);
    assert_eq!(report.phases.len(), 4);
    assert!(
        report.per_plan.iter().all(|p| p.status == "optimal"),
        "{report}"
    );
}

#[test]
fn a_changed_output_bit_is_reported_as_a_difference() {
    let mut rec = Recording::from_bytes(common::valid_bytes()).unwrap();
    // Flip the lowest mantissa bit of one recorded speed.
    let v = &mut rec.outputs[1].states[50][1];
    *v = f64::from_bits(v.to_bits() ^ 1);
    let report = run(&rec, RunOptions::default()).unwrap();
    assert!(!report.deterministic);
    assert_eq!((report.identical, report.different), (1, 1));
    let diff = report.per_plan[1].difference.as_deref().unwrap();
    assert!(diff.contains("state v[50]"), "{diff}");
}

#[test]
fn inputs_round_trip_bit_exactly_through_the_file() {
    let rec = Recording::from_bytes(common::valid_bytes()).unwrap();
    for input in &rec.inputs {
        let (spec, settings, start) = problem_from(input).unwrap();
        let RecordedStart::Guess(guess) = start else {
            panic!("the fixture has no warm starts");
        };
        let again = plan_input(&spec, &settings, guess, input.seq, input.stamp_ns);
        assert_eq!(&again, input);
        assert_eq!(again.config_hash, input.config_hash);
    }
    // A damaged config hash is caught before solving.
    let mut bad = rec.inputs[0].clone();
    bad.settings[0] = f64::from_bits(bad.settings[0].to_bits() ^ 1);
    let e = problem_from(&bad).unwrap_err().to_string();
    assert!(e.contains("config_hash"), "{e}");
}

/// A soft lane (its weight and bounds) and the end-speed bound are part of the recorded
/// input: they survive the CDR encoding bit for bit, rebuild the same problem, and a bad
/// bound is refused by name.
#[test]
fn a_soft_lane_and_an_end_speed_round_trip_through_the_recording_and_are_checked() {
    use plan_record::cdr::{decode_input, encode_input, Encoder};
    let rec = Recording::from_bytes(common::valid_bytes()).unwrap();
    let (mut spec, settings, start) = problem_from(&rec.inputs[0]).unwrap();
    let RecordedStart::Guess(guess) = start else {
        panic!("the fixture has no warm starts");
    };
    let lo: Vec<f64> = spec.e_min.iter().map(|e| e + 0.7).collect();
    let hi: Vec<f64> = spec.e_max.iter().map(|e| e - 0.7).collect();
    spec.soft_lane = planner::ocp::SoftLane::new(10.0, lo, hi);
    spec.v_end_max = 23.456789;
    let input = plan_input(&spec, &settings, guess, 7, 8);
    let mut e = Encoder::default();
    encode_input(&mut e, &input);
    let decoded = decode_input(e.bytes()).unwrap();
    assert_eq!(decoded, input);
    let (again, _, _) = problem_from(&decoded).unwrap();
    assert_eq!(again.soft_lane, spec.soft_lane);
    assert_eq!(again.v_end_max.to_bits(), spec.v_end_max.to_bits());
    let mut slow = decoded.clone();
    slow.v_end_max_mps = slow.v_min_mps;
    let e = problem_from(&slow).unwrap_err().to_string();
    assert!(e.contains("v_end_max"), "{e}");
    let mut bad = decoded.clone();
    bad.soft_e_max[40] = f64::NAN;
    let e = problem_from(&bad).unwrap_err().to_string();
    assert!(e.contains("soft_lane") && e.contains("e_max[40]"), "{e}");
    let mut short = decoded;
    short.soft_e_min.pop();
    let e = problem_from(&short).unwrap_err().to_string();
    assert!(e.contains("soft_lane") && e.contains("e_min"), "{e}");
}

#[test]
fn recorded_values_outside_their_domain_are_rejected_by_name_before_solving() {
    let rec = Recording::from_bytes(common::valid_bytes()).unwrap();
    // Outside the config hash (which covers vehicle and settings only): speed bounds
    // crossed (the guess clamps the speed between them, which must not panic), a NaN lane bound, a bad length.
    let mut bad = rec.inputs[0].clone();
    bad.v_min_mps = bad.v_max_mps + 1.0;
    let e = problem_from(&bad).unwrap_err().to_string();
    assert!(e.contains("v_max") && e.contains("recorded input"), "{e}");
    let mut bad = rec.inputs[0].clone();
    bad.e_min[37] = f64::NAN;
    let e = problem_from(&bad).unwrap_err().to_string();
    assert!(e.contains("e_min[37]"), "{e}");
    let mut bad = rec.inputs[0].clone();
    bad.length_m = -250.0;
    let e = problem_from(&bad).unwrap_err().to_string();
    assert!(e.contains("length"), "{e}");
    // And `replay run` reports it instead of a panicked solver thread.
    let mut bad_rec = rec.clone();
    bad_rec.inputs[0].v_min_mps = bad_rec.inputs[0].v_max_mps + 1.0;
    let e = run(&bad_rec, RunOptions::default())
        .unwrap_err()
        .to_string();
    assert!(!e.contains("panicked") && e.contains("v_max"), "{e}");
}

#[test]
fn recorder_never_blocks_and_counts_every_drop() {
    let d = common::temp_dir("flood");
    let f = d.join("flood.mcap");
    let rec = Recording::from_bytes(common::valid_bytes()).unwrap();
    let out: PlanOutput = rec.outputs[0].clone();
    let r = Recorder::create(&f, 1).unwrap();
    let total = 2000u64;
    let mut sent = 0;
    for i in 0..total {
        let mut o = out.clone();
        o.seq = i;
        if r.record(Record::Output(Box::new(o))) {
            sent += 1;
        }
    }
    assert_eq!(sent + r.dropped(), total);
    // A one-slot queue flooded with 2000 records: a recorder that waited for its writer
    // would drop nothing.
    assert!(
        r.dropped() > 0 && sent >= 1,
        "sent {sent}, dropped {}",
        r.dropped()
    );
    let stats = r.finish().unwrap();
    assert_eq!(stats.outputs, sent);
    assert_eq!(stats.dropped, total - sent);
    let back = Recording::read(&f).unwrap();
    assert_eq!(back.outputs.len() as u64, sent);
    assert_eq!(back.dropped(), Some(total - sent));
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn cli_run_json_and_info() {
    let d = common::temp_dir("cli");
    let f = d.join("two.mcap");
    std::fs::write(&f, common::valid_bytes()).unwrap();
    let png = d.join("latency.png");
    let out = Command::new(env!("CARGO_BIN_EXE_replay"))
        .args(["run", "--json", "--budget-ms", "1000", "--plot"])
        .arg(&png)
        .arg(&f)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["deterministic"], true);
    assert_eq!(v["plans"], 2);
    for k in [
        "p50_ms",
        "p90_ms",
        "p99_ms",
        "p999_ms",
        "max_ms",
        "jitter_ms",
        "stdev_ms",
    ] {
        assert!(v["latency"][k].as_f64().unwrap() > 0.0, "{k}: {v}");
    }
    assert!(v["deadline_misses"].is_u64());
    assert!(std::fs::metadata(&png).unwrap().len() > 1000);

    let out = Command::new(env!("CARGO_BIN_EXE_replay"))
        .args(["info", "--json"])
        .arg(&f)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["inputs"], 2);
    assert_eq!(v["channels"][0]["topic"], "/planner/input");
    assert_eq!(v["channels"][1]["messages"], 2);
    // Inputs 100 ms apart on the drive clock; the last output lands one solve later.
    let dur = v["duration_s"].as_f64().unwrap();
    assert!((0.1..10.0).contains(&dur), "{dur}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn duplicate_seqs_are_refused_not_compared_arbitrarily() {
    let rec = Recording::from_bytes(common::valid_bytes()).unwrap();
    let mut dup = rec.clone();
    let first = dup.outputs[0].clone();
    dup.outputs.push(first);
    let e = run(&dup, RunOptions::default()).unwrap_err().to_string();
    assert!(e.contains("two planner outputs"), "{e}");
    let mut dup = rec.clone();
    let first = dup.inputs[0].clone();
    dup.inputs.push(first);
    let e = run(&dup, RunOptions::default()).unwrap_err().to_string();
    assert!(e.contains("two planner inputs"), "{e}");
}

#[test]
fn pooled_recorder_lends_its_slots_and_counts_a_plan_without_one_as_two_drops() {
    use plan_record::PlanRecord;
    let d = common::temp_dir("pool");
    let f = d.join("pool.mcap");
    let rec = Recording::from_bytes(common::valid_bytes()).unwrap();
    let template = PlanRecord {
        input: rec.inputs[0].clone(),
        output: rec.outputs[0].clone(),
        warm: plan_record::PlanWarmStart::with_capacity(0, 0, 0),
    };
    let r = Recorder::create_pooled(&f, &template, 2).unwrap();
    let a = r.slot().unwrap();
    let mut b = r.slot().unwrap();
    assert!(r.slot().is_none(), "two slots lent");
    assert_eq!(r.dropped(), 2);
    b.input.seq = 7;
    b.output.seq = 7;
    assert!(r.record_plan(a));
    assert!(r.record_plan(b));
    // The writer thread returns the slots once written.
    let t0 = std::time::Instant::now();
    let c = loop {
        if let Some(c) = r.slot() {
            break c;
        }
        assert!(t0.elapsed().as_secs() < 10, "slot never returned");
        std::thread::sleep(std::time::Duration::from_millis(5));
    };
    drop(c);
    let stats = r.finish().unwrap();
    assert_eq!((stats.inputs, stats.outputs), (2, 2));
    assert_eq!(stats.dropped % 2, 0);
    let back = Recording::read(&f).unwrap();
    assert!(back.complete());
    assert_eq!(back.inputs[0], rec.inputs[0]);
    assert_eq!((back.inputs[1].seq, back.outputs[1].seq), (7, 7));
    assert_eq!(back.dropped(), Some(stats.dropped));
    let _ = std::fs::remove_dir_all(&d);
}
