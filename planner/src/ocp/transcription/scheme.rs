//! The interface between a transcription and its integrator: a [`DefectScheme`] supplies the
//! dynamics defect rows of one interval x_{k+1} - x_k - (integral of f over [s_k, s_{k+1}]),
//! evaluated with the read-only data of a [`SchemeContext`].

use crate::model::VehicleParams;
use crate::ocp::layout::Layout;

/// Read-only problem data a [`DefectScheme`] evaluates with.
#[derive(Debug, Clone, Copy)]
pub struct SchemeContext<'a> {
    /// Vehicle parameters.
    pub vehicle: &'a VehicleParams,
    /// Node spacing ds \[m\].
    pub ds: f64,
    /// k_ref at every node (R8).
    pub kappa: &'a [f64],
    /// Decision-vector layout.
    pub layout: Layout,
    /// Evaluate derivatives with the num-dual oracle instead of the fast path.
    pub oracle: bool,
}

/// Which implementation evaluates the exact Jacobian and Hessian.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Derivatives {
    /// Structured hand-written jets of [`crate::ocp::fast`] (default).
    #[default]
    Fast,
    /// num-dual duals through the generic model (the reference implementation).
    Oracle,
}

/// The integrator-specific part of a transcription: the defect rows of one interval.
///
/// All values are in scaled units; Jacobian values are written in `jac_pattern` order and
/// Hessian values (of `lambda^T defect_k`, lower triangle, global indices) in `hess_pattern`
/// order. Patterns are queried once at construction; evaluations must not allocate.
pub trait DefectScheme: Sync {
    /// Extra variables per interval (collocation stage states); 0 for single-step schemes.
    const STAGE_VARS: usize;
    /// Defect rows per interval.
    const ROWS: usize;
    /// Short name of the scheme.
    fn name(&self) -> &'static str;
    /// Name of defect row `row` (for diagnostics).
    fn row_name(&self, row: usize) -> &'static str;
    /// Jacobian pattern of interval k as (local row, global column) pairs.
    fn jac_pattern(&self, lay: &Layout, k: usize, push: &mut dyn FnMut(usize, usize));
    /// Defect values of interval k.
    fn eval(&self, cx: &SchemeContext, k: usize, z: &[f64], out: &mut [f64]);
    /// Jacobian values of interval k in `jac_pattern` order.
    fn jac(&self, cx: &SchemeContext, k: usize, z: &[f64], vals: &mut [f64]);
    /// Hessian pattern of interval k as global (row >= col) pairs.
    fn hess_pattern(&self, lay: &Layout, k: usize, push: &mut dyn FnMut(usize, usize));
    /// Hessian of `lambda^T defect_k` in `hess_pattern` order (overwrites `vals`).
    fn hess(&self, cx: &SchemeContext, k: usize, z: &[f64], lambda: &[f64], vals: &mut [f64]);
    /// Fills the stage variables of interval k of a starting point (default: nothing).
    fn guess_stage_vars(&self, _cx: &SchemeContext, _k: usize, _z: &mut [f64]) {}
}
