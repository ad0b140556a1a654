//! Initial guesses: the equilibrium guess of paper Sec. V (eq. 8) and the zero guess.
//!
//! The equilibrium guess solves one box-constrained nonlinear least-squares problem for a
//! single state/control pair whose dynamic rates vanish (straight line, k_ref = 0), with
//! our own interior-point solver and exact derivatives. Every node of the OCP then gets
//! that pair; e = dpsi = 0, s_k = k ds and t_k = s_k / V (paper Sec. V).
//!
//! The road-speed guess ([`fill_road_speed`]) keeps that pair but caps each node's speed
//! by what the road ahead allows a car on the centre line with lateral and longitudinal
//! acceleration a = mu g:
//!
//!   V_k <= sqrt(a / |k_ref(s_k)|),   V_k <= sqrt(V_{k+1}^2 + 2 a ds)   (backward pass),
//!
//! the quasi-steady-state speed profile of lap-time simulation, so a corner that enters
//! the far end of a long horizon is not guessed at straight-line speed. It still uses no
//! reference trajectory: only the road's curvature and the vehicle's friction.

use nalgebra::{SMatrix, SVector};
use num_dual::{hessian, jacobian, Dual2SVec64, DualNum, DualSVec64};

use crate::ip::{Nlp, NlpDims};
use crate::model::dynamics::time_derivatives;
use crate::model::{iu, ix, VehicleParams, NU, NX};

/// Unknowns of eq. (8): [r, V, beta, V_wr, dFz, delta, T_comb, T_bf].
const NG: usize = 8;

/// Nominal magnitudes of the unknowns: the NLP works in z / nominal (as the OCP does).
const Z_NOMINAL: [f64; NG] = [1.0, 10.0, 0.1, 10.0, 1000.0, 0.1, 1000.0, 1000.0];

/// Nominal magnitudes dividing each residual of eq. (8) so they weigh alike (the zero-cost
/// minimizers, which are what eq. 8 asks for, do not depend on them).
const RESIDUAL_SCALE: [f64; 6] = [1.0, 1.0, 0.1, 10.0, 1000.0, 1.0];

/// Which initial guess a solve starts from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GuessKind {
    /// Constant dynamic equilibrium of paper eq. (8).
    Equilibrium,
    /// Every decision variable zero (the paper's ill-informed guess).
    Zero,
    /// The equilibrium pair at speeds the road's curvature allows ([`fill_road_speed`]).
    RoadSpeed,
}

impl GuessKind {
    /// Name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            GuessKind::Equilibrium => "equilibrium",
            GuessKind::Zero => "zero",
            GuessKind::RoadSpeed => "road_speed",
        }
    }
    /// The guess a replanning cycle starts from when asked for this one cold: itself,
    /// except the zero guess, which is not a replanning start (then the equilibrium).
    pub fn cold_start(self) -> Self {
        match self {
            GuessKind::Zero => GuessKind::Equilibrium,
            kind => kind,
        }
    }
    /// Parses `equilibrium`, `zero` or `road_speed`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "equilibrium" => Some(GuessKind::Equilibrium),
            "zero" => Some(GuessKind::Zero),
            "road_speed" => Some(GuessKind::RoadSpeed),
            _ => None,
        }
    }
}

/// The constant state/control pair of the equilibrium guess.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Equilibrium {
    /// Dynamic states and kinematic placeholders [r, V, beta, V_wr, dFz, 0, 0, 0, 0].
    pub x: [f64; NX],
    /// Controls [delta, T_comb, T_bf].
    pub u: [f64; NU],
    /// Remaining cost of eq. (8) (zero at a true equilibrium).
    pub cost: f64,
    /// Status of the least-squares solve.
    pub status: &'static str,
    /// Iterations taken.
    pub iterations: usize,
}

/// Could not compute an equilibrium guess.
#[derive(Debug, thiserror::Error)]
pub enum GuessError {
    /// The least-squares problem did not converge to zero cost.
    #[error(
        "equilibrium guess (paper eq. 8) did not converge from V = {v_start} m/s \
         (speed bounds [{v_min}, {v_max}] m/s): {status} after {iterations} iterations, \
         cost {cost:e}, largest scaled residual {residual} = {residual_value:e}"
    )]
    NotConverged {
        /// What stopped the solve: `non_finite_residuals`, `no_descent` or `iteration_cap`.
        status: &'static str,
        /// Remaining cost.
        cost: f64,
        /// Start speed of the least-squares problem [m/s].
        v_start: f64,
        /// Lower speed bound [m/s].
        v_min: f64,
        /// Upper speed bound [m/s].
        v_max: f64,
        /// Iterations taken.
        iterations: usize,
        /// Name of the largest scaled residual of eq. (8) at the last iterate.
        residual: &'static str,
        /// Its value (NaN if not finite).
        residual_value: f64,
    },
}

/// Names of the residuals of eq. (8): the five dynamic rates and V - V_wr.
const RESIDUAL_NAMES: [&str; 6] = [
    "dr/dt", "dV/dt", "dbeta/dt", "dV_wr/dt", "dFz/dt", "V - V_wr",
];

/// The NLP of paper eq. (8) for one vehicle.
#[derive(Debug, Clone)]
pub struct EquilibriumProblem {
    vehicle: VehicleParams,
    v_bounds: (f64, f64),
    start: [f64; NG],
}

impl EquilibriumProblem {
    /// The problem with speed bounds `v_min..v_max`, started from speed `v_start` with
    /// 5 % rear wheel slip (as the independent reference does).
    pub fn new(vehicle: VehicleParams, v_min: f64, v_max: f64, v_start: f64) -> Self {
        // max/min, not clamp: no panic on unordered or NaN bounds (the spec check rejects
        // them first).
        let v0 = v_start.max(v_min).min(v_max);
        Self {
            vehicle,
            v_bounds: (v_min, v_max),
            start: [0.0, v0, 0.0, 1.05 * v0, 0.0, 0.0, 0.0, 0.0],
        }
    }

    /// Residuals of eq. (8) and their exact Jacobian at scaled unknowns `z`.
    pub fn residuals_jacobian(&self, z: &[f64; NG]) -> (SVector<f64, 6>, SMatrix<f64, 6, NG>) {
        let zv = SVector::<f64, NG>::from_column_slice(z);
        jacobian(
            |v: SVector<DualSVec64<NG>, NG>| {
                let a: [DualSVec64<NG>; NG] = std::array::from_fn(|i| v[i]);
                SVector::<DualSVec64<NG>, 6>::from(self.residuals(&a))
            },
            &zv,
        )
    }

    /// Scaled residuals of eq. (8): the five dynamic rates and V - V_wr.
    fn residuals<D: DualNum<Primitive = f64> + Copy>(&self, zs: &[D; NG]) -> [D; 6] {
        let zero = D::from(0.0);
        let z: [D; NG] = std::array::from_fn(|i| zs[i] * Z_NOMINAL[i]);
        let x = [z[0], z[1], z[2], z[3], z[4], zero, zero, zero, zero];
        let u = [z[5], z[6], z[7]];
        let d = time_derivatives(&self.vehicle, &x, &u, 0.0);
        let res = [
            d.dxdt[ix::R],
            d.dxdt[ix::V],
            d.dxdt[ix::BETA],
            d.dxdt[ix::VWR],
            d.dxdt[ix::DFZ],
            x[ix::V] - x[ix::VWR],
        ];
        std::array::from_fn(|i| res[i] / RESIDUAL_SCALE[i])
    }

    /// Cost of eq. (8), 0.5 * sum of squared scaled residuals, at scaled unknowns `zs`.
    fn cost<D: DualNum<Primitive = f64> + Copy>(&self, zs: &[D; NG]) -> D {
        let mut c = D::from(0.0);
        for r in self.residuals(zs) {
            c += r * r;
        }
        c * 0.5
    }

    fn derivs(&self, x: &[f64]) -> (f64, SVector<f64, NG>, nalgebra::SMatrix<f64, NG, NG>) {
        let z = SVector::<f64, NG>::from_column_slice(x);
        hessian(
            |v: SVector<Dual2SVec64<NG>, NG>| {
                let a: [Dual2SVec64<NG>; NG] = std::array::from_fn(|i| v[i]);
                self.cost(&a)
            },
            &z,
        )
    }
}

impl Nlp for EquilibriumProblem {
    fn dims(&self) -> NlpDims {
        NlpDims {
            n: NG,
            m: 0,
            nnz_jac: 0,
            nnz_hess: NG * (NG + 1) / 2,
        }
    }
    fn bounds(&self, x_l: &mut [f64], x_u: &mut [f64], _g_l: &mut [f64], _g_u: &mut [f64]) {
        let p = &self.vehicle;
        x_l.fill(f64::NEG_INFINITY);
        x_u.fill(f64::INFINITY);
        // 0- <= r <= 0+: straight-line driving (eq. 8).
        x_l[0] = -1e-6;
        x_u[0] = 1e-6;
        (x_l[1], x_u[1]) = self.v_bounds;
        x_l[3] = p.v_wr_min;
        (x_l[5 + iu::DELTA], x_u[5 + iu::DELTA]) = (-p.delta_max, p.delta_max);
        (x_l[5 + iu::TCOMB], x_u[5 + iu::TCOMB]) = (p.t_comb_min, p.t_comb_max);
        (x_l[5 + iu::TBF], x_u[5 + iu::TBF]) = (p.t_bf_min, p.t_bf_max);
        for i in 0..NG {
            x_l[i] /= Z_NOMINAL[i];
            x_u[i] /= Z_NOMINAL[i];
        }
    }
    fn initial_point(&self, x: &mut [f64]) {
        for i in 0..NG {
            x[i] = self.start[i] / Z_NOMINAL[i];
        }
    }
    fn jac_structure(&self, _: &mut [usize], _: &mut [usize]) {}
    fn hess_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        let mut k = 0;
        for i in 0..NG {
            for j in 0..=i {
                rows[k] = i;
                cols[k] = j;
                k += 1;
            }
        }
    }
    fn eval_f(&mut self, x: &[f64]) -> f64 {
        let a: [f64; NG] = std::array::from_fn(|i| x[i]);
        self.cost(&a)
    }
    fn eval_grad_f(&mut self, x: &[f64], grad: &mut [f64]) {
        let (_, g, _) = self.derivs(x);
        grad.copy_from_slice(g.as_slice());
    }
    fn eval_g(&mut self, _: &[f64], _: &mut [f64]) {}
    fn eval_jac_g(&mut self, _: &[f64], _: &mut [f64]) {}
    fn eval_hess(&mut self, x: &[f64], obj_factor: f64, _: &[f64], vals: &mut [f64]) {
        let (_, _, h) = self.derivs(x);
        let mut k = 0;
        for i in 0..NG {
            for j in 0..=i {
                vals[k] = obj_factor * h[(i, j)];
                k += 1;
            }
        }
    }
}

/// Solves eq. (8) for this vehicle (speed bounds and start speed as in
/// [`EquilibriumProblem::new`]) by projected Levenberg-Marquardt on the box, with exact
/// Jacobians from forward-mode duals. The zero-residual minimizers of eq. (8) form a
/// continuum (any straight-line speed) and sit on the bound T_bf = 0, a degenerate case
/// for an interior-point method; projected LM converges there in a few iterations.
/// Deterministic, at most `MAX_ITER` iterations. Cheap; compute once per vehicle.
pub fn equilibrium(
    vehicle: &VehicleParams,
    v_min: f64,
    v_max: f64,
    v_start: f64,
) -> Result<Equilibrium, GuessError> {
    const MAX_ITER: usize = 200;
    let prob = EquilibriumProblem::new(*vehicle, v_min, v_max, v_start);
    let mut lo = [0.0; NG];
    let mut hi = [0.0; NG];
    prob.bounds(&mut lo, &mut hi, &mut [], &mut []);
    // r is fixed at 0 (the paper's 0- <= r <= 0+).
    lo[0] = 0.0;
    hi[0] = 0.0;
    let mut z = [0.0; NG];
    prob.initial_point(&mut z);
    z[0] = 0.0;
    let project = |z: &mut [f64; NG]| {
        for i in 0..NG {
            z[i] = z[i].max(lo[i]).min(hi[i]);
        }
    };
    project(&mut z);
    let mut lambda = 1e-3;
    let (mut res, mut jac) = prob.residuals_jacobian(&z);
    let mut cost = 0.5 * res.norm_squared();
    let mut iterations = 0;
    let mut no_descent = false;
    while iterations < MAX_ITER && cost > 1e-24 {
        iterations += 1;
        // Free variables: not at a bound with the gradient pushing outwards.
        let grad = jac.transpose() * res;
        let mut free = [true; NG];
        for i in 0..NG {
            let at_lo = z[i] <= lo[i] && grad[i] > 0.0;
            let at_hi = z[i] >= hi[i] && grad[i] < 0.0;
            free[i] = !(at_lo || at_hi) && lo[i] < hi[i];
        }
        let mut a = jac.transpose() * jac;
        let mut b = -grad;
        for i in 0..NG {
            if !free[i] {
                for j in 0..NG {
                    a[(i, j)] = 0.0;
                    a[(j, i)] = 0.0;
                }
                a[(i, i)] = 1.0;
                b[i] = 0.0;
            } else {
                a[(i, i)] += lambda * (1.0 + a[(i, i)]);
            }
        }
        let Some(d) = a.cholesky().map(|c| c.solve(&b)) else {
            lambda *= 10.0;
            continue;
        };
        let mut trial = z;
        for i in 0..NG {
            trial[i] += d[i];
        }
        project(&mut trial);
        let (r_t, j_t) = prob.residuals_jacobian(&trial);
        let c_t = 0.5 * r_t.norm_squared();
        if c_t.is_finite() && c_t < cost {
            z = trial;
            res = r_t;
            jac = j_t;
            cost = c_t;
            lambda = (lambda / 10.0).max(1e-12);
        } else {
            lambda *= 10.0;
            if lambda > 1e12 {
                no_descent = true;
                break;
            }
        }
    }
    // A NaN cost is not converged either.
    if cost.is_nan() || cost > 1e-16 {
        let (worst, value) = res
            .iter()
            .enumerate()
            .find(|(_, r)| !r.is_finite())
            .or_else(|| {
                res.iter()
                    .enumerate()
                    .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            })
            .map_or((0, f64::NAN), |(i, r)| (i, *r));
        return Err(GuessError::NotConverged {
            status: if !cost.is_finite() {
                "non_finite_residuals"
            } else if no_descent {
                "no_descent"
            } else {
                "iteration_cap"
            },
            cost,
            v_start: prob.start[1],
            v_min,
            v_max,
            iterations,
            residual: RESIDUAL_NAMES[worst],
            residual_value: value,
        });
    }
    let zp: [f64; NG] = std::array::from_fn(|i| z[i] * Z_NOMINAL[i]);
    let mut x = [0.0; NX];
    x[..5].copy_from_slice(&zp[..5]);
    Ok(Equilibrium {
        x,
        u: [zp[5], zp[6], zp[7]],
        cost,
        status: "optimal",
        iterations,
    })
}

/// Fills node states and controls (physical units) from the equilibrium pair: dynamic
/// states constant, e = dpsi = 0, s_k = k ds, t_k = s_k / V (paper Sec. V). With a fixed
/// initial state, node 0 takes it and t_k uses its speed.
pub fn fill_equilibrium(
    eq: &Equilibrium,
    ds: f64,
    fixed_x0: Option<&[f64; NX]>,
    xs: &mut [[f64; NX]],
    us: &mut [[f64; NU]],
) {
    let v_avg = match fixed_x0 {
        Some(x0) if x0[ix::V] > 0.0 => x0[ix::V],
        _ => eq.x[ix::V],
    };
    for (k, x) in xs.iter_mut().enumerate() {
        *x = eq.x;
        x[ix::E] = 0.0;
        x[ix::DPSI] = 0.0;
        x[ix::S] = k as f64 * ds;
        x[ix::T] = x[ix::S] / v_avg;
    }
    if let (Some(x0), Some(first)) = (fixed_x0, xs.first_mut()) {
        *first = *x0;
    }
    for u in us.iter_mut() {
        *u = eq.u;
    }
}

/// Fills node states and controls like [`fill_equilibrium`], then caps each node's speed by
/// the road-speed profile of the module docs for curvature `kappa` (N + 1 node values)
/// and the friction mu g of `vehicle`: V and V_wr scale together, the yaw rate follows
/// the centre line (r = k_ref V), the steering adds the kinematic angle (a + b) k_ref, and
/// t_k integrates ds / V by the trapezoidal rule. Node 0 keeps a fixed initial state.
/// Allocates nothing.
pub fn fill_road_speed(
    eq: &Equilibrium,
    ds: f64,
    kappa: &[f64],
    vehicle: &VehicleParams,
    fixed_x0: Option<&[f64; NX]>,
    xs: &mut [[f64; NX]],
    us: &mut [[f64; NU]],
) {
    fill_equilibrium(eq, ds, fixed_x0, xs, us);
    let v_top = match fixed_x0 {
        Some(x0) if x0[ix::V] > 0.0 => x0[ix::V],
        _ => eq.x[ix::V],
    };
    let a = (vehicle.mu * vehicle.g).max(1e-3);
    let wheelbase = vehicle.a + vehicle.b;
    // Curvature cap, then the backward braking pass, written into V of each node.
    for (k, x) in xs.iter_mut().enumerate() {
        let kap = kappa.get(k).copied().unwrap_or(0.0).abs();
        x[ix::V] = if kap > 1e-9 {
            v_top.min((a / kap).sqrt())
        } else {
            v_top
        };
    }
    for k in (0..xs.len().saturating_sub(1)).rev() {
        let reach = (xs[k + 1][ix::V].powi(2) + 2.0 * a * ds).sqrt();
        xs[k][ix::V] = xs[k][ix::V].min(reach);
    }
    let v_eq = eq.x[ix::V].max(1e-3);
    let mut t = 0.0;
    for k in 0..xs.len() {
        let v = xs[k][ix::V].max(1e-3);
        if k > 0 {
            t += 2.0 * ds / (xs[k - 1][ix::V].max(1e-3) + v);
        }
        let kap = kappa.get(k).copied().unwrap_or(0.0);
        let x = &mut xs[k];
        x[ix::VWR] = eq.x[ix::VWR] * v / v_eq;
        x[ix::R] = kap * v;
        x[ix::T] = t;
        if let Some(u) = us.get_mut(k) {
            u[iu::DELTA] = eq.u[iu::DELTA] + wheelbase * kap;
        }
    }
    if let (Some(x0), Some(first)) = (fixed_x0, xs.first_mut()) {
        *first = *x0;
    }
}

/// Fills every node with zeros (the paper's ill-informed guess). With a fixed initial
/// state, node 0 takes it: the initial-condition rows hold x_0 there and its speed is not
/// bounded below, so a zero V_0 would put 0/0 into the node-0 saturation rows (the slips
/// divide by V). The other nodes' zero speeds are pushed up to v_min by the solver.
pub fn fill_zero(fixed_x0: Option<&[f64; NX]>, xs: &mut [[f64; NX]], us: &mut [[f64; NU]]) {
    xs.iter_mut().for_each(|x| *x = [0.0; NX]);
    us.iter_mut().for_each(|u| *u = [0.0; NU]);
    if let (Some(x0), Some(first)) = (fixed_x0, xs.first_mut()) {
        *first = *x0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::params::lc500;

    #[test]
    fn an_extreme_mass_names_the_speed_and_what_failed() {
        for m in [1e300, 1e-6] {
            let p = VehicleParams { m, ..lc500() };
            let msg = equilibrium(&p, 5.0, 40.0, 15.0)
                .expect_err("must not converge")
                .to_string();
            assert!(msg.contains("from V = 15 m/s"), "{msg}");
            assert!(msg.contains("speed bounds [5, 40] m/s"), "{msg}");
            assert!(msg.contains("largest scaled residual"), "{msg}");
        }
    }

    #[test]
    fn the_zero_guess_takes_a_fixed_initial_state_at_node_0() {
        let mut x0 = [0.0; NX];
        x0[ix::V] = 25.0;
        x0[ix::VWR] = 25.0;
        let mut xs = [[1.0; NX]; 3];
        let mut us = [[1.0; NU]; 2];
        fill_zero(Some(&x0), &mut xs, &mut us);
        assert_eq!(xs, [x0, [0.0; NX], [0.0; NX]]);
        assert_eq!(us, [[0.0; NU]; 2]);
        fill_zero(None, &mut xs, &mut us);
        assert_eq!(xs, [[0.0; NX]; 3]);
    }

    /// A hairpin at the end of the window: its nodes are guessed at the speed the
    /// friction allows on the centre line, every node before can brake to the next with
    /// mu g, the straight start keeps the start speed, and time grows by ds / V.
    #[test]
    fn the_road_speed_guess_reaches_a_far_hairpin_at_its_cornering_speed() {
        let p = lc500();
        let eq = equilibrium(&p, 5.0, 70.0, 55.0).unwrap();
        let (n, ds) = (100, 2.5);
        let kappa: Vec<f64> = (0..=n).map(|k| if k >= 90 { 0.08 } else { 0.0 }).collect();
        let mut xs = vec![[0.0; NX]; n + 1];
        let mut us = vec![[0.0; NU]; n];
        let mut x0 = eq.x;
        x0[ix::V] = 55.0;
        fill_road_speed(&eq, ds, &kappa, &p, Some(&x0), &mut xs, &mut us);
        let a = p.mu * p.g;
        let v_corner = (a / 0.08).sqrt();
        for k in 90..=n {
            assert!(
                (xs[k][ix::V] - v_corner).abs() < 1e-9,
                "node {k}: {:?}",
                xs[k]
            );
            assert!((xs[k][ix::R] - 0.08 * v_corner).abs() < 1e-9);
        }
        for k in 0..n {
            let gap = xs[k][ix::V].powi(2) - xs[k + 1][ix::V].powi(2);
            assert!(
                gap <= 2.0 * a * ds + 1e-9,
                "node {k} cannot brake to node {}",
                k + 1
            );
            assert!(xs[k + 1][ix::T] > xs[k][ix::T]);
        }
        assert_eq!(xs[0], x0);
        assert_eq!(xs[1][ix::V], 55.0);
        // The braking starts where the distance to the hairpin asks for it.
        let brake_from = 90.0 - (55.0f64.powi(2) - v_corner.powi(2)) / (2.0 * a * ds);
        assert!(xs[brake_from.floor() as usize - 1][ix::V] >= 55.0 - 1e-9);
        assert!(xs[brake_from.ceil() as usize + 1][ix::V] < 55.0);
    }

    /// On a straight road the road-speed guess is the equilibrium guess.
    #[test]
    fn on_a_straight_road_the_road_speed_guess_is_the_equilibrium_guess() {
        let p = lc500();
        let eq = equilibrium(&p, 5.0, 40.0, 20.0).unwrap();
        let (mut xa, mut ua) = (vec![[0.0; NX]; 11], vec![[0.0; NU]; 10]);
        let (mut xb, mut ub) = (xa.clone(), ua.clone());
        fill_equilibrium(&eq, 2.5, None, &mut xa, &mut ua);
        let kappa = [0.0; 11];
        fill_road_speed(&eq, 2.5, &kappa, &p, None, &mut xb, &mut ub);
        for k in 0..11 {
            for i in [ix::V, ix::VWR, ix::BETA, ix::DFZ, ix::S] {
                assert_eq!(xa[k][i], xb[k][i], "node {k} state {i}");
            }
            assert!((xa[k][ix::T] - xb[k][ix::T]).abs() < 1e-12);
        }
        assert_eq!(ua, ub);
    }
}
