//! One planning problem end to end: the OCP instance (implicit Euler), the solver and the
//! cached equilibrium guess. Everything is allocated in [`Planner::new`]; [`Planner::solve`]
//! allocates nothing.

pub mod choice;

use crate::guess::{self, Equilibrium, GuessKind};
use crate::ip::{Settings, SetupError, SolveInfo, Solver};
use crate::model::{ix, NU, NX};
use crate::ocp::transcription::{ImplicitEulerNlp, TranscriptionError};
use crate::ocp::{InitialState, OcpSpec};
use crate::trajectory::Trajectory;

mod diagnose;
mod warm;
pub use warm::{interp, shift_plan, PlanSlices, WarmDuals, WarmOptions, WarmReplan};

/// Start speed of the equilibrium least-squares problem when the initial state is free
/// (the independent reference starts it at 15 m/s, too).
pub const DEFAULT_GUESS_SPEED: f64 = 15.0;

/// Why a planner could not be built.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// The OCP data is outside its domain ([`OcpSpec::check`]).
    #[error(transparent)]
    Spec(#[from] crate::ocp::SpecError),
    /// The OCP data does not fit this transcription.
    #[error(transparent)]
    Transcription(#[from] TranscriptionError),
    /// The solver could not be set up.
    #[error(transparent)]
    Setup(#[from] SetupError),
    /// The equilibrium guess failed.
    #[error(transparent)]
    Guess(#[from] guess::GuessError),
    /// A replanning input has the wrong length (need N + 1 road samples, N + 1 states, N controls).
    #[error("replan: {field} has {got} entries, expected {expected}")]
    ReplanLength {
        /// Which input.
        field: &'static str,
        /// Required length.
        expected: usize,
        /// Given length.
        got: usize,
    },
}

/// The starting point of [`Planner::replan`].
#[derive(Debug, Clone, Copy)]
pub enum ReplanGuess<'a> {
    /// The equilibrium guess at the speed of x0 (recomputed when that speed changed, so a
    /// replan equals a fresh [`Planner::new`] + [`Planner::solve`] bit for bit), with x_0
    /// set to the fixed initial state.
    Equilibrium,
    /// The equilibrium pair at the speeds the window's curvature allows
    /// ([`guess::fill_road_speed`]), x_0 set to the fixed initial state.
    RoadSpeed,
    /// A caller-built guess (e.g. the previous solution shifted in s): N + 1 states, N controls.
    Warm(&'a [[f64; NX]], &'a [[f64; NU]]),
}

impl ReplanGuess<'_> {
    /// The cold start of a guess kind: [`ReplanGuess::RoadSpeed`] for the road-speed guess,
    /// else [`ReplanGuess::Equilibrium`] (the zero guess is not a replanning start).
    pub fn cold(kind: GuessKind) -> Self {
        match kind.cold_start() {
            GuessKind::RoadSpeed => ReplanGuess::RoadSpeed,
            _ => ReplanGuess::Equilibrium,
        }
    }
}

/// A reusable planner for one road and vehicle with N intervals.
#[derive(Debug)]
pub struct Planner<const N: usize> {
    nlp: ImplicitEulerNlp<N>,
    solver: Solver,
    equilibrium: Equilibrium,
    /// Speed the cached equilibrium was computed for.
    v_start: f64,
    xs: Vec<[f64; NX]>,
    us: Vec<[f64; NU]>,
    /// Buffers of the shifted primal-dual start ([`Planner::replan_warm`]).
    warm: warm::WarmBuffers,
}

impl<const N: usize> Planner<N> {
    /// Builds the OCP, the solver and the equilibrium guess (allocates).
    pub fn new(spec: OcpSpec, settings: Settings) -> Result<Self, PlanError> {
        spec.check()?;
        let v_start = match spec.initial {
            InitialState::Fixed(x0) => x0[ix::V],
            InitialState::Free => DEFAULT_GUESS_SPEED,
        };
        let equilibrium = guess::equilibrium(&spec.vehicle, spec.v_min, spec.v_max, v_start)?;
        let mut nlp = ImplicitEulerNlp::<N>::new(spec)?;
        let solver = Solver::new(&nlp, settings)?;
        // threads = 2: the Hessian evaluation shares the factorization's helper thread.
        nlp.set_worker(solver.kkt().worker());
        let rows: Vec<_> = (0..solver.workspace().m)
            .map(|i| {
                let r = nlp.describe_row(i);
                (r.kind, r.node)
            })
            .collect();
        let warm = warm::WarmBuffers::new(N, solver.workspace().n, &rows);
        Ok(Self {
            nlp,
            solver,
            equilibrium,
            v_start,
            xs: vec![[0.0; NX]; N + 1],
            us: vec![[0.0; NU]; N],
            warm,
        })
    }

    /// The problem data.
    pub fn spec(&self) -> &OcpSpec {
        self.nlp.spec()
    }

    /// The cached equilibrium guess (paper eq. 8).
    pub fn equilibrium(&self) -> &Equilibrium {
        &self.equilibrium
    }

    /// The solver (settings, iteration log).
    pub fn solver(&self) -> &Solver {
        &self.solver
    }

    /// Mutable solver access (to change settings between solves).
    pub fn solver_mut(&mut self) -> &mut Solver {
        &mut self.solver
    }

    /// The transcription (diagnostics: row names, violations).
    pub fn nlp(&mut self) -> &mut ImplicitEulerNlp<N> {
        &mut self.nlp
    }

    /// Writes the chosen initial guess into the transcription. Allocates nothing.
    pub fn set_guess(&mut self, kind: GuessKind) {
        let fixed = match self.nlp.spec().initial {
            InitialState::Fixed(x0) => Some(x0),
            InitialState::Free => None,
        };
        match kind {
            GuessKind::Equilibrium => guess::fill_equilibrium(
                &self.equilibrium,
                self.nlp.spec().ds(),
                fixed.as_ref(),
                &mut self.xs,
                &mut self.us,
            ),
            GuessKind::Zero => guess::fill_zero(fixed.as_ref(), &mut self.xs, &mut self.us),
            GuessKind::RoadSpeed => {
                let spec = self.nlp.spec();
                guess::fill_road_speed(
                    &self.equilibrium,
                    spec.ds(),
                    &spec.kappa,
                    &spec.vehicle,
                    fixed.as_ref(),
                    &mut self.xs,
                    &mut self.us,
                )
            }
        }
        self.nlp.set_initial_guess(&self.xs, &self.us);
    }

    /// Solves from the given guess; the solution is then in [`Self::states`] and
    /// [`Self::controls`]. Allocates nothing.
    pub fn solve(&mut self, kind: GuessKind) -> SolveInfo {
        self.set_guess(kind);
        let info = self.solver.solve(&mut self.nlp);
        self.nlp
            .trajectory_into(self.solver.x(), &mut self.xs, &mut self.us);
        self.keep_if_success(&info);
        info
    }

    /// Replans over a new road window from a fixed initial state x0 (s and t of x0 should
    /// be 0): writes the road and x0, sets the guess and solves. The solution is then in
    /// [`Self::states`] and [`Self::controls`].
    ///
    /// Updates the road and the initial state in place (no allocation, same sparsity) and
    /// solves.
    pub fn replan(
        &mut self,
        kappa: &[f64],
        e_min: &[f64],
        e_max: &[f64],
        x0: [f64; NX],
        guess: ReplanGuess<'_>,
    ) -> Result<SolveInfo, PlanError> {
        if let ReplanGuess::Warm(xs, us) = guess {
            if xs.len() != N + 1 || us.len() != N {
                return Err(PlanError::ReplanLength {
                    field: if xs.len() != N + 1 {
                        "states"
                    } else {
                        "controls"
                    },
                    expected: if xs.len() != N + 1 { N + 1 } else { N },
                    got: if xs.len() != N + 1 {
                        xs.len()
                    } else {
                        us.len()
                    },
                });
            }
        }
        self.set_window(kappa, e_min, e_max, x0)?;
        match guess {
            ReplanGuess::Equilibrium | ReplanGuess::RoadSpeed => {
                if x0[ix::V].to_bits() != self.v_start.to_bits() {
                    let spec = self.nlp.spec();
                    self.equilibrium =
                        guess::equilibrium(&spec.vehicle, spec.v_min, spec.v_max, x0[ix::V])?;
                    self.v_start = x0[ix::V];
                }
                self.set_guess(match guess {
                    ReplanGuess::RoadSpeed => GuessKind::RoadSpeed,
                    _ => GuessKind::Equilibrium,
                })
            }
            ReplanGuess::Warm(xs, us) => self.nlp.set_initial_guess(xs, us),
        }
        let info = self.solver.solve(&mut self.nlp);
        self.nlp
            .trajectory_into(self.solver.x(), &mut self.xs, &mut self.us);
        self.keep_if_success(&info);
        Ok(info)
    }

    /// Sets the tire saturation bound eps_sat of the following solves (R5: sigma - sigma_sl
    /// <= eps_sat) in place, without changing the constraint structure, so a warm start
    /// carries over. Allocates nothing.
    pub fn set_saturation_bound(&mut self, eps_sat: f64) -> Result<(), PlanError> {
        self.nlp
            .set_saturation_bound(eps_sat)
            .map_err(|e| PlanError::Spec(e.into()))
    }

    /// Sets the saturation bound and the grip of the following solves
    /// ([`crate::model::Limits`]) in place, without changing the constraint structure, so a
    /// warm start carries over. The next cold start recomputes its equilibrium guess with
    /// the new grip. Allocates nothing; refused limits leave the planner as it was.
    pub fn set_limits(&mut self, limits: crate::model::Limits) -> Result<(), PlanError> {
        self.nlp
            .set_limits(limits)
            .map_err(|e| PlanError::Spec(e.into()))?;
        // A speed no state has: the next cold replan rebuilds the equilibrium.
        self.v_start = f64::NAN;
        Ok(())
    }

    /// Sets the soft lane bounds of the following solves ([`crate::ocp::SoftLane`]; the
    /// spec's soft lane must be on) in place, one per node. Allocates nothing; a refused
    /// input (wrong length, not finite, soft lane off) leaves the planner as it was.
    pub fn set_soft_lane(&mut self, e_min: &[f64], e_max: &[f64]) -> Result<(), PlanError> {
        if let Some(k) = e_min.iter().chain(e_max).position(|v| !v.is_finite()) {
            return Err(PlanError::Spec(crate::ocp::SpecError::Field {
                field: "soft_lane".into(),
                problem: format!("bound {k} is not finite"),
            }));
        }
        self.nlp.update_soft_lane(e_min, e_max)?;
        Ok(())
    }

    /// Sets the speed bound of the last node of the following solves
    /// ([`crate::ocp::OcpSpec::v_end_max`]; `f64::INFINITY`: v_max alone) in place.
    /// Allocates nothing; a bound at or below v_min leaves the planner as it was.
    pub fn set_end_speed_cap(&mut self, v_end_max: f64) -> Result<(), PlanError> {
        self.nlp.set_end_speed_cap(v_end_max)?;
        Ok(())
    }

    /// Writes a new road window and the fixed initial state x0 into the transcription,
    /// after checking them; a refused input leaves the planner as it was.
    pub(crate) fn set_window(
        &mut self,
        kappa: &[f64],
        e_min: &[f64],
        e_max: &[f64],
        x0: [f64; NX],
    ) -> Result<(), PlanError> {
        for (field, len, expected) in [
            ("kappa", kappa.len(), N + 1),
            ("e_min", e_min.len(), N + 1),
            ("e_max", e_max.len(), N + 1),
        ] {
            if len != expected {
                return Err(PlanError::ReplanLength {
                    field,
                    expected,
                    got: len,
                });
            }
        }
        // Checked before anything changes: a refused input leaves the planner as it was.
        crate::ocp::spec::check_road(kappa, e_min, e_max, N)?;
        self.nlp
            .spec()
            .initial_domain(kappa, e_min, e_max)
            .check(&x0)?;
        // In place: same sparsity, so the solver's symbolic analysis stays valid.
        self.nlp
            .update_window(kappa, e_min, e_max, InitialState::Fixed(x0))?;
        Ok(())
    }

    /// States x_0..x_N of the last solve (physical units).
    pub fn states(&self) -> &[[f64; NX]] {
        &self.xs
    }

    /// Controls u_0..u_{N-1} of the last solve (physical units).
    pub fn controls(&self) -> &[[f64; NU]] {
        &self.us
    }

    /// The last solution as an owned [`Trajectory`] (allocates; for output).
    pub fn trajectory(&self) -> Trajectory {
        let spec = self.nlp.spec();
        Trajectory {
            name: spec.name.clone(),
            ds: spec.ds(),
            x: self.xs.clone(),
            u: self.us.clone(),
            kappa: spec.kappa.clone(),
            e_min: spec.e_min.clone(),
            e_max: spec.e_max.clone(),
            lane_e_min: spec.e_min.clone(),
            lane_e_max: spec.e_max.clone(),
            placement: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{load_scenario, load_vehicle};
    use crate::ip::Status;
    use std::path::PathBuf;

    #[test]
    fn the_zero_guess_on_a_fixed_start_with_saturation_gives_the_solver_a_finite_start() {
        let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../config");
        let vehicle = load_vehicle(&root.join("vehicles/lc500.toml")).unwrap();
        let mut spec = load_scenario(
            &root.join("scenarios/collision_avoidance.toml"),
            Some("critical"),
            vehicle,
        )
        .unwrap();
        spec.enforce_tire_saturation = true;
        let settings = Settings {
            max_iter: 5,
            ..Settings::default()
        };
        let mut planner = Planner::<{ crate::HORIZON }>::new(spec, settings).unwrap();
        let info = planner.solve(GuessKind::Zero);
        assert_ne!(info.status, Status::InvalidInput, "{info:?}");
        assert!(info.iterations > 0, "{info:?}");
        assert!(info.start_violation.is_finite(), "{info:?}");
    }
}
