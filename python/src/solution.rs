//! `trajopt.Solution` (the outcome of a solve: the solver's report and the trajectory as
//! numpy arrays with named columns) and `trajopt.Equilibrium` (the constant guess of
//! paper eq. 8).

use std::path::PathBuf;

use numpy::{PyArray1, PyArray2};
use planner::guess::{self, GuessKind};
use planner::ip::{Settings, SolveInfo};
use planner::model::{CONTROL_NAMES, NU, NX, STATE_NAMES};
use planner::ocp::OcpSpec;
use planner::trajectory::{Trajectory, CSV_COLUMNS};
use pyo3::exceptions::PyKeyError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::{column, matrix, vector};

/// What a solve leaves: the report, the trajectory, the guess it started from, and the
/// problem and settings it solved.
pub struct Run {
    /// The solver's report.
    pub info: SolveInfo,
    /// States, controls and road of the returned point.
    pub trajectory: Trajectory,
    /// The equilibrium of the guess.
    pub equilibrium: guess::Equilibrium,
    /// The KKT backend that solved.
    pub kkt: &'static str,
    /// The settings solved with.
    pub settings: Settings,
    /// The problem solved (with the solve's overrides).
    pub spec: OcpSpec,
}

/// The outcome of `Problem.solve()`: status, iterations, times and the trajectory.
///
/// `states` has shape (N + 1, 9) with columns `state_names`, `controls` shape (N, 3) with
/// columns `control_names`; `solution["V"]` is one named column.
#[pyclass(module = "trajopt", frozen)]
pub struct Solution {
    run: Run,
    guess: GuessKind,
    solver_file: PathBuf,
}

impl Solution {
    /// The solution of `run`, started from `guess` with the settings of `solver_file`.
    pub fn new(run: Run, guess: GuessKind, solver_file: PathBuf) -> Self {
        Self {
            run,
            guess,
            solver_file,
        }
    }
}

#[pymethods]
impl Solution {
    /// Scenario, segment or stretch name.
    #[getter]
    fn name(&self) -> &str {
        &self.run.trajectory.name
    }

    /// How the solve ended: `optimal`, `acceptable`, `iteration_limit`, `time_limit`, ...
    #[getter]
    fn status(&self) -> &'static str {
        self.run.info.status.name()
    }

    /// True for `optimal` and `acceptable`.
    #[getter]
    fn success(&self) -> bool {
        self.run.info.status.is_success()
    }

    /// Interior-point iterations taken.
    #[getter]
    fn iterations(&self) -> usize {
        self.run.info.iterations
    }

    /// Objective at the returned point \[s\] (t_N plus the steering-slew term).
    #[getter]
    fn objective(&self) -> f64 {
        self.run.info.objective
    }

    /// Final time t_N \[s\].
    #[getter]
    fn t_final(&self) -> f64 {
        self.run.trajectory.t_final()
    }

    /// Largest constraint violation at the returned point.
    #[getter]
    fn max_violation(&self) -> f64 {
        self.run.info.max_violation
    }

    /// Largest constraint violation at the starting point.
    #[getter]
    fn initial_violation(&self) -> f64 {
        self.run.info.initial_violation
    }

    /// Scaled dual infeasibility at the returned point.
    #[getter]
    fn dual_inf(&self) -> f64 {
        self.run.info.dual_inf
    }

    /// Scaled complementarity at the returned point.
    #[getter]
    fn compl(&self) -> f64 {
        self.run.info.compl
    }

    /// KKT factorizations.
    #[getter]
    fn factorizations(&self) -> usize {
        self.run.info.factorizations
    }

    /// Function evaluations.
    #[getter]
    fn evaluations(&self) -> usize {
        self.run.info.evaluations
    }

    /// Whether the returned point is the best iterate of a stopped solve.
    #[getter]
    fn best_iterate(&self) -> bool {
        self.run.info.best_iterate
    }

    /// Wall-clock time of the solve \[s\].
    #[getter]
    fn solve_time_s(&self) -> f64 {
        self.run.info.times.total
    }

    /// Time per phase \[s\]: `evaluation`, `factorization`, `solve`, `line_search`,
    /// `total`.
    #[getter]
    fn times<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let t = &self.run.info.times;
        let d = PyDict::new(py);
        for (k, v) in [
            ("evaluation", t.evaluation),
            ("factorization", t.factorization),
            ("solve", t.solve),
            ("line_search", t.line_search),
            ("total", t.total),
        ] {
            d.set_item(k, v)?;
        }
        Ok(d)
    }

    /// Largest |beta| over the nodes \[rad\].
    #[getter]
    fn max_abs_beta_rad(&self) -> f64 {
        self.run.trajectory.max_abs_beta()
    }

    /// The guess the solve started from: `equilibrium` or `zero`.
    #[getter]
    fn guess(&self) -> &'static str {
        self.guess.name()
    }

    /// The equilibrium of the planner's guess for this problem.
    #[getter]
    fn equilibrium(&self) -> Equilibrium {
        Equilibrium::from(self.run.equilibrium)
    }

    /// Barrier rule solved with.
    #[getter]
    fn barrier(&self) -> &'static str {
        self.run.settings.barrier.name()
    }

    /// KKT backend that solved: `sparse` or `riccati`.
    #[getter]
    fn kkt(&self) -> &'static str {
        self.run.kkt
    }

    /// Threads of the solve.
    #[getter]
    fn threads(&self) -> usize {
        self.run.settings.threads
    }

    /// The solver settings file.
    #[getter]
    fn solver_file(&self) -> PathBuf {
        self.solver_file.clone()
    }

    /// Whether the tire saturation constraints were on.
    #[getter]
    fn tire_saturation(&self) -> bool {
        self.run.spec.enforce_tire_saturation
    }

    /// Weight \[1/s\] of the objective's steering-slew term.
    #[getter]
    fn steering_slew_weight(&self) -> f64 {
        self.run.spec.steering_slew_weight
    }

    /// States x_0..x_N, shape (N + 1, 9), columns `state_names` (physical units).
    #[getter]
    fn states<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        matrix::<NX>(py, &self.run.trajectory.x)
    }

    /// Controls u_0..u_{N-1}, shape (N, 3), columns `control_names` (physical units).
    #[getter]
    fn controls<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        matrix::<NU>(py, &self.run.trajectory.u)
    }

    /// Names of the state columns: r, V, beta, V_wr, dFz, e, dpsi, s, t.
    #[getter]
    fn state_names(&self) -> Vec<&'static str> {
        STATE_NAMES.to_vec()
    }

    /// Names of the control columns: delta, T_comb, T_bf.
    #[getter]
    fn control_names(&self) -> Vec<&'static str> {
        CONTROL_NAMES.to_vec()
    }

    /// Node grid s_k = k ds \[m\] (N + 1 values).
    #[getter]
    fn s<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let t = &self.run.trajectory;
        let s: Vec<f64> = (0..t.x.len()).map(|k| k as f64 * t.ds).collect();
        PyArray1::from_vec(py, s)
    }

    /// Reference curvature at the nodes \[1/m\].
    #[getter]
    fn kappa<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.run.trajectory.kappa)
    }

    /// Right lateral bound at the nodes \[m\].
    #[getter]
    fn e_min<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.run.trajectory.e_min)
    }

    /// Left lateral bound at the nodes \[m\].
    #[getter]
    fn e_max<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.run.trajectory.e_max)
    }

    /// One state (N + 1 values) or control (N values) by name.
    fn __getitem__<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let t = &self.run.trajectory;
        if let Some(j) = STATE_NAMES.iter().position(|n| *n == name) {
            return Ok(column(py, &t.x, j));
        }
        if let Some(j) = CONTROL_NAMES.iter().position(|n| *n == name) {
            return Ok(column(py, &t.u, j));
        }
        Err(PyKeyError::new_err(format!(
            "`{name}` is neither a state ({}) nor a control ({})",
            STATE_NAMES.join(", "),
            CONTROL_NAMES.join(", ")
        )))
    }

    /// The table of `trajopt solve`'s CSV as a dict of equal-length columns (N + 1 rows;
    /// node N repeats the last control), in the CSV's column order.
    fn columns<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let t = &self.run.trajectory;
        let rows = t.x.len();
        let d = PyDict::new(py);
        for name in CSV_COLUMNS {
            let v: Vec<f64> = (0..rows).map(|k| csv_value(t, k, name)).collect();
            d.set_item(name, PyArray1::from_vec(py, v))?;
        }
        Ok(d)
    }

    fn __repr__(&self) -> String {
        format!(
            "Solution(name={:?}, status={:?}, iterations={}, t_final={:.4}, solve_time_s={:.4})",
            self.run.trajectory.name,
            self.status(),
            self.run.info.iterations,
            self.run.trajectory.t_final(),
            self.run.info.times.total
        )
    }
}

/// The value of CSV column `name` at node `k`.
fn csv_value(t: &Trajectory, k: usize, name: &str) -> f64 {
    if let Some(j) = STATE_NAMES.iter().position(|n| *n == name) {
        return t.x[k][j];
    }
    if let Some(j) = CONTROL_NAMES.iter().position(|n| *n == name) {
        return t.control_at(k)[j];
    }
    match name {
        "k" => k as f64,
        "s_grid" => k as f64 * t.ds,
        "kappa" => t.kappa[k],
        "e_min" => t.e_min[k],
        "e_max" => t.e_max[k],
        _ => f64::NAN,
    }
}

/// The constant state/control pair of the equilibrium guess (paper eq. 8): a straight-line
/// steady state whose dynamic rates vanish.
#[pyclass(module = "trajopt", frozen)]
pub struct Equilibrium {
    eq: guess::Equilibrium,
}

impl From<guess::Equilibrium> for Equilibrium {
    fn from(eq: guess::Equilibrium) -> Self {
        Self { eq }
    }
}

#[pymethods]
impl Equilibrium {
    /// The state [r, V, beta, V_wr, dFz, 0, 0, 0, 0] (9 values; e, dpsi, s, t are set per
    /// node by the guess).
    #[getter]
    fn x<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.eq.x)
    }

    /// The controls [delta, T_comb, T_bf].
    #[getter]
    fn u<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.eq.u)
    }

    /// The five dynamic states and three controls by name (as `trajopt guess` prints them).
    fn values<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (name, v) in STATE_NAMES.iter().zip(&self.eq.x).take(5) {
            d.set_item(*name, *v)?;
        }
        for (name, v) in CONTROL_NAMES.iter().zip(&self.eq.u) {
            d.set_item(*name, *v)?;
        }
        Ok(d)
    }

    /// Remaining cost of eq. (8) (zero at a true equilibrium).
    #[getter]
    fn cost(&self) -> f64 {
        self.eq.cost
    }

    /// Status of the least-squares solve.
    #[getter]
    fn status(&self) -> &'static str {
        self.eq.status
    }

    /// Iterations of the least-squares solve.
    #[getter]
    fn iterations(&self) -> usize {
        self.eq.iterations
    }

    fn __repr__(&self) -> String {
        let x = &self.eq.x;
        format!(
            "Equilibrium(V={:.4}, beta={:.6}, delta={:.6}, status={:?}, cost={:.2e})",
            x[planner::model::ix::V],
            x[planner::model::ix::BETA],
            self.eq.u[planner::model::iu::DELTA],
            self.eq.status,
            self.eq.cost
        )
    }
}
