//! Fast exact derivatives of the single-interval schemes whose defect rows are linear in
//! the states and in f at P points of the interval (Crank-Nicolson: the two nodes;
//! Gauss-Legendre: the stage states). Row block r (NX rows) reads
//!
//! `sum_(o, a) in lin_r  a y_o - ds sum_p w_rp f(y_p, u_k; k_ref(s_k + c_p ds))`,
//!
//! each row divided by the nominal of its state, where y_o is the state at local offset o.
//! The values and the patterns stay those of [`super::dense`] (dense Jacobian block over
//! the M local variables, dense lower Hessian triangle over the nonlinear ones); only the
//! derivative values come from the per-point jets of [`super::point_jets`] instead of
//! num-dual duals over all local variables.

use super::one_step::kappa_at;
use super::point_jets::{add_lower, physical, scaled_gradient, NIN, NXIN};
use super::SchemeContext;
use crate::model::NX;
use crate::ocp::fast;
use crate::ocp::scaling::X_NOMINAL;

/// The rows of a scheme as linear terms and f weights (see the module docs).
#[derive(Debug, Clone, Copy)]
pub(crate) struct PointForm<const P: usize> {
    /// Local offset (among the M local variables) of each point's state.
    pub point_off: [usize; P],
    /// Fraction of the interval at each point (k_ref is interpolated linearly there).
    pub c: [f64; P],
    /// Linear terms of each row block: (local offset of a state, coefficient).
    pub lin: &'static [[(usize, f64); 2]],
    /// f weight of each point in each row block.
    pub w: &'static [[f64; P]],
    /// The local variables of the Hessian pattern, in pattern order (those entering
    /// nonlinearly).
    pub nl: &'static [usize],
    /// Position in `nl` of input l of each point ([`hessian_positions`]).
    pub pos: [[usize; NIN]; P],
}

/// Position in `nl` of input l (r..dpsi of the point's state, then u_k) of each point whose
/// state sits at local offset `point_off[p]`; evaluated when a form is defined, so an input
/// missing from `nl` fails the build.
pub(crate) const fn hessian_positions<const P: usize>(
    point_off: [usize; P],
    nl: &[usize],
) -> [[usize; NIN]; P] {
    let mut out = [[0; NIN]; P];
    let mut p = 0;
    while p < P {
        let mut l = 0;
        while l < NIN {
            let c = local_col(point_off[p], l);
            let mut q = 0;
            while q < nl.len() && nl[q] != c {
                q += 1;
            }
            assert!(
                q < nl.len(),
                "an input of a point is not among the nonlinear variables"
            );
            out[p][l] = q;
            l += 1;
        }
        p += 1;
    }
    out
}

/// Local offset of u_k among the M local variables (after x_k).
const U_OFF: usize = NX;

/// Local column of input l (0..7 state, 7..10 control) of the point at state offset `off`.
#[inline(always)]
const fn local_col(off: usize, l: usize) -> usize {
    if l < NXIN {
        off + l
    } else {
        U_OFF + l - NXIN
    }
}

impl<const P: usize> PointForm<P> {
    /// Physical state and control at point p of interval k.
    #[inline(always)]
    fn point(&self, cx: &SchemeContext, k: usize, z: &[f64], cols: &[usize], p: usize) -> Pt {
        let off = self.point_off[p];
        let (x, u) = physical(cx, k, z, |i| cols[off + i]);
        Pt {
            x,
            u,
            kappa: kappa_at(cx.kappa, k, self.c[p]),
        }
    }

    /// Dense Jacobian values of interval k (row-major over the M local columns `cols`).
    pub fn jac(&self, cx: &SchemeContext, k: usize, z: &[f64], cols: &[usize], vals: &mut [f64]) {
        let m = cols.len();
        vals[..self.lin.len() * NX * m].fill(0.0);
        for (r, lin) in self.lin.iter().enumerate() {
            for &(off, a) in lin {
                for i in 0..NX {
                    vals[(r * NX + i) * m + off + i] += a;
                }
            }
        }
        for p in 0..P {
            let pt = self.point(cx, k, z, cols, p);
            let g = scaled_gradient(cx, &pt.x, &pt.u, pt.kappa);
            for (r, w) in self.w.iter().enumerate() {
                let coef = -cx.ds * w[p];
                for (i, gi) in g.iter().enumerate() {
                    let row = &mut vals[(r * NX + i) * m..(r * NX + i + 1) * m];
                    for (l, gl) in gi.iter().enumerate() {
                        row[local_col(self.point_off[p], l)] += coef * gl;
                    }
                }
            }
        }
    }

    /// Dense lower-triangle Hessian of `lambda^T defect` over the nonlinear local variables
    /// `nl` (in pattern order; `cols` are the global columns of the local variables).
    pub fn hess(
        &self,
        cx: &SchemeContext,
        (k, z): (usize, &[f64]),
        cols: &[usize],
        lambda: &[f64],
        vals: &mut [f64],
    ) {
        let l = self.nl.len();
        vals[..l * (l + 1) / 2].fill(0.0);
        for p in 0..P {
            let mut w = [0.0; NX];
            for (i, wi) in w.iter_mut().enumerate() {
                let mut s = 0.0;
                for (r, wr) in self.w.iter().enumerate() {
                    s += lambda[r * NX + i] * wr[p];
                }
                *wi = -cx.ds * s / X_NOMINAL[i];
            }
            let pt = self.point(cx, k, z, cols, p);
            let h = fast::defect_hessian(cx.vehicle, &pt.x, &pt.u, pt.kappa, &w);
            add_lower(&h, &self.pos[p], vals);
        }
    }
}

/// One point of an interval in physical units.
struct Pt {
    x: [f64; NX],
    u: [f64; crate::model::NU],
    kappa: f64,
}
