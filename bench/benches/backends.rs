//! Whole solves from the equilibrium guess with the general sparse LDL^T and the Riccati
//! KKT backend side by side: the oval, the ten race segments and the collision-avoidance
//! scenarios. The per-phase split (evaluation, factorization, back-solve, line search) of
//! one solve per case is printed before its timing.

use criterion::{criterion_group, criterion_main, Criterion};
use planner::guess::GuessKind;
use planner::ip::kkt::KktBackendKind;

/// (file, entry, tire saturation override) of every benchmarked case.
const CASES: [(&str, Option<&str>, Option<bool>); 14] = [
    ("oval.toml", None, None),
    ("segments.toml", Some("S01"), None),
    ("segments.toml", Some("S02"), None),
    ("segments.toml", Some("S03"), None),
    ("segments.toml", Some("S04"), None),
    ("segments.toml", Some("S05"), None),
    ("segments.toml", Some("S06"), None),
    ("segments.toml", Some("S07"), None),
    ("segments.toml", Some("S08"), None),
    ("segments.toml", Some("S09"), None),
    ("segments.toml", Some("S10"), None),
    ("collision_avoidance.toml", Some("forgiving"), Some(true)),
    ("collision_avoidance.toml", Some("forgiving"), Some(false)),
    ("collision_avoidance.toml", Some("critical"), Some(false)),
];

fn backends(c: &mut Criterion) {
    let mut g = c.benchmark_group("backends");
    g.sample_size(10);
    for (file, entry, saturation) in CASES {
        let case = match (entry, saturation) {
            (Some(e), Some(true)) => format!("{e}_saturation_on"),
            (Some(e), Some(false)) => format!("{e}_saturation_off"),
            (Some(e), None) => e.to_string(),
            (None, _) => file.trim_end_matches(".toml").to_string(),
        };
        for kkt in [KktBackendKind::Sparse, KktBackendKind::Riccati] {
            let mut p = bench::planner_for_with(
                file,
                entry,
                |spec| {
                    if let Some(on) = saturation {
                        spec.enforce_tire_saturation = on;
                    }
                },
                |settings| settings.kkt = kkt,
            );
            let name = format!("{case}/{}", kkt.name());
            report(&name, &mut p);
            g.bench_function(&name, |b| {
                b.iter(|| std::hint::black_box(p.solve(GuessKind::Equilibrium)))
            });
        }
    }
    g.finish();
}

/// Prints the per-phase split of one solve, per iteration.
fn report(name: &str, p: &mut planner::plan::Planner<100>) {
    let info = p.solve(GuessKind::Equilibrium);
    let it = info.iterations.max(1) as f64;
    eprintln!(
        "{name}: {} in {} iterations, {} factorizations; per iteration [us]: total {:.0}, \
         evaluation {:.0}, factorization {:.0}, back-solve {:.0}, line search {:.0}",
        info.status.name(),
        info.iterations,
        info.factorizations,
        info.times.total * 1e6 / it,
        info.times.evaluation * 1e6 / it,
        info.times.factorization * 1e6 / it,
        info.times.solve * 1e6 / it,
        info.times.line_search * 1e6 / it,
    );
}

criterion_group!(benches, backends);
criterion_main!(benches);
