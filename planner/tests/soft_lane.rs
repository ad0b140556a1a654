//! The soft lane (`planner::ocp::soft_lane`) in whole solves on the oval: it keeps the
//! minimum-time plan out of the room the lane bounds alone let it use, and a start past
//! it, heading for the edge, is planned back inside it.

use std::path::Path;

use planner::config::{load_scenario, load_solver, load_vehicle, shipped_solver_file};
use planner::guess::GuessKind;
use planner::ip::Status;
use planner::model::ix;
use planner::ocp::{InitialState, SoftLane};
use planner::plan::Planner;

fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"))
}

/// The oval (lane +-4 m) with the band `soft` and the initial state `initial`.
fn oval(soft: SoftLane, initial: InitialState) -> Planner<100> {
    let vehicle = load_vehicle(&root().join("vehicles/lc500.toml")).unwrap();
    let mut spec = load_scenario(&root().join("scenarios/oval.toml"), None, vehicle).unwrap();
    spec.soft_lane = soft;
    spec.initial = initial;
    spec.check().unwrap();
    let settings =
        load_solver(&root().join(shipped_solver_file(spec.steering_slew_weight))).unwrap();
    Planner::<100>::new(spec, settings).unwrap()
}

/// A soft lane 1 m inside each edge: e within +-3 m.
fn band() -> SoftLane {
    SoftLane::new(10.0, vec![-3.0; 101], vec![3.0; 101])
}

/// Deepest any node from `from` on lies inside the band's inner edges +-3 m \[m\].
fn deepest(p: &Planner<100>, from: usize) -> f64 {
    p.states()[from..]
        .iter()
        .map(|x| x[ix::E].abs() - 3.0)
        .fold(f64::NEG_INFINITY, f64::max)
}

#[test]
fn the_band_keeps_the_minimum_time_plan_out_of_the_room_the_lane_alone_gives_it() {
    let mut hard = oval(SoftLane::OFF, InitialState::Free);
    let info = hard.solve(GuessKind::Equilibrium);
    assert_eq!(info.status, Status::Optimal, "{info:?}");
    // Without the band the plan uses the lane to its edges (at least 0.5 m of the band).
    assert!(deepest(&hard, 0) > 0.5, "{}", deepest(&hard, 0));

    let mut soft = oval(band(), InitialState::Free);
    let info = soft.solve(GuessKind::Equilibrium);
    assert_eq!(info.status, Status::Optimal, "{info:?}");
    let depth = deepest(&soft, 0);
    assert!(depth < 0.1, "{depth} m into the band");
    // The room given up costs time: the band's plan is slower, and not by much.
    let (t_hard, t_soft) = (hard.states()[100][ix::T], soft.states()[100][ix::T]);
    println!(
        "lane alone: t_N {t_hard:.4} s, {:.3} m into the band; band: t_N {t_soft:.4} s, {depth:.3} m, {} iterations",
        deepest(&hard, 0),
        info.iterations
    );
    assert!(
        t_soft > t_hard && t_soft < 1.1 * t_hard,
        "{t_soft} s vs {t_hard} s"
    );
}

#[test]
fn a_start_in_the_band_heading_for_the_edge_is_planned_back_out_of_it() {
    // 0.5 m from the left edge, moving toward it at 25 m/s x sin(0.08) = 2 m/s.
    let x0 = [0.0, 25.0, 0.0, 25.0, 0.0, 3.5, 0.08, 0.0, 0.0];
    let mut p = oval(band(), InitialState::Fixed(x0));
    let info = p.solve(GuessKind::Equilibrium);
    assert_eq!(info.status, Status::Optimal, "{info:?}");
    let e = |k: usize| p.states()[k][ix::E];
    // The sideways motion carries the plan further out first, within the lane, ...
    let peak = (0..=20).map(e).fold(f64::NEG_INFINITY, f64::max);
    println!(
        "peak e {peak:.3} m, {:.3} m into the band from node 30, {} iterations",
        deepest(&p, 30),
        info.iterations
    );
    assert!(peak > 3.5 && peak < 4.0, "peak e {peak} m");
    // ... then it leaves the band and stays out of it.
    assert!(deepest(&p, 30) < 0.1, "{} m into the band", deepest(&p, 30));
}
