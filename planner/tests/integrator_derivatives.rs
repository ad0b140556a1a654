//! Exact Jacobian and Lagrangian Hessian of the whole NLP for the Crank-Nicolson, RK2,
//! RK4, Gauss-Legendre 2 / 3, BDF4-6 and Adams-Moulton transcriptions against central finite differences (a short
//! N = 10 piece of the oval keeps the dense FD loops fast).

mod common;

use common::{random_trajectory, Rng};
use planner::ip::Nlp;
use planner::model::ix;
use planner::ocp::fixtures::oval_spec;
use planner::ocp::scaling::X_NOMINAL;
use planner::ocp::{
    CrankNicolson, DefectScheme, Derivatives, ExplicitRk2, ExplicitRk4, GaussLegendre2,
    GaussLegendre3, LinearMultistep, OcpSpec, Transcription,
};
use std::collections::HashSet;

const N: usize = 10;

fn short_spec() -> OcpSpec {
    let mut spec = oval_spec();
    let ds = spec.ds();
    spec.n_intervals = N;
    spec.length = N as f64 * ds;
    spec.kappa.truncate(N + 1);
    spec.e_min.truncate(N + 1);
    spec.e_max.truncate(N + 1);
    spec
}

/// Error of an exact derivative `a` against a central difference `fd` of step `h` of a
/// function of size `size`, in units of the tolerance: 1e-6 relative plus the difference's
/// own rounding noise (1e3 eps |size| / h). Explicit RK steps at random points reach huge
/// defect values, whose rounding alone spoils a plain relative comparison.
fn scaled_err(a: f64, fd: f64, size: f64, h: f64) -> f64 {
    (a - fd).abs() / (1e-6 * a.abs().max(fd.abs()).max(1.0) + 1e3 * f64::EPSILON * size.abs() / h)
}

fn step(z: f64) -> f64 {
    1e-6 * z.abs().max(1.0)
}

struct Problem<S: DefectScheme> {
    nlp: Transcription<S, N>,
    n: usize,
    m: usize,
    jr: Vec<usize>,
    jc: Vec<usize>,
    hr: Vec<usize>,
    hc: Vec<usize>,
    z: Vec<f64>,
}

/// The transcription at a random point of the envelope (stage variables from the scheme's
/// guess, then perturbed so they are not exactly on the chord).
fn problem<S: DefectScheme>(scheme: S, seed: u64) -> Problem<S> {
    let mut nlp = Transcription::<S, N>::with_scheme(short_spec(), scheme).unwrap();
    let d = nlp.dims();
    let (mut jr, mut jc) = (vec![0; d.nnz_jac], vec![0; d.nnz_jac]);
    nlp.jac_structure(&mut jr, &mut jc);
    let (mut hr, mut hc) = (vec![0; d.nnz_hess], vec![0; d.nnz_hess]);
    nlp.hess_structure(&mut hr, &mut hc);
    let mut rng = Rng(seed);
    let (xs, us) = random_trajectory(&mut rng, N, nlp.spec().ds());
    nlp.set_initial_guess(&xs, &us);
    let mut z = vec![0.0; d.n];
    nlp.initial_point(&mut z);
    let lay = nlp.layout();
    for k in 0..N {
        for l in 0..S::STAGE_VARS {
            z[lay.w(k, l)] *= rng.range(0.95, 1.05);
        }
    }
    Problem {
        nlp,
        n: d.n,
        m: d.m,
        jr,
        jc,
        hr,
        hc,
        z,
    }
}

fn structure_is_valid<S: DefectScheme>(p: &Problem<S>) {
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
    assert_eq!(p.n, 9 * (N + 1) + (3 + S::STAGE_VARS) * N);
    assert_eq!(p.m, 9 + S::ROWS * N + 2 * N + 2 * N + 6 * (N - 1));
}

fn check_jacobian<S: DefectScheme>(p: &mut Problem<S>) {
    let z = p.z.clone();
    let mut vals = vec![0.0; p.jr.len()];
    p.nlp.eval_jac_g(&z, &mut vals);
    let mut jac = vec![0.0; p.m * p.n];
    for (e, v) in vals.iter().enumerate() {
        jac[p.jr[e] * p.n + p.jc[e]] += v;
    }
    let structure: HashSet<(usize, usize)> =
        p.jr.iter().copied().zip(p.jc.iter().copied()).collect();
    let (mut gp, mut gm, mut g0) = (vec![0.0; p.m], vec![0.0; p.m], vec![0.0; p.m]);
    p.nlp.eval_g(&z, &mut g0);
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
            if !structure.contains(&(i, j)) {
                assert!(fd.abs() < 1e-8, "FD ({i},{j}) = {fd} outside the structure");
            }
            let e = scaled_err(jac[i * p.n + j], fd, g0[i], h);
            if e > worst.0 {
                worst = (e, i, j);
            }
        }
    }
    let name = p.nlp.scheme().name();
    println!(
        "{name}: jacobian worst err {:.2e} x tol at {} col {} (exact {:.6e})",
        worst.0,
        p.nlp.row_name(worst.1),
        worst.2,
        jac[worst.1 * p.n + worst.2]
    );
    assert!(worst.0 < 1.0, "{name}");
}

fn lagrangian_grad<S: DefectScheme>(
    p: &mut Problem<S>,
    z: &[f64],
    sigma: f64,
    lam: &[f64],
) -> Vec<f64> {
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

fn check_hessian<S: DefectScheme>(p: &mut Problem<S>, seed: u64) {
    let z = p.z.clone();
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
    let g0 = lagrangian_grad(p, &z, sigma, &lam);
    let mut zz = z.clone();
    let mut worst = (0.0, 0, 0);
    let mut largest: f64 = 0.0;
    for j in 0..p.n {
        let hs = step(z[j]);
        zz[j] = z[j] + hs;
        let gp = lagrangian_grad(p, &zz, sigma, &lam);
        zz[j] = z[j] - hs;
        let gm = lagrangian_grad(p, &zz, sigma, &lam);
        zz[j] = z[j];
        for i in 0..p.n {
            let fd = (gp[i] - gm[i]) / (2.0 * hs);
            largest = largest.max(fd.abs());
            let e = scaled_err(h[i * p.n + j], fd, g0[i], hs);
            if e > worst.0 {
                worst = (e, i, j);
            }
        }
    }
    let name = p.nlp.scheme().name();
    println!(
        "{name}: hessian worst err x tol {:.2e} at ({}, {}), largest |entry| {largest:.2e}",
        worst.0, worst.1, worst.2
    );
    assert!(largest > 1e-3, "{name}: Hessian is trivially zero");
    assert!(worst.0 < 1.0, "{name}");
}

fn check_all<S: DefectScheme + Copy>(scheme: S) {
    for seed in [11u64, 12] {
        let mut p = problem(scheme, seed);
        structure_is_valid(&p);
        check_jacobian(&mut p);
        check_hessian(&mut p, seed);
    }
}

#[test]
fn crank_nicolson_derivatives_match_fd() {
    check_all(CrankNicolson);
}

#[test]
fn rk2_derivatives_match_fd() {
    check_all(ExplicitRk2);
}

#[test]
fn rk4_derivatives_match_fd() {
    check_all(ExplicitRk4);
}

#[test]
fn gauss_legendre2_derivatives_match_fd() {
    check_all(GaussLegendre2);
}

#[test]
fn gauss_legendre3_derivatives_match_fd() {
    check_all(GaussLegendre3);
}

/// N = 10 covers the start-up intervals (lower-order formulas) and the full formulas.
#[test]
fn multistep_derivatives_match_fd() {
    for scheme in [
        LinearMultistep::BDF4,
        LinearMultistep::BDF5,
        LinearMultistep::BDF6,
        LinearMultistep::ADAMS_MOULTON3,
    ] {
        check_all(scheme);
    }
}

/// The hand-written per-point jets (the default) give the num-dual oracle's Jacobian and
/// Hessian to rounding for every scheme that has them.
fn fast_matches_oracle<S: DefectScheme + Copy>(scheme: S) {
    for seed in [21u64, 22] {
        let mut p = problem(scheme, seed);
        let mut rng = Rng(seed * 31);
        let lam: Vec<f64> = (0..p.m).map(|_| rng.range(-1.0, 1.0)).collect();
        let z = p.z.clone();
        let mut out = Vec::new();
        for mode in [Derivatives::Fast, Derivatives::Oracle] {
            p.nlp.set_derivatives(mode);
            let (mut jac, mut hess) = (vec![0.0; p.jr.len()], vec![0.0; p.hr.len()]);
            p.nlp.eval_jac_g(&z, &mut jac);
            p.nlp.eval_hess(&z, 1.3, &lam, &mut hess);
            out.push((jac, hess));
        }
        let name = p.nlp.scheme().name();
        for (what, a, b) in [
            ("jac", &out[0].0, &out[1].0),
            ("hess", &out[0].1, &out[1].1),
        ] {
            let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let worst = a
                .iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs() / (y.abs() + 1e-6 * scale))
                .fold(0.0f64, f64::max);
            println!("{name} {what}: worst relative difference {worst:.2e}");
            assert!(worst < 1e-8, "{name} {what}: {worst:e}");
            assert!(a.iter().any(|&v| v != 0.0), "{name} {what} all zero");
        }
    }
}

#[test]
fn hand_written_derivatives_equal_the_oracle_for_every_scheme() {
    fast_matches_oracle(CrankNicolson);
    fast_matches_oracle(ExplicitRk2);
    fast_matches_oracle(ExplicitRk4);
    fast_matches_oracle(GaussLegendre2);
    fast_matches_oracle(GaussLegendre3);
    for scheme in [
        LinearMultistep::BDF4,
        LinearMultistep::BDF6,
        LinearMultistep::ADAMS_MOULTON3,
    ] {
        fast_matches_oracle(scheme);
    }
}

/// The NLP's RK4 defect vanishes on a trajectory built by an independent classical RK4
/// step of the model (here, in physical units, k_ref interpolated linearly within the
/// interval as the transcription documents), and only there: a scheme with wrong weights
/// or stage points leaves an O(ds^2) defect.
#[test]
fn rk4_defect_vanishes_on_its_own_steps() {
    use planner::model::{spatial_derivatives, NU, NX};
    use planner::ocp::scaling::U_NOMINAL;
    let mut p = problem(ExplicitRk4, 5);
    let lay = p.nlp.layout();
    let spec = short_spec();
    let (h, kappa) = (spec.ds(), spec.kappa.clone());
    let mut z = p.z.clone();
    for k in 0..N {
        let x0: [f64; NX] = std::array::from_fn(|i| z[lay.x(k, i)] * X_NOMINAL[i]);
        let u: [f64; NU] = std::array::from_fn(|j| z[lay.u(k, j)] * U_NOMINAL[j]);
        let kap = |c: f64| kappa[k] + c * (kappa[k + 1] - kappa[k]);
        let f = |x: &[f64; NX], c: f64| spatial_derivatives(&spec.vehicle, x, &u, kap(c));
        let at = |a: f64, d: &[f64; NX]| -> [f64; NX] { std::array::from_fn(|i| x0[i] + a * d[i]) };
        let k1 = f(&x0, 0.0);
        let k2 = f(&at(0.5 * h, &k1), 0.5);
        let k3 = f(&at(0.5 * h, &k2), 0.5);
        let k4 = f(&at(h, &k3), 1.0);
        for i in 0..NX {
            let x1 = x0[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            z[lay.x(k + 1, i)] = x1 / X_NOMINAL[i];
        }
    }
    assert!(p.nlp.max_defect(&z) < 1e-9, "{}", p.nlp.max_defect(&z));
    // t advanced by about ds / V per step.
    let t_n = z[lay.x(N, ix::T)] * X_NOMINAL[ix::T];
    assert!(t_n > 0.0 && t_n.is_finite());
    z[lay.x(N, ix::V)] += 1e-3;
    assert!(p.nlp.max_defect(&z) > 1e-4);
}
