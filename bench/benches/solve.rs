//! Whole solves from the equilibrium guess: the oval (paper Table I row implicit Euler /
//! Fig. 4b), with the per-phase split printed once, for the fast derivative path, the
//! num-dual oracle and `threads = 2` (helper thread for the factorization and the Hessian);
//! and each race segment S01-S10 (paper Table II), one
//! criterion group per segment, with one and two threads. The scenarios' objective is
//! t_N + 1 x steering slew; the `_pure_min_time` entries solve the paper's eq. 3 (weight 0),
//! with the solver file shipped for it (`config/solver_min_time.toml`).

use criterion::{criterion_group, criterion_main, Criterion};
use planner::guess::GuessKind;
use planner::ocp::Derivatives;

fn oval(c: &mut Criterion) {
    let mut g = c.benchmark_group("solve");
    g.sample_size(10);
    for (mode, name) in [
        (Derivatives::Fast, "oval_equilibrium"),
        (Derivatives::Oracle, "oval_equilibrium_oracle"),
    ] {
        let mut p = bench::planner_for("oval.toml", None);
        p.nlp().set_derivatives(mode);
        report(name, &mut p);
        g.bench_function(name, |b| {
            b.iter(|| std::hint::black_box(p.solve(GuessKind::Equilibrium)))
        });
    }
    for (name, threads, slew) in [
        ("oval_equilibrium_threads2", 2, None),
        ("oval_equilibrium_pure_min_time", 1, Some(0.0)),
    ] {
        let mut p = bench::planner_for_with(
            "oval.toml",
            None,
            |spec| {
                if let Some(w) = slew {
                    spec.steering_slew_weight = w;
                }
            },
            |s| s.threads = threads,
        );
        report(name, &mut p);
        g.bench_function(name, |b| {
            b.iter(|| std::hint::black_box(p.solve(GuessKind::Equilibrium)))
        });
    }
    g.finish();
}

/// Prints the per-phase split of one solve.
fn report(name: &str, p: &mut planner::plan::Planner<100>) {
    let info = p.solve(GuessKind::Equilibrium);
    eprintln!(
        "{name}: status {}, {} iterations, total {:.2} ms (evaluation {:.2}, factorization {:.2}, \
         solve {:.2}, line search {:.2}), {:.3} ms per iteration",
        info.status.name(),
        info.iterations,
        info.times.total * 1e3,
        info.times.evaluation * 1e3,
        info.times.factorization * 1e3,
        info.times.solve * 1e3,
        info.times.line_search * 1e3,
        info.times.total * 1e3 / info.iterations.max(1) as f64,
    );
}

/// The ten race segments of `segments.toml`, one group per segment (`segment_S01/...`).
fn segments(c: &mut Criterion) {
    for k in 1..=10 {
        let name = format!("S{k:02}");
        let mut g = c.benchmark_group(format!("segment_{name}"));
        g.sample_size(10);
        for (id, threads, slew) in [
            ("equilibrium", 1, None),
            ("equilibrium_threads2", 2, None),
            ("equilibrium_pure_min_time", 1, Some(0.0)),
        ] {
            let mut p = bench::planner_for_with(
                "segments.toml",
                Some(&name),
                |spec| {
                    if let Some(w) = slew {
                        spec.steering_slew_weight = w;
                    }
                },
                |s| s.threads = threads,
            );
            report(&format!("{name} ({id})"), &mut p);
            g.bench_function(id, |b| {
                b.iter(|| std::hint::black_box(p.solve(GuessKind::Equilibrium)))
            });
        }
        g.finish();
    }
}

criterion_group!(benches, oval, segments);
criterion_main!(benches);
