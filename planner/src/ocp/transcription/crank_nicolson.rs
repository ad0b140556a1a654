//! Crank-Nicolson (trapezoid) defect, A-stable and second order:
//! x_{k+1} - x_k - ds/2 (f(x_k, u_k; k_ref(s_k)) + f(x_{k+1}, u_k; k_ref(s_{k+1}))) = 0,
//! each row divided by the nominal of its state. Exact derivatives by the num-dual oracle.

use super::one_step::{one_step_scheme, Rule, NL_IMPLICIT};

/// Crank-Nicolson defect scheme (no stage variables, NX rows per interval).
#[derive(Debug, Clone, Copy, Default)]
pub struct CrankNicolson;

one_step_scheme!(
    CrankNicolson,
    Rule::CrankNicolson,
    "crank_nicolson",
    NL_IMPLICIT
);
