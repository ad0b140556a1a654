//! The Riccati KKT backend's factorization state: the SIMD and baseline copies agree bit
//! for bit, refactorizations reuse only what did not change, a failed or stopped sweep
//! leaves nothing stale, and the pipelined factorization equals one thread.

mod common;
mod kkt_system;

use common::Rng;
use kkt_system::{oval_spec, riccati_for, system, System};
use planner::ip::kkt::backend::VehicleRiccati;
use planner::ip::kkt::{Inertia, KktError, KktSolver};
use planner::ip::Nlp;
use planner::ocp::transcription::ImplicitEulerNlp;
use planner::ocp::Layout;

/// The AVX2-compiled copy of the factorization and solve gives the same inertia and the
/// same bits as the baseline copy (no FMA contraction, only wider independent lanes), with
/// and without dual regularization, so recordings replay bit-exactly across CPUs. On a
/// CPU without AVX2 both runs take the baseline copy.
#[test]
fn simd_and_baseline_copies_agree_bit_for_bit() {
    let spec = oval_spec();
    let mut nlp = ImplicitEulerNlp::<100>::new(spec).unwrap();
    let structure = nlp.stage_structure().expect("stage structure");
    let mut rng = Rng(23);
    for (trial, delta_c) in [0.0, 1e-10, 1.0].into_iter().enumerate() {
        let s = system(&mut nlp, &mut rng, delta_c, false);
        let values = s.values();
        let bx: Vec<f64> = (0..s.n).map(|_| 2.0 * rng.next() - 1.0).collect();
        let by: Vec<f64> = (0..s.m).map(|_| 2.0 * rng.next() - 1.0).collect();
        let mut out = Vec::new();
        for simd in [true, false] {
            let mut ric = riccati_for(&structure, &s);
            ric.set_simd(simd);
            #[cfg(target_arch = "x86_64")]
            assert!(!simd || ric.simd() == std::arch::is_x86_feature_detected!("avx2"));
            let inertia = ric.factorize(&values).expect("factorizes");
            let (mut x, mut y) = (bx.clone(), by.clone());
            ric.solve(&mut x, &mut y);
            out.push((inertia, x, y));
        }
        let ((ia, xa, ya), (ib, xb, yb)) = (&out[0], &out[1]);
        assert_eq!(ia, ib, "trial {trial}");
        for (u, v) in xa.iter().chain(ya).zip(xb.iter().chain(yb)) {
            assert_eq!(u.to_bits(), v.to_bits(), "trial {trial}: {u} vs {v}");
        }
    }
}

/// KKT systems at two random points of the oval NLP, and the generator for what follows.
fn two_points(nlp: &mut ImplicitEulerNlp<100>, seed: u64) -> (System, System, Rng) {
    let mut rng = Rng(seed);
    let a = system(nlp, &mut rng, 0.0, false);
    let b = system(nlp, &mut rng, 0.0, false);
    (a, b, rng)
}

/// A random right-hand side (x part, y part) for a system's dimensions.
fn random_rhs(s: &System, rng: &mut Rng) -> (Vec<f64>, Vec<f64>) {
    let bx = (0..s.n).map(|_| rng.range(-1.0, 1.0)).collect();
    let by = (0..s.m).map(|_| rng.range(-1.0, 1.0)).collect();
    (bx, by)
}

/// Factorizes `s` on `kkt`, solves for `rhs` and returns the step's bits.
fn step_bits(kkt: &mut VehicleRiccati, s: &System, rhs: &(Vec<f64>, Vec<f64>)) -> Vec<u64> {
    kkt.factorize(&s.values()).unwrap();
    let (mut x, mut y) = rhs.clone();
    kkt.solve(&mut x, &mut y);
    x.into_iter().chain(y).map(f64::to_bits).collect()
}

/// The inertia-correcting refactorizations of an iteration change only the diagonals, and
/// the backend then reuses its stage inverses F = E^-1: the steps must have the same bits
/// as a fresh backend's. A changed Jacobian (the next iteration) must not reuse them.
#[test]
fn refactorization_reuses_only_what_did_not_change() {
    let mut nlp = ImplicitEulerNlp::<100>::new(oval_spec()).unwrap();
    let structure = nlp.stage_structure().unwrap();
    let (a, b, mut rng) = two_points(&mut nlp, 11);
    let rhs = random_rhs(&a, &mut rng);
    let step = |kkt: &mut VehicleRiccati, s: &System| step_bits(kkt, s, &rhs);
    let mut reused = riccati_for(&structure, &a);
    step(&mut reused, &a);
    // Same Hessian and Jacobian, shifted diagonals (what an inertia correction does).
    let mut shifted = a.clone();
    shifted.dx.iter_mut().for_each(|d| *d += 1e-3);
    let fresh = step(&mut riccati_for(&structure, &shifted), &shifted);
    assert_eq!(step(&mut reused, &shifted), fresh);
    // A new Jacobian (another point) on the same backend.
    let fresh_b = step(&mut riccati_for(&structure, &b), &b);
    assert_eq!(step(&mut reused, &b), fresh_b);
    // And back: the first point again after the second.
    shifted.dx[0] += 1.0;
    let fresh_s = step(&mut riccati_for(&structure, &shifted), &shifted);
    assert_eq!(step(&mut reused, &shifted), fresh_s);
}

/// A stage that fails after its inversion (here an exactly zero Q_uu: stage 50's controls
/// have no curvature, no barrier term and no constraint entries) must not leave its new E
/// paired with the previous point's F for the next factorization.
#[test]
fn a_failed_stage_leaves_no_stale_inverse() {
    let mut nlp = ImplicitEulerNlp::<100>::new(oval_spec()).unwrap();
    let structure = nlp.stage_structure().unwrap();
    let (a, b, mut rng) = two_points(&mut nlp, 5);
    let layout = Layout::new(100, 0);
    let controls: Vec<usize> = (0..3).map(|j| layout.u(50, j)).collect();
    let mut broken = a.clone();
    for (v, c) in broken.jac.iter_mut().zip(&a.jc) {
        if controls.contains(c) {
            *v = 0.0;
        }
    }
    for ((v, r), c) in broken.hess.iter_mut().zip(&a.hr).zip(&a.hc) {
        if controls.contains(r) || controls.contains(c) {
            *v = 0.0;
        }
    }
    for &c in &controls {
        broken.dx[c] = 0.0;
    }
    let rhs = random_rhs(&a, &mut rng);
    let step = |kkt: &mut VehicleRiccati, s: &System| step_bits(kkt, s, &rhs);
    let mut kkt = riccati_for(&structure, &a);
    step(&mut kkt, &b);
    assert!(kkt.factorize(&broken.values()).is_err());
    let fresh = step(&mut riccati_for(&structure, &a), &a);
    assert_eq!(step(&mut kkt, &a), fresh);
}

/// Two KKT systems of the oval at random points, the first with a primal block convex
/// enough for the correct inertia (n, m); a copy of it whose stage `bad_stage` controls have
/// a large negative diagonal (an excess negative pivot there); that inertia; the rng.
fn inertia_fixture(
    seed: u64,
    bad_stage: usize,
) -> (
    planner::ip::kkt::StageStructure,
    System,
    System,
    System,
    Inertia,
    Rng,
) {
    let mut nlp = ImplicitEulerNlp::<100>::new(oval_spec()).unwrap();
    let structure = nlp.stage_structure().unwrap();
    let (mut a, b, rng) = two_points(&mut nlp, seed);
    a.dx.iter_mut().for_each(|d| *d += 1e3);
    let correct = Inertia {
        positive: a.n,
        negative: a.m,
        zero: 0,
    };
    let layout = Layout::new(100, 0);
    let mut bad = a.clone();
    for j in 0..3 {
        bad.dx[layout.u(bad_stage, j)] = -1e9;
    }
    (structure, a, b, bad, correct, rng)
}

/// Inertia correction only needs to know that the inertia is wrong: asked for (n, m),
/// the sweep stops at the first stage with an excess negative pivot (here stage 50's
/// controls, given a negative diagonal) and holds no factorization. The next
/// factorization is the same as a fresh backend's, and a caller that expects any other
/// inertia, or none, still gets the full count.
#[test]
fn wrong_inertia_stops_the_sweep_early() {
    let (structure, a, _, bad, correct, mut rng) = inertia_fixture(7, 50);
    let rhs = random_rhs(&a, &mut rng);
    let mut kkt = riccati_for(&structure, &a);
    assert_eq!(kkt.factorize(&a.values()).unwrap(), correct);
    let full = kkt.factorize(&bad.values()).unwrap();
    assert_ne!(full, correct);
    assert_eq!(
        kkt.factorize_expecting(&bad.values(), correct),
        Err(KktError::WrongInertia)
    );
    let other = Inertia {
        positive: a.n - 1,
        ..correct
    };
    assert_eq!(kkt.factorize_expecting(&bad.values(), other).unwrap(), full);
    assert_eq!(kkt.factorize(&bad.values()).unwrap(), full);
    assert_eq!(
        kkt.factorize_expecting(&bad.values(), correct),
        Err(KktError::WrongInertia)
    );
    assert_eq!(
        kkt.factorize_expecting(&a.values(), correct).unwrap(),
        correct
    );
    let (mut x, mut y) = rhs.clone();
    kkt.solve(&mut x, &mut y);
    let bits: Vec<u64> = x.into_iter().chain(y).map(f64::to_bits).collect();
    assert_eq!(bits, step_bits(&mut riccati_for(&structure, &a), &a, &rhs));
}

/// The pipelined factorization (a helper thread writes the stage blocks while the sweep
/// runs) gives the same results and bits as one thread over a sequence that exercises
/// every way a sweep ends: complete, stopped early at a wrong inertia (the helper is
/// cancelled mid-way), failed at a singular E_k (the error comes from the helper's unit),
/// and complete again after each.
#[test]
fn pipelined_factorization_equals_one_thread() {
    use planner::ip::kkt::RowRole;
    let (structure, a, b, bad, correct, mut rng) = inertia_fixture(11, 20);
    let mut singular = b.clone();
    for (q, (&r, &c)) in singular.jr.iter().zip(&singular.jc).enumerate() {
        if let RowRole::Dynamics { stage: 30, .. } = structure.rows[r] {
            if c / 12 == 31 {
                singular.jac[q] = 0.0;
            }
        }
    }
    let rhs = random_rhs(&a, &mut rng);
    let run = |kkt: &mut VehicleRiccati| {
        let mut out = Vec::new();
        let step = |kkt: &mut VehicleRiccati| {
            let (mut x, mut y) = rhs.clone();
            kkt.solve(&mut x, &mut y);
            x.into_iter()
                .chain(y)
                .map(f64::to_bits)
                .collect::<Vec<u64>>()
        };
        for s in [&a, &b, &a] {
            out.push(format!(
                "{:?}",
                kkt.factorize_expecting(&s.values(), correct)
            ));
            out.push(format!("{:?}", step(kkt)));
            out.push(format!(
                "{:?}",
                kkt.factorize_expecting(&bad.values(), correct)
            ));
            out.push(format!("{:?}", kkt.factorize(&bad.values())));
            out.push(format!("{:?}", step(kkt)));
            out.push(format!("{:?}", kkt.factorize(&singular.values())));
        }
        out
    };
    let mut one = riccati_for(&structure, &a);
    let mut two = riccati_for(&structure, &a);
    two.set_pipelined(true).unwrap();
    assert!(two.pipelined() && !one.pipelined());
    // A helper that claims nothing: the sweep writes every chunk itself (a late helper).
    let mut late = riccati_for(&structure, &a);
    late.set_pipelined(true).unwrap();
    late.set_helper_idle(true);
    let (r1, r2, r3) = (run(&mut one), run(&mut two), run(&mut late));
    assert!(r1.iter().any(|r| r.contains("WrongInertia")));
    assert!(r1.iter().any(|r| r.contains("Unsupported")));
    assert_eq!(r1, r2);
    assert_eq!(r1, r3);
}
