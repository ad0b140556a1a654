//! A full solve after setup allocates nothing (counting global allocator).

use std::path::Path;

use planner::config::{load_scenario, load_solver, load_vehicle};
use planner::guess::GuessKind;
use planner::ip::kkt::KktBackendKind;
use planner::plan::Planner;

#[test]
fn oval_solve_allocates_nothing() {
    oval_solve_allocates_nothing_with(KktBackendKind::Sparse);
}

#[test]
fn oval_solve_with_riccati_backend_allocates_nothing() {
    oval_solve_allocates_nothing_with(KktBackendKind::Riccati);
}

fn oval_solve_allocates_nothing_with(kkt: KktBackendKind) {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let vehicle = load_vehicle(&root.join("vehicles/lc500.toml")).unwrap();
    let spec = load_scenario(&root.join("scenarios/oval.toml"), None, vehicle).unwrap();
    let mut settings = load_solver(&root.join("solver.toml")).unwrap();
    settings.kkt = kkt;
    let mut p = Planner::<100>::new(spec, settings).unwrap();
    // Warm-up solve (any lazily sized buffer is sized here).
    p.solve(GuessKind::Equilibrium);
    let mut status = None;
    let info = allocation_counter::measure(|| {
        status = Some(p.solve(GuessKind::Equilibrium).status);
    });
    assert_eq!(info.count_total, 0, "{info:?}");
    assert_eq!(status, Some(planner::ip::Status::Optimal));
    // The counter does see allocations (the test can fail).
    let seen = allocation_counter::measure(|| {
        std::hint::black_box(vec![1u8; 16]);
    });
    assert!(seen.count_total > 0);
}

#[test]
fn replan_from_a_new_state_allocates_nothing() {
    use planner::model::ix;
    use planner::plan::ReplanGuess;
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let vehicle = load_vehicle(&root.join("vehicles/lc500.toml")).unwrap();
    let spec = load_scenario(&root.join("scenarios/oval.toml"), None, vehicle).unwrap();
    let settings = load_solver(&root.join("solver.toml")).unwrap();
    let (kappa, e_min, e_max) = (spec.kappa.clone(), spec.e_min.clone(), spec.e_max.clone());
    let mut p = Planner::<100>::new(spec, settings).unwrap();
    p.solve(GuessKind::Equilibrium);
    // Start from the planned state at node 10, as a replanning cycle would.
    let mut x0 = p.states()[10];
    x0[ix::S] = 0.0;
    x0[ix::T] = 0.0;
    p.replan(&kappa, &e_min, &e_max, x0, ReplanGuess::Equilibrium)
        .unwrap();
    x0[ix::V] += 0.5;
    let mut ok = None;
    let info = allocation_counter::measure(|| {
        ok = Some(
            p.replan(&kappa, &e_min, &e_max, x0, ReplanGuess::Equilibrium)
                .map(|i| i.status),
        );
    });
    assert_eq!(info.count_total, 0, "{info:?}");
    assert!(matches!(ok, Some(Ok(_))), "{ok:?}");
}

#[test]
fn a_warm_replan_with_its_fall_back_allocates_nothing() {
    use planner::model::{ix, NU, NX};
    use planner::plan::{shift_plan, ReplanGuess, WarmOptions};
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let vehicle = load_vehicle(&root.join("vehicles/lc500.toml")).unwrap();
    let spec = load_scenario(&root.join("scenarios/oval.toml"), None, vehicle).unwrap();
    let settings = load_solver(&root.join("solver.toml")).unwrap();
    let (kappa, e_min, e_max, ds) = (
        spec.kappa.clone(),
        spec.e_min.clone(),
        spec.e_max.clone(),
        spec.ds(),
    );
    let mut p = Planner::<100>::new(spec, settings).unwrap();
    p.solve(GuessKind::Equilibrium);
    let mut x0 = p.states()[10];
    x0[ix::S] = 0.0;
    x0[ix::T] = 0.0;
    p.replan(&kappa, &e_min, &e_max, x0, ReplanGuess::Equilibrium)
        .unwrap();
    let (mut xs, mut us) = (vec![[0.0; NX]; 101], vec![[0.0; NU]; 100]);
    let mut ok = Vec::with_capacity(2);
    let info = allocation_counter::measure(|| {
        for max_iter in [usize::MAX, 1] {
            shift_plan(p.states(), p.controls(), ds, 0.0, &x0, &mut xs, &mut us);
            let opts = WarmOptions {
                max_iter,
                ..WarmOptions::default()
            };
            ok.push(
                p.replan_warm(&kappa, &e_min, &e_max, x0, (&xs, &us), 0.0, opts)
                    .map(|r| r.fell_back),
            );
        }
    });
    assert_eq!(info.count_total, 0, "{info:?}");
    // Both paths ran: the warm solve, and the stalled one with its fall-back.
    assert!(
        matches!(ok[..], [Ok(false), Ok(true)]),
        "{:?}",
        ok.iter().map(|r| r.as_ref().ok()).collect::<Vec<_>>()
    );
}
