//! Solves the oval OCP end to end (equilibrium guess, implicit Euler, N = 100).

use std::path::Path;

use planner::config::{load_scenario, load_vehicle};
use planner::guess::{equilibrium, fill_equilibrium};
use planner::ip::{Settings, Solver};
use planner::model::{NU, NX};
use planner::ocp::transcription::ImplicitEulerNlp;

fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"))
}

#[test]
#[ignore]
fn debug_oval() {
    let vehicle = load_vehicle(&root().join("vehicles/lc500.toml")).unwrap();
    let spec = load_scenario(&root().join("scenarios/oval.toml"), None, vehicle).unwrap();
    let eq = equilibrium(&vehicle, spec.v_min, spec.v_max, 15.0).unwrap();
    println!("equilibrium {eq:?}");
    let mut nlp = ImplicitEulerNlp::<100>::new(spec.clone()).unwrap();
    let mut xs = vec![[0.0; NX]; 101];
    let mut us = vec![[0.0; NU]; 100];
    fill_equilibrium(&eq, spec.ds(), None, &mut xs, &mut us);
    if std::env::var("FROM_REF").is_ok() {
        let r = planner::ocp::fixtures::ReferenceCsv::load(
            &planner::ocp::fixtures::oval_reference_path(),
        )
        .unwrap();
        let (x, u) = r.trajectory();
        xs = x;
        us = u;
    }
    nlp.set_initial_guess(&xs, &us);
    let barrier = std::env::var("BARRIER")
        .ok()
        .and_then(|b| planner::ip::BarrierRule::parse(&b))
        .unwrap_or_default();
    let mut settings = Settings {
        barrier,
        max_iter: 300,
        ..Settings::default()
    };
    if let Ok(v) = std::env::var("DC") {
        settings.delta_c_min = v.parse().unwrap();
    }
    if std::env::var("MERIT").is_ok() {
        settings.globalization = planner::ip::Globalization::Merit;
    }
    if std::env::var("NOSOC").is_ok() {
        settings.second_order_correction = false;
    }
    let mut solver = Solver::new(&nlp, settings).unwrap();
    let obj: f64 = std::env::var("OBJ")
        .map(|v| v.parse().unwrap())
        .unwrap_or(1.0);
    let mut spy = Spy {
        inner: &mut nlp,
        k: usize::MAX,
        count: 0,
        x: vec![],
        obj,
    };
    let info = solver.solve(&mut spy);
    for l in solver.log() {
        println!(
            "{:3} f={:.6} pr={:.2e} du={:.2e} co={:.2e} mu={:.2e} a={:.2e} dw={:.1e} nf={} bt={} {:?}",
            l.iter, l.objective, l.inf_pr, l.inf_du, l.compl, l.mu, l.alpha, l.delta_w, l.factorizations, l.backtracks, l.step
        );
    }
    println!("{info:#?}");
}

/// Records the iterate at the K-th Hessian evaluation.
struct Spy<'a> {
    inner: &'a mut ImplicitEulerNlp<100>,
    k: usize,
    count: usize,
    x: Vec<f64>,
    obj: f64,
}

impl planner::ip::Nlp for Spy<'_> {
    fn dims(&self) -> planner::ip::NlpDims {
        self.inner.dims()
    }
    fn bounds(&self, a: &mut [f64], b: &mut [f64], c: &mut [f64], d: &mut [f64]) {
        self.inner.bounds(a, b, c, d)
    }
    fn initial_point(&self, x: &mut [f64]) {
        self.inner.initial_point(x)
    }
    fn jac_structure(&self, r: &mut [usize], c: &mut [usize]) {
        self.inner.jac_structure(r, c)
    }
    fn hess_structure(&self, r: &mut [usize], c: &mut [usize]) {
        self.inner.hess_structure(r, c)
    }
    fn eval_f(&mut self, x: &[f64]) -> f64 {
        self.obj * self.inner.eval_f(x)
    }
    fn eval_grad_f(&mut self, x: &[f64], g: &mut [f64]) {
        self.inner.eval_grad_f(x, g);
        g.iter_mut().for_each(|v| *v *= self.obj)
    }
    fn eval_g(&mut self, x: &[f64], g: &mut [f64]) {
        self.inner.eval_g(x, g)
    }
    fn eval_jac_g(&mut self, x: &[f64], v: &mut [f64]) {
        self.inner.eval_jac_g(x, v)
    }
    fn eval_hess(&mut self, x: &[f64], s: f64, l: &[f64], v: &mut [f64]) {
        if self.count == self.k {
            self.x = x.to_vec();
        }
        self.count += 1;
        self.inner.eval_hess(x, s * self.obj, l, v)
    }
}

#[test]
#[ignore]
fn debug_rows() {
    use planner::ip::Nlp;
    let vehicle = load_vehicle(&root().join("vehicles/lc500.toml")).unwrap();
    let spec = load_scenario(&root().join("scenarios/oval.toml"), None, vehicle).unwrap();
    let mut nlp = ImplicitEulerNlp::<100>::new(spec.clone()).unwrap();
    let r =
        planner::ocp::fixtures::ReferenceCsv::load(&planner::ocp::fixtures::oval_reference_path())
            .unwrap();
    let (xs, us) = r.trajectory();
    nlp.set_initial_guess(&xs, &us);
    let k: usize = std::env::var("K").map(|v| v.parse().unwrap()).unwrap_or(22);
    let settings = Settings {
        barrier: planner::ip::BarrierRule::Monotone,
        max_iter: 300,
        ..Settings::default()
    };
    let mut solver = Solver::new(&nlp, settings).unwrap();
    let mut spy = Spy {
        inner: &mut nlp,
        k,
        count: 0,
        x: vec![],
        obj: 1.0,
    };
    let _ = solver.solve(&mut spy);
    let x = spy.x.clone();
    let d = nlp.dims();
    let mut g = vec![0.0; d.m];
    let (mut xl, mut xu, mut gl, mut gu) = (
        vec![0.0; d.n],
        vec![0.0; d.n],
        vec![0.0; d.m],
        vec![0.0; d.m],
    );
    nlp.bounds(&mut xl, &mut xu, &mut gl, &mut gu);
    nlp.eval_g(&x, &mut g);
    let mut v: Vec<(f64, usize)> = (0..d.m)
        .map(|i| ((gl[i] - g[i]).max(g[i] - gu[i]).max(0.0), i))
        .collect();
    v.sort_by(|a, b| b.0.partial_cmp(&a.0).unwrap());
    for (val, i) in v.iter().take(15) {
        println!("{:.3e} {}", val, nlp.row_name(*i));
    }
    let (xs2, us2) = nlp.trajectory_from(&x);
    for kk in (0..=100).step_by(10) {
        println!(
            "node {kk}: x={:?} u={:?}",
            xs2[kk].map(|v| (v * 1000.0).round() / 1000.0),
            us2[kk.min(99)].map(|v| (v * 1000.0).round() / 1000.0)
        );
    }
}
