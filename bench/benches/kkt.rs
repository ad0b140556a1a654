//! One KKT factorization and one solve of the oval NLP (N = 100, implicit Euler) at the
//! reference optimum, for the general sparse LDL^T and the Riccati backend side by side.

use bench::oval_nlp_at_reference;
use criterion::{criterion_group, criterion_main, Criterion};
use planner::ip::kkt::backend::VehicleRiccati;
use planner::ip::kkt::{KktSolver, KktValues, SparseLdlt};
use planner::ip::Nlp;
use std::hint::black_box;

fn kkt(c: &mut Criterion) {
    let (mut nlp, z) = oval_nlp_at_reference();
    let d = nlp.dims();
    let (n, m) = (d.n, d.m);
    let (mut hr, mut hc) = (vec![0; d.nnz_hess], vec![0; d.nnz_hess]);
    let (mut jr, mut jc) = (vec![0; d.nnz_jac], vec![0; d.nnz_jac]);
    nlp.hess_structure(&mut hr, &mut hc);
    nlp.jac_structure(&mut jr, &mut jc);
    let lambda: Vec<f64> = (0..m).map(|i| ((i % 7) as f64 - 3.0) * 0.1).collect();
    let mut hess = vec![0.0; d.nnz_hess];
    let mut jac = vec![0.0; d.nnz_jac];
    nlp.eval_hess(&z, 1.0, &lambda, &mut hess);
    nlp.eval_jac_g(&z, &mut jac);
    let (mut xl, mut xu, mut gl, mut gu) = (vec![0.0; n], vec![0.0; n], vec![0.0; m], vec![0.0; m]);
    nlp.bounds(&mut xl, &mut xu, &mut gl, &mut gu);
    // Barrier-like diagonals; equality rows with the sparse backend's base regularization.
    let dx: Vec<f64> = (0..n).map(|i| 1.0 + (i % 5) as f64).collect();
    let dc: Vec<f64> = (0..m)
        .map(|i| {
            if gl[i] == gu[i] {
                -1e-10
            } else {
                -0.1 - (i % 3) as f64
            }
        })
        .collect();
    let dc0: Vec<f64> = (0..m)
        .map(|i| if gl[i] == gu[i] { 0.0 } else { dc[i] })
        .collect();
    let values = KktValues {
        hess: &hess,
        jac: &jac,
        primal_diag: &dx,
        dual_diag: &dc,
    };
    let values0 = KktValues {
        dual_diag: &dc0,
        ..values
    };
    let rhs_x: Vec<f64> = (0..n).map(|i| ((i % 11) as f64 - 5.0) * 0.1).collect();
    let rhs_y: Vec<f64> = (0..m).map(|i| ((i % 13) as f64 - 6.0) * 0.1).collect();
    let (mut bx, mut by) = (rhs_x.clone(), rhs_y.clone());

    let mut sparse = SparseLdlt::new(n, m, &hr, &hc, &jr, &jc).expect("sparse setup");
    let structure = nlp.stage_structure().expect("stage structure");
    let mut ric = VehicleRiccati::new(&structure, n, &hr, &hc, &jr, &jc).expect("riccati setup");

    let mut g = c.benchmark_group("kkt_oval_n100");
    g.bench_function("sparse_ldlt/factorize", |b| {
        b.iter(|| sparse.factorize(black_box(&values)).expect("factorizes"))
    });
    g.bench_function("sparse_ldlt/solve", |b| {
        b.iter(|| {
            bx.copy_from_slice(&rhs_x);
            by.copy_from_slice(&rhs_y);
            sparse.solve(black_box(&mut bx), black_box(&mut by));
        })
    });
    g.bench_function("riccati/factorize", |b| {
        b.iter(|| ric.factorize(black_box(&values0)).expect("factorizes"))
    });
    g.bench_function("riccati/factorize_regularized", |b| {
        b.iter(|| ric.factorize(black_box(&values)).expect("factorizes"))
    });
    ric.factorize(&values0).expect("factorizes");
    g.bench_function("riccati/solve", |b| {
        b.iter(|| {
            bx.copy_from_slice(&rhs_x);
            by.copy_from_slice(&rhs_y);
            ric.solve(black_box(&mut bx), black_box(&mut by));
        })
    });
    g.finish();
}

criterion_group!(benches, kkt);
criterion_main!(benches);
