//! Warm-started plans in a recording: each is recorded with where it started (guess `warm`
//! and a `/planner/warm_start` message holding the shifted guess and multipliers) and
//! replays bit-identically on its own, the fall-back to the cold start included; a warm
//! input without its warm start is refused by seq before anything is solved. A logged plan
//! (`--log-plan`) shows one row per iteration and the rows its start and end violate most.

mod common;

use plan_record::{PlanWarmStart, Record, Recorder, Recording, WARM_GUESS};
use planner::config::{load_scenario, load_solver, load_vehicle};
use planner::guess::GuessKind;
use planner::model::{ix, NU, NX};
use planner::ocp::OcpSpec;
use planner::plan::{shift_plan, Planner, ReplanGuess, WarmOptions};
use planner::record::{plan_input, plan_output, write_warm};
use replay::run::{run, ReplayError, RunOptions};
use replay::N;
use std::path::Path;

fn oval() -> (OcpSpec, planner::ip::Settings) {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let vehicle = load_vehicle(&root.join("vehicles/lc500.toml")).unwrap();
    let spec = load_scenario(&root.join("scenarios/oval.toml"), None, vehicle).unwrap();
    let settings = load_solver(&root.join("solver.toml")).unwrap();
    (spec, settings)
}

/// The oval's road `j` nodes on (wrapping around the lap) and the free-start lap's state
/// there, re-referenced to s = t = 0.
fn window(spec: &OcpSpec, lap: &[[f64; NX]], j: usize) -> ([Vec<f64>; 3], [f64; NX]) {
    let road = |v: &[f64]| (0..=N).map(|k| v[(k + j) % N]).collect::<Vec<f64>>();
    let mut x0 = lap[j % N];
    x0[ix::S] = 0.0;
    x0[ix::T] = 0.0;
    (
        [road(&spec.kappa), road(&spec.e_min), road(&spec.e_max)],
        x0,
    )
}

/// A replanning drive along the oval, two nodes per cycle: one cold plan, then warm plans
/// (the last one with a one-iteration warm cap, so it falls back to the equilibrium start),
/// recorded as the planner process records them.
fn drive(path: &Path) -> Recording {
    let (spec, settings) = oval();
    let mut lap = Planner::<N>::new(spec.clone(), settings).unwrap();
    assert!(lap.solve(GuessKind::Equilibrium).status.is_success());
    let lap = lap.states().to_vec();
    let ds = spec.ds();
    let mut p = Planner::<N>::new(spec.clone(), settings).unwrap();
    let r = Recorder::create(path, 32).unwrap();
    let (mut gx, mut gu) = (vec![[0.0; NX]; N + 1], vec![[0.0; NU]; N]);
    let cycles = 6u64;
    for seq in 0..cycles {
        let ([k, lo, hi], x0) = window(&spec, &lap, 2 * seq as usize);
        let mut warm = None;
        let info = if seq == 0 {
            p.replan(&k, &lo, &hi, x0, ReplanGuess::Equilibrium)
                .unwrap()
        } else {
            let shift = 2.0 * ds;
            shift_plan(p.states(), p.controls(), ds, shift, &x0, &mut gx, &mut gu);
            let opts = WarmOptions {
                max_iter: if seq == cycles - 1 { 1 } else { usize::MAX },
                ..WarmOptions::default()
            };
            let w = p
                .replan_warm(&k, &lo, &hi, x0, (&gx, &gu), shift, opts)
                .unwrap();
            assert_eq!(w.fell_back, seq == cycles - 1, "seq {seq}: {w:?}");
            let mut m = PlanWarmStart::with_capacity(N, 0, 0);
            write_warm(&mut m, (seq, seq, shift), &opts, (&gx, &gu), p.warm_duals());
            warm = Some(m);
            w.info
        };
        assert!(info.status.is_success(), "seq {seq}: {info:?}");
        let mut input = plan_input(p.spec(), &settings, GuessKind::Equilibrium, seq, seq);
        if let Some(m) = warm {
            input.guess = WARM_GUESS.into();
            assert!(r.record(Record::Input(Box::new(input))));
            assert!(r.record(Record::Warm(Box::new(m))));
        } else {
            assert!(r.record(Record::Input(Box::new(input))));
        }
        let out = plan_output(seq, seq, &info, p.states(), p.controls());
        assert!(r.record(Record::Output(Box::new(out))));
    }
    let stats = r.finish().unwrap();
    assert_eq!(stats.warm_starts, cycles - 1);
    Recording::read(path).unwrap()
}

#[test]
fn warm_started_plans_replay_bit_identically_with_their_fall_back() {
    let d = common::temp_dir("warm_replay");
    let rec = drive(&d.join("warm.mcap"));
    assert_eq!(rec.warm_starts.len(), 5);
    let r = run(&rec, RunOptions::default()).unwrap();
    assert_eq!((r.identical, r.different, r.unverified), (6, 0, 0), "{r}");
    assert!(r.deterministic, "{r}");
    // The warm plans took fewer iterations than the cold one: the recorded start is used.
    let its: Vec<u32> = r.per_plan.iter().map(|p| p.iterations).collect();
    assert!(its[1..5].iter().all(|&i| i < its[0]), "{its:?}");
}

/// `--reshift` re-derives each warm guess from the recorded plan it shifts: on an
/// untouched recording it reproduces every recorded guess bit for bit (so every plan is
/// still compared and identical); with the recorded guesses moved 0.3 m sideways it solves
/// from the re-derived guesses all the same (the iterations of the untouched replay) and
/// compares the warm plans with nothing, since their recorded guesses are not what it
/// solved from.
#[test]
fn a_reshifted_replay_rederives_each_warm_guess_from_the_plan_it_shifts() {
    let d = common::temp_dir("warm_reshift");
    let rec = drive(&d.join("warm.mcap"));
    let reshift = RunOptions {
        reshift: true,
        ..RunOptions::default()
    };
    let r = run(&rec, reshift).unwrap();
    assert_eq!((r.identical, r.different, r.unverified), (6, 0, 0), "{r}");
    let mut spoiled = rec.clone();
    for w in &mut spoiled.warm_starts {
        for x in &mut w.states[1..] {
            x[ix::E] += 0.3;
        }
    }
    let plain = run(&spoiled, RunOptions::default()).unwrap();
    let its =
        |r: &replay::run::RunReport| r.per_plan.iter().map(|p| p.iterations).collect::<Vec<_>>();
    assert_ne!(
        its(&plain),
        its(&r),
        "the spoiled guesses must change the plain replay"
    );
    let again = run(&spoiled, reshift).unwrap();
    assert_eq!(its(&again), its(&r));
    assert_eq!((again.identical, again.unverified), (1, 5), "{again}");
}

/// `--warm-max-iter K` re-solves each warm plan with its warm cap set to K: a cap equal to
/// the recorded one (the last plan's one iteration) keeps that plan compared and
/// bit-identical, while the plans recorded without a cap now fall back to their cold start
/// after one iteration, so they take more iterations than before and are compared with
/// nothing. A cap out of range is refused before anything is solved.
#[test]
fn a_warm_cap_replay_falls_back_where_the_cap_bites_and_keeps_the_recorded_cap_identical() {
    let d = common::temp_dir("warm_cap");
    let rec = drive(&d.join("warm.mcap"));
    let plain = run(&rec, RunOptions::default()).unwrap();
    let capped = run(
        &rec,
        RunOptions {
            warm_max_iter: Some(1),
            ..RunOptions::default()
        },
    )
    .unwrap();
    let same: Vec<Option<bool>> = capped.per_plan.iter().map(|p| p.identical).collect();
    assert_eq!(
        same,
        [Some(true), None, None, None, None, Some(true)],
        "{capped}"
    );
    for (a, b) in plain.per_plan[1..5].iter().zip(&capped.per_plan[1..5]) {
        assert!(b.iterations > a.iterations, "seq {}: {a:?} {b:?}", a.seq);
        assert_eq!(b.status, "optimal", "{b:?}");
    }
    for k in [0, 100_001] {
        match run(
            &rec,
            RunOptions {
                warm_max_iter: Some(k),
                ..RunOptions::default()
            },
        ) {
            Err(ReplayError::WarmMaxIter(got)) => assert_eq!(got, k),
            other => panic!("expected --warm-max-iter {k} to be refused, got {other:?}"),
        }
    }
}

/// `--warm-max-iter-after-failure K` caps a warm solve only after a replayed solve that
/// did not succeed. Under a 3-iteration budget every plan fails: each warm solve takes
/// its 3 (the last one its recorded 1) and leaves its fall-back 1 (2), while under the
/// cap of 1 the warm plans after the first failure leave their fall-back 2. The cold
/// first plan and the plans whose cap it does not lower are unchanged.
#[test]
fn a_warm_cap_after_failure_applies_only_after_a_failed_solve() {
    let d = common::temp_dir("warm_cap_after_failure");
    let rec = drive(&d.join("warm.mcap"));
    let budget = RunOptions {
        budgets: replay::budget::Budgets {
            budget_ms: None,
            max_iter: Some(3),
        },
        ..RunOptions::default()
    };
    let its = |r: &replay::run::RunReport| -> Vec<u32> {
        r.per_plan.iter().map(|p| p.iterations).collect()
    };
    let plain = run(&rec, budget).unwrap();
    assert!(
        plain.per_plan.iter().all(|p| p.status != "optimal"),
        "{plain}"
    );
    assert_eq!(its(&plain), [3, 1, 1, 1, 1, 2]);
    let capped = run(
        &rec,
        RunOptions {
            warm_max_iter_after_failure: Some(1),
            ..budget
        },
    )
    .unwrap();
    assert_eq!(its(&capped), [3, 2, 2, 2, 2, 2]);
}

#[test]
fn a_warm_input_without_its_warm_start_is_refused_by_seq() {
    let d = common::temp_dir("warm_missing");
    let mut rec = drive(&d.join("warm.mcap"));
    rec.warm_starts.retain(|w| w.seq != 3);
    match run(&rec, RunOptions::default()) {
        Err(ReplayError::MissingWarmStart { seq: 3 }) => {}
        other => panic!("expected the missing warm start of seq 3, got {other:?}"),
    }
}

#[test]
fn a_rewritten_recording_keeps_its_warm_starts() {
    let d = common::temp_dir("warm_rewrite");
    let rec = drive(&d.join("warm.mcap"));
    let copy = d.join("copy.mcap");
    let stats = plan_record::write_recording(&rec, &copy).unwrap();
    assert_eq!(stats.warm_starts, 5);
    let back = Recording::read(&copy).unwrap();
    assert_eq!(back.warm_starts, rec.warm_starts);
    assert_eq!(back.inputs, rec.inputs);
}

#[test]
fn the_warm_started_oval_drive_records_every_warm_start_and_replays_bit_identically() {
    let d = common::temp_dir("warm_drive");
    let f = d.join("drive.mcap");
    let opts = replay::oval::OvalOptions {
        scenario: common::repo().join("config/scenarios/oval.toml"),
        vehicle: common::repo().join("config/vehicles/lc500.toml"),
        solver: common::repo().join("config/solver.toml"),
        plans: 6,
        rate_hz: 10.0,
        out: f.clone(),
        warm_start: true,
        saturation_at_end: true,
        mu_match: planner::ip::MuMatch::DEFAULT,
        cold_guess: planner::guess::GuessKind::Equilibrium,
    };
    let summary = replay::oval::record_oval(&opts, |_, _, _| {}).unwrap();
    assert!(
        summary.statuses.iter().all(|s| *s == "optimal"),
        "{:?}",
        summary.statuses
    );
    let rec = Recording::read(&f).unwrap();
    assert_eq!(rec.inputs[0].guess, "equilibrium");
    assert!(rec.inputs[1..].iter().all(|i| i.guess == WARM_GUESS));
    assert_eq!(rec.warm_starts.len(), 5);
    let r = run(&rec, RunOptions::default()).unwrap();
    assert_eq!((r.identical, r.different, r.unverified), (6, 0, 0), "{r}");
    // Warm plans take fewer iterations than the cold first one.
    let its: Vec<u32> = r.per_plan.iter().map(|p| p.iterations).collect();
    assert!(its[1..].iter().all(|&i| i < its[0]), "{its:?}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_logged_plan_shows_its_iterations_and_the_rows_its_start_and_end_violate_most() {
    let d = common::temp_dir("warm_log");
    let rec = drive(&d.join("warm.mcap"));
    for seq in [0, 2] {
        let r = run(
            &rec,
            RunOptions {
                log_plan: Some(seq),
                ..RunOptions::default()
            },
        )
        .unwrap();
        let log = r.plan_log.as_ref().expect("logged");
        assert_eq!(log.seq, seq);
        assert_eq!(
            log.iterations.len(),
            r.per_plan[seq as usize].iterations as usize,
            "one log row per iteration"
        );
        // Both starts (the equilibrium guess, the shifted plan with its extended tail) lie
        // off the dynamics; the converged plans only within the solver's tolerance.
        let start = log
            .worst_at_start
            .first()
            .expect("violated rows at the start");
        assert!(start.violation > 1e-3, "{start:?}");
        assert!(
            log.worst_at_end.iter().all(|w| w.violation < 1e-5),
            "{:?}",
            log.worst_at_end
        );
        let shown = format!("{log}");
        assert!(shown.contains(&start.row), "{shown}");
    }
    match run(
        &rec,
        RunOptions {
            log_plan: Some(99),
            ..RunOptions::default()
        },
    ) {
        Err(ReplayError::NoSuchPlan(99)) => {}
        other => panic!("expected --log-plan 99 to be refused, got {other:?}"),
    }
}
