//! One stage of the backward sweep in general form, and the factors it keeps.
//!
//! At stage k the sweep holds P (the eliminated future's weight on x_{k+1}) and the
//! coupling Y of z_k to x_{k+1}, and eliminates the pair (x_{k+1}, lambda_k) through
//!
//! ```text
//! M = [[P, E^T], [E, -Delta]],    C = [Y, J^T]    (z_k's coupling to the pair),
//! Q = W~ - C M^-1 C^T             (z_k's block after the elimination),
//! ```
//!
//! with F = E^-1 and P^ = F^T P F, M^-1 = diag(F, I) [[P^, I], [I, -Delta]]^-1 diag(F^T, I).
//! Then u_k: Q_uu = L D L^T, P_k = Q_xx - Q_xu Q_uu^-1 Q_ux, and u_k's coupling R to z_{k-1}
//! turns into Y_{k-1} and the pending update of W_{k-1}. The common case (Delta = 0,
//! J = [-I, G]) has its own column-array version in [`super::fast_stage`].

use super::inverse::invert;
use super::kernels::{ldlt_factor, ldlt_solve_cols, mul_nn, mul_tn, symmetrize};
use crate::ip::kkt::{Inertia, KktError};
use nalgebra::{SMatrix, SVector};

/// E_k^-1, computed with unit k and reused while E_k keeps its bits (the
/// inertia-correcting refactorizations of an iteration change only diagonals).
#[derive(Debug, Clone)]
pub(super) struct StageInverse<const NX: usize> {
    /// F^T = E_k^-T, the only copy kept: its columns are F's rows, which the sweep's
    /// products read as contiguous vectors (F's entries they only broadcast).
    pub(super) ft: SMatrix<f64, NX, NX>,
    /// The E that `ft` inverts (NaN until the first success).
    pub(super) e_in: SMatrix<f64, NX, NX>,
    /// Whether E_k of the current assembly is invertible (`ft` is its inverse's transpose).
    pub(super) ok: bool,
    /// J_k = [-I, G] in the current assembly (see [`super::kernels::minus_identity_head`]).
    pub(super) j_minus_identity: bool,
}

impl<const NX: usize> Default for StageInverse<NX> {
    fn default() -> Self {
        Self {
            ft: SMatrix::zeros(),
            e_in: SMatrix::repeat(f64::NAN),
            ok: false,
            j_minus_identity: false,
        }
    }
}

/// Factors of one stage, kept for the solves.
#[derive(Debug, Clone)]
pub(super) struct StageFactor<const NX: usize, const NU: usize, const NZ: usize> {
    // J_k stays in the arena, and F^T = E_k^-T and whether J_k = [-I, G] in the stage's
    // [`StageInverse`], until the next assembly; the solves read them there.
    /// Delta_k = 0: [[P^, I], [I, 0]]^-1 = [[0, I], [I, -P^]] and a11, a12 are unused.
    pub(super) zero_delta: bool,
    /// Blocks of [[P^, I], [I, -Delta]]^-1 = [[a11, a12], [a12^T, a22]].
    pub(super) a11: SMatrix<f64, NX, NX>,
    pub(super) a12: SMatrix<f64, NX, NX>,
    pub(super) a22: SMatrix<f64, NX, NX>,
    /// Large uniform Delta = delta I (restoration): lambda_k is eliminated first and
    /// S_x = P + E^T E / delta = sx_l diag(sx_d) sx_l^T; `e` and `delta` kept for solves.
    pub(super) lambda_first: bool,
    pub(super) sx_l: SMatrix<f64, NX, NX>,
    pub(super) sx_d: SVector<f64, NX>,
    pub(super) e: SMatrix<f64, NX, NX>,
    pub(super) delta: f64,
    /// Coupling Y of z_k to x_{k+1} at elimination time, stored transposed (Y^T, NX x NZ),
    /// and C^ = Y F.
    pub(super) yt: SMatrix<f64, NX, NZ>,
    pub(super) chat: SMatrix<f64, NZ, NX>,
    /// Q_uu = L D L^T (unit lower L).
    pub(super) quu_l: SMatrix<f64, NU, NU>,
    pub(super) quu_d: SVector<f64, NU>,
    /// Q_ux and the coupling R of u_k to z_{k-1}.
    pub(super) q_ux: SMatrix<f64, NU, NX>,
    pub(super) r: SMatrix<f64, NZ, NU>,
}

impl<const NX: usize, const NU: usize, const NZ: usize> Default for StageFactor<NX, NU, NZ> {
    fn default() -> Self {
        Self {
            zero_delta: true,
            lambda_first: false,
            sx_l: SMatrix::zeros(),
            sx_d: SVector::zeros(),
            e: SMatrix::zeros(),
            delta: 0.0,
            a11: SMatrix::zeros(),
            a12: SMatrix::zeros(),
            a22: SMatrix::zeros(),
            yt: SMatrix::zeros(),
            chat: SMatrix::zeros(),
            quu_l: SMatrix::zeros(),
            quu_d: SVector::zeros(),
            q_ux: SMatrix::zeros(),
            r: SMatrix::zeros(),
        }
    }
}

/// Eliminates the pair (x_{k+1}, lambda_k) (`fac` holds Y^T on entry; E_k, J_k and the
/// stage inverse `inv` are read in place) and returns z_k's block after the update,
/// Q = W~ - C M^-1 C^T, in `q`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn eliminate_pair<const NX: usize, const NU: usize, const NZ: usize>(
    fac: &mut StageFactor<NX, NU, NZ>,
    p: &SMatrix<f64, NX, NX>,
    e: &SMatrix<f64, NX, NX>,
    inv: &StageInverse<NX>,
    j: &SMatrix<f64, NX, NZ>,
    delta: &SVector<f64, NX>,
    q: &mut SMatrix<f64, NZ, NZ>,
    inertia: &mut Inertia,
) -> Result<(), KktError> {
    let f = &inv.ft.transpose();
    let mut phat = mul_tn(f, &mul_nn(p, f));
    symmetrize(&mut phat);
    // C^ = Y F (Y is zero outside the few rows of z_k that couple to x_{k+1}).
    let y = fac.yt.transpose();
    fac.chat = mul_nn(&y, f);
    fac.zero_delta = delta.iter().all(|&d| d == 0.0);
    fac.lambda_first = false;
    if fac.zero_delta {
        pair_unregularized(fac, phat, inv, j, q, inertia);
        return Ok(());
    }
    // A large uniform Delta = delta I (the restoration phase's delta_c = 1): eliminate
    // lambda_k first, M^-1 through S_x = P + E^T E / delta; the pair formula would lose
    // digits in K P^ when delta P^ is large.
    let d0 = delta[0];
    if d0 > 0.0 && delta.iter().all(|&d| d == d0) && d0 * phat.amax() > 1.0 {
        return pair_lambda_first(fac, p, e, j, y, d0, q, inertia);
    }
    pair_regularized(fac, phat, j, delta, q, inertia)
}

/// The pair step with Delta = 0: M^-1 = diag(F, I) [[0, I], [I, -P^]] diag(F^T, I), inertia
/// (NX, NX). With J = [-I, G], Q = W~ - C^J - (C^J)^T + J^T P^ J is written blockwise.
#[inline(always)]
fn pair_unregularized<const NX: usize, const NU: usize, const NZ: usize>(
    fac: &mut StageFactor<NX, NU, NZ>,
    phat: SMatrix<f64, NX, NX>,
    inv: &StageInverse<NX>,
    j: &SMatrix<f64, NX, NZ>,
    q: &mut SMatrix<f64, NZ, NZ>,
    inertia: &mut Inertia,
) {
    inertia.positive += NX;
    inertia.negative += NX;
    fac.a22 = -phat;
    if inv.j_minus_identity {
        let g: SMatrix<f64, NX, NU> = j.fixed_view::<NX, NU>(0, NX).into_owned();
        let cg = mul_nn(&fac.chat, &g);
        let pg = mul_nn(&phat, &g);
        let gpg = mul_tn(&g, &pg);
        for c in 0..NX {
            for r in 0..NZ {
                q[(r, c)] += fac.chat[(r, c)];
                q[(c, r)] += fac.chat[(r, c)];
            }
        }
        for c in 0..NU {
            for r in 0..NZ {
                q[(r, NX + c)] -= cg[(r, c)];
                q[(NX + c, r)] -= cg[(r, c)];
            }
        }
        for c in 0..NX {
            for r in 0..NX {
                q[(r, c)] += phat[(r, c)];
            }
        }
        for c in 0..NU {
            for r in 0..NX {
                q[(r, NX + c)] -= pg[(r, c)];
                q[(NX + c, r)] -= pg[(r, c)];
            }
            for r in 0..NU {
                q[(NX + r, NX + c)] += gpg[(r, c)];
            }
        }
    } else {
        let cj = fac.chat * j;
        *q -= cj + cj.transpose();
        *q += j.tr_mul(&(phat * j));
    }
    symmetrize(q);
}

/// The pair step with Delta = `d0` I large: lambda_k first, through
/// S_x = P + E^T E / delta = L D L^T, whose negative pivots add to the pair's NX.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn pair_lambda_first<const NX: usize, const NU: usize, const NZ: usize>(
    fac: &mut StageFactor<NX, NU, NZ>,
    p: &SMatrix<f64, NX, NX>,
    e: &SMatrix<f64, NX, NX>,
    j: &SMatrix<f64, NX, NZ>,
    y: SMatrix<f64, NZ, NX>,
    d0: f64,
    q: &mut SMatrix<f64, NZ, NZ>,
    inertia: &mut Inertia,
) -> Result<(), KktError> {
    let mut sx = p + e.tr_mul(e) / d0;
    symmetrize(&mut sx);
    let (l, dd, neg) = ldlt_factor(&sx)?;
    inertia.positive += NX - neg;
    inertia.negative += NX + neg;
    // Q = W~ - V S_x^-1 V^T + J^T J / delta with V = Y + J^T E / delta.
    let v = y + j.tr_mul(e) / d0;
    let mut gvt = v.transpose();
    ldlt_solve_cols(&l, &dd, &mut gvt);
    *q -= v * gvt;
    *q += j.tr_mul(j) / d0;
    symmetrize(q);
    fac.lambda_first = true;
    fac.sx_l = l;
    fac.sx_d = dd;
    fac.e = *e;
    fac.delta = d0;
    Ok(())
}

/// The pair step with Delta != 0 (a raised dual regularization): the general blocks of
/// [[P^, I], [I, -Delta]]^-1, inertia from I + Delta^1/2 P^ Delta^1/2 = L D L^T.
#[inline(always)]
fn pair_regularized<const NX: usize, const NU: usize, const NZ: usize>(
    fac: &mut StageFactor<NX, NU, NZ>,
    phat: SMatrix<f64, NX, NX>,
    j: &SMatrix<f64, NX, NZ>,
    delta: &SVector<f64, NX>,
    q: &mut SMatrix<f64, NZ, NZ>,
    inertia: &mut Inertia,
) -> Result<(), KktError> {
    let sqrt_d = delta.map(|d| d.max(0.0).sqrt());
    let mut ts = phat;
    for c in 0..NX {
        for r in 0..NX {
            ts[(r, c)] *= sqrt_d[r] * sqrt_d[c];
        }
        ts[(c, c)] += 1.0;
    }
    let (ts_l, ts_d, neg) = ldlt_factor(&ts)?;
    inertia.positive += NX - neg;
    inertia.negative += NX + neg;
    // K = (I + P^ Delta)^-1; [[Delta K, K^T], [K, -K P^]].
    let uniform = delta.iter().all(|&d| d == delta[0]);
    let k = if uniform {
        // Uniform Delta (the solver's case): I + P^ Delta = T_s, inverted through the
        // LDL^T already computed (no pivot threshold on a badly scaled P^).
        let mut k = SMatrix::<f64, NX, NX>::identity();
        ldlt_solve_cols(&ts_l, &ts_d, &mut k);
        k
    } else {
        let mut t = phat;
        for c in 0..NX {
            for r in 0..NX {
                t[(r, c)] *= delta[c];
            }
            t[(c, c)] += 1.0;
        }
        invert(&t).ok_or(KktError::Singular)?
    };
    let mut a11 = k;
    for r in 0..NX {
        for c in 0..NX {
            a11[(r, c)] *= delta[r];
        }
    }
    symmetrize(&mut a11);
    let mut a22 = -(k * phat);
    symmetrize(&mut a22);
    fac.a11 = a11;
    fac.a12 = k.transpose();
    fac.a22 = a22;
    // S = C^ a11 C^T + C^ a12 J + J^T a12^T C^T + J^T a22 J.
    let cross = fac.chat * fac.a12 * j;
    *q -= fac.chat * a11 * fac.chat.transpose() + cross + cross.transpose();
    *q -= j.tr_mul(&(a22 * j));
    symmetrize(q);
    Ok(())
}

/// One stage in general form: the pair step ([`eliminate_pair`]), then u_k. On entry `q`
/// holds W_k - pending, `p` and `yt` the state from stage k + 1; on exit they hold P_k,
/// Y_{k-1}^T and (for k > 0) the pending update of W_{k-1}.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn general_stage<const NX: usize, const NU: usize, const NZ: usize>(
    fac: &mut StageFactor<NX, NU, NZ>,
    p: &mut SMatrix<f64, NX, NX>,
    yt: &mut SMatrix<f64, NX, NZ>,
    pending: &mut SMatrix<f64, NZ, NZ>,
    inv: &StageInverse<NX>,
    e: &SMatrix<f64, NX, NX>,
    j: &SMatrix<f64, NX, NZ>,
    delta: &SVector<f64, NX>,
    q: &mut SMatrix<f64, NZ, NZ>,
    prev: Option<&SMatrix<f64, NZ, NZ>>,
    inertia: &mut Inertia,
) -> Result<(), KktError> {
    fac.yt = *yt;
    eliminate_pair(fac, p, e, inv, j, delta, q, inertia)?;
    // u_k.
    let quu: SMatrix<f64, NU, NU> = q.fixed_view::<NU, NU>(NX, NX).into_owned();
    let (l, d, neg) = ldlt_factor(&quu)?;
    inertia.positive += NU - neg;
    inertia.negative += neg;
    fac.quu_l = l;
    fac.quu_d = d;
    fac.q_ux = q.fixed_view::<NU, NX>(NX, 0).into_owned();
    // g = Q_uu^-1 Q_ux.
    let mut g = fac.q_ux;
    ldlt_solve_cols(&l, &d, &mut g);
    *p = q.fixed_view::<NX, NX>(0, 0) - fac.q_ux.tr_mul(&g);
    symmetrize(p);
    if let Some(xc) = prev {
        // Y = X_{k-1}[x rows]^T - R g and W_{k-1} -= R Q_uu^-1 R^T.
        fac.r = xc.fixed_view::<NU, NZ>(NX, 0).transpose();
        *yt = xc.fixed_view::<NX, NZ>(0, 0) - g.tr_mul(&fac.r.transpose());
        let mut rt = fac.r.transpose();
        ldlt_solve_cols(&l, &d, &mut rt);
        *pending = fac.r * rt;
        symmetrize(pending);
    } else {
        fac.r = SMatrix::zeros();
    }
    Ok(())
}
