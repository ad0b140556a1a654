//! Solver settings: tolerances, caps on every loop, and the barrier rule. Loaded from
//! `config/solver.toml` (all keys optional; unknown keys are rejected).

use super::kkt::KktBackendKind;
use serde::{Deserialize, Serialize};

/// Barrier parameter update rule (paper Sec. VI-C, Table IV).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum BarrierRule {
    /// Fiacco-McCormick: fixed mu until the barrier subproblem is solved, then decrease
    /// (Waechter & Biegler 2006, Sec. 2.1). The default: the most robust rule here.
    #[default]
    Monotone,
    /// Mehrotra predictor-corrector without safeguards (Nocedal, Waechter, Waltz 2009).
    Fullmpc,
    /// Mehrotra predictor-corrector whose corrector is only taken when it does not shorten
    /// the step (KNITRO's "dampmpc"; Byrd, Nocedal, Waltz 2006).
    Dampmpc,
    /// LOQO rule: mu from the spread of the complementarity products (Vanderbei-Shanno).
    Loqo,
    /// Quality-function oracle: mu = sigma * average complementarity, with sigma minimizing
    /// a merit of the linearized KKT residuals after the step d_aff + sigma d_cen (golden
    /// section, capped evaluations; Nocedal, Waechter, Waltz 2009, Sec. 4; KNITRO's
    /// "quality").
    Quality,
    /// KNITRO's "adaptive": mu from the complementarity gap alone, a fixed fraction
    /// [`crate::ip::barrier::GAP_SIGMA`] of the average complementarity s^T z / m at every
    /// iteration (the gap rule of Nocedal, Waechter, Waltz 2009, Sec. 2).
    Adaptive,
    /// Mehrotra probing: an affine-scaling probe gives mu = (mu_aff / mu_avg)^3 mu_avg, then
    /// a plain Newton step with that mu, no corrector (Byrd, Nocedal, Waltz 2006, KNITRO).
    Probing,
}

impl BarrierRule {
    /// Name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            BarrierRule::Monotone => "monotone",
            BarrierRule::Fullmpc => "fullmpc",
            BarrierRule::Dampmpc => "dampmpc",
            BarrierRule::Loqo => "loqo",
            BarrierRule::Quality => "quality",
            BarrierRule::Adaptive => "adaptive",
            BarrierRule::Probing => "probing",
        }
    }

    /// Parses a rule name (`dampmpc`, `probing`, `fullmpc`, `adaptive`, `quality`,
    /// `monotone`, `loqo`).
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "monotone" => Some(BarrierRule::Monotone),
            "fullmpc" => Some(BarrierRule::Fullmpc),
            "dampmpc" => Some(BarrierRule::Dampmpc),
            "loqo" => Some(BarrierRule::Loqo),
            "quality" => Some(BarrierRule::Quality),
            "adaptive" => Some(BarrierRule::Adaptive),
            "probing" => Some(BarrierRule::Probing),
            _ => None,
        }
    }

    /// All implemented rules (the order of the paper's Table IV, then ours).
    pub const ALL: [BarrierRule; 7] = [
        BarrierRule::Dampmpc,
        BarrierRule::Probing,
        BarrierRule::Fullmpc,
        BarrierRule::Adaptive,
        BarrierRule::Quality,
        BarrierRule::Monotone,
        BarrierRule::Loqo,
    ];
}

/// How steps are accepted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Globalization {
    /// Filter line search on (violation, barrier objective) (Waechter & Biegler 2006).
    #[default]
    Filter,
    /// Armijo line search on the l2 merit function of paper eq. (5).
    Merit,
}

/// Tolerances, caps and algorithm choices of the interior-point solver.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct Settings {
    /// Overall (scaled) KKT tolerance for `optimal`.
    pub tol: f64,
    /// Max constraint violation for `optimal` (NLP units).
    pub constr_viol_tol: f64,
    /// Unscaled dual infeasibility for `optimal`.
    pub dual_inf_tol: f64,
    /// Unscaled complementarity for `optimal`.
    pub compl_inf_tol: f64,
    /// Overall tolerance for `acceptable` (used when a cap is hit).
    pub acceptable_tol: f64,
    /// Constraint violation for `acceptable`.
    pub acceptable_constr_viol_tol: f64,
    /// Cap on iterations.
    pub max_iter: usize,
    /// Wall-clock budget of a solve in seconds, checked at every point where the solver
    /// can stop cleanly (each iteration, factorization, line-search trial and restoration
    /// step); a solve that spends it ends `time_limit` with its best iterate. Not
    /// deterministic: where a solve stops depends on the machine (`max_iter` is).
    pub max_time_s: f64,
    /// Cap on backtracking steps per line search.
    pub max_backtracks: usize,
    /// Cap on factorizations per iteration while correcting inertia.
    pub max_inertia_corrections: usize,
    /// Cap on KKT factorizations in one iteration, the convexified fallback included: after
    /// `max_refactorizations - 1` inertia-correcting attempts the iteration takes the
    /// fallback step, whose matrix has the right inertia by construction (see
    /// `Solver::factorize_with`). Bounds the work per iteration (paper Sec. VI-B).
    pub max_refactorizations: usize,
    /// Cap on consecutive failed line searches before giving up.
    pub max_ls_failures: usize,
    /// Cap on feasibility-restoration iterations per solve.
    pub max_restoration_steps: usize,
    /// Barrier update rule.
    pub barrier: BarrierRule,
    /// Step acceptance.
    pub globalization: Globalization,
    /// Safeguard of the free rules: mu >= this factor times min(1, KKT error); 0 switches
    /// the floor off (the rules as published).
    pub mu_floor_factor: f64,
    /// Safeguard of the free rules: mu >= this fraction of the previous iteration's mu (at
    /// most a 10x decrease with 0.1); 0 switches the cap off (the rules as published).
    pub mu_max_decrease: f64,
    /// Initial barrier parameter (monotone rule).
    pub mu_init: f64,
    /// Smallest barrier parameter.
    pub mu_min: f64,
    /// Monotone rule: linear decrease factor kappa_mu of mu (IPOPT: 0.2).
    pub mu_linear_decrease: f64,
    /// Monotone rule: superlinear decrease power theta_mu of mu (IPOPT: 1.5).
    pub mu_superlinear_power: f64,
    /// Monotone rule: a barrier problem counts as solved once its error is below this
    /// factor times mu (IPOPT's barrier_tol_factor is 10; 30 here, for the planner's
    /// objective; `config/solver_min_time.toml` keeps 10 for the pure minimum time).
    pub barrier_tol_factor: f64,
    /// Relative push of the starting point into the bounds.
    pub bound_push: f64,
    /// Relative push of the starting point into the bounds, as a fraction of the interval.
    pub bound_frac: f64,
    /// Relative relaxation of the bounds (IPOPT's bound_relax_factor).
    pub bound_relax: f64,
    /// Smallest fraction-to-the-boundary parameter tau.
    pub tau_min: f64,
    /// Armijo constant of the merit line search.
    pub armijo: f64,
    /// Try a second-order correction when the full step is rejected. Off by default: on the
    /// vehicle OCP the corrected trial violates the constraints more often than not (the
    /// stiff wheel-speed rows at the first nodes), so the corrections cost iterations.
    pub second_order_correction: bool,
    /// Initial penalty parameter nu of the merit function (paper eq. 5).
    pub penalty_init: f64,
    /// First primal regularization tried when the inertia is wrong.
    pub delta_w_init: f64,
    /// Factor by which the previous iteration's regularization is reduced for the first
    /// factorization of the next iteration (IPOPT uses 3).
    pub delta_w_decrease: f64,
    /// Largest primal regularization before the iteration is declared failed.
    pub delta_w_max: f64,
    /// Dual regularization always present (keeps redundant constraints factorizable).
    pub delta_c_min: f64,
    /// Relative threshold on the infeasibility-stationarity measure for `locally_infeasible`.
    pub infeas_stat_tol: f64,
    /// KKT backend: `auto` (Riccati where the stage structure allows, else sparse),
    /// `sparse` or `riccati`.
    pub kkt: KktBackendKind,
    /// Threads of a solve: 1, or 2 to pipeline the Riccati factorization over a helper
    /// thread that writes the stage blocks while the sweep runs (same bits as 1; pays off
    /// only when the helper has a core of its own). Fixed at setup; not recorded, since it
    /// does not change results.
    pub threads: usize,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            tol: 1e-6,
            constr_viol_tol: 1e-6,
            dual_inf_tol: 1.0,
            compl_inf_tol: 1e-4,
            acceptable_tol: 1e-4,
            acceptable_constr_viol_tol: 1e-4,
            max_iter: 500,
            max_time_s: 10.0,
            max_backtracks: 30,
            max_inertia_corrections: 12,
            max_refactorizations: 6,
            max_ls_failures: 6,
            max_restoration_steps: 200,
            barrier: BarrierRule::Monotone,
            globalization: Globalization::Filter,
            mu_floor_factor: 1e-2,
            mu_max_decrease: 0.1,
            mu_init: 0.1,
            mu_min: 1e-11,
            mu_linear_decrease: 0.2,
            mu_superlinear_power: 1.5,
            barrier_tol_factor: 30.0,
            bound_push: 1e-2,
            bound_frac: 1e-2,
            bound_relax: 1e-8,
            tau_min: 0.99,
            armijo: 1e-4,
            second_order_correction: false,
            penalty_init: 1.0,
            delta_w_init: 1e-4,
            delta_w_max: 1e20,
            delta_w_decrease: 10.0,
            delta_c_min: 1e-10,
            infeas_stat_tol: 1e-6,
            kkt: KktBackendKind::Auto,
            threads: 1,
        }
    }
}

/// Largest wall-clock cap of one solve \[s\].
pub const MAX_TIME_S: f64 = 3600.0;

/// A setting outside its valid range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("solver setting `{field}` = {value}: {expected}")]
pub struct SettingsError {
    /// Name of the offending key.
    pub field: &'static str,
    /// Its value, printed.
    pub value: String,
    /// What was expected.
    pub expected: &'static str,
}

impl Settings {
    /// Checks every value is finite and in range.
    pub fn validate(&self) -> Result<(), SettingsError> {
        self.check_ranges()?;
        self.check_relations()?;
        self.check_caps()
    }

    /// The values that must be positive and finite, and those in (0, 1).
    fn check_ranges(&self) -> Result<(), SettingsError> {
        let pos = [
            ("tol", self.tol),
            ("constr_viol_tol", self.constr_viol_tol),
            ("dual_inf_tol", self.dual_inf_tol),
            ("compl_inf_tol", self.compl_inf_tol),
            ("acceptable_tol", self.acceptable_tol),
            (
                "acceptable_constr_viol_tol",
                self.acceptable_constr_viol_tol,
            ),
            ("max_time_s", self.max_time_s),
            ("mu_init", self.mu_init),
            ("mu_min", self.mu_min),
            ("bound_push", self.bound_push),
            ("bound_frac", self.bound_frac),
            ("penalty_init", self.penalty_init),
            ("delta_w_init", self.delta_w_init),
            ("delta_w_max", self.delta_w_max),
            ("delta_w_decrease", self.delta_w_decrease),
            ("infeas_stat_tol", self.infeas_stat_tol),
            ("barrier_tol_factor", self.barrier_tol_factor),
        ];
        for (field, v) in pos {
            if v.is_nan() || v <= 0.0 || v.is_infinite() {
                return Err(SettingsError {
                    field,
                    value: v.to_string(),
                    expected: "must be a positive finite number",
                });
            }
        }
        let off_or_unit = [
            ("mu_floor_factor", self.mu_floor_factor, f64::INFINITY),
            ("mu_max_decrease", self.mu_max_decrease, 1.0),
        ];
        for (field, v, hi) in off_or_unit {
            if !(v >= 0.0 && v < hi) {
                return Err(SettingsError {
                    field,
                    value: v.to_string(),
                    expected: if hi.is_finite() {
                        "must lie in [0, 1) (0: safeguard off)"
                    } else {
                        "must be a finite number >= 0 (0: safeguard off)"
                    },
                });
            }
        }
        let unit = [
            ("tau_min", self.tau_min),
            ("mu_linear_decrease", self.mu_linear_decrease),
            ("armijo", self.armijo),
        ];
        for (field, v) in unit {
            if !(v > 0.0 && v < 1.0) {
                return Err(SettingsError {
                    field,
                    value: v.to_string(),
                    expected: "must lie in (0, 1)",
                });
            }
        }
        Ok(())
    }

    /// The relations between values and the ranges narrower than (0, 1).
    fn check_relations(&self) -> Result<(), SettingsError> {
        // Relations between values: each one's violation gives nonsense or cannot converge.
        let relations = [
            (
                "bound_frac",
                self.bound_frac,
                self.bound_frac <= 0.5,
                "must lie in (0, 0.5] (a larger fraction pushes the start past the far bound)",
            ),
            (
                "mu_min",
                self.mu_min,
                self.mu_min <= self.mu_init && self.mu_min <= self.tol,
                "must not exceed mu_init or tol (mu could not fall to the tolerance)",
            ),
            (
                "acceptable_tol",
                self.acceptable_tol,
                self.acceptable_tol >= self.tol,
                "must not be below tol",
            ),
            (
                "delta_w_init",
                self.delta_w_init,
                self.delta_w_init <= self.delta_w_max,
                "must not exceed delta_w_max",
            ),
            (
                "delta_w_decrease",
                self.delta_w_decrease,
                self.delta_w_decrease >= 1.0,
                "must be at least 1 (below 1 the shift would grow every iteration)",
            ),
        ];
        for (field, v, ok, expected) in relations {
            if !ok {
                return Err(SettingsError {
                    field,
                    value: v.to_string(),
                    expected,
                });
            }
        }
        if !(self.mu_superlinear_power > 1.0 && self.mu_superlinear_power < 2.0) {
            return Err(SettingsError {
                field: "mu_superlinear_power",
                value: self.mu_superlinear_power.to_string(),
                expected: "must lie in (1, 2)",
            });
        }
        if !(self.bound_relax >= 0.0 && self.bound_relax < 1e-2) {
            return Err(SettingsError {
                field: "bound_relax",
                value: self.bound_relax.to_string(),
                expected: "must lie in [0, 1e-2)",
            });
        }
        if !(self.delta_c_min >= 0.0 && self.delta_c_min < 1e-2) {
            return Err(SettingsError {
                field: "delta_c_min",
                value: self.delta_c_min.to_string(),
                expected: "must lie in [0, 1e-2)",
            });
        }
        Ok(())
    }

    /// The caps on time, iterations and the inner loops, and the thread count.
    fn check_caps(&self) -> Result<(), SettingsError> {
        // The caps bound the worst-case time of a solve (settings may come from a
        // recording): iterations, and within one iteration at most max_refactorizations
        // factorizations and max_backtracks trial evaluations.
        if self.max_time_s > MAX_TIME_S {
            return Err(SettingsError {
                field: "max_time_s",
                value: self.max_time_s.to_string(),
                expected: "must not exceed 3600 s",
            });
        }
        let caps = [
            (
                "max_iter",
                self.max_iter,
                100_000,
                "must be an integer in 1..=100000",
            ),
            (
                "max_backtracks",
                self.max_backtracks,
                100,
                "must be an integer in 1..=100 (2^-100: no step left)",
            ),
            (
                "max_inertia_corrections",
                self.max_inertia_corrections,
                100,
                "must be an integer in 1..=100",
            ),
            (
                "max_refactorizations",
                self.max_refactorizations,
                100,
                "must be an integer in 1..=100",
            ),
            (
                "max_ls_failures",
                self.max_ls_failures,
                1000,
                "must be an integer in 1..=1000",
            ),
            (
                "max_restoration_steps",
                self.max_restoration_steps,
                100_000,
                "must be an integer in 1..=100000",
            ),
        ];
        for (field, v, max, expected) in caps {
            if v == 0 || v > max {
                return Err(SettingsError {
                    field,
                    value: v.to_string(),
                    expected,
                });
            }
        }
        if !(1..=2).contains(&self.threads) {
            return Err(SettingsError {
                field: "threads",
                value: self.threads.to_string(),
                expected: "must be 1 or 2",
            });
        }
        if self.max_refactorizations < 2 {
            return Err(SettingsError {
                field: "max_refactorizations",
                value: self.max_refactorizations.to_string(),
                expected: "must be at least 2 (one Newton attempt plus the fallback)",
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The field `validate` names for settings changed by `f`.
    fn refused(f: impl Fn(&mut Settings)) -> &'static str {
        let mut s = Settings::default();
        f(&mut s);
        s.validate().expect_err("must be refused").field
    }

    #[test]
    fn defaults_are_valid() {
        assert_eq!(Settings::default().validate(), Ok(()));
    }

    #[test]
    fn the_free_rules_safeguards_switch_off_at_zero_and_refuse_negatives() {
        let off = Settings {
            mu_floor_factor: 0.0,
            mu_max_decrease: 0.0,
            ..Settings::default()
        };
        assert_eq!(off.validate(), Ok(()));
        assert_eq!(refused(|s| s.mu_floor_factor = -1e-3), "mu_floor_factor");
        assert_eq!(refused(|s| s.mu_floor_factor = f64::NAN), "mu_floor_factor");
        assert_eq!(refused(|s| s.mu_max_decrease = 1.0), "mu_max_decrease");
        assert_eq!(refused(|s| s.mu_max_decrease = -0.1), "mu_max_decrease");
    }

    #[test]
    fn every_rule_parses_from_its_table_iv_name() {
        for rule in BarrierRule::ALL {
            assert_eq!(BarrierRule::parse(rule.name()), Some(rule));
        }
        assert_eq!(BarrierRule::parse("quality"), Some(BarrierRule::Quality));
        assert_eq!(BarrierRule::parse("adaptive"), Some(BarrierRule::Adaptive));
        assert_eq!(BarrierRule::parse("mehrotra"), None);
    }

    #[test]
    fn values_that_would_panic_diverge_or_never_converge_are_refused_by_name() {
        assert_eq!(refused(|s| s.bound_frac = 1.5), "bound_frac");
        assert_eq!(refused(|s| s.bound_frac = 0.75), "bound_frac");
        assert_eq!(refused(|s| s.bound_frac = f64::NAN), "bound_frac");
        // mu_max = 1e3 mu_init would fall below mu_min (an adaptive rule's clamp).
        assert_eq!(
            refused(|s| {
                s.mu_init = 1e-12;
                s.mu_min = 1e-8;
            }),
            "mu_min"
        );
        assert_eq!(refused(|s| s.mu_min = 10.0 * s.tol), "mu_min");
        assert_eq!(
            refused(|s| s.acceptable_tol = 0.1 * s.tol),
            "acceptable_tol"
        );
        assert_eq!(
            refused(|s| s.delta_w_init = 10.0 * s.delta_w_max),
            "delta_w_init"
        );
        assert_eq!(refused(|s| s.delta_w_decrease = 0.5), "delta_w_decrease");
        assert_eq!(refused(|s| s.tau_min = 1.0), "tau_min");
        assert_eq!(refused(|s| s.max_iter = 0), "max_iter");
        // The caps bound a solve's time: no infinite clock, no unbounded loops.
        assert_eq!(refused(|s| s.max_time_s = f64::INFINITY), "max_time_s");
        assert_eq!(refused(|s| s.max_time_s = 3601.0), "max_time_s");
        assert_eq!(refused(|s| s.max_iter = 100_001), "max_iter");
        assert_eq!(refused(|s| s.max_backtracks = 101), "max_backtracks");
        assert_eq!(
            refused(|s| s.max_refactorizations = 101),
            "max_refactorizations"
        );
        let at_caps = Settings {
            max_time_s: MAX_TIME_S,
            max_backtracks: 100,
            max_iter: 100_000,
            ..Default::default()
        };
        assert_eq!(at_caps.validate(), Ok(()));
    }
}
