//! The integrator study of paper Sec. IV / VI-A (Table I, Fig. 4a): the oval solved from
//! the equilibrium guess with each of the nine integrators, timed (median of `repeat`
//! solves) and compared with the 3-stage Gauss-Legendre ground truth by the NRMSE of each
//! control.
//!
//! **NRMSE.** For control j (delta, T_comb, T_bf) with values u_{j,k} and ground truth
//! u*_{j,k} on the N intervals,
//! `NRMSE_j = 100 % * sqrt(mean_k (u_{j,k} - u*_{j,k})^2) / (max_k u*_{j,k} - min_k u*_{j,k})`,
//! the root-mean-square error over the range of the reference (the paper's "standard root
//! mean square error" normalised, Sec. VI-A). All schemes use the same N and the same s
//! grid, so u_k and u*_k are compared at the same s_k; [`nrmse_pct`] interpolates the
//! reference linearly in s if the grids ever differ. Every interval counts (including
//! interval 0, whose free initial state is not physical, reference README finding c, and
//! the nodes where a braking-saturated front axle leaves the steering undetermined,
//! finding d): no data is hidden.
//!
//! Each solve's status is reported as the solver returned it; the NRMSE of a failed solve
//! is computed from the iterate it returned and is shown next to its status.

use serde::Serialize;

use super::StudyError;
use crate::guess::{equilibrium, fill_equilibrium};
use crate::ip::{Settings, Solver};
use crate::model::{ix, CONTROL_NAMES, NU, NX};
use crate::ocp::{
    CrankNicolson, DefectScheme, ExplicitRk2, ExplicitRk4, GaussLegendre2, GaussLegendre3,
    ImplicitEuler, LinearMultistep, OcpSpec, Transcription,
};
use crate::plan::DEFAULT_GUESS_SPEED;
use crate::stats::median;

/// One transcription of the study.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Integrator {
    /// Implicit Euler (order 1, A-stable).
    ImplicitEuler,
    /// BDF4 (order 4, A(73 deg)-stable).
    Bdf4,
    /// BDF5 (order 5, A(52 deg)-stable).
    Bdf5,
    /// BDF6 (order 6, A(18 deg)-stable).
    Bdf6,
    /// Crank-Nicolson (order 2, A-stable).
    CrankNicolson,
    /// 3-step Adams-Moulton (order 4, not A-stable).
    AdamsMoulton3,
    /// 2-stage Gauss-Legendre (order 4, A-stable).
    GaussLegendre2,
    /// Explicit midpoint RK2.
    Rk2,
    /// Classical explicit RK4.
    Rk4,
    /// 3-stage Gauss-Legendre (order 6, A-stable): the ground truth.
    GaussLegendre3,
}

impl Integrator {
    /// The nine integrators of Table I followed by the ground truth.
    pub const ALL: [Integrator; 10] = [
        Integrator::ImplicitEuler,
        Integrator::Bdf4,
        Integrator::Bdf5,
        Integrator::Bdf6,
        Integrator::CrankNicolson,
        Integrator::AdamsMoulton3,
        Integrator::GaussLegendre2,
        Integrator::Rk2,
        Integrator::Rk4,
        Integrator::GaussLegendre3,
    ];

    /// The ground truth every NRMSE is measured against.
    pub const REFERENCE: Integrator = Integrator::GaussLegendre3;

    /// Name (the transcription's scheme name).
    pub fn name(self) -> &'static str {
        match self {
            Integrator::ImplicitEuler => "implicit_euler",
            Integrator::Bdf4 => "bdf4",
            Integrator::Bdf5 => "bdf5",
            Integrator::Bdf6 => "bdf6",
            Integrator::CrankNicolson => "crank_nicolson",
            Integrator::AdamsMoulton3 => "adams_moulton3",
            Integrator::GaussLegendre2 => "gauss_legendre2",
            Integrator::Rk2 => "rk2",
            Integrator::Rk4 => "rk4",
            Integrator::GaussLegendre3 => "gauss_legendre3",
        }
    }

    /// The integrator called `name`.
    pub fn from_name(name: &str) -> Result<Self, StudyError> {
        Self::ALL
            .into_iter()
            .find(|i| i.name() == name)
            .ok_or_else(|| StudyError::UnknownIntegrator {
                name: name.to_string(),
                known: Self::ALL.map(Integrator::name).join(", "),
            })
    }

    /// Order of consistency.
    pub fn order(self) -> usize {
        match self {
            Integrator::ImplicitEuler => 1,
            Integrator::CrankNicolson | Integrator::Rk2 => 2,
            Integrator::Bdf4
            | Integrator::AdamsMoulton3
            | Integrator::GaussLegendre2
            | Integrator::Rk4 => 4,
            Integrator::Bdf5 => 5,
            Integrator::Bdf6 | Integrator::GaussLegendre3 => 6,
        }
    }

    /// The derivative code of the scheme's defect rows: the hand-written jets of f at each
    /// point of [`crate::ocp::fast`] for every scheme whose defect is linear in f at fixed
    /// points, and for explicit RK, which nests f inside f, the lean forward-mode jets of
    /// [`crate::ocp::jet`] carried through its stages over the 10 inputs of an interval.
    pub fn derivatives(self) -> &'static str {
        match self {
            Integrator::Rk2 | Integrator::Rk4 => "jets through the stages",
            _ => "hand-written",
        }
    }

    /// A-stable (the property the paper finds decisive, Sec. IV).
    pub fn a_stable(self) -> bool {
        matches!(
            self,
            Integrator::ImplicitEuler
                | Integrator::CrankNicolson
                | Integrator::GaussLegendre2
                | Integrator::GaussLegendre3
        )
    }
}

/// Outcome of one integrator: the last of `repeat` identical solves, with all their times.
#[derive(Debug, Clone, Serialize)]
pub struct IntegratorRun {
    /// Which integrator.
    pub integrator: Integrator,
    /// Solver status name (`optimal`, `iteration_limit`, ...), never hidden.
    pub status: String,
    /// Whether the status is a success (optimal or acceptable).
    pub success: bool,
    /// Interior-point iterations.
    pub iterations: usize,
    /// Median wall-clock solve time \[ms\].
    pub median_ms: f64,
    /// Every solve's time \[ms\].
    pub solve_ms_all: Vec<f64>,
    /// t_N of the returned point \[s\].
    pub t_final: f64,
    /// Largest constraint violation of the returned point (scaled NLP units).
    pub max_violation: f64,
    /// NRMSE of each control against the ground truth [%], in [`CONTROL_NAMES`] order.
    pub nrmse_pct: [f64; NU],
    /// Largest of `nrmse_pct` [%] (Fig. 4a's accuracy axis).
    pub max_nrmse_pct: f64,
    /// Largest control NRMSE [%] over intervals 1..N-1 only: interval 0 follows the free
    /// initial state, which no physical start pins.
    pub max_nrmse_pct_excl0: f64,
    /// Median solve time divided by the iterations \[ms\].
    pub ms_per_iteration: f64,
    /// KKT backend the solver chose for the scheme (`riccati` or `sparse`).
    pub kkt_backend: &'static str,
    /// Derivative code of the defect rows ([`Integrator::derivatives`]).
    pub derivatives: &'static str,
    /// Order of consistency.
    pub order: usize,
    /// A-stability.
    pub a_stable: bool,
    /// Physical controls of the returned point (N intervals).
    #[serde(skip)]
    pub controls: Vec<[f64; NU]>,
    /// Physical states of the returned point (N + 1 nodes).
    #[serde(skip)]
    pub states: Vec<[f64; NX]>,
}

/// Settings of [`run_study`].
#[derive(Debug, Clone)]
pub struct StudyConfig {
    /// Solves per integrator (the median time is reported); at least 1.
    pub repeat: usize,
    /// Integrators to run (the ground truth is always solved, and listed last).
    pub integrators: Vec<Integrator>,
    /// The ground truth ([`Integrator::REFERENCE`] for the paper's study; another choice
    /// only makes quick checks cheap).
    pub reference: Integrator,
}

/// The whole study.
#[derive(Debug, Clone, Serialize)]
pub struct IntegratorStudy {
    /// Scenario name.
    pub scenario: String,
    /// Intervals N.
    pub n_intervals: usize,
    /// Solves per integrator.
    pub repeat: usize,
    /// Solver wall-clock cap per solve \[s\].
    pub max_time_s: f64,
    /// Name of the ground truth.
    pub reference: &'static str,
    /// Control names, the order of every `nrmse_pct`.
    pub controls: [&'static str; NU],
    /// One row per integrator (the ground truth last).
    pub runs: Vec<IntegratorRun>,
}

impl IntegratorStudy {
    /// The ground truth's row.
    pub fn reference_run(&self) -> Option<&IntegratorRun> {
        self.runs
            .iter()
            .find(|r| r.integrator.name() == self.reference)
    }

    /// The human table (Table I with the accuracy column), one line per integrator.
    pub fn table(&self) -> String {
        let mut s = format!(
            "integrator study: {} (N = {}), equilibrium guess, median of {} solve(s), \
             NRMSE vs {}\n",
            self.scenario, self.n_intervals, self.repeat, self.reference
        );
        s.push_str(&format!(
            "{:<16} {:>8} {:<17} {:>6} {:>11} {:>9} {:>10} {:>8} {:>8} {:>8}\n",
            "integrator",
            "A-stable",
            "status",
            "iters",
            "median ms",
            "t_N s",
            "max NRMSE%",
            "delta%",
            "T_comb%",
            "T_bf%"
        ));
        for r in &self.runs {
            s.push_str(&format!(
                "{:<16} {:>8} {:<17} {:>6} {:>11.1} {:>9.4} {:>10.3} {:>8.3} {:>8.3} {:>8.3}\n",
                r.integrator.name(),
                if r.integrator.a_stable() { "yes" } else { "no" },
                r.status,
                r.iterations,
                r.median_ms,
                r.t_final,
                r.max_nrmse_pct,
                r.nrmse_pct[0],
                r.nrmse_pct[1],
                r.nrmse_pct[2],
            ));
        }
        s
    }
}

/// NRMSE [%] of `u` against the reference `u_ref` (see the module docs). `s` and `s_ref`
/// are the grid positions of the samples; where they differ, the reference is linearly
/// interpolated in s (clamped at its ends). Returns NaN for a reference without range or
/// empty input.
pub fn nrmse_pct(s: &[f64], u: &[f64], s_ref: &[f64], u_ref: &[f64]) -> f64 {
    if u.is_empty() || u_ref.is_empty() || s.len() != u.len() || s_ref.len() != u_ref.len() {
        return f64::NAN;
    }
    let (lo, hi) = u_ref
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let range = hi - lo;
    if range.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return f64::NAN;
    }
    let at = |x: f64| -> f64 {
        let last = s_ref.len() - 1;
        if last == 0 || x.is_nan() || x <= s_ref[0] {
            return u_ref[0];
        }
        if x >= s_ref[last] {
            return u_ref[last];
        }
        let i = s_ref.partition_point(|&v| v <= x).clamp(1, last);
        let (s0, s1) = (s_ref[i - 1], s_ref[i]);
        let w = if s1 > s0 { (x - s0) / (s1 - s0) } else { 0.0 };
        u_ref[i - 1] + w * (u_ref[i] - u_ref[i - 1])
    };
    let mse = s
        .iter()
        .zip(u)
        .map(|(&x, &v)| (v - at(x)).powi(2))
        .sum::<f64>()
        / u.len() as f64;
    100.0 * mse.sqrt() / range
}

/// Solves `spec` with `scheme` from the equilibrium guess `repeat` times.
fn run_scheme<S: DefectScheme, const N: usize>(
    integrator: Integrator,
    scheme: S,
    spec: &OcpSpec,
    settings: &Settings,
    repeat: usize,
) -> Result<IntegratorRun, StudyError> {
    let eq = equilibrium(&spec.vehicle, spec.v_min, spec.v_max, DEFAULT_GUESS_SPEED)?;
    let (mut xs, mut us) = (vec![[0.0; NX]; N + 1], vec![[0.0; NU]; N]);
    fill_equilibrium(&eq, spec.ds(), None, &mut xs, &mut us);
    let mut nlp = Transcription::<S, N>::with_scheme(spec.clone(), scheme)?;
    let mut solver = Solver::new(&nlp, *settings)?;
    let mut times = Vec::with_capacity(repeat);
    let mut last = None;
    for _ in 0..repeat {
        nlp.set_initial_guess(&xs, &us);
        let info = solver.solve(&mut nlp);
        times.push(info.times.total * 1e3);
        last = Some(info);
    }
    let info = last.ok_or_else(|| StudyError::Invalid("repeat must be at least 1".into()))?;
    let (states, controls) = nlp.trajectory_from(solver.x());
    let median_ms = median(&mut times);
    Ok(IntegratorRun {
        integrator,
        status: info.status.name().to_string(),
        success: info.status.is_success(),
        iterations: info.iterations,
        median_ms,
        solve_ms_all: times,
        t_final: states[N][ix::T],
        max_violation: info.max_violation,
        nrmse_pct: [f64::NAN; NU],
        max_nrmse_pct: f64::NAN,
        max_nrmse_pct_excl0: f64::NAN,
        ms_per_iteration: median_ms / info.iterations.max(1) as f64,
        kkt_backend: solver.kkt().name(),
        derivatives: integrator.derivatives(),
        order: integrator.order(),
        a_stable: integrator.a_stable(),
        controls,
        states,
    })
}

/// Solves `spec` with one integrator (`repeat` times from the equilibrium guess).
pub fn run_integrator<const N: usize>(
    integrator: Integrator,
    spec: &OcpSpec,
    settings: &Settings,
    repeat: usize,
) -> Result<IntegratorRun, StudyError> {
    let (sp, st) = (spec, settings);
    match integrator {
        Integrator::ImplicitEuler => run_scheme::<_, N>(integrator, ImplicitEuler, sp, st, repeat),
        Integrator::Bdf4 => run_scheme::<_, N>(integrator, LinearMultistep::BDF4, sp, st, repeat),
        Integrator::Bdf5 => run_scheme::<_, N>(integrator, LinearMultistep::BDF5, sp, st, repeat),
        Integrator::Bdf6 => run_scheme::<_, N>(integrator, LinearMultistep::BDF6, sp, st, repeat),
        Integrator::CrankNicolson => run_scheme::<_, N>(integrator, CrankNicolson, sp, st, repeat),
        Integrator::AdamsMoulton3 => {
            run_scheme::<_, N>(integrator, LinearMultistep::ADAMS_MOULTON3, sp, st, repeat)
        }
        Integrator::GaussLegendre2 => {
            run_scheme::<_, N>(integrator, GaussLegendre2, sp, st, repeat)
        }
        Integrator::Rk2 => run_scheme::<_, N>(integrator, ExplicitRk2, sp, st, repeat),
        Integrator::Rk4 => run_scheme::<_, N>(integrator, ExplicitRk4, sp, st, repeat),
        Integrator::GaussLegendre3 => {
            run_scheme::<_, N>(integrator, GaussLegendre3, sp, st, repeat)
        }
    }
}

/// Runs the study: every requested integrator (in the given order, duplicates dropped) and
/// the ground truth (last), then the NRMSE of every run against the ground truth.
/// `progress` is called after each integrator (e.g. to print a line).
pub fn run_study<const N: usize>(
    spec: &OcpSpec,
    settings: &Settings,
    config: &StudyConfig,
    mut progress: impl FnMut(&IntegratorRun),
) -> Result<IntegratorStudy, StudyError> {
    if config.repeat == 0 {
        return Err(StudyError::Invalid("repeat must be at least 1".into()));
    }
    let reference = config.reference;
    let mut order: Vec<Integrator> = Vec::new();
    for &i in &config.integrators {
        if i != reference && !order.contains(&i) {
            order.push(i);
        }
    }
    order.push(reference);
    let mut runs = Vec::with_capacity(order.len());
    for i in order {
        let run = run_integrator::<N>(i, spec, settings, config.repeat)?;
        progress(&run);
        runs.push(run);
    }
    let ds = spec.ds();
    if let Some(truth) = runs.iter().find(|r| r.integrator == reference) {
        let reference = truth.controls.clone();
        let s_ref: Vec<f64> = (0..reference.len()).map(|k| k as f64 * ds).collect();
        for run in &mut runs {
            let s: Vec<f64> = (0..run.controls.len()).map(|k| k as f64 * ds).collect();
            let mut excl0 = f64::NAN;
            for j in 0..NU {
                let u: Vec<f64> = run.controls.iter().map(|u| u[j]).collect();
                let ur: Vec<f64> = reference.iter().map(|u| u[j]).collect();
                run.nrmse_pct[j] = nrmse_pct(&s, &u, &s_ref, &ur);
                let from1 = |v: &[f64]| v.get(1..).unwrap_or(&[]).to_vec();
                excl0 = excl0.max(nrmse_pct(
                    &from1(&s),
                    &from1(&u),
                    &from1(&s_ref),
                    &from1(&ur),
                ));
            }
            run.max_nrmse_pct = run.nrmse_pct.iter().copied().fold(f64::NAN, f64::max);
            run.max_nrmse_pct_excl0 = excl0;
        }
    }
    Ok(IntegratorStudy {
        scenario: spec.name.clone(),
        n_intervals: N,
        repeat: config.repeat,
        max_time_s: settings.max_time_s,
        reference: reference.name(),
        controls: CONTROL_NAMES,
        runs,
    })
}
