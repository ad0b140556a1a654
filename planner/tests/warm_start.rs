//! Warm-started replanning (`Planner::replan_warm`): the previous plan shifted in s, primal
//! and dual, with a barrier parameter matched to the shifted point, and the fall-back to
//! the equilibrium start when the warm solve stalls.

use planner::config::{load_scenario, load_solver, load_vehicle};
use planner::guess::GuessKind;
use planner::model::{ix, NU, NX};
use planner::ocp::OcpSpec;
use planner::plan::{shift_plan, Planner, ReplanGuess, WarmOptions};
use std::path::Path;

const N: usize = planner::HORIZON;

fn oval() -> (OcpSpec, planner::ip::Settings) {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let vehicle = load_vehicle(&root.join("vehicles/lc500.toml")).unwrap();
    let spec = load_scenario(&root.join("scenarios/oval.toml"), None, vehicle).unwrap();
    let settings = load_solver(&root.join("solver.toml")).unwrap();
    (spec, settings)
}

/// The window of the oval `j` nodes on (the road wraps around the lap), and the free-start
/// lap's state there with s and t reset, as a fixed initial state.
fn window(
    spec: &OcpSpec,
    lap: &[[f64; NX]],
    j: usize,
) -> (Vec<f64>, Vec<f64>, Vec<f64>, [f64; NX]) {
    let road = |v: &[f64]| (0..=N).map(|k| v[(k + j) % N]).collect::<Vec<f64>>();
    let mut x0 = lap[j];
    x0[ix::S] = 0.0;
    x0[ix::T] = 0.0;
    (road(&spec.kappa), road(&spec.e_min), road(&spec.e_max), x0)
}

/// A planner that has solved the window at node 0 from the equilibrium guess, and the
/// free-start lap it drives along.
fn planned() -> (Planner<N>, OcpSpec, Vec<[f64; NX]>) {
    let (spec, settings) = oval();
    let mut lap = Planner::<N>::new(spec.clone(), settings).unwrap();
    assert!(lap.solve(GuessKind::Equilibrium).status.is_success());
    let lap_states = lap.states().to_vec();
    let mut p = Planner::<N>::new(spec.clone(), settings).unwrap();
    let (k, lo, hi, x0) = window(&spec, &lap_states, 0);
    let info = p
        .replan(&k, &lo, &hi, x0, ReplanGuess::Equilibrium)
        .unwrap();
    assert!(info.status.is_success(), "{info:?}");
    (p, spec, lap_states)
}

fn shifted(
    p: &Planner<N>,
    ds: f64,
    shift: f64,
    x0: &[f64; NX],
) -> (Vec<[f64; NX]>, Vec<[f64; NU]>) {
    let (mut xs, mut us) = (vec![[0.0; NX]; N + 1], vec![[0.0; NU]; N]);
    shift_plan(p.states(), p.controls(), ds, shift, x0, &mut xs, &mut us);
    (xs, us)
}

#[test]
fn a_warm_replan_of_the_same_window_from_its_own_solution_takes_a_third_of_the_cold_iterations() {
    let (mut p, spec, lap) = planned();
    let cold_iterations = p.solver().log().len();
    let objective = p.solver().log().last().unwrap().objective;
    let (k, lo, hi, x0) = window(&spec, &lap, 0);
    let (xs, us) = shifted(&p, spec.ds(), 0.0, &x0);
    let r = p
        .replan_warm(&k, &lo, &hi, x0, (&xs, &us), 0.0, WarmOptions::default())
        .unwrap();
    assert!(r.info.status.is_success() && !r.fell_back, "{r:?}");
    // With the multipliers and the matched barrier parameter the start lies near the
    // central path close to the optimum (the bound push moves it off the active bounds).
    assert!(
        3 * r.info.iterations <= cold_iterations,
        "warm {} vs cold {cold_iterations}",
        r.info.iterations
    );
    assert!((r.info.objective - objective).abs() <= 1e-6 * objective.abs());
}

#[test]
fn a_warm_replan_two_nodes_on_reaches_the_cold_solution_in_fewer_iterations() {
    let (mut p, spec, lap) = planned();
    let (spec2, settings) = oval();
    let (k, lo, hi, x0) = window(&spec, &lap, 2);
    let shift = 2.0 * spec.ds();
    let (xs, us) = shifted(&p, spec.ds(), shift, &x0);
    let r = p
        .replan_warm(&k, &lo, &hi, x0, (&xs, &us), shift, WarmOptions::default())
        .unwrap();
    assert!(r.info.status.is_success() && !r.fell_back, "{r:?}");
    let mut cold = Planner::<N>::new(spec2, settings).unwrap();
    let c = cold
        .replan(&k, &lo, &hi, x0, ReplanGuess::Equilibrium)
        .unwrap();
    assert!(c.status.is_success());
    assert!(
        r.info.iterations < c.iterations,
        "warm {} vs cold {}",
        r.info.iterations,
        c.iterations
    );
    let tn = |s: &[[f64; NX]]| s[N][ix::T];
    assert!((tn(p.states()) - tn(cold.states())).abs() <= 1e-4 * tn(cold.states()));
}

#[test]
fn a_stalled_warm_solve_falls_back_to_the_equilibrium_start_and_gives_its_bits() {
    let (mut p, spec, lap) = planned();
    let (spec2, settings) = oval();
    let (k, lo, hi, x0) = window(&spec, &lap, 2);
    let shift = 2.0 * spec.ds();
    let (xs, us) = shifted(&p, spec.ds(), shift, &x0);
    let opts = WarmOptions {
        max_iter: 1,
        ..WarmOptions::default()
    };
    let r = p
        .replan_warm(&k, &lo, &hi, x0, (&xs, &us), shift, opts)
        .unwrap();
    assert!(r.fell_back, "{r:?}");
    assert_eq!(r.warm_iterations, 1);
    assert_eq!(r.total_iterations(), 1 + r.info.iterations);
    // The fall-back keeps the caps of one solve: settings restored afterwards.
    assert_eq!(*p.solver().settings(), settings);
    let mut cold = Planner::<N>::new(spec2, settings).unwrap();
    let c = cold
        .replan(&k, &lo, &hi, x0, ReplanGuess::Equilibrium)
        .unwrap();
    assert_eq!(r.info.iterations, c.iterations);
    let bits = |s: &[[f64; NX]]| s.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(p.states()), bits(cold.states()));
}

#[test]
fn a_warm_solve_stopped_by_the_clock_returns_its_best_iterate_instead_of_falling_back() {
    let (mut p, spec, lap) = planned();
    let (k, lo, hi, x0) = window(&spec, &lap, 2);
    let shift = 2.0 * spec.ds();
    let (xs, us) = shifted(&p, spec.ds(), shift, &x0);
    let base = *p.solver().settings();
    let tiny = planner::ip::Settings {
        max_time_s: 1e-9,
        ..base
    };
    p.solver_mut().set_settings(tiny).unwrap();
    let r = p
        .replan_warm(&k, &lo, &hi, x0, (&xs, &us), shift, WarmOptions::default())
        .unwrap();
    assert_eq!(r.info.status, planner::ip::Status::TimeLimit, "{r:?}");
    assert!(!r.fell_back, "{r:?}");
    assert!(r.info.max_violation.is_finite());
    // The best iterate is the shifted plan, not the equilibrium guess: it starts at x0
    // and keeps the previous plan's speeds.
    assert_eq!(p.states()[0], x0);
    let v_gap = (p.states()[N / 2][ix::V] - xs[N / 2][ix::V]).abs();
    assert!(
        v_gap < 1.0,
        "speed at the middle node moved {v_gap} m/s from the warm guess"
    );
}

/// The warm start's barrier rule changes where the solve starts, not where it ends: from
/// the same shifted plan the mean and the geometric rule (factors 3 and 300) reach the same
/// t_N, and the geometric rule's first barrier parameter scales with its factor (100 times
/// for 100 times the factor, unless clipped to [mu_floor, mu_init]).
#[test]
fn the_warm_barrier_rules_reach_the_same_plan_and_the_geometric_one_scales_with_its_factor() {
    use planner::ip::MuMatch;
    let run = |mu_match: MuMatch| {
        let (mut p, spec, lap) = planned();
        let (k, lo, hi, x0) = window(&spec, &lap, 2);
        let shift = 2.0 * spec.ds();
        let (xs, us) = shifted(&p, spec.ds(), shift, &x0);
        let opts = WarmOptions {
            mu_match,
            ..WarmOptions::default()
        };
        let r = p
            .replan_warm(&k, &lo, &hi, x0, (&xs, &us), shift, opts)
            .unwrap();
        assert!(
            r.info.status.is_success() && !r.fell_back,
            "{mu_match:?}: {r:?}"
        );
        (p.states()[N][ix::T], p.solver().log()[0].mu)
    };
    let (t_mean, _) = run(MuMatch::Mean);
    let (t_3, mu_3) = run(MuMatch::Geometric { factor: 3.0 });
    let (t_300, mu_300) = run(MuMatch::Geometric { factor: 300.0 });
    for t in [t_3, t_300] {
        assert!(
            (t - t_mean).abs() <= 1e-6 * t_mean,
            "t_N {t} against {t_mean}"
        );
    }
    let settings = oval().1;
    let (lo, hi) = (WarmOptions::default().mu_floor, settings.mu_init);
    assert!(mu_3 > lo && mu_300 < hi, "clipped: {mu_3}, {mu_300}");
    assert!(
        (mu_300 / mu_3 - 100.0).abs() < 1e-9 * 100.0,
        "first mu {mu_3} and {mu_300}"
    );
}
