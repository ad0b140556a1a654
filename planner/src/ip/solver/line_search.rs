//! The filter line search (Waechter & Biegler 2006, Sec. 2.3-2.4) with second-order
//! corrections, and the trial points and step acceptance shared with the merit search.

use std::time::Instant;

use super::clock::{Clock, Deadline, OutOfTime, Phase};
use super::ln_sum::LnSum;
use super::{LoopState, Solver};
use crate::elementary::pow;
use crate::ip::info::SolveInfo;
use crate::ip::kkt::KktSolver;
use crate::ip::nlp::Nlp;
use crate::ip::residuals;
use crate::ip::settings::Globalization;
use crate::ip::vector;
use crate::ip::workspace::Workspace;

/// Filter margin on the violation (Waechter & Biegler 2006, gamma_theta).
const GAMMA_THETA: f64 = 1e-5;
/// Filter margin on the barrier objective (gamma_phi).
const GAMMA_PHI: f64 = 1e-8;
/// Exponent of the violation in the switching condition (s_theta).
const S_THETA: f64 = 1.1;
/// Exponent of the objective decrease in the switching condition (s_phi).
const S_PHI: f64 = 2.3;
/// Factor of the switching condition (delta).
const DELTA: f64 = 1.0;
/// Second-order corrections per line search at most.
const MAX_SOC: usize = 4;

impl<K: KktSolver> Solver<K> {
    /// The iteration's line search along the current direction by the configured
    /// globalization, from a point with ||c||_1 = `theta`. Returns (alpha, backtracks, used
    /// a second-order correction), or None when no step was accepted; `Err(OutOfTime)`
    /// when the time budget ran out before a trial.
    pub(super) fn search<P: Nlp + ?Sized>(
        &mut self,
        nlp: &mut P,
        st: &mut LoopState,
        theta: f64,
        delta_w: f64,
        info: &mut SolveInfo,
        clock: &mut Clock,
    ) -> Result<Option<(f64, usize, bool)>, OutOfTime> {
        let s = self.settings;
        let (mu, theta_bounds, deadline) = (st.mu, (st.theta_min, st.theta_max), clock.deadline);
        let nu = &mut st.nu;
        let evals = &mut info.evaluations;
        clock.time_with_evaluations(Phase::LineSearch, |teval| match s.globalization {
            Globalization::Filter => self.filter_line_search(
                nlp,
                mu,
                theta,
                delta_w,
                theta_bounds,
                deadline,
                teval,
                evals,
            ),
            Globalization::Merit => self.line_search(nlp, mu, nu, delta_w, deadline, teval, evals),
        })
    }

    /// Barrier objective f - mu sum ln(slacks) at primal point `w` with objective `f`.
    pub(super) fn barrier_value(&self, w: &[f64], f: f64, mu: f64) -> f64 {
        let ws = &self.ws;
        let mut b = LnSum::default();
        for j in 0..ws.n + ws.m {
            if ws.has_lo[j] {
                b.add(w[j] - ws.lo[j]);
            }
            if ws.has_hi[j] {
                b.add(ws.hi[j] - w[j]);
            }
        }
        f - mu * b.value()
    }

    /// Filter line search on (theta = ||c||_1, given for the current point, barrier
    /// objective) with second-order corrections (Waechter & Biegler 2006, Sec. 2.3-2.4).
    /// Returns (alpha, backtracks, used a second-order correction), or None when alpha fell
    /// below alpha_min; `Err(OutOfTime)` when `deadline`, checked before each trial and
    /// each second-order correction, has passed.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn filter_line_search<P: Nlp + ?Sized>(
        &mut self,
        nlp: &mut P,
        mu: f64,
        theta: f64,
        delta_w: f64,
        (theta_min, theta_max): (f64, f64),
        deadline: Deadline,
        teval: &mut f64,
        evals: &mut usize,
    ) -> Result<Option<(f64, usize, bool)>, OutOfTime> {
        let s = self.settings;
        let m = self.ws.m;
        let tau = (1.0 - mu).max(s.tau_min);
        let (alpha_max, alpha_z) = self.max_steps(tau);
        let grad_d = self.barrier_grad_dot_dw(mu);
        let phi = match self.phi_current.take() {
            Some((bits, phi)) if bits == mu.to_bits() => phi,
            _ => self.barrier_value(&self.ws.w, self.ws.f, mu),
        };
        let alpha_min = {
            let g = 0.05;
            if grad_d < 0.0 {
                g * GAMMA_THETA
                    .min(GAMMA_PHI * theta / -grad_d)
                    .min(DELTA * pow(theta, S_THETA) / pow(-grad_d, S_PHI))
            } else {
                g * GAMMA_THETA
            }
        };
        let acceptable = |ws: &Workspace, th: f64, ph: f64| -> bool {
            th <= theta_max && ws.filter.iter().all(|&(tf, pf)| th < tf || ph < pf)
        };
        let mut alpha = alpha_max;
        for bt in 0..s.max_backtracks {
            if alpha < alpha_min && bt > 0 {
                break;
            }
            deadline.check()?;
            self.set_trial(alpha);
            let Some((f_t, theta_t, phi_t)) = self.eval_trial(nlp, mu, teval, evals) else {
                alpha *= 0.5;
                continue;
            };
            let switching =
                grad_d < 0.0 && alpha * pow(-grad_d, S_PHI) > DELTA * pow(theta, S_THETA);
            let armijo = le(phi_t, phi + 1e-8 * alpha * grad_d, phi);
            let f_type = theta <= theta_min && switching;
            let ok = if f_type {
                armijo
            } else {
                le(theta_t, (1.0 - GAMMA_THETA) * theta, theta)
                    || le(phi_t, phi - GAMMA_PHI * theta, phi)
            };
            if ok && acceptable(&self.ws, theta_t, phi_t) {
                if !(switching && armijo) {
                    self.augment_filter((1.0 - GAMMA_THETA) * theta, phi - GAMMA_PHI * theta);
                }
                self.accept(f_t, alpha, alpha_z, mu, true);
                self.phi_current = Some((mu.to_bits(), phi_t));
                return Ok(Some((alpha, bt, false)));
            }
            // Second-order corrections on the first trial when the violation grew.
            if bt == 0 && theta_t >= theta && s.second_order_correction {
                {
                    let ws = &mut self.ws;
                    for i in 0..m {
                        ws.tmp_m[i] = alpha * ws.c[i] + ws.c_t[i];
                    }
                }
                let mut theta_soc_prev = theta;
                let mut accepted = false;
                for _ in 0..MAX_SOC {
                    deadline.check()?;
                    self.solve_direction(delta_w, true);
                    let (ap, az) = self.max_steps(tau);
                    self.set_trial(ap);
                    let Some((f_s, theta_s, phi_s)) = self.eval_trial(nlp, mu, teval, evals) else {
                        break;
                    };
                    let ok = if f_type {
                        le(phi_s, phi + 1e-8 * alpha * grad_d, phi)
                    } else {
                        le(theta_s, (1.0 - GAMMA_THETA) * theta, theta)
                            || le(phi_s, phi - GAMMA_PHI * theta, phi)
                    };
                    if ok && acceptable(&self.ws, theta_s, phi_s) {
                        if !f_type {
                            self.augment_filter(
                                (1.0 - GAMMA_THETA) * theta,
                                phi - GAMMA_PHI * theta,
                            );
                        }
                        self.accept(f_s, ap, az, mu, true);
                        self.phi_current = Some((mu.to_bits(), phi_s));
                        accepted = true;
                        alpha = ap;
                        break;
                    }
                    if theta_s > 0.99 * theta_soc_prev {
                        break;
                    }
                    theta_soc_prev = theta_s;
                    let ws = &mut self.ws;
                    for i in 0..m {
                        ws.tmp_m[i] = ap * ws.tmp_m[i] + ws.c_t[i];
                    }
                }
                if accepted {
                    return Ok(Some((alpha, bt, true)));
                }
                self.restore_direction(delta_w);
            }
            alpha *= 0.5;
        }
        Ok(None)
    }

    /// w_t = w + alpha dw.
    pub(super) fn set_trial(&mut self, alpha: f64) {
        vector::set_trial(&mut self.ws, alpha);
    }

    /// Evaluates f and c at w_t; returns (f, ||c||_1, barrier objective) when finite.
    pub(super) fn eval_trial<P: Nlp + ?Sized>(
        &mut self,
        nlp: &mut P,
        mu: f64,
        teval: &mut f64,
        evals: &mut usize,
    ) -> Option<(f64, f64, f64)> {
        let n = self.ws.n;
        let te = Instant::now();
        let f_t = nlp.eval_f(&self.ws.w_t[..n]);
        {
            let ws = &mut self.ws;
            nlp.eval_g(&ws.w_t[..n], &mut ws.g_t);
        }
        *teval += te.elapsed().as_secs_f64();
        *evals += 1;
        if !f_t.is_finite() || !vector::all_finite(&self.ws.g_t) {
            return None;
        }
        let ws = &mut self.ws;
        residuals::constraint_residual(&ws.is_eq, &ws.g_l, n, &ws.g_t, &ws.w_t, &mut ws.c_t);
        let theta_t = vector::norm1(&self.ws.c_t);
        let phi_t = self.barrier_value(&self.ws.w_t, f_t, mu);
        phi_t.is_finite().then_some((f_t, theta_t, phi_t))
    }

    pub(super) fn augment_filter(&mut self, theta: f64, phi: f64) {
        let f = &mut self.ws.filter;
        // Drop entries the new one dominates, then add it (capacity permitting).
        f.retain(|&(t, p)| !(t >= theta && p >= phi));
        if f.len() < f.capacity() {
            f.push((theta, phi));
        }
    }

    /// grad(barrier objective) . dw at the current point.
    pub(super) fn barrier_grad_dot_dw(&self, mu: f64) -> f64 {
        vector::barrier_grad_dot(&self.ws, mu)
    }

    /// Takes the step: w = w_t (already holding w + alpha dw), y += alpha dy, z += alpha_z dz.
    pub(super) fn accept(&mut self, f_t: f64, alpha: f64, alpha_z: f64, mu: f64, update_y: bool) {
        self.phi_current = None;
        let ws = &mut self.ws;
        ws.grad_lag_fresh = false;
        let m = ws.m;
        // Swapped, not copied: every trial rewrites w_t, g_t and c_t whole before reading
        // them (`set_trial`, `eval_trial`).
        std::mem::swap(&mut ws.w, &mut ws.w_t);
        ws.f = f_t;
        std::mem::swap(&mut ws.g, &mut ws.g_t);
        std::mem::swap(&mut ws.c, &mut ws.c_t);
        if update_y {
            for i in 0..m {
                ws.y[i] += alpha * ws.dy[i];
            }
        }
        vector::step_bound_duals(ws, alpha_z, mu);
    }
}

/// `a <= b` up to rounding in quantities of magnitude `base` (IPOPT's Compare_le).
pub(super) fn le(a: f64, b: f64, base: f64) -> bool {
    a - b <= 10.0 * f64::EPSILON * base.abs().max(1.0)
}
