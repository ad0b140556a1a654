//! Cost of one full derivative evaluation of the oval NLP (N = 100, implicit Euler):
//! objective gradient, constraints, constraint Jacobian and Lagrangian Hessian, for the
//! fast structured derivative path (default) and the num-dual oracle for comparison; and
//! the structured model pieces alone (`pieces_x100`), to tell their cost from the
//! assembly's around them; and the Jacobian plus Hessian of every other transcription of
//! Table I in both modes (`schemes`), so the integrator table compares integrators and not
//! derivative code.

use bench::oval_nlp_at_reference;
use criterion::{criterion_group, criterion_main, Criterion};
use planner::ip::Nlp;
use planner::ocp::Derivatives;
use std::hint::black_box;

fn eval(c: &mut Criterion) {
    for (mode, name) in [
        (Derivatives::Fast, "oval_ie_n100"),
        (Derivatives::Oracle, "oval_ie_n100_oracle"),
    ] {
        let (mut nlp, z) = oval_nlp_at_reference();
        nlp.set_derivatives(mode);
        let d = nlp.dims();
        let mut grad = vec![0.0; d.n];
        let mut g = vec![0.0; d.m];
        let mut jac = vec![0.0; d.nnz_jac];
        let mut hess = vec![0.0; d.nnz_hess];
        let lambda: Vec<f64> = (0..d.m).map(|i| ((i % 7) as f64 - 3.0) * 0.1).collect();

        let mut group = c.benchmark_group(name);
        group.bench_function("full_eval(grad,g,jac,hess)", |b| {
            b.iter(|| {
                nlp.eval_grad_f(black_box(&z), &mut grad);
                nlp.eval_g(black_box(&z), &mut g);
                nlp.eval_jac_g(black_box(&z), &mut jac);
                nlp.eval_hess(black_box(&z), 1.0, black_box(&lambda), &mut hess);
            })
        });
        group.bench_function("g", |b| b.iter(|| nlp.eval_g(black_box(&z), &mut g)));
        group.bench_function("jac_g", |b| {
            b.iter(|| nlp.eval_jac_g(black_box(&z), &mut jac))
        });
        group.bench_function("hess", |b| {
            b.iter(|| nlp.eval_hess(black_box(&z), 1.0, black_box(&lambda), &mut hess))
        });
        // The baseline x86-64 copy of the same code (the default runs the AVX2 copy where
        // the CPU has it; both give the same bits).
        nlp.set_simd(false);
        group.bench_function("hess_baseline_copy", |b| {
            b.iter(|| nlp.eval_hess(black_box(&z), 1.0, black_box(&lambda), &mut hess))
        });
        nlp.set_simd(true);
        group.finish();

        // Split of the Hessian cost: the same point without the saturation rows.
        let mut spec = nlp.spec().clone();
        spec.enforce_tire_saturation = false;
        let mut nlp = planner::ocp::ImplicitEulerNlp::<100>::new(spec).expect("N = 100");
        nlp.set_derivatives(mode);
        let d = nlp.dims();
        let mut hess = vec![0.0; d.nnz_hess];
        let lambda: Vec<f64> = (0..d.m).map(|i| ((i % 7) as f64 - 3.0) * 0.1).collect();
        c.bench_function(&format!("{name}_no_saturation/hess"), |b| {
            b.iter(|| nlp.eval_hess(black_box(&z), 1.0, black_box(&lambda), &mut hess))
        });
    }
}

/// The structured model pieces alone, over the 100 intervals of the same point: where the
/// Hessian and Jacobian time goes, in copies compiled with the features of the solver's AVX2
/// entry points (`avx,avx2`).
#[cfg(target_arch = "x86_64")]
fn pieces(c: &mut Criterion) {
    use planner::model::{NU, NX};
    use planner::ocp::fast;
    let (nlp, z) = oval_nlp_at_reference();
    let (xs, us) = nlp.trajectory_from(&z);
    let p = nlp.spec().vehicle;
    let kappa = nlp.spec().kappa.clone();
    let w: [f64; NX] = std::array::from_fn(|i| 0.3 - 0.1 * i as f64);

    #[target_feature(enable = "avx,avx2")]
    unsafe fn defect_h(
        p: &planner::model::VehicleParams,
        xs: &[[f64; NX]],
        us: &[[f64; NU]],
        kappa: &[f64],
        w: &[f64; NX],
    ) -> f64 {
        let mut acc = 0.0;
        for k in 0..us.len() {
            acc += black_box(&fast::defect_hessian(
                p,
                &xs[k + 1],
                &us[k],
                kappa[k + 1],
                w,
            ))
            .h[3][2];
        }
        acc
    }
    #[target_feature(enable = "avx,avx2")]
    unsafe fn sat_h(p: &planner::model::VehicleParams, xs: &[[f64; NX]], us: &[[f64; NU]]) -> f64 {
        let mut acc = 0.0;
        for k in 0..us.len() {
            acc += black_box(&fast::saturation_hessian(p, &xs[k], &us[k], [0.3, -0.2])).h[3][2];
        }
        acc
    }
    #[target_feature(enable = "avx,avx2")]
    unsafe fn defect_j(
        p: &planner::model::VehicleParams,
        xs: &[[f64; NX]],
        us: &[[f64; NU]],
        kappa: &[f64],
    ) -> f64 {
        let mut acc = 0.0;
        for k in 0..us.len() {
            acc += black_box(&fast::defect_jacobian(p, &xs[k + 1], &us[k], kappa[k + 1]))[2].g[3];
        }
        acc
    }
    if !std::arch::is_x86_feature_detected!("avx2") {
        return;
    }
    let mut g = c.benchmark_group("pieces_x100");
    // SAFETY: AVX2 was detected above.
    g.bench_function("defect_hessian", |b| {
        b.iter(|| unsafe { defect_h(&p, black_box(&xs), &us, &kappa, &w) })
    });
    g.bench_function("saturation_hessian", |b| {
        b.iter(|| unsafe { sat_h(&p, black_box(&xs), &us) })
    });
    g.bench_function("defect_jacobian", |b| {
        b.iter(|| unsafe { defect_j(&p, black_box(&xs), &us, &kappa) })
    });
    g.finish();
}

/// The pieces are timed in their AVX2 copies only.
#[cfg(not(target_arch = "x86_64"))]
fn pieces(_: &mut Criterion) {}

/// Jacobian plus Lagrangian Hessian of each transcription at the oval's reference
/// trajectory (stage states on the chords), hand-written jets against the num-dual oracle.
fn schemes(c: &mut Criterion) {
    use planner::ocp::{
        CrankNicolson, DefectScheme, ExplicitRk2, ExplicitRk4, GaussLegendre2, GaussLegendre3,
        LinearMultistep, Transcription,
    };
    fn one<S: DefectScheme>(c: &mut Criterion, scheme: S) {
        let (ie, z_ie) = oval_nlp_at_reference();
        let (xs, us) = ie.trajectory_from(&z_ie);
        let mut nlp =
            Transcription::<S, 100>::with_scheme(ie.spec().clone(), scheme).expect("N = 100");
        nlp.set_initial_guess(&xs, &us);
        let d = nlp.dims();
        let mut z = vec![0.0; d.n];
        nlp.initial_point(&mut z);
        let (mut jac, mut hess) = (vec![0.0; d.nnz_jac], vec![0.0; d.nnz_hess]);
        let lambda: Vec<f64> = (0..d.m).map(|i| ((i % 7) as f64 - 3.0) * 0.1).collect();
        let mut group = c.benchmark_group(format!("schemes/{}", nlp.scheme().name()));
        for (mode, name) in [(Derivatives::Fast, "fast"), (Derivatives::Oracle, "oracle")] {
            nlp.set_derivatives(mode);
            group.bench_function(format!("jac_hess_{name}"), |b| {
                b.iter(|| {
                    nlp.eval_jac_g(black_box(&z), &mut jac);
                    nlp.eval_hess(black_box(&z), 1.0, black_box(&lambda), &mut hess);
                })
            });
        }
        group.finish();
    }
    one(c, CrankNicolson);
    one(c, LinearMultistep::BDF4);
    one(c, LinearMultistep::ADAMS_MOULTON3);
    one(c, GaussLegendre2);
    one(c, GaussLegendre3);
    one(c, ExplicitRk2);
    one(c, ExplicitRk4);
}

criterion_group!(benches, eval, pieces, schemes);
criterion_main!(benches);
