//! One stage of the backward sweep in its common case, Delta_k = 0 and J_k = [-I, G]
//! (implicit Euler, the dual regularization off): the steps of [`super::stage`] written over
//! column arrays (`[[f64; R]; C]`, one array per column), so that every product is a run of
//! contiguous column updates and only the lower triangles of symmetric results are formed.
//!
//! With M^-1 = diag(F, I) [[0, I], [I, -P^]] diag(F^T, I) the pair step is
//!
//! ```text
//! Q = W~ + [C^, -C^ G] + [C^, -C^ G]^T + [-I, G]^T P^ [-I, G],   C^ = Y F,
//! ```
//!
//! and Y is nonzero only in the columns that some Hessian or path-row entry couples across
//! stages (`y_live`), so the products with Y and R run over those columns alone.

use super::kernels::{dot, ldlt_factor, ldlt_solve_vec, mm_acc, mm_acc_bt, sym_lower};
use super::stage::{StageFactor, StageInverse};
use crate::ip::kkt::{Inertia, KktError};
use nalgebra::{SMatrix, SVector};

/// The common stage: the pair step ([`pair_update`]), u_k ([`control_update`]) and u_k's
/// coupling to z_{k-1} ([`coupling_update`]). On entry `q` holds W_k - pending, `p` and
/// `yt` the state from stage k + 1; on exit they hold P_k, Y_{k-1}^T and the pending update
/// of W_{k-1}.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn fast_stage<const NX: usize, const NU: usize, const NZ: usize>(
    fac: &mut StageFactor<NX, NU, NZ>,
    p: &mut SMatrix<f64, NX, NX>,
    yt: &mut SMatrix<f64, NX, NZ>,
    pending: &mut SMatrix<f64, NZ, NZ>,
    inv: &StageInverse<NX>,
    j: &SMatrix<f64, NX, NZ>,
    q: &mut SMatrix<f64, NZ, NZ>,
    prev: Option<&SMatrix<f64, NZ, NZ>>,
    y_live: &[bool; NZ],
    inertia: &mut Inertia,
) -> Result<(), KktError> {
    let phat = pair_update::<NX, NU, NZ>(p, yt, inv, j, q, y_live, inertia);
    let (l, d, qxu, gm) = control_update::<NX, NU, NZ>(p, q, inertia)?;
    fac.zero_delta = true;
    fac.lambda_first = false;
    fac.a22.data.0 = phat.map(|col| col.map(|v| -v));
    fac.yt = *yt;
    fac.quu_l = l;
    fac.quu_d = d;
    fac.q_ux = SMatrix::from_fn(|k, c| qxu[k][c]);
    let Some(xc) = prev else {
        fac.r = SMatrix::zeros();
        return Ok(());
    };
    coupling_update(fac, yt, pending, xc, &l, &d, &gm, y_live);
    Ok(())
}

/// The pair step: P^ = F^T (P F) (its pair has inertia (NX, NX)), C^^T = F^T Y^T in the
/// live columns, and Q += the pair's update (lower triangle of Q_xx and Q_uu, all of
/// Q_ux). Returns P^.
#[inline(always)]
fn pair_update<const NX: usize, const NU: usize, const NZ: usize>(
    p: &SMatrix<f64, NX, NX>,
    yt: &SMatrix<f64, NX, NZ>,
    inv: &StageInverse<NX>,
    j: &SMatrix<f64, NX, NZ>,
    q: &mut SMatrix<f64, NZ, NZ>,
    y_live: &[bool; NZ],
    inertia: &mut Inertia,
) -> [[f64; NX]; NX] {
    let ft = &inv.ft.data.0;
    // P^ = F^T (P F): its pair has inertia (NX, NX).
    let mut pf = [[0.0; NX]; NX];
    mm_acc_bt(&mut pf, &p.data.0, ft);
    let mut phat = [[0.0; NX]; NX];
    mm_acc(&mut phat, ft, &pf, 1.0);
    sym_lower(&mut phat);
    inertia.positive += NX;
    inertia.negative += NX;
    // C^^T = F^T Y^T, in the columns where Y^T can be nonzero.
    let mut ct = [[0.0; NX]; NZ];
    for ((oc, yc), _) in ct
        .iter_mut()
        .zip(&yt.data.0)
        .zip(y_live)
        .filter(|(_, &l)| l)
    {
        let mut acc = [0.0; NX];
        for (fk, &y) in ft.iter().zip(yc) {
            for (o, &x) in acc.iter_mut().zip(fk) {
                *o += x * y;
            }
        }
        *oc = acc;
    }
    let y_states_zero = !y_live[..NX].contains(&true);
    let jc = &j.data.0;
    let g: [[f64; NX]; NU] = std::array::from_fn(|c| jc[NX + c]);
    // Q = W~ + [C^, -C^ G] + [C^, -C^ G]^T + [-I, G]^T P^ [-I, G], blockwise; S = P^ + C^_x.
    let mut pg = [[0.0; NX]; NU];
    mm_acc(&mut pg, &phat, &g, 1.0);
    let sg = if y_states_zero {
        pg
    } else {
        let mut s = phat;
        for (c, col) in s.iter_mut().enumerate() {
            for (r, v) in col.iter_mut().enumerate() {
                *v += ct[r][c];
            }
        }
        let mut sg = [[0.0; NX]; NU];
        mm_acc(&mut sg, &s, &g, 1.0);
        sg
    };
    let qc = &mut q.data.0;
    for c in 0..NX {
        for r in c..NX {
            qc[c][r] += phat[c][r] + (ct[c][r] + ct[r][c]);
        }
    }
    for c in 0..NU {
        for r in 0..NX {
            qc[NX + c][r] += ct[NX + c][r] - sg[c][r];
        }
        for r in c..NU {
            let gpg = dot(&g[r], &pg[c]);
            let cg = dot(&ct[NX + r], &g[c]) + dot(&ct[NX + c], &g[r]);
            qc[NX + c][NX + r] += gpg - cg;
        }
    }
    phat
}

/// Factors and solves of one stage's u_k step, as column arrays.
type Control<const NX: usize, const NU: usize> = (
    SMatrix<f64, NU, NU>,
    SVector<f64, NU>,
    [[f64; NX]; NU],
    [[f64; NU]; NX],
);

/// u_k: Q_uu = L D L^T, g = Q_uu^-1 Q_ux, P_k = Q_xx - Q_xu g (written into `p`). Returns
/// (L, D, Q_xu as columns, g as columns).
#[inline(always)]
fn control_update<const NX: usize, const NU: usize, const NZ: usize>(
    p: &mut SMatrix<f64, NX, NX>,
    q: &SMatrix<f64, NZ, NZ>,
    inertia: &mut Inertia,
) -> Result<Control<NX, NU>, KktError> {
    let qc = &q.data.0;
    let quu = SMatrix::<f64, NU, NU>::from_fn(|r, c| qc[NX + c.min(r)][NX + c.max(r)]);
    let (l, d, neg) = ldlt_factor(&quu)?;
    inertia.positive += NU - neg;
    inertia.negative += neg;
    let qxu: [[f64; NX]; NU] = std::array::from_fn(|k| std::array::from_fn(|r| qc[NX + k][r]));
    let mut gm = [[0.0; NU]; NX];
    for (c, gc) in gm.iter_mut().enumerate() {
        let mut v = SVector::<f64, NU>::from_fn(|k, _| qxu[k][c]);
        ldlt_solve_vec(&l, &d, &mut v);
        *gc = v.data.0[0];
    }
    // Written in place (no temporaries to copy: these blocks are the sweep's hot memory).
    let pc = &mut p.data.0;
    for (pcol, qcol) in pc.iter_mut().zip(qc.iter()) {
        pcol.copy_from_slice(&qcol[..NX]);
    }
    mm_acc(pc, &qxu, &gm, -1.0);
    sym_lower(pc);
    Ok((l, d, qxu, gm))
}

/// u_k's coupling to z_{k-1}: R = X_{k-1}[u rows]^T, Y_{k-1}^T = X_{k-1}[x rows] - g^T R^T
/// and W_{k-1} -= R Q_uu^-1 R^T (into `pending`).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn coupling_update<const NX: usize, const NU: usize, const NZ: usize>(
    fac: &mut StageFactor<NX, NU, NZ>,
    yt: &mut SMatrix<f64, NX, NZ>,
    pending: &mut SMatrix<f64, NZ, NZ>,
    xc: &SMatrix<f64, NZ, NZ>,
    l: &SMatrix<f64, NU, NU>,
    d: &SVector<f64, NU>,
    gm: &[[f64; NU]; NX],
    y_live: &[bool; NZ],
) {
    let xcc = &xc.data.0;
    for (k, rcol) in fac.r.data.0.iter_mut().enumerate() {
        for (o, xcol) in rcol.iter_mut().zip(xcc.iter()) {
            *o = xcol[NX + k];
        }
    }
    let rc = &fac.r.data.0;
    // R^T as columns (row i of R per column), for g^T R^T and Q_uu^-1 R^T.
    let rtc: [[f64; NU]; NZ] = std::array::from_fn(|i| std::array::from_fn(|k| rc[k][i]));
    let gt: [[f64; NX]; NU] = std::array::from_fn(|k| std::array::from_fn(|j| gm[j][k]));
    let ytn = &mut yt.data.0;
    for (ycol, xcol) in ytn.iter_mut().zip(xcc.iter()) {
        ycol.copy_from_slice(&xcol[..NX]);
    }
    // Only the live columns of X_{k-1} (hence of R^T) can be nonzero: the products below
    // run over them alone. Elsewhere they would add exact zeros (+0 on a +0 start, so the
    // bits, signed zeros included, are those of the full products).
    let pd = &mut pending.data.0;
    for col in pd.iter_mut() {
        *col = [0.0; NZ];
    }
    for (i, _) in y_live.iter().enumerate().filter(|(_, &l)| l) {
        let mut acc = ytn[i];
        for (gk, &r) in gt.iter().zip(&rtc[i]) {
            let s = -r;
            for (o, &x) in acc.iter_mut().zip(gk) {
                *o += x * s;
            }
        }
        ytn[i] = acc;
        let mut v = SVector::<f64, NU>::from(rtc[i]);
        ldlt_solve_vec(l, d, &mut v);
        let rt = v.data.0[0];
        let mut col = [0.0; NZ];
        for (rk, &t) in rc.iter().zip(&rt) {
            for (o, &x) in col.iter_mut().zip(rk) {
                *o += x * t;
            }
        }
        pd[i] = col;
    }
    sym_lower(pd);
}
