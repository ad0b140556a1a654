//! Budget replays: an iteration budget gives the same bits on every run and the same bits
//! as a recording made with that cap; the report says how many solves hit it and what the
//! car would have been sent.

mod common;

use std::process::Command;

use plan_record::{Record, Recorder, Recording};
use planner::plan::choice::DRIVABLE_VIOLATION;
use planner::plan::Planner;
use planner::record::{plan_input, plan_output, problem_from, RecordedStart};
use replay::budget::Budgets;
use replay::run::{run, RunOptions, RunReport};
use replay::N;

/// An iteration budget short of convergence on the oval drive's plans.
const K: usize = 8;

/// The fixture's inputs solved and recorded with `max_iter = K` (as `trajopt solve
/// --record` or `planner_proc --record` with such a solver file would).
fn record_capped(path: &std::path::Path) -> Recording {
    let fixture = Recording::from_bytes(common::valid_bytes()).unwrap();
    let r = Recorder::create(path, 8).unwrap();
    for input in &fixture.inputs {
        let (spec, mut settings, start) = problem_from(input).unwrap();
        let RecordedStart::Guess(guess) = start else {
            panic!("the fixture has no warm starts");
        };
        settings.max_iter = K;
        let capped = plan_input(&spec, &settings, guess, input.seq, input.stamp_ns);
        let mut planner = Planner::<N>::new(spec, settings).unwrap();
        let info = planner.solve(guess);
        let out = plan_output(input.seq, 0, &info, planner.states(), planner.controls());
        assert!(r.record(Record::Input(Box::new(capped))));
        assert!(r.record(Record::Output(Box::new(out))));
    }
    r.finish().unwrap();
    Recording::read(path).unwrap()
}

fn replay(rec: &Recording, max_iter: Option<usize>) -> RunReport {
    let opts = RunOptions {
        budgets: Budgets {
            budget_ms: None,
            max_iter,
        },
        ..RunOptions::default()
    };
    run(rec, opts).unwrap()
}

#[test]
fn an_iteration_budget_replays_bit_identically_across_runs_and_against_its_recording() {
    let d = common::temp_dir("capped");
    let rec = record_capped(&d.join("capped.mcap"));
    let a = replay(&rec, Some(K));
    let b = replay(&rec, Some(K));
    for r in [&a, &b] {
        assert_eq!((r.identical, r.different, r.unverified), (2, 0, 0), "{r}");
        assert!(r.deterministic, "{r}");
        assert_eq!(r.max_iter, Some(K));
        assert_eq!(r.hit_budget, 2, "{r}");
        let c = r.sent;
        assert_eq!(
            c.sent_converged + c.sent_best_iterate + c.sent_previous_shifted + c.sent_nothing,
            2
        );
        assert_eq!(c.sent_converged, 0, "{r}");
    }
    // Same bits on both runs, and the same decision.
    for (p, q) in a.per_plan.iter().zip(&b.per_plan) {
        assert_eq!(p.max_violation.to_bits(), q.max_violation.to_bits());
        assert_eq!(p.sent, q.sent);
        assert_eq!(p.status, "iteration_limit");
        // The rule: a best iterate is sent exactly when it is within the threshold.
        let drivable = p.max_violation <= DRIVABLE_VIOLATION;
        assert_eq!(
            p.sent == Some(planner::plan::choice::PlanKind::BestIterate),
            drivable,
            "{p:?}"
        );
    }
    // Without a budget, the recorded caps apply: the same bits again.
    let recorded = replay(&rec, None);
    assert_eq!(recorded.identical, 2, "{recorded}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_budget_that_stops_a_solve_the_recording_did_not_is_compared_with_nothing() {
    let rec = Recording::from_bytes(common::valid_bytes()).unwrap();
    let capped = replay(&rec, Some(K));
    assert_eq!(
        (capped.identical, capped.different, capped.unverified),
        (0, 0, 2),
        "{capped}"
    );
    assert_eq!(capped.hit_budget, 2);
    // A budget that does not bind changes no bits: compared, and identical.
    let roomy = replay(&rec, Some(400));
    assert_eq!((roomy.identical, roomy.hit_budget), (2, 0), "{roomy}");
    assert_eq!(roomy.sent.sent_converged, 2, "{roomy}");
}

#[test]
fn cli_budget_replay_reports_hits_and_what_the_car_would_have_been_sent() {
    let d = common::temp_dir("cli-budget");
    let f = d.join("two.mcap");
    std::fs::write(&f, common::valid_bytes()).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_replay"))
        .args(["run", "--json", "--max-iter", "8", "--budget-ms", "5000"])
        .arg(&f)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["budget_ms"], 5000.0, "{v}");
    assert_eq!(v["budget_applied"], true, "{v}");
    assert_eq!(v["max_iter"], 8, "{v}");
    assert_eq!(v["hit_budget"], 2, "{v}");
    let sent: u64 = [
        "sent_converged",
        "sent_best_iterate",
        "sent_previous_shifted",
        "sent_nothing",
    ]
    .iter()
    .map(|k| v[k].as_u64().unwrap_or(99))
    .sum();
    assert_eq!(sent, 2, "{v}");
    assert_eq!(v["sent_kinds"].as_array().map(Vec::len), Some(2), "{v}");
    assert!(stderr.contains("2 of 2 solves hit it"), "{stderr}");
    let _ = std::fs::remove_dir_all(&d);
}
