//! Replays under another initial guess: a recording made from the road-speed guess
//! replays bit-identically, and `replay run --guess` re-solves from the guess it names and
//! compares those solves with no recorded output.

mod common;

use plan_record::{Record, Recorder, Recording};
use planner::guess::GuessKind;
use planner::plan::Planner;
use planner::record::{plan_input, plan_output, problem_from};
use replay::run::{run, RunOptions};
use replay::N;

/// The fixture's inputs solved from `guess` and recorded with it.
fn record_with(path: &std::path::Path, guess: GuessKind) -> Recording {
    let fixture = Recording::from_bytes(common::valid_bytes()).unwrap();
    let r = Recorder::create(path, 8).unwrap();
    for input in &fixture.inputs {
        let (spec, settings, _) = problem_from(input).unwrap();
        let recorded = plan_input(&spec, &settings, guess, input.seq, input.stamp_ns);
        let mut planner = Planner::<N>::new(spec, settings).unwrap();
        let info = planner.solve(guess);
        let out = plan_output(input.seq, 0, &info, planner.states(), planner.controls());
        assert!(r.record(Record::Input(Box::new(recorded))));
        assert!(r.record(Record::Output(Box::new(out))));
    }
    r.finish().unwrap();
    Recording::read(path).unwrap()
}

#[test]
fn a_road_speed_recording_replays_bit_identically() {
    let d = common::temp_dir("road_speed");
    let rec = record_with(&d.join("road_speed.mcap"), GuessKind::RoadSpeed);
    assert!(rec.inputs.iter().all(|i| i.guess == "road_speed"));
    let r = run(&rec, RunOptions::default()).unwrap();
    assert_eq!((r.identical, r.different, r.unverified), (2, 0, 0), "{r}");
    assert!(r.deterministic, "{r}");
}

#[test]
fn another_guess_is_solved_from_and_compared_with_nothing() {
    let d = common::temp_dir("other_guess");
    let rec = record_with(&d.join("eq.mcap"), GuessKind::Equilibrium);
    let same = run(
        &rec,
        RunOptions {
            guess: Some(GuessKind::Equilibrium),
            ..RunOptions::default()
        },
    )
    .unwrap();
    assert_eq!(same.identical, 2, "{same}");
    let other = run(
        &rec,
        RunOptions {
            guess: Some(GuessKind::Zero),
            ..RunOptions::default()
        },
    )
    .unwrap();
    assert_eq!((other.identical, other.different), (0, 0), "{other}");
    assert!(!other.deterministic, "{other}");
    // The zero guess takes other iterates than the recorded equilibrium starts.
    let its =
        |r: &replay::run::RunReport| r.per_plan.iter().map(|p| p.iterations).collect::<Vec<_>>();
    assert_ne!(its(&same), its(&other));
}
