//! The [`Nlp`] interface of a transcription: dimensions, bounds, structures and the
//! evaluations the interior-point solver calls, each into the caller's buffer.

use super::stage_eval::StageEval;
use super::{DefectScheme, RowKind, Transcription};
use crate::ip::kkt::{RowRole, StageStructure};
use crate::ip::{Nlp, NlpDims};
use crate::model::{NU, NX};
use crate::ocp::path_constraints::INITIAL_ROWS;

impl<S: DefectScheme, const N: usize> Nlp for Transcription<S, N> {
    fn dims(&self) -> NlpDims {
        NlpDims {
            n: self.layout.n(),
            m: self.m,
            nnz_jac: self.jac_rows.len(),
            nnz_hess: self.hess_rows.len(),
        }
    }

    fn bounds(&self, x_l: &mut [f64], x_u: &mut [f64], g_l: &mut [f64], g_u: &mut [f64]) {
        x_l.copy_from_slice(&self.x_l);
        x_u.copy_from_slice(&self.x_u);
        g_l.copy_from_slice(&self.g_l);
        g_u.copy_from_slice(&self.g_u);
    }

    fn initial_point(&self, x: &mut [f64]) {
        x.copy_from_slice(&self.z0);
    }

    fn jac_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        rows.copy_from_slice(&self.jac_rows);
        cols.copy_from_slice(&self.jac_cols);
    }

    fn hess_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        rows.copy_from_slice(&self.hess_rows);
        cols.copy_from_slice(&self.hess_cols);
    }

    /// Objective t_N / OBJECTIVE_SCALE (= 10 t_N), plus the steering-slew term
    /// ([`Objective`](crate::ocp::objective::Objective)).
    fn eval_f(&mut self, x: &[f64]) -> f64 {
        self.objective.value(x, self.spec.soft_lane.bounds())
    }

    fn eval_grad_f(&mut self, x: &[f64], grad: &mut [f64]) {
        self.objective
            .gradient(x, self.spec.soft_lane.bounds(), grad);
    }

    fn eval_g(&mut self, x: &[f64], g: &mut [f64]) {
        let this = &*self;
        let lay = &this.layout;
        for (r, &i) in INITIAL_ROWS.iter().enumerate() {
            g[r] = x[lay.x(0, i)];
        }
        this.for_stages(
            g,
            |st| st.row_defect,
            |k, out, off| this.stage_for_cpu(StageEval::Rows, x, k, out, off),
        );
    }

    fn eval_jac_g(&mut self, x: &[f64], vals: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if self.simd {
            // SAFETY: `simd` is only true when the CPU reports AVX2.
            return unsafe { self.eval_jac_avx2(x, vals) };
        }
        self.eval_jac_body(x, vals)
    }

    /// Stages z_k = (x_k, u_k) for single-step schemes (no stage variables); the Riccati
    /// backend checks at setup that the defects couple only x_k, u_k and x_{k+1}.
    fn stage_structure(&self) -> Option<StageStructure> {
        if S::STAGE_VARS != 0 || S::ROWS != NX {
            return None;
        }
        let rows = self
            .rows
            .iter()
            .map(|r| match r.kind {
                RowKind::Initial { .. } => RowRole::Initial,
                RowKind::Defect { row } => RowRole::Dynamics {
                    stage: r.node,
                    index: row,
                },
                _ => RowRole::Path,
            })
            .collect();
        Some(StageStructure {
            n_stages: N,
            nx: NX,
            nu: NU,
            rows,
        })
    }

    /// Hessian of `obj_factor f + lambda^T g`: the defect and saturation rows (all other
    /// rows are linear) and the objective's constant steering-slew term.
    fn eval_hess(&mut self, x: &[f64], obj_factor: f64, lambda: &[f64], vals: &mut [f64]) {
        self.eval_hess_for_cpu(x, lambda, vals);
        // The objective's curvature: the steering-slew term (constant) and the soft lane.
        let soft = self.spec.soft_lane.bounds();
        self.objective.add_hessian(x, soft, obj_factor, vals);
    }
}

impl<S: DefectScheme, const N: usize> Transcription<S, N> {
    /// Largest constraint violation at `z` in the scaled NLP's units: max over equality
    /// residuals, inequality excesses and variable-bound excesses (allocation-free).
    pub fn max_violation(&mut self, z: &[f64]) -> f64 {
        let mut g = std::mem::take(&mut self.g_buf);
        self.eval_g(z, &mut g);
        let mut v: f64 = 0.0;
        for ((gi, lo), hi) in g.iter().zip(&self.g_l).zip(&self.g_u) {
            v = v.max(lo - gi).max(gi - hi);
        }
        for (i, zi) in z.iter().enumerate() {
            v = v.max(self.x_l[i] - zi).max(zi - self.x_u[i]);
        }
        self.g_buf = g;
        v
    }

    /// Largest absolute scaled defect residual (dynamics only) at `z`.
    pub fn max_defect(&mut self, z: &[f64]) -> f64 {
        let mut g = std::mem::take(&mut self.g_buf);
        self.eval_g(z, &mut g);
        let mut v: f64 = 0.0;
        for st in &self.stages {
            for gi in &g[st.row_defect..st.row_defect + S::ROWS] {
                v = v.max(gi.abs());
            }
        }
        self.g_buf = g;
        v
    }
}
