//! Exact first and second derivatives of the whole NLP against central finite differences
//! at random points of the operating envelope.

mod common;

use common::{random_trajectory, Rng};
use planner::ip::Nlp;
use planner::ocp::fixtures::oval_spec;
use planner::ocp::{ImplicitEulerNlp, InitialState, SoftLane};
use std::collections::HashSet;

const N: usize = 100;

/// Relative error with an absolute floor: |a - b| / max(|a|, |b|, 1).
fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(1.0)
}

fn step(z: f64) -> f64 {
    1e-6 * z.abs().max(1.0)
}

struct Problem {
    nlp: ImplicitEulerNlp<N>,
    n: usize,
    m: usize,
    jr: Vec<usize>,
    jc: Vec<usize>,
    hr: Vec<usize>,
    hc: Vec<usize>,
}

fn problem(sat: bool, fixed: bool) -> Problem {
    problem_w(sat, fixed, 0.0)
}

/// As [`problem`], with the objective's steering-slew term at weight `w` [1/s].
fn problem_w(sat: bool, fixed: bool, w: f64) -> Problem {
    problem_ws(sat, fixed, w, SoftLane::OFF)
}

/// A soft lane +-0.8 m wide: the random trajectories' e (within +-2.6 m) lie past it at
/// some nodes and inside it at others.
fn band() -> SoftLane {
    SoftLane::new(2.5, vec![-0.8; N + 1], vec![0.8; N + 1])
}

/// As [`problem_w`], with the soft lane band `soft`.
fn problem_ws(sat: bool, fixed: bool, w: f64, soft: SoftLane) -> Problem {
    problem_wse(sat, fixed, w, soft, false)
}

/// As [`problem_ws`], with the saturation rows at the last node (x_N, u_{N-1}) when `end`.
fn problem_wse(sat: bool, fixed: bool, w: f64, soft: SoftLane, end: bool) -> Problem {
    let mut spec = oval_spec();
    spec.enforce_tire_saturation = sat;
    spec.saturation_at_end = end;
    spec.steering_slew_weight = w;
    spec.soft_lane = soft;
    if fixed {
        spec.initial = InitialState::Fixed([0.1, 20.0, 0.01, 20.5, 300.0, 0.5, 0.02, 0.0, 0.0]);
    }
    let nlp = ImplicitEulerNlp::<N>::new(spec).unwrap();
    let d = nlp.dims();
    let (mut jr, mut jc) = (vec![0; d.nnz_jac], vec![0; d.nnz_jac]);
    nlp.jac_structure(&mut jr, &mut jc);
    let (mut hr, mut hc) = (vec![0; d.nnz_hess], vec![0; d.nnz_hess]);
    nlp.hess_structure(&mut hr, &mut hc);
    Problem {
        nlp,
        n: d.n,
        m: d.m,
        jr,
        jc,
        hr,
        hc,
    }
}

fn random_z(p: &Problem, seed: u64) -> Vec<f64> {
    let mut rng = Rng(seed);
    let (xs, us) = random_trajectory(&mut rng, N, 2.6);
    let mut z = vec![0.0; p.n];
    p.nlp.pack(&xs, &us, &mut z);
    z
}

fn dense_jac(p: &mut Problem, z: &[f64]) -> Vec<f64> {
    let mut vals = vec![0.0; p.jr.len()];
    p.nlp.eval_jac_g(z, &mut vals);
    let mut d = vec![0.0; p.m * p.n];
    for (e, v) in vals.iter().enumerate() {
        d[p.jr[e] * p.n + p.jc[e]] += v;
    }
    d
}

/// grad of sigma f + lambda^T g (analytic first derivatives).
fn lagrangian_grad(p: &mut Problem, z: &[f64], sigma: f64, lam: &[f64]) -> Vec<f64> {
    let mut gf = vec![0.0; p.n];
    p.nlp.eval_grad_f(z, &mut gf);
    let mut vals = vec![0.0; p.jr.len()];
    p.nlp.eval_jac_g(z, &mut vals);
    let mut out: Vec<f64> = gf.iter().map(|g| sigma * g).collect();
    for (e, v) in vals.iter().enumerate() {
        out[p.jc[e]] += lam[p.jr[e]] * v;
    }
    out
}

#[test]
fn structures_are_valid() {
    for (sat, fixed, w, end) in [
        (true, false, 0.0, false),
        (false, true, 0.0, false),
        (true, false, 1.0, false),
        (true, true, 0.0, true),
        (false, true, 0.0, true),
    ] {
        let p = problem_wse(sat, fixed, w, SoftLane::OFF, end);
        let mut seen = HashSet::new();
        for (&r, &c) in p.jr.iter().zip(&p.jc) {
            assert!(r < p.m && c < p.n);
            assert!(seen.insert((r, c)), "duplicate Jacobian entry ({r},{c})");
        }
        let mut seen = HashSet::new();
        for (&r, &c) in p.hr.iter().zip(&p.hc) {
            assert!(r >= c && r < p.n, "not lower triangle ({r},{c})");
            assert!(seen.insert((r, c)), "duplicate Hessian entry ({r},{c})");
        }
        assert_eq!(p.n, 9 * (N + 1) + 3 * N);
        let init = 9; // all nine initial-condition rows in both modes
        let sat_rows = match (sat, end) {
            (false, _) => 0,
            (true, false) => 2 * N,
            (true, true) => 2 * (N + 1),
        };
        assert_eq!(p.m, init + 9 * N + 2 * N + sat_rows + 6 * (N - 1));
    }
}

#[test]
fn objective_gradient_matches_fd() {
    // Weight 0: t_N only; weight 1: the steering-slew term too (non-zero on every control);
    // the soft lane: non-zero on the e of the nodes past its bounds, and only there.
    for (w, soft) in [(0.0, SoftLane::OFF), (1.0, SoftLane::OFF), (0.0, band())] {
        let on = soft.is_on();
        let mut p = problem_ws(true, false, w, soft);
        let z = random_z(&p, 7);
        let mut g = vec![0.0; p.n];
        p.nlp.eval_grad_f(&z, &mut g);
        let nonzero = g.iter().filter(|v| **v != 0.0).count();
        assert_eq!(
            nonzero > 1,
            w > 0.0 || on,
            "weight {w}: {nonzero} non-zero entries"
        );
        if on {
            assert!(
                (10..N).contains(&(nonzero - 1)),
                "{} nodes inside the band",
                nonzero - 1
            );
        }
        let mut zz = z.clone();
        for j in 0..p.n {
            let h = step(z[j]);
            zz[j] = z[j] + h;
            let fp = p.nlp.eval_f(&zz);
            zz[j] = z[j] - h;
            let fm = p.nlp.eval_f(&zz);
            zz[j] = z[j];
            assert!(
                rel(g[j], (fp - fm) / (2.0 * h)) < 1e-6,
                "weight {w}: grad f [{j}]"
            );
        }
    }
}

fn check_jacobian(sat: bool, fixed: bool, seed: u64) {
    check_jacobian_of(problem(sat, fixed), seed);
}

/// The Jacobian of `p` at a random point against central differences.
fn check_jacobian_of(mut p: Problem, seed: u64) {
    let (sat, fixed) = (
        p.nlp.spec().enforce_tire_saturation,
        p.nlp.spec().initial != InitialState::Free,
    );
    let z = random_z(&p, seed);
    let jac = dense_jac(&mut p, &z);
    let structure: HashSet<(usize, usize)> =
        p.jr.iter().copied().zip(p.jc.iter().copied()).collect();
    let (mut gp, mut gm) = (vec![0.0; p.m], vec![0.0; p.m]);
    let mut zz = z.clone();
    let mut worst = (0.0, 0, 0);
    for j in 0..p.n {
        let h = step(z[j]);
        zz[j] = z[j] + h;
        p.nlp.eval_g(&zz, &mut gp);
        zz[j] = z[j] - h;
        p.nlp.eval_g(&zz, &mut gm);
        zz[j] = z[j];
        for i in 0..p.m {
            let fd = (gp[i] - gm[i]) / (2.0 * h);
            if fd != 0.0 && !structure.contains(&(i, j)) {
                assert!(
                    fd.abs() < 1e-8,
                    "FD entry ({i},{j}) = {fd} outside the structure ({})",
                    p.nlp.row_name(i)
                );
            }
            let e = rel(jac[i * p.n + j], fd);
            if e > worst.0 {
                worst = (e, i, j);
            }
        }
    }
    println!(
        "jacobian sat={sat} fixed={fixed}: worst rel err {:.2e} at row {} ({}) col {}",
        worst.0,
        worst.1,
        p.nlp.row_name(worst.1),
        worst.2
    );
    assert!(worst.0 < 1e-6);
}

#[test]
fn constraint_jacobian_matches_fd() {
    check_jacobian(true, false, 11);
    check_jacobian(true, false, 12);
}

#[test]
fn constraint_jacobian_matches_fd_fixed_initial_no_saturation() {
    check_jacobian(false, true, 13);
}

#[test]
fn constraint_jacobian_matches_fd_with_the_last_nodes_saturation_rows() {
    check_jacobian_of(problem_wse(true, true, 0.0, SoftLane::OFF, true), 14);
}

#[test]
fn lagrangian_hessian_matches_fd() {
    // Seed 22 with the steering-slew term: its curvature scales with sigma (obj_factor);
    // seed 23 with the soft lane (curvature on the e of the nodes past its bounds).
    // Seed 21 again with the saturation rows at the last node (x_N, u_{N-1}).
    for (seed, w, soft, end) in [
        (21u64, 0.0, SoftLane::OFF, false),
        (22, 1.0, SoftLane::OFF, false),
        (23, 0.0, band(), false),
        (21, 0.0, SoftLane::OFF, true),
    ] {
        let mut p = problem_wse(true, false, w, soft, end);
        let z = random_z(&p, seed);
        let mut rng = Rng(seed * 7919);
        let lam: Vec<f64> = (0..p.m).map(|_| rng.range(-1.0, 1.0)).collect();
        let sigma = rng.range(0.5, 2.0);
        let mut hv = vec![0.0; p.hr.len()];
        p.nlp.eval_hess(&z, sigma, &lam, &mut hv);
        let mut h = vec![0.0; p.n * p.n];
        for (e, v) in hv.iter().enumerate() {
            let (r, c) = (p.hr[e], p.hc[e]);
            h[r * p.n + c] += v;
            if r != c {
                h[c * p.n + r] += v;
            }
        }
        let mut zz = z.clone();
        let mut worst = (0.0, 0, 0);
        for j in 0..p.n {
            let hstep = step(z[j]);
            zz[j] = z[j] + hstep;
            let gp = lagrangian_grad(&mut p, &zz, sigma, &lam);
            zz[j] = z[j] - hstep;
            let gm = lagrangian_grad(&mut p, &zz, sigma, &lam);
            zz[j] = z[j];
            for i in 0..p.n {
                let fd = (gp[i] - gm[i]) / (2.0 * hstep);
                let e = rel(h[i * p.n + j], fd);
                if e > worst.0 {
                    worst = (e, i, j);
                }
            }
        }
        println!(
            "hessian seed {seed}: worst rel err {:.2e} at ({}, {})",
            worst.0, worst.1, worst.2
        );
        assert!(worst.0 < 1e-6);
    }
}

/// With a helper thread (`threads = 2`) the constraints, Jacobian and Hessian are evaluated
/// by halves of the stages on two threads; the values have the same bits as the serial
/// evaluation, with and without the saturation rows (and the last node's), with a fixed and
/// a free start.
#[test]
fn stage_parallel_evaluation_has_the_serial_bits() {
    let worker = planner::worker::shared().unwrap();
    for (sat, fixed, w, end) in [
        (true, true, 0.0, false),
        (false, false, 0.0, false),
        (true, false, 1.0, false),
        (true, true, 0.0, true),
    ] {
        let mut serial = problem_wse(sat, fixed, w, SoftLane::OFF, end);
        let mut split = problem_wse(sat, fixed, w, SoftLane::OFF, end);
        split.nlp.set_worker(Some(worker.clone()));
        let z = random_z(&serial, 41);
        let mut rng = Rng(43);
        let lambda: Vec<f64> = (0..serial.m).map(|_| rng.range(-2.0, 2.0)).collect();
        let d = serial.nlp.dims();
        let run = |p: &mut Problem| {
            let mut g = vec![0.0; p.m];
            let mut jac = vec![0.0; d.nnz_jac];
            let mut hess = vec![0.0; d.nnz_hess];
            p.nlp.eval_g(&z, &mut g);
            p.nlp.eval_jac_g(&z, &mut jac);
            p.nlp.eval_hess(&z, 1.0, &lambda, &mut hess);
            [g, jac, hess].map(|v| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>())
        };
        let (a, b) = (run(&mut serial), run(&mut split));
        assert!(a.iter().all(|v| v.iter().any(|&x| x != 0)));
        assert!(a == b, "sat {sat}, fixed {fixed}: values differ");
    }
}
