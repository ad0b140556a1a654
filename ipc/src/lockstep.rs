//! Lockstep: a closed loop on simulated time alone, the same bits on any machine.
//!
//! In real time the tracker simulates the car on the wall clock, the planner plans on its
//! own wall-clock ticks from the latest state, each solve is bounded by a wall-clock budget
//! B, and a plan reaches the car after the time it took. Which state a plan starts from,
//! when it arrives and where its solve stops all depend on the machine and its load, so two
//! runs differ after the first few cycles and a change to the planner can be judged only
//! on many laps.
//!
//! In lockstep the tracker flags one state per planning period T (at t_k = k T of
//! simulated time; [`crate::msg::FLAG_PLAN_NOW`]) and waits for the answer; the planner
//! plans from that state at once. A solve's time is modelled as c milliseconds per
//! iteration (`--lockstep-ms-per-iter`): its budget B becomes floor(B / c) iterations
//! ([`Lockstep::iterations`]), and the plan starts to be driven at t_k + min(c n, T) for a solve of
//! n iterations ([`Lockstep::latency_s`]); until then the car drives the previous plan. Everything
//! else (the plant, its noise, the estimator, the controller, the solver, the warm starts,
//! the publish policy) is deterministic, so a lockstep run repeats bit for bit, and it
//! runs as fast as the solves allow instead of at the wall clock's pace.

/// Default modelled time of one solver iteration \[ms\]: what an iteration of the long
/// solves (100-270 iterations, with more trial steps per iteration than a warm solve's)
/// takes on the AMD EPYC test machine, so the 80 ms budget stops them where the real-time
/// budget does there (docs/performance.md, "Lockstep").
pub const MS_PER_ITER: f64 = 0.6;

/// Wall-clock cap of a lockstep solve \[s\]: never the binding cap (the iteration budget
/// is), only the end of a solve that would otherwise hang the loop. A run that hits it
/// is no longer machine-independent, and the planner logs it as past its budget.
pub const WALL_CAP_S: f64 = 60.0;

/// The lockstep settings both processes share.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lockstep {
    /// Planning period T \[s\].
    pub period_s: f64,
    /// Modelled time of one solver iteration c \[ms\].
    pub ms_per_iter: f64,
}

impl Lockstep {
    /// Checks the modelled iteration time and the period (both finite and > 0, the period
    /// at most 10 s, an iteration at most one period).
    pub fn new(rate_hz: f64, ms_per_iter: f64) -> Result<Self, String> {
        if !(rate_hz > 0.0 && rate_hz <= 1000.0 && 1.0 / rate_hz <= 10.0) {
            return Err(format!(
                "lockstep rate {rate_hz} Hz: must lie in [0.1, 1000]"
            ));
        }
        let period_s = 1.0 / rate_hz;
        if !(ms_per_iter > 0.0 && ms_per_iter * 1e-3 <= period_s) {
            return Err(format!(
                "--lockstep-ms-per-iter {ms_per_iter}: must be > 0 and at most the period ({} ms)",
                period_s * 1e3
            ));
        }
        Ok(Self {
            period_s,
            ms_per_iter,
        })
    }

    /// The iterations a budget of `budget_ms` allows: floor(budget / c), at least 1.
    pub fn iterations(&self, budget_ms: f64) -> usize {
        let n = (budget_ms / self.ms_per_iter).floor();
        if n >= 1.0 {
            n.min(1e9) as usize
        } else {
            1
        }
    }

    /// How long after its state a plan of `iterations` iterations starts to be driven
    /// \[s\]: c n, at most one period (the next state is flagged then).
    pub fn latency_s(&self, iterations: u32) -> f64 {
        (f64::from(iterations) * self.ms_per_iter * 1e-3).min(self.period_s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_budget_becomes_whole_iterations_and_a_plan_arrives_within_one_period() {
        let ls = Lockstep::new(10.0, 0.6).unwrap();
        assert_eq!(ls.iterations(80.0), 133);
        assert_eq!(ls.iterations(0.1), 1);
        assert!((ls.latency_s(10) - 6e-3).abs() < 1e-15);
        assert_eq!(ls.latency_s(1000), 0.1);
    }

    #[test]
    fn lockstep_settings_out_of_range_are_refused_with_the_option_named() {
        assert!(Lockstep::new(10.0, 0.0)
            .unwrap_err()
            .contains("--lockstep-ms-per-iter"));
        assert!(Lockstep::new(10.0, f64::NAN).is_err());
        assert!(Lockstep::new(10.0, 200.0).is_err());
        assert!(Lockstep::new(0.0, 0.3).is_err());
        assert!(Lockstep::new(f64::INFINITY, 0.3).is_err());
    }
}
