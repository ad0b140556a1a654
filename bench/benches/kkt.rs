//! One KKT factorization and one solve of the oval NLP (N = 100, implicit Euler) at the
//! reference optimum, for the general sparse LDL^T and the Riccati backend side by side,
//! and the Riccati factorization pipelined over a helper thread (`threads = 2`).
//! `riccati/factorize_new_jacobian` alternates two Jacobians (the second's entries other
//! than 0 and +-1 scaled by 1 + 1e-12), so every factorization inverts all E_k anew, as
//! the first factorization of each solver iteration does (the others reuse E_k^-1);
//! `riccati/factorize_pipelined_new_jacobian` is the same over two threads, and
//! `riccati/factorize_new_jacobian_cold` starts each factorization with cold caches (4 MB
//! written first, untimed), as in a solve, where evaluation and line search run in between.
//! `riccati_split/*` is the backend the solver uses on this OCP: the arc length s split off
//! as a decoupled chain, the rest in 8-state blocks.

use bench::OvalKkt;
use criterion::{criterion_group, criterion_main, Criterion};
use planner::ip::kkt::KktSolver;
use std::hint::black_box;

fn kkt(c: &mut Criterion) {
    // Equality rows with the sparse backend's base regularization, and without (what the
    // solver gives the Riccati backend).
    let sys = OvalKkt::new(-1e-10);
    let sys0 = OvalKkt::new(0.0);
    let (values, values0) = (sys.values(), sys0.values());
    let (n, m) = (sys.n, sys.m);
    let rhs_x: Vec<f64> = (0..n).map(|i| ((i % 11) as f64 - 5.0) * 0.1).collect();
    let rhs_y: Vec<f64> = (0..m).map(|i| ((i % 13) as f64 - 6.0) * 0.1).collect();
    let (mut bx, mut by) = (rhs_x.clone(), rhs_y.clone());

    let mut sparse = sys.sparse();
    let mut ric = sys.riccati();

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
    let mut sys1 = OvalKkt::new(0.0);
    for v in sys1.jac.iter_mut() {
        if *v != 0.0 && v.abs() != 1.0 {
            *v *= 1.0 + 1e-12;
        }
    }
    let values1 = sys1.values();
    let mut flip = false;
    g.bench_function("riccati/factorize_new_jacobian", |b| {
        b.iter(|| {
            flip = !flip;
            let v = if flip { &values1 } else { &values0 };
            ric.factorize(black_box(v)).expect("factorizes")
        })
    });
    // As in a solve, where the evaluation, the line search and the back-solves run between
    // two factorizations: 4 MB (more than a 1 MB L2 cache) are written first, outside the
    // timing, so the blocks, factors and index lists come from L3 or memory.
    let mut evict = vec![0u8; 4 << 20];
    g.bench_function("riccati/factorize_new_jacobian_cold", |b| {
        b.iter_batched(
            || {
                flip = !flip;
                evict.iter_mut().for_each(|v| *v = v.wrapping_add(1));
                flip
            },
            |f| {
                let v = if f { &values1 } else { &values0 };
                ric.factorize(black_box(v)).expect("factorizes")
            },
            criterion::BatchSize::PerIteration,
        )
    });
    g.bench_function("riccati/factorize_regularized", |b| {
        b.iter(|| ric.factorize(black_box(&values)).expect("factorizes"))
    });
    let mut piped = sys.riccati();
    piped.set_pipelined(true).expect("helper thread starts");
    g.bench_function("riccati/factorize_pipelined", |b| {
        b.iter(|| piped.factorize(black_box(&values0)).expect("factorizes"))
    });
    g.bench_function("riccati/factorize_pipelined_new_jacobian", |b| {
        b.iter(|| {
            flip = !flip;
            let v = if flip { &values1 } else { &values0 };
            piped.factorize(black_box(v)).expect("factorizes")
        })
    });
    drop(piped);
    ric.factorize(&values0).expect("factorizes");
    g.bench_function("riccati/solve", |b| {
        b.iter(|| {
            bx.copy_from_slice(&rhs_x);
            by.copy_from_slice(&rhs_y);
            ric.solve(black_box(&mut bx), black_box(&mut by));
        })
    });
    // What the solver runs: the arc length s split off, 8-state blocks.
    let mut split = sys.split_riccati();
    g.bench_function("riccati_split/factorize", |b| {
        b.iter(|| split.factorize(black_box(&values0)).expect("factorizes"))
    });
    g.bench_function("riccati_split/factorize_new_jacobian", |b| {
        b.iter(|| {
            flip = !flip;
            let v = if flip { &values1 } else { &values0 };
            split.factorize(black_box(v)).expect("factorizes")
        })
    });
    split.factorize(&values0).expect("factorizes");
    g.bench_function("riccati_split/solve", |b| {
        b.iter(|| {
            bx.copy_from_slice(&rhs_x);
            by.copy_from_slice(&rhs_y);
            split.solve(black_box(&mut bx), black_box(&mut by));
        })
    });
    // The same with the helper thread of `threads = 2` writing the stage blocks.
    split
        .inner_mut()
        .set_pipelined(true)
        .expect("helper thread starts");
    g.bench_function("riccati_split/factorize_pipelined", |b| {
        b.iter(|| split.factorize(black_box(&values0)).expect("factorizes"))
    });
    g.bench_function("riccati_split/factorize_pipelined_new_jacobian", |b| {
        b.iter(|| {
            flip = !flip;
            let v = if flip { &values1 } else { &values0 };
            split.factorize(black_box(v)).expect("factorizes")
        })
    });
    g.finish();
}

criterion_group!(benches, kkt);
criterion_main!(benches);
