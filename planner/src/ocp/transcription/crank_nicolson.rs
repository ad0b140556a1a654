//! Crank-Nicolson (trapezoid) defect, A-stable and second order:
//! x_{k+1} - x_k - ds/2 (f(x_k, u_k; k_ref(s_k)) + f(x_{k+1}, u_k; k_ref(s_{k+1}))) = 0,
//! each row divided by the nominal of its state. Exact derivatives from the per-point jets
//! of f at both nodes (`point_form`); the num-dual oracle stays for checks.

use super::one_step::{one_step_scheme, FastPath, Rule, M, NL_IMPLICIT};
use super::point_form::{hessian_positions, PointForm};
use crate::model::{NU, NX};

/// Crank-Nicolson defect scheme (no stage variables, NX rows per interval).
#[derive(Debug, Clone, Copy, Default)]
pub struct CrankNicolson;

/// Local offset of x_{k+1} among (x_k, u_k, x_{k+1}).
const X1: usize = NX + NU;

/// The trapezoid as a point form: f at x_k (c = 0) and at x_{k+1} (c = 1), weights 1/2.
const FORM: PointForm<2> = PointForm {
    point_off: [0, X1],
    c: [0.0, 1.0],
    lin: &[[(X1, 1.0), (0, -1.0)]],
    w: &[[0.5, 0.5]],
    nl: &NL_IMPLICIT,
    pos: hessian_positions([0, X1], &NL_IMPLICIT),
};

const _: () = assert!(X1 + NX == M);

one_step_scheme!(
    CrankNicolson,
    Rule::CrankNicolson,
    "crank_nicolson",
    NL_IMPLICIT,
    FastPath::Points(&FORM)
);
