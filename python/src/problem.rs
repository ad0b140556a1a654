//! `trajopt.Problem`: one OCP instance (road, speed bounds, objective, initial state,
//! vehicle) loaded from a scenario file or cut from an indexed track, and its solve with
//! the options of `trajopt solve`.

use std::path::PathBuf;

use numpy::PyArray1;
use planner::config::paths::resolve_path;
use planner::config::{data_root_of, load_scenario_for_horizon, load_vehicle, stretch_spec};
use planner::guess::{self, GuessKind};
use planner::model::{ix, NU, NX};
use planner::ocp::{InitialState, OcpSpec};
use planner::plan::{Planner, DEFAULT_GUESS_SPEED};
use planner::HORIZON;
use pyo3::prelude::*;

/// Edge margin of a stretch when none is given \[m\] (`segments.toml`'s default).
const DEFAULT_EDGE_MARGIN_M: f64 = 1.0;

use crate::arrays::{matrix, vector};
use crate::err;
use crate::options::{self, SolverOptions};
use crate::solution::{Equilibrium, Run, Solution};

/// One planning problem: the road of N + 1 nodes with its lateral bounds, speed bounds,
/// objective, initial state and vehicle; `solve()` solves it.
#[pyclass(module = "trajopt", frozen)]
pub struct Problem {
    spec: OcpSpec,
    /// The solver file named at load time, if any.
    solver: Option<PathBuf>,
}

/// Loads the scenario `path` (a segment or scenario of a multi-entry file by `segment`)
/// with the vehicle file `vehicle`; `solver` names the solver file of its solves. Relative
/// paths resolve as on the command line (the working directory, else the repository).
#[pyfunction]
#[pyo3(signature = (path, segment = None, vehicle = PathBuf::from(options::VEHICLE), solver = None))]
pub fn load_scenario(
    path: PathBuf,
    segment: Option<&str>,
    vehicle: PathBuf,
    solver: Option<PathBuf>,
) -> PyResult<Problem> {
    let vehicle = load_vehicle(&resolve_path(&vehicle)).map_err(err)?;
    let spec =
        load_scenario_for_horizon(&resolve_path(&path), segment, vehicle, HORIZON).map_err(err)?;
    Ok(Problem { spec, solver })
}

/// The stretch of `track` (a name of `config/tracks/tracks.toml`) from track s = `start_s`
/// over `length_m` metres, `edge_margin_m` from both edges (default: the segments file's),
/// with the `[defaults]` of `segments` (speed bounds, tire saturation, objective, free
/// initial state) and N = HORIZON intervals.
#[pyfunction]
#[pyo3(signature = (track, start_s, length_m = 250.0, edge_margin_m = None, vehicle = PathBuf::from(options::VEHICLE), solver = None, segments = PathBuf::from(options::SEGMENTS)))]
pub fn track_stretch(
    track: String,
    start_s: f64,
    length_m: f64,
    edge_margin_m: Option<f64>,
    vehicle: PathBuf,
    solver: Option<PathBuf>,
    segments: PathBuf,
) -> PyResult<Problem> {
    let vehicle = load_vehicle(&resolve_path(&vehicle)).map_err(err)?;
    // The stretch takes the data root of the segments file (its tracks/ index) and the
    // segments file's edge margin unless one is given.
    let data_root = data_root_of(&resolve_path(&segments));
    let margin = edge_margin_m.unwrap_or(DEFAULT_EDGE_MARGIN_M);
    let spec = stretch_spec(&data_root, &track, start_s, length_m, margin, vehicle).map_err(err)?;
    Ok(Problem { spec, solver })
}

impl Problem {
    /// The fixed initial state, if the problem has one.
    fn fixed_x0(&self) -> Option<[f64; NX]> {
        match self.spec.initial {
            InitialState::Fixed(x0) => Some(x0),
            InitialState::Free => None,
        }
    }

    /// The equilibrium of the planner's guess: at the fixed initial speed, else at
    /// [`DEFAULT_GUESS_SPEED`], within the problem's speed bounds.
    fn equilibrium(&self) -> PyResult<guess::Equilibrium> {
        let v_start = self.fixed_x0().map_or(DEFAULT_GUESS_SPEED, |x0| x0[ix::V]);
        let s = &self.spec;
        guess::equilibrium(&s.vehicle, s.v_min, s.v_max, v_start).map_err(err)
    }
}

#[pymethods]
impl Problem {
    /// Scenario, segment or stretch name.
    #[getter]
    fn name(&self) -> &str {
        &self.spec.name
    }

    /// Number of intervals N.
    #[getter]
    fn n_intervals(&self) -> usize {
        self.spec.n_intervals
    }

    /// Horizon length \[m\].
    #[getter]
    fn length_m(&self) -> f64 {
        self.spec.length
    }

    /// Node spacing ds \[m\].
    #[getter]
    fn ds_m(&self) -> f64 {
        self.spec.ds()
    }

    /// Local arc length s_k = k ds of the nodes \[m\] (N + 1 values).
    #[getter]
    fn s<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let s: Vec<f64> = (0..=self.spec.n_intervals)
            .map(|k| k as f64 * self.spec.ds())
            .collect();
        PyArray1::from_vec(py, s)
    }

    /// Reference curvature at the nodes \[1/m\].
    #[getter]
    fn kappa<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.spec.kappa)
    }

    /// Right lateral bound of e at the nodes \[m\].
    #[getter]
    fn e_min<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.spec.e_min)
    }

    /// Left lateral bound of e at the nodes \[m\].
    #[getter]
    fn e_max<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.spec.e_max)
    }

    /// Speed bounds (v_min, v_max) \[m/s\].
    #[getter]
    fn speed_bounds(&self) -> (f64, f64) {
        (self.spec.v_min, self.spec.v_max)
    }

    /// Whether the tire saturation constraints are on.
    #[getter]
    fn tire_saturation(&self) -> bool {
        self.spec.enforce_tire_saturation
    }

    /// Weight \[1/s\] of the objective's steering-slew term (0: pure minimum time).
    #[getter]
    fn steering_slew_weight(&self) -> f64 {
        self.spec.steering_slew_weight
    }

    /// The equilibrium guess (paper eq. 8) the planner starts this problem from.
    fn equilibrium_guess(&self, py: Python<'_>) -> PyResult<Equilibrium> {
        let eq = py.detach(|| self.equilibrium())?;
        Ok(Equilibrium::from(eq))
    }

    /// The initial guess of a solve, `equilibrium` or `zero`, as the pair (states of shape
    /// (N + 1, 9), controls of shape (N, 3)).
    #[pyo3(signature = (guess = "equilibrium"))]
    #[allow(clippy::type_complexity)]
    fn initial_guess<'py>(
        &self,
        py: Python<'py>,
        guess: &str,
    ) -> PyResult<(
        Bound<'py, numpy::PyArray2<f64>>,
        Bound<'py, numpy::PyArray2<f64>>,
    )> {
        let kind = options::guess(guess)?;
        let n = self.spec.n_intervals;
        let (mut xs, mut us) = (vec![[0.0; NX]; n + 1], vec![[0.0; NU]; n]);
        let fixed = self.fixed_x0();
        match kind {
            GuessKind::Equilibrium => {
                let eq = py.detach(|| self.equilibrium())?;
                guess::fill_equilibrium(&eq, self.spec.ds(), fixed.as_ref(), &mut xs, &mut us);
            }
            GuessKind::Zero => guess::fill_zero(fixed.as_ref(), &mut xs, &mut us),
            GuessKind::RoadSpeed => {
                let eq = py.detach(|| self.equilibrium())?;
                let (ds, kappa, p) = (self.spec.ds(), &self.spec.kappa, &self.spec.vehicle);
                let x0 = fixed.as_ref();
                guess::fill_road_speed(&eq, ds, kappa, p, x0, &mut xs, &mut us);
            }
        }
        Ok((matrix(py, &xs)?, matrix(py, &us)?))
    }

    /// Solves the problem as `trajopt solve` does, with its options: `guess`
    /// (`equilibrium`, `zero` or `road_speed`), `max_iter`, `budget_ms` (wall-clock budget: a solve that
    /// spends it ends `time_limit`), `steering_slew_weight` and `tire_saturation`
    /// (override the problem's), `barrier`, `kkt`, `threads`, `solver` (the solver file;
    /// default: the one named at load time, else the shipped one for the objective).
    /// The interpreter lock is released while it solves.
    #[pyo3(signature = (*, guess = "equilibrium", max_iter = None, budget_ms = None, steering_slew_weight = None, tire_saturation = None, barrier = None, kkt = None, threads = None, solver = None))]
    #[allow(clippy::too_many_arguments)]
    fn solve(
        &self,
        py: Python<'_>,
        guess: &str,
        max_iter: Option<i64>,
        budget_ms: Option<f64>,
        steering_slew_weight: Option<f64>,
        tire_saturation: Option<bool>,
        barrier: Option<&str>,
        kkt: Option<&str>,
        threads: Option<usize>,
        solver: Option<PathBuf>,
    ) -> PyResult<Solution> {
        let kind = options::guess(guess)?;
        let mut spec = self.spec.clone();
        if let Some(w) = steering_slew_weight {
            spec.steering_slew_weight = options::slew_weight(w)?;
        }
        if let Some(on) = tire_saturation {
            spec.enforce_tire_saturation = on;
        }
        let given = solver.as_deref().or(self.solver.as_deref());
        let solver_file = options::solver_file(given, spec.steering_slew_weight);
        let o = SolverOptions {
            max_iter,
            budget_ms,
            barrier,
            kkt,
            threads,
        };
        let settings = options::settings(&solver_file, &o)?;
        let run = py.detach(move || -> Result<Run, planner::plan::PlanError> {
            let mut planner = Planner::<HORIZON>::new(spec, settings)?;
            let info = planner.solve(kind);
            Ok(Run {
                info,
                trajectory: planner.trajectory(),
                equilibrium: *planner.equilibrium(),
                kkt: planner.solver().kkt().name(),
                settings,
                spec: planner.spec().clone(),
            })
        });
        let run = run.map_err(err)?;
        Ok(Solution::new(run, kind, solver_file))
    }

    fn __repr__(&self) -> String {
        format!(
            "Problem(name={:?}, n_intervals={}, length_m={}, tire_saturation={}, steering_slew_weight={})",
            self.spec.name,
            self.spec.n_intervals,
            self.spec.length,
            if self.spec.enforce_tire_saturation {
                "True"
            } else {
                "False"
            },
            self.spec.steering_slew_weight
        )
    }
}
