//! The Riccati KKT backend against the general sparse LDL^T (FATROP's test habit): the same
//! inertia and the same Newton steps on the oval OCP's KKT systems, and the same solve.

mod common;
mod kkt_system;

use common::Rng;
use kkt_system::{oval_spec, riccati_for, root, system, System};
use planner::config::load_solver;
use planner::guess::GuessKind;
use planner::ip::kkt::backend::{split_riccati, VehicleRiccati, VehicleSplitRiccati};
use planner::ip::kkt::chain::Reduced;
use planner::ip::kkt::{KktBackendKind, KktSolver, KktValues, SparseLdlt};
use planner::ip::{Nlp, Status};
use planner::ocp::transcription::ImplicitEulerNlp;
use planner::ocp::{InitialState, OcpSpec};
use planner::plan::Planner;

/// K [x; y] in full (both triangles).
fn matvec(s: &System, x: &[f64], y: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let mut ox = vec![0.0; s.n];
    let mut oy = vec![0.0; s.m];
    for ((&r, &c), &v) in s.hr.iter().zip(&s.hc).zip(&s.hess) {
        ox[r] += v * x[c];
        if r != c {
            ox[c] += v * x[r];
        }
    }
    for ((&r, &c), &v) in s.jr.iter().zip(&s.jc).zip(&s.jac) {
        oy[r] += v * x[c];
        ox[c] += v * y[r];
    }
    for i in 0..s.n {
        ox[i] += s.dx[i] * x[i];
    }
    for i in 0..s.m {
        oy[i] += s.dc[i] * y[i];
    }
    (ox, oy)
}

fn inf_norm(a: &[f64]) -> f64 {
    a.iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// A measured initial state (20 m/s straight ahead) for the fixed-x0 cases.
fn fixed_x0() -> InitialState {
    let mut x0 = [0.0; 9];
    x0[1] = 20.0;
    x0[3] = 20.0;
    InitialState::Fixed(x0)
}

/// The Riccati backend with the arc-length state split off ([`planner::ip::kkt::chain`]).
fn split_for(structure: &planner::ip::kkt::StageStructure, s: &System) -> VehicleSplitRiccati {
    let red = Reduced::detect(structure, s.n, &s.hr, &s.hc, &s.jr, &s.jc)
        .expect("the arc length s is a chain state");
    assert_eq!(red.structure.nx, 8, "exactly one chain state (s)");
    split_riccati(structure, s.n, &s.hr, &s.hc, &s.jr, &s.jc).expect("split backend")
}

/// Both structured backends: on the whole system and with s split off.
fn structured(
    structure: &planner::ip::kkt::StageStructure,
    s: &System,
) -> [(&'static str, Box<dyn KktSolver>); 2] {
    [
        ("riccati", Box::new(riccati_for(structure, s))),
        ("split", Box::new(split_for(structure, s))),
    ]
}

fn check_same_steps(initial: InitialState, delta_c: f64, seed: u64) {
    let mut spec = oval_spec();
    spec.initial = initial;
    let mut nlp = ImplicitEulerNlp::<100>::new(spec).unwrap();
    let structure = nlp
        .stage_structure()
        .expect("implicit Euler has a stage structure");
    let mut rng = Rng(seed);
    for trial in 0..3 {
        let s = system(&mut nlp, &mut rng, delta_c, false);
        let values = s.values();
        let mut sparse = SparseLdlt::new(s.n, s.m, &s.hr, &s.hc, &s.jr, &s.jc).unwrap();
        // Its LDL^T without pivoting needs a few refinement steps to be a reference.
        sparse.set_refine_steps(5);
        let in_s = sparse.factorize(&values).unwrap();
        let bx: Vec<f64> = (0..s.n).map(|_| rng.range(-1.0, 1.0)).collect();
        let by: Vec<f64> = (0..s.m).map(|_| rng.range(-1.0, 1.0)).collect();
        let (mut xs, mut ys) = (bx.clone(), by.clone());
        sparse.solve(&mut xs, &mut ys);
        for (name, mut ric) in structured(&structure, &s) {
            let in_r = ric.factorize(&values).unwrap();
            assert_eq!(in_s, in_r, "{name}: inertia, trial {trial}");
            assert_eq!(in_r.positive + in_r.negative, s.n + s.m);
            let (mut xr, mut yr) = (bx.clone(), by.clone());
            ric.solve(&mut xr, &mut yr);

            // Both solve the system...
            let b_norm = inf_norm(&bx).max(inf_norm(&by));
            for (name, x, y) in [("sparse", &xs, &ys), (name, &xr, &yr)] {
                let (kx, ky) = matvec(&s, x, y);
                let res = kx
                    .iter()
                    .zip(&bx)
                    .chain(ky.iter().zip(&by))
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                let scale = inf_norm(x).max(inf_norm(y)).max(b_norm);
                eprintln!("{name}: residual {res:e} (scale {scale:e})");
                assert!(
                    res <= 1e-9 * scale,
                    "{name} does not solve the system: residual {res:e} against {scale:e} (trial {trial})"
                );
            }
            // ... and agree.
            let sol_norm = inf_norm(&xs).max(inf_norm(&ys));
            let diff = xs
                .iter()
                .zip(&xr)
                .chain(ys.iter().zip(&yr))
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            eprintln!("{name} trial {trial}: |dx| {sol_norm:e}, max diff {diff:e}");
            assert!(
                diff <= 1e-9 * sol_norm,
                "{name}: steps differ: {diff:e} against |step| {sol_norm:e} (trial {trial})"
            );
        }
    }
}

#[test]
fn same_steps_as_sparse_free_start() {
    check_same_steps(InitialState::Free, 1e-10, 7);
}

#[test]
fn same_steps_as_sparse_fixed_start() {
    check_same_steps(fixed_x0(), 1e-10, 11);
}

fn oval_planner(kkt: KktBackendKind) -> Planner<100> {
    let mut settings = load_solver(&root().join("solver.toml")).unwrap();
    settings.kkt = kkt;
    Planner::<100>::new(oval_spec(), settings).unwrap()
}

/// Both backends solve the oval to the same optimum. (Their iterates are not identical:
/// the sparse LDL^T without pivoting misjudges the inertia on some iterations, see
/// `inertia_matches_dense_eigenvalues`, and regularizes where the exact Riccati sweep
/// does not.)
#[test]
fn oval_same_optimum_with_both_backends() {
    let mut sp = oval_planner(KktBackendKind::Sparse);
    let mut rp = oval_planner(KktBackendKind::Riccati);
    let is = sp.solve(GuessKind::Equilibrium);
    let ir = rp.solve(GuessKind::Equilibrium);
    assert_eq!(is.status, Status::Optimal);
    assert_eq!(ir.status, Status::Optimal, "{ir:?}");
    assert_eq!(rp.solver().kkt().name(), "riccati");
    assert_eq!(rp.solver().kkt().fallbacks(), 0);
    // The arc length s is split off: the sweep runs on 8-state blocks.
    assert_eq!(rp.solver().kkt().chain_states(), 1);
    let t_s = sp.states()[100][8];
    let t_r = rp.states()[100][8];
    assert!((t_s - t_r).abs() < 1e-6 * t_s, "{t_s} vs {t_r}");
}

/// Oval data cut to N intervals of the same length.
fn small_spec(n: usize) -> OcpSpec {
    let mut spec = oval_spec();
    let ds = spec.ds();
    spec.n_intervals = n;
    spec.length = ds * n as f64;
    spec.kappa.truncate(n + 1);
    spec.e_min.truncate(n + 1);
    spec.e_max.truncate(n + 1);
    spec
}

/// The KKT matrix as a dense matrix (small N only).
fn dense_matrix(s: &System) -> nalgebra::DMatrix<f64> {
    let dim = s.n + s.m;
    let mut k = nalgebra::DMatrix::<f64>::zeros(dim, dim);
    for ((&r, &c), &v) in s.hr.iter().zip(&s.hc).zip(&s.hess) {
        k[(r, c)] += v;
        if r != c {
            k[(c, r)] += v;
        }
    }
    for ((&r, &c), &v) in s.jr.iter().zip(&s.jc).zip(&s.jac) {
        k[(s.n + r, c)] += v;
        k[(c, s.n + r)] += v;
    }
    for i in 0..s.n {
        k[(i, i)] += s.dx[i];
    }
    for i in 0..s.m {
        k[(s.n + i, s.n + i)] += s.dc[i];
    }
    k
}

/// Inertia of the dense KKT matrix from its eigenvalues.
fn dense_inertia(s: &System) -> (usize, usize, usize) {
    let dim = s.n + s.m;
    let k = dense_matrix(s);
    let eig = k.symmetric_eigenvalues();
    let tol = 1e-12 * eig.amax();
    let pos = eig.iter().filter(|&&e| e > tol).count();
    let neg = eig.iter().filter(|&&e| e < -tol).count();
    (pos, neg, dim - pos - neg)
}

/// The inertia the Riccati sweep reports is the true one (dense eigenvalues), also for
/// indefinite Hessians with barrier terms on only some variables.
#[test]
fn inertia_matches_dense_eigenvalues() {
    const N: usize = 6;
    for (seed, fixed) in [(3u64, false), (5, true), (9, false), (17, true)] {
        let mut spec = small_spec(N);
        if fixed {
            spec.initial = fixed_x0();
        }
        let mut nlp = ImplicitEulerNlp::<N>::new(spec).unwrap();
        let structure = nlp.stage_structure().unwrap();
        let mut rng = Rng(seed);
        for trial in 0..4 {
            let s = system(&mut nlp, &mut rng, 1e-8, true);
            let values = s.values();
            let mut sparse = SparseLdlt::new(s.n, s.m, &s.hr, &s.hc, &s.jr, &s.jc).unwrap();
            let (pos, neg, zero) = dense_inertia(&s);
            let sp = sparse.factorize(&values);
            for (name, mut ric) in structured(&structure, &s) {
                let r = ric.factorize(&values);
                eprintln!("seed {seed} trial {trial}: dense ({pos}, {neg}, {zero}) {name} {r:?} sparse {sp:?}");
                let r = r.unwrap();
                assert_eq!((r.positive, r.negative, r.zero), (pos, neg, zero), "{name}");
            }
        }
    }
}

/// Every Riccati solve during the oval solve is backward stable: residual below 1e-10 of
/// the right-hand side.
#[test]
fn riccati_residuals_during_oval_solve() {
    use planner::ip::kkt::{Inertia, KktError};
    use planner::ip::workspace::Workspace;
    use planner::ip::Solver;
    struct Checked {
        inner: VehicleRiccati,
        s: System,
        worst: f64,
    }
    impl KktSolver for Checked {
        fn factorize(&mut self, v: &KktValues<'_>) -> Result<Inertia, KktError> {
            self.s.hess.copy_from_slice(v.hess);
            self.s.jac.copy_from_slice(v.jac);
            self.s.dx.copy_from_slice(v.primal_diag);
            self.s.dc.copy_from_slice(v.dual_diag);
            self.inner.factorize(v)
        }
        fn solve(&mut self, x: &mut [f64], y: &mut [f64]) {
            let (bx, by) = (x.to_vec(), y.to_vec());
            self.inner.solve(x, y);
            let (kx, ky) = matvec(&self.s, x, y);
            let res = kx
                .iter()
                .zip(&bx)
                .chain(ky.iter().zip(&by))
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            let scale = inf_norm(&bx).max(inf_norm(&by));
            let rel = res / scale.max(1e-300);
            if rel > self.worst {
                self.worst = rel;
            }
        }
    }
    let settings = load_solver(&root().join("solver.toml")).unwrap();
    let mut planner = oval_planner(KktBackendKind::Riccati);
    planner.set_guess(GuessKind::Equilibrium);
    let nlp = planner.nlp();
    let mut rng = Rng(1);
    let s = system(nlp, &mut rng, 0.0, false);
    let st = nlp.stage_structure().unwrap();
    let inner = riccati_for(&st, &s);
    let ws = Workspace::new(&*nlp, settings.max_iter + 2);
    let mut solver = Solver::with_backend(
        settings,
        ws,
        Checked {
            inner,
            s,
            worst: 0.0,
        },
    )
    .expect("valid settings");
    let info = solver.solve(nlp);
    assert_eq!(info.status, Status::Optimal);
    let worst = solver.kkt().worst;
    assert!(worst < 1e-10, "worst relative residual {worst:e}");
}

/// Same input, same bits: a second solve from the same guess repeats the first exactly.
#[test]
fn riccati_solves_are_repeatable() {
    let mut p = oval_planner(KktBackendKind::Riccati);
    let a = p.solve(GuessKind::Equilibrium);
    let fa = p.solver().kkt().fallbacks();
    let xa = p.solver().x().to_vec();
    let b = p.solve(GuessKind::Equilibrium);
    let fb = p.solver().kkt().fallbacks();
    eprintln!(
        "{} its ({fa} fallbacks) then {} its ({fb})",
        a.iterations, b.iterations
    );
    assert_eq!(a.iterations, b.iterations);
    assert!(xa
        .iter()
        .zip(p.solver().x())
        .all(|(u, v)| u.to_bits() == v.to_bits()));
}

/// Dense LU solution of the KKT system (small N only).
fn dense_solve(s: &System, bx: &[f64], by: &[f64]) -> Vec<f64> {
    let dim = s.n + s.m;
    let k = dense_matrix(s);
    let b = nalgebra::DVector::from_iterator(dim, bx.iter().chain(by).copied());
    k.lu()
        .solve(&b)
        .expect("nonsingular")
        .iter()
        .copied()
        .collect()
}

/// Exact steps, with and without dual regularization and with large inequality terms on
/// the initial rows, against a dense LU solve.
#[test]
fn steps_match_dense_solve() {
    const N: usize = 5;
    // (seed, fixed x0, dual regularization, some primal diagonals 1e10: a badly scaled P^
    // as in the restoration phase, where delta_c = 1).
    for (seed, fixed, delta_c, badly_scaled) in [
        (21u64, false, 0.0, false),
        (22, true, 0.0, false),
        (23, false, 1e-6, false),
        (24, true, 1e-3, false),
        (25, false, 1.0, true),
        (26, true, 1.0, true),
        (27, false, 0.0, true),
    ] {
        let mut spec = small_spec(N);
        if fixed {
            spec.initial = fixed_x0();
        }
        let mut nlp = ImplicitEulerNlp::<N>::new(spec).unwrap();
        let structure = nlp.stage_structure().unwrap();
        let mut rng = Rng(seed);
        let mut s = system(&mut nlp, &mut rng, delta_c, true);
        if badly_scaled {
            for v in s.dx.iter_mut().step_by(7) {
                *v = 1e10;
            }
        }
        let values = s.values();
        let bx: Vec<f64> = (0..s.n).map(|_| rng.range(-1.0, 1.0)).collect();
        let by: Vec<f64> = (0..s.m).map(|_| rng.range(-1.0, 1.0)).collect();
        let exact = dense_solve(&s, &bx, &by);
        let norm = inf_norm(&exact);
        for (name, mut ric) in structured(&structure, &s) {
            ric.factorize(&values).unwrap();
            let (mut x, mut y) = (bx.clone(), by.clone());
            ric.solve(&mut x, &mut y);
            let diff = x
                .iter()
                .chain(&y)
                .zip(&exact)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            let residual = |x: &[f64], y: &[f64]| {
                let (kx, ky) = matvec(&s, x, y);
                kx.iter()
                    .zip(&bx)
                    .chain(ky.iter().zip(&by))
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
            };
            let (ex, ey) = exact.split_at(s.n);
            eprintln!(
                "seed {seed}: {name} diff {diff:e}, |step| {norm:e}, residual {:e} dense {:e}",
                residual(&x, &y),
                residual(ex, ey)
            );
            assert!(
                diff <= 1e-9 * norm,
                "seed {seed}: {name} diff {diff:e}, |step| {norm:e}"
            );
        }
    }
}

/// A NaN or infinity anywhere in the values (Hessian, Jacobian, either diagonal) is
/// `NonFinite`, whichever entry it is; the same system then factorizes again.
#[test]
fn non_finite_values_are_rejected() {
    use planner::ip::kkt::KktError;
    const N: usize = 5;
    let mut nlp = ImplicitEulerNlp::<N>::new(small_spec(N)).unwrap();
    let structure = nlp.stage_structure().unwrap();
    let mut rng = Rng(37);
    let s = system(&mut nlp, &mut rng, 1e-8, false);
    let mut ric = riccati_for(&structure, &s);
    assert!(ric.factorize(&s.values()).is_ok());
    let lens = [s.hess.len(), s.jac.len(), s.dx.len(), s.dc.len()];
    for (which, &len) in lens.iter().enumerate() {
        // First, last and a middle entry (the vector loop and its remainder).
        for at in [0, len / 2, len - 1] {
            for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                let mut t = s.clone();
                match which {
                    0 => t.hess[at] = bad,
                    1 => t.jac[at] = bad,
                    2 => t.dx[at] = bad,
                    _ => t.dc[at] = bad,
                }
                assert_eq!(
                    ric.factorize(&t.values()),
                    Err(KktError::NonFinite),
                    "array {which}, entry {at}: {bad}"
                );
            }
        }
    }
    assert!(ric.factorize(&s.values()).is_ok());
}

/// A singular dynamics Jacobian E_k is outside what the Riccati sweep takes: it reports
/// `Unsupported`, and the `auto` backend hands that factorization to the sparse LDL^T,
/// whose step still solves the system.
#[test]
fn singular_dynamics_jacobian_falls_back_to_sparse() {
    use planner::ip::kkt::backend::{KktBackend, Pattern};
    use planner::ip::kkt::{KktError, RowRole};
    const N: usize = 5;
    let mut nlp = ImplicitEulerNlp::<N>::new(small_spec(N)).unwrap();
    let structure = nlp.stage_structure().unwrap();
    let mut rng = Rng(31);
    let mut s = system(&mut nlp, &mut rng, 1e-8, false);
    // E_2 = d defect_2 / d x_3 := 0.
    let nz = 12;
    for (q, (&r, &c)) in s.jr.iter().zip(&s.jc).enumerate() {
        if let RowRole::Dynamics { stage: 2, .. } = structure.rows[r] {
            if c / nz == 3 {
                s.jac[q] = 0.0;
            }
        }
    }
    let values = s.values();
    let mut ric = riccati_for(&structure, &s);
    assert_eq!(ric.factorize(&values), Err(KktError::Unsupported));

    let pattern = Pattern {
        n: s.n,
        m: s.m,
        hess_rows: &s.hr,
        hess_cols: &s.hc,
        jac_rows: &s.jr,
        jac_cols: &s.jc,
    };
    let mut auto = KktBackend::new(KktBackendKind::Auto, pattern, Some(&structure)).unwrap();
    assert_eq!(auto.name(), "riccati");
    auto.factorize(&values)
        .expect("the sparse backend takes over");
    assert_eq!(auto.fallbacks(), 1);
    let bx: Vec<f64> = (0..s.n).map(|_| rng.range(-1.0, 1.0)).collect();
    let by: Vec<f64> = (0..s.m).map(|_| rng.range(-1.0, 1.0)).collect();
    let (mut x, mut y) = (bx.clone(), by.clone());
    auto.solve(&mut x, &mut y);
    let exact = dense_solve(&s, &bx, &by);
    let diff = x
        .iter()
        .chain(&y)
        .zip(&exact)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(diff <= 1e-6 * inf_norm(&exact), "diff {diff:e}");
}
