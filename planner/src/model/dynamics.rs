//! Equations of motion of the single-track model in curvilinear coordinates (paper eq. 1,
//! with the resolutions R1-R3 of `lc500.toml`), generic over the scalar so that f64,
//! first-order and second-order duals all run the same code.

use super::tire::{tire_forces, TireForces};
use super::{iu, ix, VehicleParams, NU, NX};
use crate::elementary as trig;
use num_dual::DualNum;

/// Time derivatives dx/dt of all nine states and the path speed sdot, plus the tire forces.
#[derive(Debug, Clone, Copy)]
pub struct TimeDerivatives<D> {
    /// dx/dt in state order [r, V, beta, V_wr, dFz, e, dpsi, s, t] (t row is 1).
    pub dxdt: [D; NX],
    /// Path speed sdot = V cos(dpsi) / (1 - kappa e) [m/s].
    pub sdot: D,
    /// Tire forces and slips at this point.
    pub tires: TireForces<D>,
}

/// Time derivatives of paper eq. (1) (the bracketed vector before division by sdot).
///
/// `kappa` is k_ref at the evaluation point (R8: the grid value). s and t are not read.
#[inline]
pub fn time_derivatives<D: DualNum<Primitive = f64> + Copy>(
    p: &VehicleParams,
    x: &[D; NX],
    u: &[D; NU],
    kappa: f64,
) -> TimeDerivatives<D> {
    let r = x[ix::R];
    let v = x[ix::V];
    let beta = x[ix::BETA];
    let dfz = x[ix::DFZ];
    let e = x[ix::E];
    let dpsi = x[ix::DPSI];
    let delta = u[iu::DELTA];
    let t_comb = u[iu::TCOMB];

    let tires = tire_forces(p, x, u);
    let TireForces {
        fxf, fyf, fxr, fyr, ..
    } = tires;

    let (sd, cd) = trig::sin_cos(delta);
    let (sb, cb) = trig::sin_cos(beta);
    let (sdb, cdb) = trig::sin_cos(delta - beta);

    // eq. (1) row 1: r_dot = (a (F_xf sin delta + F_yf cos delta) - b F_yr) / I_z.
    let r_dot = ((fxf * sd + fyf * cd) * p.a - fyr * p.b) / p.i_z;
    // eq. (1) row 2: V_dot = (F_xf cos(delta-beta) - F_yf sin(delta-beta) + F_xr cos beta
    //                        + F_yr sin beta) / m.
    let v_dot = (fxf * cdb - fyf * sdb + fxr * cb + fyr * sb) / p.m;
    // eq. (1) row 3: beta_dot = -r + (F_xf sin(delta-beta) + F_yf cos(delta-beta)
    //                         - F_xr sin beta + F_yr cos beta) / (m V).
    let beta_dot = (fxf * sdb + fyf * cdb - fxr * sb + fyr * cb) / (v * p.m) - r;
    // eq. (1) row 4 with R2 (only T_comb acts on the rear wheel):
    // V_wr_dot = R_w (T_comb - R_w F_xr) / I_w.
    let vwr_dot = (t_comb - fxr * p.r_w) * (p.r_w / p.i_w);
    // eq. (1) row 5: dFz_dot = -c_L (dFz - h_cg F_x,net / L),
    // F_x,net = F_xr + F_xf cos delta - F_yf sin delta.
    let fx_net = fxr + fxf * cd - fyf * sd;
    let dfz_dot = -(dfz - fx_net * (p.h_cg / p.l)) * p.c_l;
    // Path speed (paper, below eq. 1): sdot = V cos(dpsi) / (1 - kappa e).
    let (sp, cp) = trig::sin_cos(dpsi);
    let sdot = v * cp / (-(e * kappa) + 1.0);
    // eq. (1) rows 6-9: e_dot = V sin dpsi, dpsi_dot = beta_dot + r - kappa sdot,
    // s_dot = sdot, t_dot = 1 (R3).
    let e_dot = v * sp;
    let dpsi_dot = beta_dot + r - sdot * kappa;
    let one = D::from(1.0);
    TimeDerivatives {
        dxdt: [
            r_dot, v_dot, beta_dot, vwr_dot, dfz_dot, e_dot, dpsi_dot, sdot, one,
        ],
        sdot,
        tires,
    }
}

/// Spatial derivatives dx/ds = (dx/dt) / sdot of paper eq. (1) (R3: ds/ds = 1 and
/// dt/ds = (1 - kappa e) / (V cos dpsi)). s and t are not read.
#[inline]
pub fn spatial_derivatives<D: DualNum<Primitive = f64> + Copy>(
    p: &VehicleParams,
    x: &[D; NX],
    u: &[D; NU],
    kappa: f64,
) -> [D; NX] {
    let td = time_derivatives(p, x, u, kappa);
    let inv = td.sdot.recip();
    let mut out = td.dxdt;
    for o in out.iter_mut().take(ix::S) {
        *o *= inv;
    }
    // eq. (1) row 8: ds/ds = 1 exactly; row 9 (R3): dt/ds = 1/sdot.
    out[ix::S] = D::from(1.0);
    out[ix::T] = inv;
    out
}
