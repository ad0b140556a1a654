//! The fast structured derivative path (`planner::ocp::fast`) against the num-dual oracle
//! through the generic model: value, gradient and Hessian at many random points of the
//! operating envelope, including saturated tires (x > 1) and the active R7 floor, and the
//! whole NLP (Jacobian and Hessian values) in both modes.

#![allow(clippy::needless_range_loop)] // index-based matrix comparison

mod common;

use common::{random_control, random_state, random_trajectory, Rng};
use num_dual::{Dual2SVec64, DualNum, DualSVec64};
use planner::ip::Nlp;
use planner::model::params::lc500;
use planner::model::{ix, saturation, spatial_derivatives, tire_forces, VehicleParams, NU, NX};
use planner::ocp::fast::{self, NF, NT, TIRE_TO_FULL};
use planner::ocp::fixtures::oval_spec;
use planner::ocp::{Derivatives, ImplicitEulerNlp, InitialState};

/// Tolerance relative to the entry, with a floor relative to the largest entry of the block.
const TOL: f64 = 1e-10;

fn close(a: f64, b: f64, scale: f64) -> bool {
    (a - b).abs() <= TOL * (a.abs().max(b.abs()) + 1e-2 * scale) + 1e-300
}

/// Physical (x, u) as jets of the 10 defect inputs.
fn full_point<D: DualNum<Primitive = f64> + Copy>(
    x: &[f64; NX],
    u: &[f64; NU],
    seed: impl Fn(f64, usize) -> D,
) -> ([D; NX], [D; NU]) {
    let xd = std::array::from_fn(|i| if i < 7 { seed(x[i], i) } else { D::from(x[i]) });
    let ud = std::array::from_fn(|j| seed(u[j], 7 + j));
    (xd, ud)
}

/// Physical (x, u) with the 7 tire inputs as jets.
fn tire_point<D: DualNum<Primitive = f64> + Copy>(
    x: &[f64; NX],
    u: &[f64; NU],
    seed: impl Fn(f64, usize) -> D,
) -> ([D; NX], [D; NU]) {
    let (mut xd, mut ud) = (x.map(|v| D::from(v)), u.map(|v| D::from(v)));
    for (l, &f) in TIRE_TO_FULL.iter().enumerate() {
        if f < 7 {
            xd[f] = seed(x[f], l);
        } else {
            ud[f - 7] = seed(u[f - 7], l);
        }
    }
    (xd, ud)
}

#[derive(Default)]
struct Worst(f64);

impl Worst {
    fn check(&mut self, what: &str, a: f64, b: f64, scale: f64) {
        let e = (a - b).abs() / (a.abs().max(b.abs()) + 1e-2 * scale).max(1e-300);
        self.0 = self.0.max(e);
        assert!(close(a, b, scale), "{what}: fast {a:e} oracle {b:e}");
    }
}

fn hmax<const M: usize>(h: &[[f64; M]; M]) -> f64 {
    h.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()))
}

fn check_point(
    p: &VehicleParams,
    x: &[f64; NX],
    u: &[f64; NU],
    kappa: f64,
    rng: &mut Rng,
    w: &mut Worst,
) {
    // Defect rows: value and gradient.
    let jf = fast::defect_jacobian(p, x, u, kappa);
    let (xd, ud) = full_point(x, u, |v, i| DualSVec64::<NF>::from_re(v).derivative(i));
    let fo = spatial_derivatives(p, &xd, &ud, kappa);
    for i in 0..NX {
        w.check("f", jf[i].re, fo[i].re, fo[i].re.abs());
        if i == ix::S {
            continue;
        }
        let g = fo[i].eps.0.as_ref().unwrap();
        let sc = (0..NF).fold(0.0f64, |m, l| m.max(g[l].abs()));
        for l in 0..NF {
            w.check("df", jf[i].g[l], g[l], sc);
        }
    }
    // Weighted defect Hessian.
    let wt: [f64; NX] = std::array::from_fn(|_| rng.range(-2.0, 2.0));
    let hf = fast::defect_hessian(p, x, u, kappa, &wt);
    let (xd, ud) = full_point(x, u, |v, i| Dual2SVec64::<NF>::from_re(v).derivative(i));
    let f2 = spatial_derivatives(p, &xd, &ud, kappa);
    let mut phi = Dual2SVec64::<NF>::from_re(0.0);
    for i in (0..NX).filter(|&i| i != ix::S) {
        phi += f2[i] * wt[i];
    }
    let h = phi.v2.0.unwrap();
    let ho: [[f64; NF]; NF] = std::array::from_fn(|i| std::array::from_fn(|j| h[(i, j)]));
    let sc = hmax(&ho);
    w.check("phi", hf.re, phi.re, phi.re.abs());
    let g = phi.v1.0.unwrap();
    for l in 0..NF {
        w.check("dphi", hf.g[l], g[l], sc);
    }
    for i in 0..NF {
        for j in 0..=i {
            w.check("d2phi", hf.h[i][j], ho[i][j], sc);
        }
    }
    // Saturation rows.
    let sf = fast::saturation_jacobian(p, x, u);
    let (xd, ud) = tire_point(x, u, |v, i| DualSVec64::<NT>::from_re(v).derivative(i));
    let so = saturation(p, &xd, &ud);
    for r in 0..2 {
        w.check("sat", sf[r].re, so[r].re, 1.0);
        let g = so[r].eps.0.as_ref().unwrap();
        let sc = (0..NT).fold(0.0f64, |m, l| m.max(g[l].abs()));
        for l in 0..NT {
            w.check("dsat", sf[r].g[l], g[l], sc);
        }
    }
    let lam = [rng.range(-2.0, 2.0), rng.range(-2.0, 2.0)];
    let hs = fast::saturation_hessian(p, x, u, lam);
    let (xd, ud) = tire_point(x, u, |v, i| Dual2SVec64::<NT>::from_re(v).derivative(i));
    let s2 = saturation(p, &xd, &ud);
    let phi = s2[0] * lam[0] + s2[1] * lam[1];
    let h = phi.v2.0.unwrap();
    let ho: [[f64; NT]; NT] = std::array::from_fn(|i| std::array::from_fn(|j| h[(i, j)]));
    let sc = hmax(&ho);
    w.check("satphi", hs.re, phi.re, 1.0);
    for i in 0..NT {
        for j in 0..=i {
            w.check("d2sat", hs.h[i][j], ho[i][j], sc);
        }
    }
}

/// Which regimes a point exercises: [front saturated, rear saturated, R7 floor active].
fn regime(p: &VehicleParams, x: &[f64; NX], u: &[f64; NU]) -> [bool; 3] {
    let t = tire_forces(p, x, u);
    let fxf = t.fxf;
    let d = (p.mu * t.fzf).powi(2) - fxf * fxf;
    let q_min = (p.fmax_floor_frac * p.mu * p.fz_nom_front()).powi(2);
    [
        t.sigma_f > t.sigma_sl_f,
        t.sigma_r > t.sigma_sl_r,
        d < 3.0 * q_min,
    ]
}

#[test]
fn fast_path_matches_oracle_in_the_envelope() {
    let p = lc500();
    let mut rng = Rng(0x5eed_1234_abcd);
    let mut w = Worst::default();
    let mut seen = [0usize; 3];
    for n in 0..3000 {
        let mut x = random_state(&mut rng);
        let mut u = random_control(&mut rng);
        match n % 3 {
            // Strongly saturated: large slips at low speed.
            1 => {
                x[ix::V] = rng.range(8.0, 15.0);
                x[ix::BETA] = 0.3 * if rng.next() < 0.5 { -1.0 } else { 1.0 };
                x[ix::R] = -x[ix::BETA].signum() * rng.range(0.5, 1.0);
            }
            // R7 floor active: (mu F_zf)^2 - F_xf^2 within a few q_min of zero.
            2 => {
                x[ix::DFZ] = rng.range(1500.0, 3000.0);
                let fzf = p.fz_nom_front() - x[ix::DFZ];
                let q_min = (p.fmax_floor_frac * p.mu * p.fz_nom_front()).powi(2);
                let d = rng.range(-3.0, 3.0) * q_min;
                u[2] = -p.r_w * ((p.mu * fzf).powi(2) - d).sqrt();
            }
            _ => {}
        }
        let kappa = [0.0, 0.04, -0.02, rng.range(-0.05, 0.05)][n % 4];
        let r = regime(&p, &x, &u);
        for (s, b) in seen.iter_mut().zip(r) {
            *s += b as usize;
        }
        check_point(&p, &x, &u, kappa, &mut rng, &mut w);
    }
    println!(
        "worst relative error {:.2e}; saturated front/rear, floor active: {seen:?}",
        w.0
    );
    assert!(seen.iter().all(|&s| s > 200), "{seen:?}");
}

/// The whole NLP: Jacobian and Hessian values of the fast path equal the oracle's.
#[test]
fn nlp_fast_matches_oracle() {
    for (sat, fixed, seed) in [(true, false, 3u64), (true, true, 4), (false, false, 5)] {
        let mut spec = oval_spec();
        spec.enforce_tire_saturation = sat;
        if fixed {
            spec.initial = InitialState::Fixed([0.1, 20.0, 0.01, 20.5, 300.0, 0.5, 0.02, 0.0, 0.0]);
        }
        let mut nlp = ImplicitEulerNlp::<100>::new(spec).unwrap();
        let d = nlp.dims();
        let mut rng = Rng(seed);
        let (xs, us) = random_trajectory(&mut rng, 100, 2.6);
        let mut z = vec![0.0; d.n];
        nlp.pack(&xs, &us, &mut z);
        let lam: Vec<f64> = (0..d.m).map(|_| rng.range(-1.0, 1.0)).collect();
        let mut out = [
            (vec![0.0; d.nnz_jac], vec![0.0; d.nnz_hess]),
            (vec![0.0; d.nnz_jac], vec![0.0; d.nnz_hess]),
        ];
        for (mode, (jac, hess)) in [Derivatives::Fast, Derivatives::Oracle]
            .into_iter()
            .zip(out.iter_mut())
        {
            nlp.set_derivatives(mode);
            nlp.eval_jac_g(&z, jac);
            nlp.eval_hess(&z, 1.0, &lam, hess);
        }
        let [(jf, hf), (jo, ho)] = &out;
        let mut w = Worst::default();
        let sj = jo.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (a, b) in jf.iter().zip(jo) {
            w.check("jac", *a, *b, sj);
        }
        let sh = ho.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (a, b) in hf.iter().zip(ho) {
            w.check("hess", *a, *b, sh);
        }
        println!("sat={sat} fixed={fixed}: worst relative error {:.2e}", w.0);
    }
}

/// The AVX2-compiled copy of the derivative evaluation gives the same bits as the baseline
/// copy (so recordings replay bit-exactly on CPUs with and without AVX2).
#[test]
fn simd_and_baseline_evaluation_agree_bit_for_bit() {
    if !planner::cpu::avx2_available() {
        println!("no AVX2 on this CPU: only the baseline copy exists");
        return;
    }
    let mut nlp = ImplicitEulerNlp::<100>::new(oval_spec()).unwrap();
    let d = nlp.dims();
    let mut rng = Rng(11);
    let (xs, us) = random_trajectory(&mut rng, 100, 2.6);
    let mut z = vec![0.0; d.n];
    nlp.pack(&xs, &us, &mut z);
    let lam: Vec<f64> = (0..d.m).map(|_| rng.range(-1.0, 1.0)).collect();
    let mut out = Vec::new();
    for simd in [true, false] {
        nlp.set_simd(simd);
        let (mut jac, mut hess) = (vec![0.0; d.nnz_jac], vec![0.0; d.nnz_hess]);
        nlp.eval_jac_g(&z, &mut jac);
        nlp.eval_hess(&z, 1.0, &lam, &mut hess);
        out.push((jac, hess));
    }
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&out[0].0), bits(&out[1].0), "Jacobian");
    assert_eq!(bits(&out[0].1), bits(&out[1].1), "Hessian");
    assert!(out[0].1.iter().any(|&v| v != 0.0));
}
