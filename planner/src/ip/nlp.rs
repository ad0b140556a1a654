//! The problem interface the interior-point solver sees: a sparse NLP with exact first and
//! second derivatives, independent of vehicles.

/// Sizes of an [`Nlp`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NlpDims {
    /// Number of variables n.
    pub n: usize,
    /// Number of general constraints m.
    pub m: usize,
    /// Number of Jacobian entries (coordinate format).
    pub nnz_jac: usize,
    /// Number of lower-triangle Hessian entries (coordinate format).
    pub nnz_hess: usize,
}

/// A smooth NLP  min f(x)  s.t.  g_l <= g(x) <= g_u,  x_l <= x <= x_u.
///
/// Rows with `g_l == g_u` are equalities; infinite bounds are absent bounds. The Lagrangian
/// is `sigma f(x) + lambda^T g(x)` (IPOPT's convention). Sparsity structures are fixed:
/// `jac_structure` and `hess_structure` are called once at setup and every `eval_*` writes
/// values in the same order. Hessian entries are in the lower triangle (row >= col);
/// repeated (row, col) pairs are summed. Evaluations must not allocate.
pub trait Nlp {
    /// Problem sizes.
    fn dims(&self) -> NlpDims;
    /// Variable and constraint bounds (use +-f64::INFINITY for none).
    fn bounds(&self, x_l: &mut [f64], x_u: &mut [f64], g_l: &mut [f64], g_u: &mut [f64]);
    /// Starting point.
    fn initial_point(&self, x: &mut [f64]);
    /// Row and column of every Jacobian entry.
    fn jac_structure(&self, rows: &mut [usize], cols: &mut [usize]);
    /// Row and column (row >= col) of every lower-triangle Hessian entry.
    fn hess_structure(&self, rows: &mut [usize], cols: &mut [usize]);
    /// Objective f(x).
    fn eval_f(&mut self, x: &[f64]) -> f64;
    /// Objective gradient.
    fn eval_grad_f(&mut self, x: &[f64], grad: &mut [f64]);
    /// Constraint values g(x).
    fn eval_g(&mut self, x: &[f64], g: &mut [f64]);
    /// Constraint Jacobian values, in `jac_structure` order.
    fn eval_jac_g(&mut self, x: &[f64], vals: &mut [f64]);
    /// Hessian of `obj_factor * f + lambda^T g`, lower triangle, in `hess_structure` order.
    fn eval_hess(&mut self, x: &[f64], obj_factor: f64, lambda: &[f64], vals: &mut [f64]);
    /// Stage structure of an optimal-control NLP, which lets the solver use the Riccati
    /// KKT backend; `None` (the default) leaves it the general sparse one.
    fn stage_structure(&self) -> Option<super::kkt::StageStructure> {
        None
    }
}
