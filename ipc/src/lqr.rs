//! Speed-scheduled LQR on the tracking-error dynamics.
//!
//! The error z = x - x_ref over the states [r, V, beta, V_wr, e, dpsi] and the control
//! correction v = u - u_ref over [delta, T_comb, T_bf] obey, to first order around the plan,
//! z_dot = A z + B v with A = df/dx, B = df/du of the single-track model (paper eq. 1).
//! The Jacobians are taken exactly (dual numbers through `time_derivatives`) at
//! straight-line cruise at speed V (r = beta = dFz = e = dpsi = 0, V_wr = V, u = 0,
//! kappa = 0) with the planner's vehicle parameters: the tracker knows the model, not the
//! car. They are discretised with the control period T_c (zero-order hold,
//! exp([[A, B], [0, 0]] T_c) by a scaled Taylor series) and the discrete algebraic Riccati
//! equation P = A'PA - A'PB (R + B'PB)^-1 B'PA + Q is solved by the structure-preserving
//! doubling algorithm, which converges quadratically also when the slow modes sit close to
//! the unit circle (T_c = 1 ms). The gain K = (R + B'PB)^-1 B'PA gives v = -K z.
//!
//! The steering reaches the road wheels through a first-order actuator of time constant
//! tau (`actuator.steering_lag_s` of the mismatch, which the tracker knows as it knows its
//! own hardware): delta_dot = (delta_cmd - delta) / tau. The design therefore runs on the
//! error state augmented by the actuator's steering error, z_a = [z, delta - delta_ref],
//!
//!   z_a_dot = [[A, b_delta], [0, -1/tau]] z_a + [[0, b_T, b_bf], [1/tau, 0, 0]] v,
//!
//! so the gain knows that a steering command acts only after the lag (a design on z alone
//! asks for corrections the actuator delivers 50 ms late, which at speed destabilises the
//! yaw mode it is meant to damp). With tau at or below the control period the actuator is
//! as fast as the loop and the augmented state is the commanded steering itself.
//!
//! The gains are designed once at start-up on a grid of speeds and interpolated linearly in
//! V in the control step ([`GainSchedule::gain`]), which allocates nothing.

use nalgebra::{SMatrix, SVector};
use num_dual::DualSVec64;
use planner::model::{iu, ix, time_derivatives, VehicleParams, NU, NX};

/// Number of error states [r, V, beta, V_wr, e, dpsi].
pub const NZ: usize = 6;
/// Number of design states: the error states and the actuator's steering error.
pub const NA: usize = NZ + 1;
/// Number of feedback inputs [delta, T_comb, T_bf].
pub const NV: usize = 3;
/// State index (in x) of each error state.
pub const Z_STATES: [usize; NZ] = [ix::R, ix::V, ix::BETA, ix::VWR, ix::E, ix::DPSI];
/// Control index (in u) of each feedback input.
pub const V_INPUTS: [usize; NV] = [iu::DELTA, iu::TCOMB, iu::TBF];

type MatZ = SMatrix<f64, NZ, NZ>;
type MatB = SMatrix<f64, NZ, NV>;
type MatA = SMatrix<f64, NA, NA>;
type MatBa = SMatrix<f64, NA, NV>;
/// Feedback gain K (v = -K z_a) on the augmented error z_a = [z, delta - delta_ref].
pub type Gain = SMatrix<f64, NV, NA>;

/// Diagonal LQR weights, as the largest acceptable error or correction (Bryson's rule:
/// weight 1 / max^2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Weights {
    /// Largest acceptable error per state [r, V, beta, V_wr, e, dpsi, steering] (SI units).
    pub z_max: [f64; NA],
    /// Largest acceptable correction per input [delta \[rad\], T_comb \[N m\], T_bf
    /// \[N m\]].
    pub v_max: [f64; NV],
}

impl Default for Weights {
    /// Position and heading first (0.05 m, 0.02 rad), speed loosely (0.5 m/s), yaw rate
    /// and sideslip very loosely (the plan's values come from the nominal model, which a
    /// mismatched car cannot match in a steady curve), the wheel speed tightly (0.3 m/s: the
    /// rear wheel mode is fast and unstable past the tire peak; at 0.2 m/s the torque loop
    /// rings at its limits from 55 m/s on behind a 20 ms transport delay, which the design
    /// does not model), the actuator's steering as loosely as the steering correction
    /// (0.02 rad).
    fn default() -> Self {
        Self {
            z_max: [1.0, 0.5, 0.5, 0.3, 0.05, 0.02, 0.02],
            v_max: [0.02, 600.0, 600.0],
        }
    }
}

/// Jacobians A = df/dz, B = df/dv of the model at straight-line cruise at speed `v`.
pub fn linearise(p: &VehicleParams, v: f64) -> (MatZ, MatB) {
    type D = DualSVec64<{ NZ + NV }>;
    let mut x0 = [0.0; NX];
    x0[ix::V] = v;
    x0[ix::VWR] = v;
    let mut x: [D; NX] = std::array::from_fn(|i| D::from_re(x0[i]));
    for (j, &i) in Z_STATES.iter().enumerate() {
        x[i] = D::from_re(x0[i]).derivative(j);
    }
    let mut u: [D; NU] = std::array::from_fn(|_| D::from_re(0.0));
    for (m, &i) in V_INPUTS.iter().enumerate() {
        u[i] = D::from_re(0.0).derivative(NZ + m);
    }
    let f = time_derivatives(p, &x, &u, 0.0).dxdt;
    let mut a = MatZ::zeros();
    let mut b = MatB::zeros();
    for (row, &i) in Z_STATES.iter().enumerate() {
        let g: [f64; NZ + NV] = match &f[i].eps.0 {
            Some(m) => std::array::from_fn(|k| m[k]),
            None => [0.0; NZ + NV],
        };
        for j in 0..NZ {
            a[(row, j)] = g[j];
        }
        for m in 0..NV {
            b[(row, m)] = g[NZ + m];
        }
    }
    (a, b)
}

/// Zero-order-hold discretisation over `ts` \[s\]: (exp(A ts), int_0^ts exp(A t) dt B).
pub fn discretise(a: &MatA, b: &MatBa, ts: f64) -> (MatA, MatBa) {
    const N: usize = NA + NV;
    let mut m = SMatrix::<f64, N, N>::zeros();
    m.fixed_view_mut::<NA, NA>(0, 0).copy_from(&(a * ts));
    m.fixed_view_mut::<NA, NV>(0, NA).copy_from(&(b * ts));
    // Scale so the norm is below 1/2, sum the Taylor series, square back.
    let norm = m.abs().sum();
    let mut squarings = 0;
    let mut scale = 1.0;
    while norm * scale > 0.5 && squarings < 60 {
        scale *= 0.5;
        squarings += 1;
    }
    let ms = m * scale;
    let mut e = SMatrix::<f64, N, N>::identity();
    let mut term = SMatrix::<f64, N, N>::identity();
    for k in 1..=20 {
        term = term * ms / k as f64;
        e += term;
    }
    for _ in 0..squarings {
        e = e * e;
    }
    (
        e.fixed_view::<NA, NA>(0, 0).into_owned(),
        e.fixed_view::<NA, NV>(0, NA).into_owned(),
    )
}

/// The error dynamics (A, B) augmented by the steering actuator of time constant `tau`
/// \[s\] (module documentation).
pub fn augment(a: &MatZ, b: &MatB, tau: f64) -> (MatA, MatBa) {
    let mut aa = MatA::zeros();
    let mut ba = MatBa::zeros();
    aa.fixed_view_mut::<NZ, NZ>(0, 0).copy_from(a);
    aa.fixed_view_mut::<NZ, 1>(0, NZ).copy_from(&b.column(0));
    aa[(NZ, NZ)] = -1.0 / tau;
    for m in 1..NV {
        ba.fixed_view_mut::<NZ, 1>(0, m).copy_from(&b.column(m));
    }
    ba[(NZ, 0)] = 1.0 / tau;
    (aa, ba)
}

/// The stabilising solution's gain K of the discrete LQR (A, B, diag q, diag r) by the
/// structure-preserving doubling algorithm (at most 100 doublings); `None` when it does
/// not converge or a matrix is singular.
pub fn dlqr(a: &MatA, b: &MatBa, q: &[f64; NA], r: &[f64; NV]) -> Option<Gain> {
    type MatZ = MatA;
    const NZ: usize = NA;
    let q = MatZ::from_diagonal(&SVector::<f64, NZ>::from(*q));
    let r = SMatrix::<f64, NV, NV>::from_diagonal(&SVector::<f64, NV>::from(*r));
    let r_inv = r.try_inverse()?;
    let mut ak = *a;
    let mut gk = b * r_inv * b.transpose();
    let mut hk = q;
    let id = MatZ::identity();
    for _ in 0..100 {
        let w = (id + gk * hk).try_inverse()?;
        let a_next = ak * w * ak;
        let g_next = gk + ak * w * gk * ak.transpose();
        let h_next = hk + ak.transpose() * hk * w * ak;
        let change = (h_next - hk).abs().max() / h_next.abs().max().max(1e-300);
        ak = a_next;
        gk = g_next;
        hk = h_next;
        if change < 1e-13 {
            let p = hk;
            let s = r + b.transpose() * p * b;
            let k = s.try_inverse()? * b.transpose() * p * a;
            return k.iter().all(|v| v.is_finite()).then_some(k);
        }
    }
    None
}

/// LQR gains on a grid of speeds.
#[derive(Debug, Clone)]
pub struct GainSchedule {
    v_lo: f64,
    dv: f64,
    gains: Vec<Gain>,
}

/// Lowest and highest speed of the schedule [m/s]; outside, the end gains hold.
pub const SCHEDULE_SPEEDS: (f64, f64) = (3.0, 90.0);

impl GainSchedule {
    /// Designs the gains for the model `p`, control period `ts` \[s\] and `weights` on a
    /// 1 m/s grid over [`SCHEDULE_SPEEDS`]. Errors name the speed where the design fails.
    /// `tau` \[s\] is the steering actuator's time constant (at least `ts` is used).
    pub fn design(p: &VehicleParams, weights: &Weights, ts: f64, tau: f64) -> Result<Self, String> {
        let tau = tau.max(ts);
        let q: [f64; NA] = std::array::from_fn(|i| weights.z_max[i].powi(-2));
        let r: [f64; NV] = std::array::from_fn(|i| weights.v_max[i].powi(-2));
        let (v_lo, v_hi) = SCHEDULE_SPEEDS;
        let dv = 1.0;
        let n = ((v_hi - v_lo) / dv).round() as usize + 1;
        let mut gains = Vec::with_capacity(n);
        for k in 0..n {
            let v = v_lo + k as f64 * dv;
            let (a, b) = linearise(p, v);
            let (aa, ba) = augment(&a, &b, tau);
            let (ad, bd) = discretise(&aa, &ba, ts);
            let gain = dlqr(&ad, &bd, &q, &r)
                .ok_or_else(|| format!("LQR design failed at V = {v} m/s"))?;
            gains.push(gain);
        }
        Ok(Self { v_lo, dv, gains })
    }

    /// The gain at speed `v`, interpolated linearly (end gains outside the grid; NaN gives
    /// the lowest speed's gain). Allocates nothing.
    pub fn gain(&self, v: f64) -> Gain {
        let last = self.gains.len() - 1;
        let q = ((v - self.v_lo) / self.dv).clamp(0.0, last as f64);
        let q = if q.is_nan() { 0.0 } else { q };
        let k = (q.floor() as usize).min(last.saturating_sub(1));
        let w = q - k as f64;
        if last == 0 {
            return self.gains[0];
        }
        self.gains[k] * (1.0 - w) + self.gains[k + 1] * w
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn lc500() -> VehicleParams {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        planner::config::load_vehicle(&root.join("config/vehicles/lc500.toml")).unwrap()
    }

    #[test]
    fn the_jacobians_match_central_differences_of_the_model() {
        let p = lc500();
        let v = 20.0;
        let (a, b) = linearise(&p, v);
        let f = |dz: &[f64; NZ], dv: &[f64; NV]| {
            let mut x = [0.0; NX];
            x[ix::V] = v;
            x[ix::VWR] = v;
            let mut u = [0.0; NU];
            for (j, &i) in Z_STATES.iter().enumerate() {
                x[i] += dz[j];
            }
            for (m, &i) in V_INPUTS.iter().enumerate() {
                u[i] += dv[m];
            }
            time_derivatives(&p, &x, &u, 0.0).dxdt
        };
        // Steps per column [r, V, beta, V_wr, e, dpsi, delta, T_comb, T_bf].
        let steps = [1e-6, 1e-5, 1e-7, 1e-6, 1e-6, 1e-7, 1e-7, 1e-2, 1e-2];
        for (j, &h) in steps.iter().enumerate() {
            let (mut zp, mut zm) = ([0.0; NZ], [0.0; NZ]);
            let (mut vp, mut vm) = ([0.0; NV], [0.0; NV]);
            if j < NZ {
                zp[j] = h;
                zm[j] = -h;
            } else {
                vp[j - NZ] = h;
                vm[j - NZ] = -h;
            }
            let (fp, fm) = (f(&zp, &vp), f(&zm, &vm));
            for (row, &i) in Z_STATES.iter().enumerate() {
                let fd = (fp[i] - fm[i]) / (2.0 * h);
                let exact = if j < NZ {
                    a[(row, j)]
                } else {
                    b[(row, j - NZ)]
                };
                assert!(
                    (fd - exact).abs() <= 1e-4 * (1.0 + exact.abs()),
                    "d f[{i}] / d[{j}]: exact {exact}, differences {fd}"
                );
            }
        }
    }

    /// The discrete closed loop A - B K of the lag-augmented error dynamics is stable
    /// (spectral radius below 1) at every speed of the schedule, for the default 50 ms
    /// steering lag and for an actuator as fast as the loop.
    #[test]
    fn the_designed_gains_stabilise_the_error_dynamics_at_every_speed() {
        let p = lc500();
        let ts = 0.001;
        for tau in [0.05, 0.0] {
            let sched = GainSchedule::design(&p, &Weights::default(), ts, tau).unwrap();
            let (lo, hi) = SCHEDULE_SPEEDS;
            let mut v = lo;
            while v <= hi {
                let (a, b) = linearise(&p, v);
                let (aa, ba) = augment(&a, &b, tau.max(ts));
                let (ad, bd) = discretise(&aa, &ba, ts);
                let cl = ad - bd * sched.gain(v);
                let rho = cl
                    .complex_eigenvalues()
                    .iter()
                    .map(|z| z.norm())
                    .fold(0.0, f64::max);
                assert!(rho < 1.0, "tau {tau}, V = {v}: spectral radius {rho}");
                v += 2.5;
            }
        }
    }

    #[test]
    fn the_discretisation_matches_euler_for_a_small_step() {
        let p = lc500();
        let (a, b) = linearise(&p, 30.0);
        let (a, b) = augment(&a, &b, 0.05);
        let ts = 1e-7;
        let (ad, bd) = discretise(&a, &b, ts);
        let euler = MatA::identity() + a * ts;
        assert!((ad - euler).abs().max() < 1e-9);
        assert!((bd - b * ts).abs().max() < 1e-9 * b.abs().max());
    }
}
