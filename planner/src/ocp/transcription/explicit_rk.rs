//! Explicit Runge-Kutta defects x_{k+1} - Phi(x_k) = 0 (multiple shooting with one RK step
//! per interval), each row divided by the nominal of its state.
//!
//! Within interval k the control u_k is held (zero-order hold, as in every other scheme)
//! and k_ref, known only at the nodes, is linearly interpolated: k_ref(s_k + c ds) =
//! (1 - c) kappa_k + c kappa_{k+1}, i.e. kappa_k / kappa_mid / kappa_{k+1} at the RK
//! nodes c = 0, 1/2, 1. (The road data is thus second-order accurate between nodes, which
//! caps RK4's global accuracy on curvature transitions, but never makes it inconsistent.)
//! Exact derivatives from lean jets carried through the stages (`rk_jets`): the stages
//! nest f inside f, so the rows are not linear in f at fixed points and the per-point
//! jets of the implicit schemes do not apply; the num-dual oracle stays for checks. Neither scheme is A-stable: on the stiff
//! vehicle dynamics they need small steps (paper Sec. IV).

use super::one_step::{one_step_scheme, FastPath, Rule, NL_EXPLICIT};
use super::rk_jets::Stages;

/// Explicit midpoint RK2 defect scheme (no stage variables, NX rows per interval).
#[derive(Debug, Clone, Copy, Default)]
pub struct ExplicitRk2;

/// Classical explicit RK4 defect scheme (no stage variables, NX rows per interval).
#[derive(Debug, Clone, Copy, Default)]
pub struct ExplicitRk4;

one_step_scheme!(
    ExplicitRk2,
    Rule::Rk2,
    "rk2",
    NL_EXPLICIT,
    FastPath::Stages(Stages::Rk2)
);
one_step_scheme!(
    ExplicitRk4,
    Rule::Rk4,
    "rk4",
    NL_EXPLICIT,
    FastPath::Stages(Stages::Rk4)
);
