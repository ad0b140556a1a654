//! Shared fixtures for the criterion benchmarks.

use planner::ip::Nlp;
use planner::ocp::fixtures::{oval_reference_path, oval_spec, ReferenceCsv};
use planner::ocp::ImplicitEulerNlp;

/// The oval implicit-Euler NLP (N = 100) and an evaluation point: the peer reference optimum
/// if `config/reference/oval_ie_ipopt.csv` is readable, else the default starting point.
pub fn oval_nlp_at_reference() -> (ImplicitEulerNlp<100>, Vec<f64>) {
    let nlp = ImplicitEulerNlp::<100>::new(oval_spec()).expect("oval spec has N = 100");
    let mut z = vec![0.0; nlp.dims().n];
    match ReferenceCsv::load(&oval_reference_path()) {
        Ok(csv) => {
            let (xs, us) = csv.trajectory();
            nlp.pack(&xs, &us, &mut z);
        }
        Err(_) => nlp.initial_point(&mut z),
    }
    (nlp, z)
}

/// A planner for a shipped scenario (`config/` of this repository), with the shipped solver
/// settings. `select` picks a segment or collision-avoidance scenario.
pub fn planner_for(scenario: &str, select: Option<&str>) -> planner::plan::Planner<100> {
    planner_for_with(scenario, select, |_| {}, |_| {})
}

/// As [`planner_for`], with the scenario spec adjusted by `edit_spec`, then the shipped solver
/// file for the spec's objective loaded ([`planner::config::shipped_solver_file`]) and
/// adjusted by `edit_settings`.
pub fn planner_for_with(
    scenario: &str,
    select: Option<&str>,
    edit_spec: impl FnOnce(&mut planner::ocp::OcpSpec),
    edit_settings: impl FnOnce(&mut planner::ip::Settings),
) -> planner::plan::Planner<100> {
    let root = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let vehicle = planner::config::load_vehicle(&root.join("vehicles/lc500.toml"))
        .expect("shipped vehicle file loads");
    let mut spec =
        planner::config::load_scenario(&root.join("scenarios").join(scenario), select, vehicle)
            .expect("shipped scenario loads");
    edit_spec(&mut spec);
    let solver_file = planner::config::shipped_solver_file(spec.steering_slew_weight);
    let mut settings =
        planner::config::load_solver(&root.join(solver_file)).expect("shipped solver file loads");
    edit_settings(&mut settings);
    planner::plan::Planner::<100>::new(spec, settings).expect("planner builds")
}

/// One KKT system of the oval NLP at the reference point, for the backend benchmarks:
/// sparsity, Hessian and Jacobian values, barrier-like primal and dual diagonals (equality
/// rows get `eq_reg`), and the stage structure.
pub struct OvalKkt {
    /// Variables.
    pub n: usize,
    /// Constraint rows.
    pub m: usize,
    /// Hessian rows and columns (lower triangle).
    pub hess_rows: Vec<usize>,
    /// Hessian columns.
    pub hess_cols: Vec<usize>,
    /// Jacobian rows.
    pub jac_rows: Vec<usize>,
    /// Jacobian columns.
    pub jac_cols: Vec<usize>,
    /// Hessian values.
    pub hess: Vec<f64>,
    /// Jacobian values.
    pub jac: Vec<f64>,
    /// Primal diagonal.
    pub primal_diag: Vec<f64>,
    /// Dual diagonal.
    pub dual_diag: Vec<f64>,
    /// Stage structure for the Riccati backend.
    pub structure: planner::ip::kkt::StageStructure,
}

impl OvalKkt {
    /// The system, with `eq_reg` (<= 0) on the dual diagonal of equality rows.
    pub fn new(eq_reg: f64) -> Self {
        let (mut nlp, z) = oval_nlp_at_reference();
        // The baseline evaluation copy (same bits as the AVX2 one): keeps the KKT loops
        // runnable under valgrind, whose decoder lacks some AVX2 encodings.
        nlp.set_simd(false);
        let d = nlp.dims();
        let (n, m) = (d.n, d.m);
        let (mut hess_rows, mut hess_cols) = (vec![0; d.nnz_hess], vec![0; d.nnz_hess]);
        let (mut jac_rows, mut jac_cols) = (vec![0; d.nnz_jac], vec![0; d.nnz_jac]);
        nlp.hess_structure(&mut hess_rows, &mut hess_cols);
        nlp.jac_structure(&mut jac_rows, &mut jac_cols);
        let lambda: Vec<f64> = (0..m).map(|i| ((i % 7) as f64 - 3.0) * 0.1).collect();
        let mut hess = vec![0.0; d.nnz_hess];
        let mut jac = vec![0.0; d.nnz_jac];
        nlp.eval_hess(&z, 1.0, &lambda, &mut hess);
        nlp.eval_jac_g(&z, &mut jac);
        let (mut xl, mut xu) = (vec![0.0; n], vec![0.0; n]);
        let (mut gl, mut gu) = (vec![0.0; m], vec![0.0; m]);
        nlp.bounds(&mut xl, &mut xu, &mut gl, &mut gu);
        let primal_diag = (0..n).map(|i| 1.0 + (i % 5) as f64).collect();
        let dual_diag = (0..m)
            .map(|i| {
                if gl[i] == gu[i] {
                    eq_reg
                } else {
                    -0.1 - (i % 3) as f64
                }
            })
            .collect();
        let structure = nlp.stage_structure().expect("implicit Euler has stages");
        Self {
            n,
            m,
            hess_rows,
            hess_cols,
            jac_rows,
            jac_cols,
            hess,
            jac,
            primal_diag,
            dual_diag,
            structure,
        }
    }

    /// The values as the backends take them.
    pub fn values(&self) -> planner::ip::kkt::KktValues<'_> {
        planner::ip::kkt::KktValues {
            hess: &self.hess,
            jac: &self.jac,
            primal_diag: &self.primal_diag,
            dual_diag: &self.dual_diag,
        }
    }

    /// The general sparse backend for this pattern.
    pub fn sparse(&self) -> planner::ip::kkt::SparseLdlt {
        planner::ip::kkt::SparseLdlt::new(
            self.n,
            self.m,
            &self.hess_rows,
            &self.hess_cols,
            &self.jac_rows,
            &self.jac_cols,
        )
        .expect("sparse setup")
    }

    /// The Riccati backend with the arc-length state split off (what the solver uses).
    pub fn split_riccati(&self) -> planner::ip::kkt::backend::VehicleSplitRiccati {
        planner::ip::kkt::backend::split_riccati(
            &self.structure,
            self.n,
            &self.hess_rows,
            &self.hess_cols,
            &self.jac_rows,
            &self.jac_cols,
        )
        .expect("split riccati setup")
    }

    /// The Riccati backend for this pattern (on the whole system).
    pub fn riccati(&self) -> planner::ip::kkt::backend::VehicleRiccati {
        planner::ip::kkt::backend::VehicleRiccati::new(
            &self.structure,
            self.n,
            &self.hess_rows,
            &self.hess_cols,
            &self.jac_rows,
            &self.jac_cols,
        )
        .expect("riccati setup")
    }
}
