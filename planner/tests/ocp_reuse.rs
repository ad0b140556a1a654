//! Re-using one transcription for a new planning problem of the same size:
//! `update_road` and `set_initial` allocate nothing, leave the structure alone, give the
//! bounds of a freshly built transcription, and a solve after the update equals a solve of
//! a fresh instance.

use std::path::Path;

use planner::config::{load_scenario, load_solver, load_vehicle};
use planner::guess;
use planner::ip::{Nlp, Settings, Solver, Status};
use planner::model::{NU, NX};
use planner::ocp::{ImplicitEulerNlp, InitialState, OcpSpec, TranscriptionError};

const N: usize = 100;

fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"))
}

fn oval() -> (OcpSpec, Settings) {
    let vehicle = load_vehicle(&root().join("vehicles/lc500.toml")).unwrap();
    let spec = load_scenario(&root().join("scenarios/oval.toml"), None, vehicle).unwrap();
    (spec, load_solver(&root().join("solver.toml")).unwrap())
}

/// A different road on the same grid: curvature scaled by 0.9, narrower and asymmetric
/// lateral bounds.
fn other_road(spec: &OcpSpec) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let kappa = spec.kappa.iter().map(|k| 0.9 * k).collect();
    let e_min = (0..=N).map(|k| -3.5 + 0.002 * k as f64).collect();
    let e_max = (0..=N).map(|k| 3.8 - 0.001 * k as f64).collect();
    (kappa, e_min, e_max)
}

const X0: [f64; NX] = [0.0, 20.0, 0.0, 20.2, 0.0, 0.5, 0.0, 0.0, 0.0];

struct Bounds {
    xl: Vec<f64>,
    xu: Vec<f64>,
    gl: Vec<f64>,
    gu: Vec<f64>,
}

fn bounds(nlp: &ImplicitEulerNlp<N>) -> Bounds {
    let d = nlp.dims();
    let mut b = Bounds {
        xl: vec![0.0; d.n],
        xu: vec![0.0; d.n],
        gl: vec![0.0; d.m],
        gu: vec![0.0; d.m],
    };
    nlp.bounds(&mut b.xl, &mut b.xu, &mut b.gl, &mut b.gu);
    b
}

fn same_bounds(a: &ImplicitEulerNlp<N>, b: &ImplicitEulerNlp<N>) {
    assert_eq!(a.dims(), b.dims());
    let (x, y) = (bounds(a), bounds(b));
    assert_eq!(x.xl, y.xl);
    assert_eq!(x.xu, y.xu);
    assert_eq!(x.gl, y.gl);
    assert_eq!(x.gu, y.gu);
    assert_eq!(a.spec(), b.spec());
}

#[test]
fn update_and_set_initial_do_not_allocate() {
    let (spec, _) = oval();
    let mut nlp = ImplicitEulerNlp::<N>::new(spec.clone()).unwrap();
    let (kappa, e_min, e_max) = other_road(&spec);
    nlp.update_road(&kappa, &e_min, &e_max).unwrap(); // warm-up
    let info = allocation_counter::measure(|| {
        nlp.update_road(&spec.kappa, &spec.e_min, &spec.e_max)
            .unwrap();
        nlp.set_initial(InitialState::Fixed(X0));
        nlp.update_road(&kappa, &e_min, &e_max).unwrap();
        nlp.set_initial(InitialState::Free);
        assert!(nlp.update_road(&kappa[1..], &e_min, &e_max).is_err());
    });
    assert_eq!(info.count_total, 0, "{info:?}");
    // A wrong length is reported and changes nothing.
    let before = nlp.spec().clone();
    assert!(matches!(
        nlp.update_road(&kappa, &e_min[..N], &e_max),
        Err(TranscriptionError::BadLength { field: "e_min", .. })
    ));
    assert_eq!(nlp.spec(), &before);
}

#[test]
fn updated_instance_equals_fresh_build() {
    let (spec, _) = oval();
    let (kappa, e_min, e_max) = other_road(&spec);
    let mut nlp = ImplicitEulerNlp::<N>::new(spec.clone()).unwrap();
    let d = nlp.dims();
    let structure = |nlp: &ImplicitEulerNlp<N>| {
        let (mut jr, mut jc) = (vec![0; d.nnz_jac], vec![0; d.nnz_jac]);
        nlp.jac_structure(&mut jr, &mut jc);
        let (mut hr, mut hc) = (vec![0; d.nnz_hess], vec![0; d.nnz_hess]);
        nlp.hess_structure(&mut hr, &mut hc);
        (jr, jc, hr, hc)
    };
    let s0 = structure(&nlp);
    for initial in [
        InitialState::Fixed(X0),
        InitialState::Free,
        InitialState::Fixed(X0),
    ] {
        nlp.update_road(&kappa, &e_min, &e_max).unwrap();
        nlp.set_initial(initial);
        let mut fresh = spec.clone();
        fresh.kappa.clone_from(&kappa);
        fresh.e_min.clone_from(&e_min);
        fresh.e_max.clone_from(&e_max);
        fresh.initial = initial;
        let fresh = ImplicitEulerNlp::<N>::new(fresh).unwrap();
        same_bounds(&nlp, &fresh);
        assert!(structure(&nlp) == s0 && structure(&fresh) == s0);
    }
    // Free mode: s_0, t_0, dpsi_0 are the only equalities among the initial rows, the
    // others finite inactive envelopes; e_0 has its node-0 variable bounds. Fixed: x_0 is
    // not variable-bounded.
    nlp.set_initial(InitialState::Free);
    let b = bounds(&nlp);
    let eq: Vec<bool> = (0..NX).map(|r| b.gl[r] == b.gu[r]).collect();
    assert_eq!(
        eq,
        [true, true, true, false, false, false, false, false, false]
    );
    let lay = nlp.layout();
    assert_eq!((b.xl[lay.x(0, 5)], b.xu[lay.x(0, 5)]), (e_min[0], e_max[0])); // e nominal 1 m
    assert!((0..NX).all(|r| b.gl[r].is_finite() && b.gu[r].is_finite()));
    nlp.set_initial(InitialState::Fixed(X0));
    let b = bounds(&nlp);
    assert!((0..NX).all(|i| b.xl[i].is_infinite() && b.xu[i].is_infinite()));
}

/// Solves `nlp` with `solver` from the equilibrium guess.
fn solve(
    solver: &mut Solver,
    nlp: &mut ImplicitEulerNlp<N>,
    eq: &guess::Equilibrium,
) -> (planner::ip::SolveInfo, Vec<f64>) {
    let mut xs = vec![[0.0; NX]; N + 1];
    let mut us = vec![[0.0; NU]; N];
    let fixed = match nlp.spec().initial {
        InitialState::Fixed(x0) => Some(x0),
        InitialState::Free => None,
    };
    guess::fill_equilibrium(eq, nlp.spec().ds(), fixed.as_ref(), &mut xs, &mut us);
    nlp.set_initial_guess(&xs, &us);
    let info = solver.solve(nlp);
    (info, solver.x().to_vec())
}

#[test]
fn solve_after_update_equals_fresh_solve() {
    let (spec, settings) = oval();
    let (kappa, e_min, e_max) = other_road(&spec);
    let eq = guess::equilibrium(&spec.vehicle, spec.v_min, spec.v_max, 15.0).unwrap();

    // One instance and solver: the original problem, then the new road with a fixed x_0.
    let mut nlp = ImplicitEulerNlp::<N>::new(spec.clone()).unwrap();
    let mut solver = Solver::new(&nlp, settings).unwrap();
    let (first, _) = solve(&mut solver, &mut nlp, &eq);
    assert_eq!(first.status, Status::Optimal);
    for initial in [InitialState::Free, InitialState::Fixed(X0)] {
        nlp.update_road(&kappa, &e_min, &e_max).unwrap();
        nlp.set_initial(initial);
        let (a, za) = solve(&mut solver, &mut nlp, &eq);

        let mut fresh = spec.clone();
        fresh.kappa.clone_from(&kappa);
        fresh.e_min.clone_from(&e_min);
        fresh.e_max.clone_from(&e_max);
        fresh.initial = initial;
        let mut nlp_b = ImplicitEulerNlp::<N>::new(fresh).unwrap();
        let mut solver_b = Solver::new(&nlp_b, settings).unwrap();
        let (b, zb) = solve(&mut solver_b, &mut nlp_b, &eq);
        println!(
            "{initial:?}: {} its, t_N objective {:.6}, status {:?}",
            a.iterations, a.objective, a.status
        );
        assert_eq!(a.status, Status::Optimal, "{a:?}");
        assert_eq!((a.status, a.iterations), (b.status, b.iterations));
        for (x, y) in za.iter().zip(&zb) {
            assert_eq!(x.to_bits(), y.to_bits());
        }
    }
}

/// The tire saturation rows are scaled by the initial-state treatment (0.1 with a fixed x_0,
/// 3 with a free one; `planner::ocp::scaling::saturation_scale`), consistently in the row
/// values, their bounds, their Jacobian and their Hessian (fast path and num-dual oracle),
/// and switching back and forth with `set_initial` gives the same rows again. Nothing else
/// changes. Checked at a perturbed guess, where the tires slip and the saturation
/// derivatives are non-zero.
#[test]
fn saturation_rows_follow_the_initial_state_scale() {
    use planner::ocp::scaling::{saturation_scale, SATURATION_SCALE_FIXED, SATURATION_SCALE_FREE};
    use planner::ocp::transcription::RowKind;
    use planner::ocp::Derivatives;
    assert_eq!(
        saturation_scale(&InitialState::Fixed(X0)),
        SATURATION_SCALE_FIXED
    );
    assert_eq!(saturation_scale(&InitialState::Free), SATURATION_SCALE_FREE);
    let (spec, _) = oval();
    let mut nlp = ImplicitEulerNlp::<N>::new(spec).unwrap();
    let d = nlp.dims();
    let mut z = vec![0.0; d.n];
    nlp.initial_point(&mut z);
    for (i, v) in z.iter_mut().enumerate() {
        *v += 0.05 * ((i * 7919 % 23) as f64 / 23.0 - 0.5);
    }
    let (mut jr, mut jc) = (vec![0; d.nnz_jac], vec![0; d.nnz_jac]);
    nlp.jac_structure(&mut jr, &mut jc);
    let is_sat = |nlp: &ImplicitEulerNlp<N>, i: usize| {
        matches!(nlp.describe_row(i).kind, RowKind::Saturation { .. })
    };
    // Multipliers on the saturation rows only and no objective term (obj_factor 0, so the
    // shipped steering-slew curvature drops out): the Hessian is theirs alone.
    let lambda: Vec<f64> = (0..d.m)
        .map(|i| {
            if is_sat(&nlp, i) {
                1.0 + (i % 5) as f64
            } else {
                0.0
            }
        })
        .collect();
    let rows = |nlp: &mut ImplicitEulerNlp<N>| {
        let (mut g, mut jac, mut hess) =
            (vec![0.0; d.m], vec![0.0; d.nnz_jac], vec![0.0; d.nnz_hess]);
        nlp.eval_g(&z, &mut g);
        nlp.eval_jac_g(&z, &mut jac);
        nlp.eval_hess(&z, 0.0, &lambda, &mut hess);
        (g, jac, hess, bounds(nlp))
    };
    let ratio = SATURATION_SCALE_FIXED / SATURATION_SCALE_FREE;
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1e-300);
    for derivatives in [Derivatives::Fast, Derivatives::Oracle] {
        nlp.set_derivatives(derivatives);
        nlp.set_initial(InitialState::Free);
        let free = rows(&mut nlp);
        nlp.set_initial(InitialState::Fixed(X0));
        let fixed = rows(&mut nlp);
        nlp.set_initial(InitialState::Free);
        let again = rows(&mut nlp);
        assert!(again.0 == free.0 && again.1 == free.1 && again.2 == free.2);
        let (mut sat_rows, mut sat_nonzero) = (0, 0);
        for i in 0..d.m {
            if is_sat(&nlp, i) {
                sat_rows += 1;
                assert!(close(free.0[i], ratio * fixed.0[i]), "row {i}");
                // The rear row at node 0 of a fixed start has a bound it never reaches.
                let info = nlp.describe_row(i);
                if !(info.node == 0 && info.kind == (RowKind::Saturation { rear: true })) {
                    assert!(close(free.3.gu[i], ratio * fixed.3.gu[i]), "bound {i}");
                }
            } else {
                assert_eq!(free.0[i].to_bits(), fixed.0[i].to_bits(), "row {i}");
            }
        }
        assert_eq!(sat_rows, 2 * N);
        for (q, &r) in jr.iter().enumerate() {
            if is_sat(&nlp, r) {
                sat_nonzero += usize::from(free.1[q] != 0.0);
                assert!(close(free.1[q], ratio * fixed.1[q]), "entry {q}");
            } else {
                assert_eq!(free.1[q].to_bits(), fixed.1[q].to_bits(), "entry {q}");
            }
        }
        let hess_nonzero = free.2.iter().filter(|v| **v != 0.0).count();
        for (q, (&a, &b)) in free.2.iter().zip(&fixed.2).enumerate() {
            assert!(close(a, ratio * b), "Hessian entry {q}: {a} against {b}");
        }
        // The point exercises the derivatives: most saturation entries are non-zero.
        assert!(
            sat_nonzero > 2 * N * 5,
            "{sat_nonzero} non-zero Jacobian entries"
        );
        assert!(
            hess_nonzero > N * 10,
            "{hess_nonzero} non-zero Hessian entries"
        );
    }
}

/// A fixed start measured in a slide (rear tire past its sliding slip by e_0 > eps_sat)
/// cannot be back within eps_sat at the next node: the rear rows of the first K nodes are
/// bounded by eps_sat + (e_0 - eps_sat)(1 - k / K), then eps_sat; the front rows and every
/// row of a start within eps_sat keep eps_sat.
#[test]
fn a_sliding_start_ramps_the_rear_saturation_bound_down_from_its_own_excess() {
    use planner::model::{ix, saturation};
    use planner::ocp::scaling::saturation_scale;
    use planner::ocp::transcription::{RowKind, SATURATION_RAMP_NODES};
    let (spec, _) = oval();
    let eps = spec.vehicle.eps_sat;
    let mut sliding = X0;
    sliding[ix::BETA] = -0.3;
    sliding[ix::R] = 0.6;
    let excess = saturation(&spec.vehicle, &sliding, &[0.0; NU])[1];
    assert!(excess > eps + 0.05, "the start slides: {excess}");
    assert!(saturation(&spec.vehicle, &X0, &[0.0; NU])[1] <= eps);
    let mut nlp = ImplicitEulerNlp::<N>::new(spec).unwrap();
    let scale = saturation_scale(&InitialState::Fixed(X0));
    for (x0, e0) in [(sliding, excess), (X0, eps)] {
        nlp.set_initial(InitialState::Fixed(x0));
        let b = bounds(&nlp);
        for i in 0..nlp.dims().m {
            let info = nlp.describe_row(i);
            let RowKind::Saturation { rear } = info.kind else {
                continue;
            };
            let k = info.node;
            let physical = if !rear {
                eps
            } else if k == 0 {
                continue; // never active at a fixed start
            } else if k < SATURATION_RAMP_NODES {
                eps + (e0 - eps) * (1.0 - k as f64 / SATURATION_RAMP_NODES as f64)
            } else {
                eps
            };
            let want = physical / scale;
            assert!(
                (b.gu[i] - want).abs() <= 1e-12 * want.abs(),
                "row {i} node {k}"
            );
        }
    }
}
