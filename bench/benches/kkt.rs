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
use criterion::measurement::WallTime;
use criterion::{criterion_group, criterion_main, BenchmarkGroup, Criterion};
use planner::ip::kkt::{KktSolver, KktValues};
use std::hint::black_box;

/// The oval KKT system with and without the base regularization, the system with the
/// perturbed Jacobian, and a right-hand side.
struct Fixture {
    /// With the sparse backend's base regularization on the equality rows.
    sys: OvalKkt,
    /// Without (what the solver gives the Riccati backend).
    sys0: OvalKkt,
    /// Without, the Jacobian's entries other than 0 and +-1 scaled by 1 + 1e-12.
    sys1: OvalKkt,
    rhs_x: Vec<f64>,
    rhs_y: Vec<f64>,
}

/// The KKT values of the fixture's three systems.
struct Values<'a> {
    values: KktValues<'a>,
    values0: KktValues<'a>,
    values1: KktValues<'a>,
}

impl Fixture {
    fn new() -> Self {
        let sys = OvalKkt::new(-1e-10);
        let sys0 = OvalKkt::new(0.0);
        let (n, m) = (sys.n, sys.m);
        let rhs_x: Vec<f64> = (0..n).map(|i| ((i % 11) as f64 - 5.0) * 0.1).collect();
        let rhs_y: Vec<f64> = (0..m).map(|i| ((i % 13) as f64 - 6.0) * 0.1).collect();
        let mut sys1 = OvalKkt::new(0.0);
        for v in sys1.jac.iter_mut() {
            if *v != 0.0 && v.abs() != 1.0 {
                *v *= 1.0 + 1e-12;
            }
        }
        Self {
            sys,
            sys0,
            sys1,
            rhs_x,
            rhs_y,
        }
    }

    /// Benchmarks `solve` of a factorized `kkt` on a fresh copy of the right-hand side.
    fn bench_solve(
        &self,
        g: &mut BenchmarkGroup<'_, WallTime>,
        name: &str,
        kkt: &mut impl KktSolver,
    ) {
        let (mut bx, mut by) = (self.rhs_x.clone(), self.rhs_y.clone());
        g.bench_function(name, |b| {
            b.iter(|| {
                bx.copy_from_slice(&self.rhs_x);
                by.copy_from_slice(&self.rhs_y);
                kkt.solve(black_box(&mut bx), black_box(&mut by));
            })
        });
    }

    /// Benchmarks `factorize` of `kkt` alternating the two Jacobians (`flip` carries the
    /// alternation from one benchmark to the next).
    fn bench_new_jacobian(
        &self,
        g: &mut BenchmarkGroup<'_, WallTime>,
        name: &str,
        kkt: &mut impl KktSolver,
        vals: &Values<'_>,
        flip: &mut bool,
    ) {
        g.bench_function(name, |b| {
            b.iter(|| {
                *flip = !*flip;
                let v = if *flip { &vals.values1 } else { &vals.values0 };
                kkt.factorize(black_box(v)).expect("factorizes")
            })
        });
    }
}

/// The general sparse LDL^T backend.
fn sparse_ldlt(g: &mut BenchmarkGroup<'_, WallTime>, fx: &Fixture, vals: &Values<'_>) {
    let mut sparse = fx.sys.sparse();
    g.bench_function("sparse_ldlt/factorize", |b| {
        b.iter(|| {
            sparse
                .factorize(black_box(&vals.values))
                .expect("factorizes")
        })
    });
    fx.bench_solve(g, "sparse_ldlt/solve", &mut sparse);
}

/// The Riccati backend on the whole state, serial and pipelined.
fn riccati(g: &mut BenchmarkGroup<'_, WallTime>, fx: &Fixture, vals: &Values<'_>, flip: &mut bool) {
    let mut ric = fx.sys.riccati();
    g.bench_function("riccati/factorize", |b| {
        b.iter(|| ric.factorize(black_box(&vals.values0)).expect("factorizes"))
    });
    fx.bench_new_jacobian(g, "riccati/factorize_new_jacobian", &mut ric, vals, flip);
    // As in a solve, where the evaluation, the line search and the back-solves run between
    // two factorizations: 4 MB (more than a 1 MB L2 cache) are written first, outside the
    // timing, so the blocks, factors and index lists come from L3 or memory.
    let mut evict = vec![0u8; 4 << 20];
    g.bench_function("riccati/factorize_new_jacobian_cold", |b| {
        b.iter_batched(
            || {
                *flip = !*flip;
                evict.iter_mut().for_each(|v| *v = v.wrapping_add(1));
                *flip
            },
            |f| {
                let v = if f { &vals.values1 } else { &vals.values0 };
                ric.factorize(black_box(v)).expect("factorizes")
            },
            criterion::BatchSize::PerIteration,
        )
    });
    g.bench_function("riccati/factorize_regularized", |b| {
        b.iter(|| ric.factorize(black_box(&vals.values)).expect("factorizes"))
    });
    let mut piped = fx.sys.riccati();
    piped.set_pipelined(true).expect("helper thread starts");
    g.bench_function("riccati/factorize_pipelined", |b| {
        b.iter(|| {
            piped
                .factorize(black_box(&vals.values0))
                .expect("factorizes")
        })
    });
    fx.bench_new_jacobian(
        g,
        "riccati/factorize_pipelined_new_jacobian",
        &mut piped,
        vals,
        flip,
    );
    drop(piped);
    ric.factorize(&vals.values0).expect("factorizes");
    fx.bench_solve(g, "riccati/solve", &mut ric);
}

/// What the solver runs: the arc length s split off, 8-state blocks.
fn riccati_split(
    g: &mut BenchmarkGroup<'_, WallTime>,
    fx: &Fixture,
    vals: &Values<'_>,
    flip: &mut bool,
) {
    let mut split = fx.sys.split_riccati();
    g.bench_function("riccati_split/factorize", |b| {
        b.iter(|| {
            split
                .factorize(black_box(&vals.values0))
                .expect("factorizes")
        })
    });
    fx.bench_new_jacobian(
        g,
        "riccati_split/factorize_new_jacobian",
        &mut split,
        vals,
        flip,
    );
    split.factorize(&vals.values0).expect("factorizes");
    fx.bench_solve(g, "riccati_split/solve", &mut split);
    // The same with the helper thread of `threads = 2` writing the stage blocks.
    split
        .inner_mut()
        .set_pipelined(true)
        .expect("helper thread starts");
    g.bench_function("riccati_split/factorize_pipelined", |b| {
        b.iter(|| {
            split
                .factorize(black_box(&vals.values0))
                .expect("factorizes")
        })
    });
    fx.bench_new_jacobian(
        g,
        "riccati_split/factorize_pipelined_new_jacobian",
        &mut split,
        vals,
        flip,
    );
}

fn kkt(c: &mut Criterion) {
    let fx = Fixture::new();
    let vals = Values {
        values: fx.sys.values(),
        values0: fx.sys0.values(),
        values1: fx.sys1.values(),
    };
    let mut flip = false;
    let mut g = c.benchmark_group("kkt_oval_n100");
    sparse_ldlt(&mut g, &fx, &vals);
    riccati(&mut g, &fx, &vals, &mut flip);
    riccati_split(&mut g, &fx, &vals, &mut flip);
    g.finish();
}

criterion_group!(benches, kkt);
criterion_main!(benches);
