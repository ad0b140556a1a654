//! What a planning cycle publishes ([`planner::plan::choice::choose`]) and the previous
//! plan it falls back on.
//!
//! A cycle sends its solve's plan when it converged or when its best iterate is drivable;
//! otherwise it republishes the last plan it sent that way, shifted to the car's arc
//! length: with the car at s_car and the previous plan's origin at s_prev, the shift is
//! d = s_car - s_prev >= 0, and the republished plan starts at the last node the car has
//! passed, m = floor(d / ds): its node k is the previous plan's node k + m and its origin
//! s_prev + m ds, with s re-referenced to k ds and t to 0 at node 0. Shifting by whole
//! nodes keeps the plan exactly (the controls are held on their intervals, which a
//! fractional shift would smear over two). Past the previous horizon the states are held
//! at its last node and t runs on at the last node's speed; the decision rule republishes
//! only while d is at most an eighth of the horizon, so the car never reaches that part. With no usable previous plan (the first
//! cycle, another tracker run, the car past an eighth of the horizon) the cycle sends the
//! notice that it has no drivable plan (`crate::msg::KIND_NO_PLAN`): among obstacles the
//! tracker brakes to a stop in its lane at once; on a closed road it holds its plan until
//! the plan is stale, then brakes in lane.

use planner::ip::{SolveInfo, Status};
use planner::model::{ix, NU, NX};
use planner::plan::choice::{choose, previous_usable, Outcome, PlanKind};

use crate::kinds::KindCounts;
use crate::msg::{RunId, HORIZON_N};
use planner::plan::interp;

/// The last plan sent as converged or best iterate, and its shifted copy.
#[derive(Debug, Clone)]
pub struct PreviousPlan {
    xs: Vec<[f64; NX]>,
    us: Vec<[f64; NU]>,
    shifted_x: Vec<[f64; NX]>,
    shifted_u: Vec<[f64; NU]>,
    /// Track s of its node 0 \[m\].
    s_origin: f64,
    /// The tracker run it was planned for.
    run_id: RunId,
    /// Its solve's max constraint violation.
    max_violation: f64,
    /// The cycle that solved it.
    cycle: u64,
    /// False until a plan is stored.
    valid: bool,
}

impl Default for PreviousPlan {
    fn default() -> Self {
        Self::new()
    }
}

impl PreviousPlan {
    /// No previous plan yet (allocates the buffers once).
    pub fn new() -> Self {
        Self {
            xs: vec![[0.0; NX]; HORIZON_N + 1],
            us: vec![[0.0; NU]; HORIZON_N],
            shifted_x: vec![[0.0; NX]; HORIZON_N + 1],
            shifted_u: vec![[0.0; NU]; HORIZON_N],
            s_origin: 0.0,
            run_id: 0,
            max_violation: 0.0,
            cycle: 0,
            valid: false,
        }
    }

    /// Keeps a copy of a plan just sent (allocates nothing).
    pub fn store(
        &mut self,
        xs: &[[f64; NX]],
        us: &[[f64; NU]],
        s_origin: f64,
        run_id: RunId,
        max_violation: f64,
        cycle: u64,
    ) {
        self.xs.copy_from_slice(xs);
        self.us.copy_from_slice(us);
        self.s_origin = s_origin;
        self.run_id = run_id;
        self.max_violation = max_violation;
        self.cycle = cycle;
        self.valid = true;
    }

    /// The shift from its origin to `s_car` when it may be republished for run `run_id`
    /// ([`previous_usable`]); `None` otherwise.
    pub fn usable_shift(&self, s_car: f64, run_id: RunId, ds: f64) -> Option<f64> {
        let shift = s_car - self.s_origin;
        (self.valid && self.run_id == run_id && previous_usable(shift, HORIZON_N as f64 * ds))
            .then_some(shift)
    }

    /// Its solve's max constraint violation.
    pub fn max_violation(&self) -> f64 {
        self.max_violation
    }

    /// Cycles from its solve to `cycle`.
    pub fn age(&self, cycle: u64) -> u32 {
        cycle.saturating_sub(self.cycle).min(u64::from(u32::MAX)) as u32
    }

    /// Writes the plan shifted to the last node the car at `s_car` has passed (see the
    /// module documentation) into [`Self::shifted_plan`]; returns its origin s and the
    /// planned time from that node to the car \[s\]. Allocates nothing.
    pub fn shift_to(&mut self, s_car: f64, ds: f64) -> (f64, f64) {
        let shift = (s_car - self.s_origin).max(0.0);
        let m = ((shift / ds).floor() as usize).min(HORIZON_N);
        let t0 = self.xs[m][ix::T];
        let last = self.xs[HORIZON_N];
        for k in 0..=HORIZON_N {
            let s = k as f64 * ds;
            let mut x = if k + m <= HORIZON_N {
                self.xs[k + m]
            } else {
                let mut x = last;
                x[ix::T] += (k + m - HORIZON_N) as f64 * ds / last[ix::V].max(1.0);
                x
            };
            x[ix::S] = s;
            x[ix::T] -= t0;
            self.shifted_x[k] = x;
        }
        for k in 0..HORIZON_N {
            self.shifted_u[k] = self.us[(k + m).min(HORIZON_N - 1)];
        }
        let to_car = interp(&self.xs, ds, shift)[ix::T] - t0;
        (self.s_origin + m as f64 * ds, to_car)
    }

    /// The states and controls [`Self::shift_to`] wrote.
    pub fn shifted_plan(&self) -> (&[[f64; NX]], &[[f64; NU]]) {
        (&self.shifted_x, &self.shifted_u)
    }
}

/// The publish policy's state: the previous plan and the counts of what was sent.
#[derive(Debug, Clone, Default)]
pub struct Policy {
    /// The plan a failed cycle republishes.
    pub previous: PreviousPlan,
    /// Plans sent, by kind.
    pub sent: KindCounts,
    /// Cycles that solved but sent no plan (no usable previous plan): each sent the notice
    /// of no drivable plan instead.
    pub not_sent: u64,
}

impl Policy {
    /// What the cycle that solved `info` (`None`: the replan failed) from the car at
    /// `s_car` for run `run_id` sends; counts it and logs the first cycles past
    /// convergence. `None`: nothing.
    pub fn decide(
        &mut self,
        info: Option<&SolveInfo>,
        s_car: f64,
        run_id: RunId,
        ds: f64,
    ) -> Option<PlanKind> {
        let usable = self.previous.usable_shift(s_car, run_id, ds).is_some();
        let kind = choose(info.map(Outcome::of), usable);
        match kind {
            Some(k) => self.sent.count(k),
            None => self.not_sent += 1,
        }
        let past = kind != Some(PlanKind::Converged);
        let n = self.sent.best_iterate + self.sent.previous_shifted + self.not_sent;
        if past && (n <= 10 || n.is_multiple_of(100)) {
            let (status, its, viol) = info.map_or(("failed", 0, f64::NAN), |i| {
                (i.status.name(), i.iterations, i.max_violation)
            });
            crate::elog!(
                "planner: cycle at s = {s_car:.1} m ended {status} after {its} iterations, max violation {viol:.2e}: {} ({n} past convergence so far)",
                match kind {
                    Some(PlanKind::BestIterate) => "sending its best iterate",
                    Some(PlanKind::PreviousShifted) => "republishing the previous plan shifted",
                    _ => "no usable previous plan, sending the notice of no drivable plan",
                }
            );
        }
        kind
    }
}

/// Status code to publish for a cycle whose replan failed before solving.
pub fn failed_status() -> Status {
    Status::InvalidInput
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A plan at constant speed `v` with lateral offset e = 0.01 s on grid `ds`.
    fn plan(v: f64, ds: f64) -> (Vec<[f64; NX]>, Vec<[f64; NU]>) {
        let xs = (0..=HORIZON_N)
            .map(|k| {
                let s = k as f64 * ds;
                let mut x = [0.0; NX];
                x[ix::V] = v;
                x[ix::VWR] = v;
                x[ix::E] = 0.01 * s;
                x[ix::S] = s;
                x[ix::T] = s / v;
                x
            })
            .collect();
        let us = (0..HORIZON_N).map(|k| [k as f64, 0.0, 0.0]).collect();
        (xs, us)
    }

    #[test]
    fn the_shifted_plan_starts_at_the_car_and_keeps_the_previous_geometry() {
        let ds = 2.0;
        let (xs, us) = plan(20.0, ds);
        let mut prev = PreviousPlan::new();
        assert_eq!(prev.usable_shift(100.0, 1, ds), None);
        prev.store(&xs, &us, 100.0, 1, 1e-7, 4);
        assert_eq!(prev.usable_shift(95.0, 1, ds), None, "the car is behind it");
        assert_eq!(prev.usable_shift(105.0, 2, ds), None, "another tracker run");
        assert_eq!(
            prev.usable_shift(126.0, 1, ds),
            None,
            "past an eighth of the horizon"
        );
        let shift = prev.usable_shift(105.0, 1, ds).expect("usable");
        assert_eq!(shift, 5.0);
        assert_eq!(prev.age(7), 3);
        // The car at 105 m has passed node 2 (104 m): the plan restarts there.
        let (origin, to_car) = prev.shift_to(105.0, ds);
        assert_eq!(origin, 104.0);
        assert!((to_car - 1.0 / 20.0).abs() < 1e-12, "{to_car}");
        let (sx, su) = prev.shifted_plan();
        for k in 0..=HORIZON_N {
            let s = k as f64 * ds;
            assert_eq!(sx[k][ix::S], s);
            // Same track geometry: e at track s 104 + s is the previous plan's at 4 + s.
            let e_prev = 0.01 * (s + 4.0).min(HORIZON_N as f64 * ds);
            assert!((sx[k][ix::E] - e_prev).abs() < 1e-12, "node {k}");
            assert!((sx[k][ix::T] - s / 20.0).abs() < 1e-12, "node {k}");
        }
        assert_eq!(su[0][0], 2.0, "control of the interval holding s = 4");
        assert_eq!(su[HORIZON_N - 1][0], (HORIZON_N - 1) as f64);
    }

    #[test]
    fn a_cycle_past_convergence_republishes_the_previous_plan_or_sends_nothing() {
        let ds = 2.0;
        let (xs, us) = plan(20.0, ds);
        let mut policy = Policy::default();
        let failed = SolveInfo {
            max_violation: 0.5,
            ..capped(Status::TimeLimit)
        };
        // No previous plan: no plan is sent (the process sends its notice).
        assert_eq!(policy.decide(Some(&failed), 0.0, 1, ds), None);
        policy.previous.store(&xs, &us, 0.0, 1, 1e-8, 0);
        assert_eq!(
            policy.decide(Some(&failed), 3.0, 1, ds),
            Some(PlanKind::PreviousShifted)
        );
        assert_eq!(
            policy.decide(None, 3.0, 1, ds),
            Some(PlanKind::PreviousShifted)
        );
        let good = SolveInfo {
            max_violation: 2e-4,
            ..capped(Status::TimeLimit)
        };
        assert_eq!(
            policy.decide(Some(&good), 3.0, 1, ds),
            Some(PlanKind::BestIterate)
        );
        assert_eq!(
            policy.sent,
            KindCounts {
                converged: 0,
                best_iterate: 1,
                previous_shifted: 2
            }
        );
        assert_eq!(policy.not_sent, 1);
    }

    /// The planner's cycle on the oval: a converged plan from s = 0, then a replan 5 m on
    /// capped at 3 iterations, whose best iterate is past the threshold: the cycle
    /// republishes the converged plan shifted to the car, which matches it at the car's s.
    #[test]
    fn a_cycle_capped_before_convergence_republishes_the_previous_plan_shifted() {
        use crate::road::{RoadWindow, Scenario};
        use planner::ip::Settings;
        use planner::plan::{Planner, ReplanGuess};

        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let sc = Scenario::load(
            &root.join("config/scenarios/oval.toml"),
            &root.join("config/vehicles/lc500.toml"),
            &root.join("config/solver.toml"),
        )
        .expect("oval scenario");
        let ds = sc.ds();
        let mut planner = Planner::<HORIZON_N>::new(sc.spec.clone(), sc.settings).unwrap();
        let mut road = RoadWindow::default();
        let mut replan = |planner: &mut Planner<HORIZON_N>, s: f64, x0: [f64; NX]| {
            sc.road
                .window(s, ds, 0.5, super::super::MARGIN_RAMP_M, &mut road);
            planner
                .replan(
                    &road.kappa,
                    &road.e_min,
                    &road.e_max,
                    x0,
                    ReplanGuess::Equilibrium,
                )
                .unwrap()
        };
        let mut x0 = crate::plant::Plant::cruise(sc.spec.vehicle, 15.0).x;
        x0[ix::S] = 0.0;
        x0[ix::T] = 0.0;
        let first = replan(&mut planner, 0.0, x0);
        let mut policy = Policy::default();
        assert_eq!(
            policy.decide(Some(&first), 0.0, 1, ds),
            Some(PlanKind::Converged)
        );
        policy.previous.store(
            planner.states(),
            planner.controls(),
            0.0,
            1,
            first.max_violation,
            0,
        );
        let converged = planner.states().to_vec();

        // The car 5 m on, on the plan; the next solve gets 3 iterations.
        let shift = 5.0;
        let mut x1 = interp(&converged, ds, shift);
        x1[ix::S] = 0.0;
        x1[ix::T] = 0.0;
        let capped = Settings {
            max_iter: 3,
            ..sc.settings
        };
        planner.solver_mut().set_settings(capped).unwrap();
        let info = replan(&mut planner, shift, x1);
        assert_eq!(info.status, Status::IterationLimit);
        assert!(
            info.max_violation > planner::plan::choice::DRIVABLE_VIOLATION,
            "{info:?}"
        );
        assert_eq!(
            policy.decide(Some(&info), shift, 1, ds),
            Some(PlanKind::PreviousShifted)
        );
        let (origin, _) = policy.previous.shift_to(shift, ds);
        assert_eq!(origin, ds, "the car 5 m on has passed node 1");
        let (xs, _) = policy.previous.shifted_plan();
        // The shifted plan is the converged one, seen from the car.
        for k in 0..HORIZON_N / 2 {
            let want = converged[k + 1];
            for i in [ix::V, ix::E, ix::DPSI, ix::BETA, ix::R] {
                assert!((xs[k][i] - want[i]).abs() < 1e-12, "node {k} state {i}");
            }
        }
        assert_eq!(xs[0][ix::T], 0.0);
        // The next cycle with a roomy budget converges again and is sent as such.
        planner.solver_mut().set_settings(sc.settings).unwrap();
        let again = replan(&mut planner, shift, x1);
        assert_eq!(
            policy.decide(Some(&again), shift, 1, ds),
            Some(PlanKind::Converged)
        );
    }

    #[test]
    fn keeping_shifting_and_choosing_the_previous_plan_allocates_nothing() {
        let ds = 2.0;
        let (xs, us) = plan(20.0, ds);
        let mut prev = PreviousPlan::new();
        let measured = allocation_counter::measure(|| {
            for i in 0..100 {
                prev.store(&xs, &us, 0.0, 1, 1e-8, i);
                let usable = prev.usable_shift(0.1 * i as f64, 1, ds).is_some();
                assert_eq!(choose(None, usable), Some(PlanKind::PreviousShifted));
                prev.shift_to(0.1 * i as f64, ds);
            }
        });
        assert_eq!(measured.count_total, 0, "{measured:?}");
        // The counter sees allocations (the test can fail).
        let seen = allocation_counter::measure(|| {
            std::hint::black_box(vec![1u8; 16]);
        });
        assert!(seen.count_total > 0);
    }

    fn capped(status: Status) -> SolveInfo {
        SolveInfo {
            status,
            iterations: 3,
            objective: 0.0,
            max_violation: 0.0,
            initial_violation: 0.0,
            start_violation: 0.0,
            dual_inf: 0.0,
            compl: 0.0,
            mu: 0.0,
            factorizations: 0,
            max_factorizations_per_iter: 0,
            fallback_steps: 0,
            evaluations: 0,
            times: Default::default(),
            best_iterate: true,
            best_iteration: 2,
        }
    }
}
