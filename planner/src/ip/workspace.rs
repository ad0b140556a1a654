//! Every buffer of the interior-point solver, allocated once at setup.
//!
//! The primal vector `w = (x, s)` holds the NLP variables followed by one slack per
//! constraint row; slacks of equality rows are unused (no bounds, value fixed at `g_l`).

use super::info::IterLog;
use super::nlp::{Nlp, NlpDims};

/// Vectors and structures for one problem size; reused across solves.
#[derive(Debug, Clone)]
pub struct Workspace {
    /// Number of NLP variables.
    pub n: usize,
    /// Number of constraint rows.
    pub m: usize,
    /// Constraint lower bounds.
    pub g_l: Vec<f64>,
    /// Constraint upper bounds.
    pub g_u: Vec<f64>,
    /// True for equality rows.
    pub is_eq: Vec<bool>,
    /// Lower bound of each w entry (relaxed), -inf when absent.
    pub lo: Vec<f64>,
    /// Upper bound of each w entry (relaxed), +inf when absent.
    pub hi: Vec<f64>,
    /// Original lower bound of each w entry (for violation reports).
    pub lo_orig: Vec<f64>,
    /// Original upper bound of each w entry.
    pub hi_orig: Vec<f64>,
    /// w entry has a lower bound.
    pub has_lo: Vec<bool>,
    /// w entry has an upper bound.
    pub has_hi: Vec<bool>,
    /// `has_lo` as 1.0 / 0.0: the vector kernels select on a compare of these, which
    /// vectorizes to whole AVX2 vectors where a bool lane does not.
    pub on_lo: Vec<f64>,
    /// `has_hi` as 1.0 / 0.0.
    pub on_hi: Vec<f64>,
    /// Number of complementarity pairs.
    pub n_compl: usize,
    /// Jacobian row indices.
    pub jac_rows: Vec<usize>,
    /// Jacobian column indices.
    pub jac_cols: Vec<usize>,
    /// The Jacobian pattern by columns (J^T products).
    pub jac_t: super::sparse::ColumnJacobian,
    /// Hessian row indices (lower triangle).
    pub hess_rows: Vec<usize>,
    /// Hessian column indices.
    pub hess_cols: Vec<usize>,

    /// Primal iterate w = (x, s).
    pub w: Vec<f64>,
    /// Constraint multipliers.
    pub y: Vec<f64>,
    /// Lower-bound multipliers (per w entry, 0 when no bound).
    pub zl: Vec<f64>,
    /// Upper-bound multipliers.
    pub zu: Vec<f64>,

    /// Objective at w.
    pub f: f64,
    /// Objective gradient at x.
    pub grad: Vec<f64>,
    /// Constraint values g(x).
    pub g: Vec<f64>,
    /// Constraint residual c = g(x) - s (or g - g_l for equalities).
    pub c: Vec<f64>,
    /// Jacobian values.
    pub jac: Vec<f64>,
    /// Hessian values.
    pub hess: Vec<f64>,

    /// Trial primal point.
    pub w_t: Vec<f64>,
    /// Constraint values at the trial point.
    pub g_t: Vec<f64>,
    /// Residual at the trial point.
    pub c_t: Vec<f64>,

    /// Primal KKT diagonal (barrier terms + regularization) for x.
    pub primal_diag: Vec<f64>,
    /// Dual KKT diagonal.
    pub dual_diag: Vec<f64>,
    /// Barrier Hessian diagonal Sigma for every w entry.
    pub sigma: Vec<f64>,
    /// Right-hand side of the primal block (all of w).
    pub rhs_w: Vec<f64>,
    /// Solve buffer, x part.
    pub sol_x: Vec<f64>,
    /// Solve buffer, y part.
    pub sol_y: Vec<f64>,
    /// Complementarity targets for lower bounds.
    pub tgt_l: Vec<f64>,
    /// Complementarity targets for upper bounds.
    pub tgt_u: Vec<f64>,

    /// Primal direction.
    pub dw: Vec<f64>,
    /// Constraint multiplier direction.
    pub dy: Vec<f64>,
    /// Lower multiplier direction.
    pub dzl: Vec<f64>,
    /// Upper multiplier direction.
    pub dzu: Vec<f64>,
    /// Affine (predictor) primal direction.
    pub dw_aff: Vec<f64>,
    /// Affine lower multiplier direction.
    pub dzl_aff: Vec<f64>,
    /// Affine upper multiplier direction.
    pub dzu_aff: Vec<f64>,
    /// Scratch of length n + m.
    pub tmp_w: Vec<f64>,
    /// grad f + J^T y over x, as the KKT error computation last formed it.
    pub grad_lag: Vec<f64>,
    /// `grad_lag` is that of the current (x, y) and derivatives: set by the solver after
    /// the iteration's error computation, cleared when the iterate or its derivatives
    /// change, so the Newton right-hand side reuses it instead of forming J^T y again.
    pub grad_lag_fresh: bool,
    /// Scratch of length m.
    pub tmp_m: Vec<f64>,

    /// Best iterate so far (w).
    pub best_w: Vec<f64>,
    /// Best iterate's y.
    pub best_y: Vec<f64>,
    /// Best iterate's zl.
    pub best_zl: Vec<f64>,
    /// Best iterate's zu.
    pub best_zu: Vec<f64>,

    /// Iteration log (capacity max_iter + 2, never grows).
    pub log: Vec<IterLog>,
    /// Line-search filter of (violation, barrier objective) pairs.
    pub filter: Vec<(f64, f64)>,
    /// Free-mode progress filter of (violation, objective) pairs.
    pub progress: Vec<(f64, f64)>,
    /// Run the vector kernels in their AVX2 copy (same bits). Only
    /// [`Workspace::set_simd`] sets it, so it is never true on a CPU without AVX2.
    pub(crate) simd: bool,
}

impl Workspace {
    /// Marks which bounds entry j of w has (`has_lo`/`has_hi` and their f64 copies).
    pub fn set_bounds_present(&mut self, j: usize, lo: bool, hi: bool) {
        self.has_lo[j] = lo;
        self.has_hi[j] = hi;
        self.on_lo[j] = if lo { 1.0 } else { 0.0 };
        self.on_hi[j] = if hi { 1.0 } else { 0.0 };
    }

    /// Runs the vector kernels in their AVX2 copy when `on` and the CPU has AVX2 (the
    /// default where available); same bits either way.
    pub fn set_simd(&mut self, on: bool) {
        self.simd = on && crate::cpu::avx2_available();
    }

    /// Allocates every buffer for this NLP; `log_capacity` bounds the iteration log.
    pub fn new<P: Nlp + ?Sized>(nlp: &P, log_capacity: usize) -> Self {
        let NlpDims {
            n,
            m,
            nnz_jac,
            nnz_hess,
        } = nlp.dims();
        let nw = n + m;
        let mut jac_rows = vec![0; nnz_jac];
        let mut jac_cols = vec![0; nnz_jac];
        nlp.jac_structure(&mut jac_rows, &mut jac_cols);
        let mut hess_rows = vec![0; nnz_hess];
        let mut hess_cols = vec![0; nnz_hess];
        nlp.hess_structure(&mut hess_rows, &mut hess_cols);
        let v = |k: usize| vec![0.0; k];
        Self {
            n,
            m,
            g_l: v(m),
            g_u: v(m),
            is_eq: vec![false; m],
            lo: v(nw),
            hi: v(nw),
            lo_orig: v(nw),
            hi_orig: v(nw),
            has_lo: vec![false; nw],
            has_hi: vec![false; nw],
            on_lo: v(nw),
            on_hi: v(nw),
            n_compl: 0,
            jac_t: super::sparse::ColumnJacobian::new(&jac_rows, &jac_cols, n),
            jac_rows,
            jac_cols,
            hess_rows,
            hess_cols,
            w: v(nw),
            y: v(m),
            zl: v(nw),
            zu: v(nw),
            f: 0.0,
            grad: v(n),
            g: v(m),
            c: v(m),
            jac: v(nnz_jac),
            hess: v(nnz_hess),
            w_t: v(nw),
            g_t: v(m),
            c_t: v(m),
            primal_diag: v(n),
            dual_diag: v(m),
            sigma: v(nw),
            rhs_w: v(nw),
            sol_x: v(n),
            sol_y: v(m),
            tgt_l: v(nw),
            tgt_u: v(nw),
            dw: v(nw),
            dy: v(m),
            dzl: v(nw),
            dzu: v(nw),
            dw_aff: v(nw),
            dzl_aff: v(nw),
            dzu_aff: v(nw),
            tmp_w: v(nw),
            grad_lag: v(n),
            grad_lag_fresh: false,
            tmp_m: v(m),
            best_w: v(nw),
            best_y: v(m),
            best_zl: v(nw),
            best_zu: v(nw),
            log: Vec::with_capacity(log_capacity),
            filter: Vec::with_capacity(log_capacity),
            progress: Vec::with_capacity(log_capacity),
            simd: crate::cpu::avx2_available(),
        }
    }

    /// The NLP variables x (first n entries of w).
    pub fn x(&self) -> &[f64] {
        &self.w[..self.n]
    }
}
