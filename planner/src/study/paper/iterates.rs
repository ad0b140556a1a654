//! The iterates of one solve, for the paper's Fig. 4b (iterates overlaid on the oval) and
//! Fig. 5 (the distance ||Z - Z*||_2 of every iterate Z to the returned point Z*), and the
//! starting point's violation in the paper's (unscaled) units.
//!
//! The solver evaluates grad f once per iteration, at the iterate it then steps from
//! (and once at the start point, before the first iteration); [`Recorder`] wraps the NLP
//! and keeps a copy of the point of every such evaluation, dropping a repeat of the point
//! just kept. Z is the scaled decision vector (states and controls over their nominals,
//! [`crate::ocp::scaling`]), the variables the solver iterates on.

use crate::ip::kkt::StageStructure;
use crate::ip::{Nlp, NlpDims};
use crate::ocp::layout::VarKind;
use crate::ocp::path_constraints::rate_bounds;
use crate::ocp::scaling::{saturation_scale, FRICTION_SCALE, U_NOMINAL, X_NOMINAL};
use crate::ocp::transcription::RowKind;
use crate::ocp::ImplicitEulerNlp;

/// Cap on kept iterates (the solver's own iteration cap is lower in every study).
pub const MAX_KEPT: usize = 5000;

/// An NLP that forwards every call to `inner` and keeps the points where grad f is
/// evaluated (the iterates).
pub struct Recorder<'a, P: Nlp> {
    /// The wrapped NLP.
    pub inner: &'a mut P,
    /// Scaled decision vectors, in order (at most [`MAX_KEPT`]).
    pub iterates: Vec<Vec<f64>>,
}

impl<'a, P: Nlp> Recorder<'a, P> {
    /// Wraps `inner` with an empty record.
    pub fn new(inner: &'a mut P) -> Self {
        Self {
            inner,
            iterates: Vec::new(),
        }
    }
}

impl<P: Nlp> Nlp for Recorder<'_, P> {
    fn dims(&self) -> NlpDims {
        self.inner.dims()
    }
    fn bounds(&self, x_l: &mut [f64], x_u: &mut [f64], g_l: &mut [f64], g_u: &mut [f64]) {
        self.inner.bounds(x_l, x_u, g_l, g_u)
    }
    fn initial_point(&self, x: &mut [f64]) {
        self.inner.initial_point(x)
    }
    fn jac_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        self.inner.jac_structure(rows, cols)
    }
    fn hess_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        self.inner.hess_structure(rows, cols)
    }
    fn eval_f(&mut self, x: &[f64]) -> f64 {
        self.inner.eval_f(x)
    }
    fn eval_grad_f(&mut self, x: &[f64], grad: &mut [f64]) {
        let repeat = self.iterates.last().is_some_and(|l| l.as_slice() == x);
        if !repeat && self.iterates.len() < MAX_KEPT {
            self.iterates.push(x.to_vec());
        }
        self.inner.eval_grad_f(x, grad)
    }
    fn eval_g(&mut self, x: &[f64], g: &mut [f64]) {
        self.inner.eval_g(x, g)
    }
    fn eval_jac_g(&mut self, x: &[f64], vals: &mut [f64]) {
        self.inner.eval_jac_g(x, vals)
    }
    fn eval_hess(&mut self, x: &[f64], obj_factor: f64, lambda: &[f64], vals: &mut [f64]) {
        self.inner.eval_hess(x, obj_factor, lambda, vals)
    }
    fn stage_structure(&self) -> Option<StageStructure> {
        self.inner.stage_structure()
    }
}

/// ||Z - Z*||_2 of every kept iterate against the last one (Fig. 5's metric).
pub fn distances_to_last(iterates: &[Vec<f64>]) -> Vec<f64> {
    let Some(last) = iterates.last() else {
        return Vec::new();
    };
    iterates
        .iter()
        .map(|z| {
            z.iter()
                .zip(last)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
                .sqrt()
        })
        .collect()
}

/// Largest constraint violation at `z` in the scaled NLP's units and in physical units
/// (the paper's unscaled NLP: each defect row times its state's nominal, friction rows in
/// N, saturation rows unscaled, rate rows times their rate bound, bound excesses times the
/// variable's nominal). Returns (scaled, physical, name of the physical maximum's row).
pub fn violation_both<const N: usize>(
    nlp: &mut ImplicitEulerNlp<N>,
    z: &[f64],
) -> (f64, f64, String) {
    let d = nlp.dims();
    let (mut xl, mut xu) = (vec![0.0; d.n], vec![0.0; d.n]);
    let (mut gl, mut gu) = (vec![0.0; d.m], vec![0.0; d.m]);
    nlp.bounds(&mut xl, &mut xu, &mut gl, &mut gu);
    let mut g = vec![0.0; d.m];
    nlp.eval_g(z, &mut g);
    let sat = saturation_scale(&nlp.spec().initial);
    let rates = rate_bounds(&nlp.spec().vehicle);
    let (mut scaled, mut phys, mut at) = (0.0_f64, 0.0_f64, String::from("-"));
    for i in 0..d.m {
        let v = (gl[i] - g[i]).max(g[i] - gu[i]).max(0.0);
        let v = if v.is_nan() { f64::INFINITY } else { v };
        let factor = match nlp.describe_row(i).kind {
            RowKind::Initial { state } => X_NOMINAL[state],
            RowKind::Defect { row } => X_NOMINAL[row.min(X_NOMINAL.len() - 1)],
            RowKind::Friction { .. } => FRICTION_SCALE,
            RowKind::Saturation { .. } => sat,
            RowKind::RateUpper { control } | RowKind::RateLower { control } => rates[control],
        };
        scaled = scaled.max(v);
        if v * factor > phys || (v * factor).is_infinite() && phys.is_finite() {
            phys = v * factor;
            at = nlp.row_name(i);
        }
    }
    let lay = nlp.layout();
    for i in 0..d.n {
        let v = (xl[i] - z[i]).max(z[i] - xu[i]).max(0.0);
        let factor = match lay.describe(i).1 {
            VarKind::State(j) => X_NOMINAL[j],
            VarKind::Control(j) => U_NOMINAL[j],
            VarKind::Stage(_) => 1.0,
        };
        scaled = scaled.max(v);
        if v * factor > phys {
            phys = v * factor;
            at = format!("bound of variable {i}");
        }
    }
    (scaled, phys, at)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::guess::{equilibrium, fill_equilibrium};
    use crate::ip::{Settings, Solver};
    use crate::model::{NU, NX};
    use crate::ocp::fixtures;

    #[test]
    fn the_distance_to_the_last_iterate_is_the_euclidean_norm_and_ends_at_zero() {
        let it = vec![vec![3.0, 4.0], vec![0.0, 1.0], vec![0.0, 0.0]];
        assert_eq!(distances_to_last(&it), vec![5.0, 1.0, 0.0]);
        assert!(distances_to_last(&[]).is_empty());
    }

    #[test]
    fn the_recorder_keeps_one_point_per_iteration_from_the_start_to_the_returned_point() {
        const N: usize = 100;
        let spec = fixtures::oval_spec();
        let eq = equilibrium(&spec.vehicle, spec.v_min, spec.v_max, 15.0).expect("equilibrium");
        let (mut xs, mut us) = (vec![[0.0; NX]; N + 1], vec![[0.0; NU]; N]);
        fill_equilibrium(&eq, spec.ds(), None, &mut xs, &mut us);
        let mut nlp = ImplicitEulerNlp::<N>::new(spec).expect("nlp");
        nlp.set_initial_guess(&xs, &us);
        let settings = Settings {
            max_iter: 4,
            ..Settings::default()
        };
        let mut solver = Solver::new(&nlp, settings).expect("solver");
        let mut rec = Recorder::new(&mut nlp);
        let info = solver.solve(&mut rec);
        assert_eq!(info.iterations, 4);
        // The start (iteration 0), the points of iterations 1..=4 and, when the solver
        // returns an earlier (best) iterate, that point once more.
        let restored = usize::from(info.best_iterate);
        assert_eq!(rec.iterates.len(), 5 + restored, "{:?}", info.status);
        assert_ne!(rec.iterates[0], rec.iterates[1]);
        // The returned point (the last or the best iterate) is one of the recorded ones.
        assert!(rec.iterates.iter().any(|z| z.as_slice() == solver.x()));
    }
}
