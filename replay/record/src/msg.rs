//! The recorded messages: plain structs with public fields.

/// States per node (r, V, beta, V_wr, dFz, e, dpsi, s, t).
pub const STATE_LEN: usize = 9;
/// Controls per interval (delta, T_comb, T_bf).
pub const CONTROL_LEN: usize = 3;
/// Names of the state columns of [`PlanOutput::states`] (CDR field names).
pub const STATE_NAMES: [&str; STATE_LEN] = ["r", "v", "beta", "v_wr", "dfz", "e", "dpsi", "s", "t"];
/// Names of the control columns of [`PlanOutput::controls`] (CDR field names).
pub const CONTROL_NAMES: [&str; CONTROL_LEN] = ["delta", "t_comb", "t_bf"];

/// Vehicle parameters per input, in [`VEHICLE_FIELDS`] order.
pub const VEHICLE_LEN: usize = 25;
/// Order of [`PlanInput::vehicle`] (the fields of `planner::model::VehicleParams`).
pub const VEHICLE_FIELDS: [&str; VEHICLE_LEN] = [
    "m",
    "l",
    "a",
    "b",
    "h_cg",
    "i_z",
    "g",
    "r_w",
    "i_w",
    "c_f",
    "c_r",
    "mu",
    "c_l",
    "delta_max",
    "t_comb_max",
    "t_comb_min",
    "t_bf_min",
    "t_bf_max",
    "v_wr_min",
    "delta_rate_max",
    "t_comb_rate_max",
    "t_bf_rate_max",
    "eps_sigma",
    "eps_sat",
    "fmax_floor_frac",
];

/// Solver settings per input, in [`SETTINGS_FIELDS`] order.
pub const SETTINGS_LEN: usize = 35;
/// Order of [`PlanInput::settings`] (the fields of `planner::ip::Settings`; integers, enum
/// indices and booleans stored as exact f64).
pub const SETTINGS_FIELDS: [&str; SETTINGS_LEN] = [
    "tol",
    "constr_viol_tol",
    "dual_inf_tol",
    "compl_inf_tol",
    "acceptable_tol",
    "acceptable_constr_viol_tol",
    "max_iter",
    "max_time_s",
    "max_backtracks",
    "max_inertia_corrections",
    "max_ls_failures",
    "max_restoration_steps",
    "barrier",
    "globalization",
    "mu_floor_factor",
    "mu_init",
    "mu_min",
    "bound_push",
    "bound_frac",
    "bound_relax",
    "tau_min",
    "armijo",
    "second_order_correction",
    "penalty_init",
    "delta_w_init",
    "delta_w_max",
    "delta_c_min",
    "infeas_stat_tol",
    "mu_max_decrease",
    "mu_linear_decrease",
    "mu_superlinear_power",
    "barrier_tol_factor",
    "delta_w_decrease",
    "max_refactorizations",
    "kkt",
];

/// [`PlanInput::guess`] of a warm-started solve: its start is the [`PlanWarmStart`] of the
/// same seq.
pub const WARM_GUESS: &str = "warm";

/// Everything one solve acted on: the problem (road, bounds, initial state, vehicle) and
/// the solver configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanInput {
    /// Planning cycle number; the matching [`PlanOutput`] has the same value.
    pub seq: u64,
    /// When the cycle started \[ns since the Unix epoch\]; the MCAP log time.
    pub stamp_ns: u64,
    /// Scenario or segment name.
    pub scenario: String,
    /// Initial guess (`equilibrium`, `zero`, `road_speed`, or [`WARM_GUESS`]: the
    /// [`PlanWarmStart`] of the same seq).
    pub guess: String,
    /// Number of intervals N.
    pub n_intervals: u32,
    /// Horizon length \[m\].
    pub length_m: f64,
    /// Speed lower bound \[m/s\].
    pub v_min_mps: f64,
    /// Speed upper bound \[m/s\].
    pub v_max_mps: f64,
    /// Speed upper bound at the last node \[m/s\] (infinite: `v_max_mps` alone).
    pub v_end_max_mps: f64,
    /// Weight of the objective's steering-slew term \[1/s\] (0: pure minimum time).
    pub steering_slew_weight: f64,
    /// Weight of leaving the soft lane bounds \[s/m^2\] (0: no soft lane).
    pub soft_lane_weight: f64,
    /// Tire saturation constraints on.
    pub enforce_tire_saturation: bool,
    /// The tire saturation rows also at the last node, (x_N, u_{N-1}).
    pub saturation_at_end: bool,
    /// True when `x0` is the fixed initial state (vehicle state); false: paper's free start.
    pub initial_state_fixed: bool,
    /// Initial vehicle state (zeros when free).
    pub x0: [f64; STATE_LEN],
    /// Reference curvature at every node \[1/m\] (N + 1 values).
    pub kappa: Vec<f64>,
    /// Right lateral bound at every node \[m\].
    pub e_min: Vec<f64>,
    /// Left lateral bound at every node \[m\].
    pub e_max: Vec<f64>,
    /// Soft right bound at every node \[m\] (empty without a soft lane).
    pub soft_e_min: Vec<f64>,
    /// Soft left bound at every node \[m\] (empty without a soft lane).
    pub soft_e_max: Vec<f64>,
    /// Vehicle parameters in [`VEHICLE_FIELDS`] order.
    pub vehicle: [f64; VEHICLE_LEN],
    /// Solver settings in [`SETTINGS_FIELDS`] order.
    pub settings: [f64; SETTINGS_LEN],
    /// [`config_hash`] of `vehicle` and `settings` (checked on read).
    pub config_hash: u64,
    /// The settings as JSON, for people (replay uses `settings`).
    pub settings_json: String,
}

/// What one solve produced.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanOutput {
    /// Planning cycle number of the input.
    pub seq: u64,
    /// When the solve ended \[ns since the Unix epoch\]; the MCAP log time.
    pub stamp_ns: u64,
    /// Solver status name (`optimal`, `acceptable`, ...).
    pub status: String,
    /// Iterations taken.
    pub iterations: u32,
    /// Objective at the returned point.
    pub objective: f64,
    /// Max constraint violation at the returned point.
    pub max_violation: f64,
    /// Final time t_N \[s\].
    pub t_final_s: f64,
    /// KKT factorizations.
    pub factorizations: u32,
    /// Function evaluations.
    pub evaluations: u32,
    /// Evaluation time \[s\].
    pub time_evaluation_s: f64,
    /// Factorization time \[s\].
    pub time_factorization_s: f64,
    /// Back-substitution time \[s\].
    pub time_solve_s: f64,
    /// Line-search time \[s\].
    pub time_line_search_s: f64,
    /// Total solve time \[s\].
    pub time_total_s: f64,
    /// States x_0..x_N.
    pub states: Vec<[f64; STATE_LEN]>,
    /// Controls u_0..u_{N-1}.
    pub controls: Vec<[f64; CONTROL_LEN]>,
}

impl PlanOutput {
    /// An empty output with room for a horizon of `n_intervals` and any status name, so
    /// filling it in place allocates nothing.
    pub fn with_capacity(n_intervals: usize) -> Self {
        Self {
            seq: 0,
            stamp_ns: 0,
            status: String::with_capacity(STATUS_CAPACITY),
            iterations: 0,
            objective: 0.0,
            max_violation: 0.0,
            t_final_s: 0.0,
            factorizations: 0,
            evaluations: 0,
            time_evaluation_s: 0.0,
            time_factorization_s: 0.0,
            time_solve_s: 0.0,
            time_line_search_s: 0.0,
            time_total_s: 0.0,
            states: Vec::with_capacity(n_intervals + 1),
            controls: Vec::with_capacity(n_intervals),
        }
    }
}

/// What a warm-started solve started from beyond its [`PlanInput`]: the primal guess (the
/// previous plan shifted in s) and the multipliers (the previous solve's, shifted), with
/// the options of the warm solve and of its fall-back. Together with the input it makes
/// the solve reproducible bit for bit without the plans before it.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanWarmStart {
    /// Planning cycle number of the input.
    pub seq: u64,
    /// When the cycle started \[ns since the Unix epoch\]; the MCAP log time.
    pub stamp_ns: u64,
    /// How far the window moved since the previous plan \[m\] (for people; the guess and
    /// multipliers below are already shifted).
    pub shift_m: f64,
    /// Iterations the warm solve may take before it falls back (`u64::MAX`: the solver's
    /// cap).
    pub warm_max_iter: u64,
    /// Lower clip of the matched barrier parameter.
    pub mu_floor: f64,
    /// How the barrier parameter is matched to the start (`mean` or `geometric`).
    pub mu_match: String,
    /// Multiple of the geometric mean (`geometric`; 1 for `mean`).
    pub mu_match_factor: f64,
    /// The cold guess the solve falls back to (`equilibrium` or `road_speed`).
    pub cold_guess: String,
    /// Primal guess x_0..x_N (physical units).
    pub states: Vec<[f64; STATE_LEN]>,
    /// Primal guess u_0..u_{N-1}.
    pub controls: Vec<[f64; CONTROL_LEN]>,
    /// Row multipliers (m).
    pub y: Vec<f64>,
    /// Lower-bound multipliers (variables, then rows).
    pub zl: Vec<f64>,
    /// Upper-bound multipliers (variables, then rows).
    pub zu: Vec<f64>,
}

impl PlanWarmStart {
    /// An empty warm start with room for a horizon of `n_intervals`, `n` variables and `m`
    /// rows, so filling it in place allocates nothing.
    pub fn with_capacity(n_intervals: usize, n: usize, m: usize) -> Self {
        Self {
            seq: 0,
            stamp_ns: 0,
            shift_m: 0.0,
            warm_max_iter: u64::MAX,
            mu_floor: 0.0,
            mu_match: String::with_capacity(STATUS_CAPACITY),
            mu_match_factor: 1.0,
            cold_guess: String::with_capacity(STATUS_CAPACITY),
            states: Vec::with_capacity(n_intervals + 1),
            controls: Vec::with_capacity(n_intervals),
            y: Vec::with_capacity(m),
            zl: Vec::with_capacity(n + m),
            zu: Vec::with_capacity(n + m),
        }
    }
}

/// Bytes reserved for a status name in [`PlanOutput::with_capacity`].
const STATUS_CAPACITY: usize = 32;

/// One plan, input and output, in storage a pooled [`crate::Recorder`] reuses: the
/// recording thread fills a free one in place and hands it to the writer thread, which
/// returns it once written.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanRecord {
    /// What the solve acted on.
    pub input: PlanInput,
    /// What it produced.
    pub output: PlanOutput,
    /// Where it started when `input.guess` is [`WARM_GUESS`] (written only then; the
    /// storage stays for the next warm-started plan).
    pub warm: PlanWarmStart,
}

impl PlanRecord {
    /// A copy whose vectors and strings have the capacities of these (a derived `clone`
    /// gives them only their lengths), so filling it in place allocates no more than
    /// filling this one.
    pub(crate) fn clone_with_capacity(&self) -> Self {
        fn vec<T: Clone>(v: &[T], capacity: usize) -> Vec<T> {
            let mut c = Vec::with_capacity(capacity);
            c.extend_from_slice(v);
            c
        }
        fn string(s: &String) -> String {
            let mut c = String::with_capacity(s.capacity());
            c.push_str(s);
            c
        }
        let (i, o, w) = (&self.input, &self.output, &self.warm);
        Self {
            input: PlanInput {
                scenario: string(&i.scenario),
                guess: string(&i.guess),
                kappa: vec(&i.kappa, i.kappa.capacity()),
                e_min: vec(&i.e_min, i.e_min.capacity()),
                e_max: vec(&i.e_max, i.e_max.capacity()),
                soft_e_min: vec(&i.soft_e_min, i.soft_e_min.capacity()),
                soft_e_max: vec(&i.soft_e_max, i.soft_e_max.capacity()),
                settings_json: string(&i.settings_json),
                ..i.clone()
            },
            output: PlanOutput {
                status: string(&o.status),
                states: vec(&o.states, o.states.capacity()),
                controls: vec(&o.controls, o.controls.capacity()),
                ..o.clone()
            },
            warm: PlanWarmStart {
                mu_match: string(&w.mu_match),
                cold_guess: string(&w.cold_guess),
                states: vec(&w.states, w.states.capacity()),
                controls: vec(&w.controls, w.controls.capacity()),
                y: vec(&w.y, w.y.capacity()),
                zl: vec(&w.zl, w.zl.capacity()),
                zu: vec(&w.zu, w.zu.capacity()),
                ..w.clone()
            },
        }
    }
}

/// FNV-1a 64 over the raw bits of the vehicle parameters and the settings.
pub fn config_hash(vehicle: &[f64; VEHICLE_LEN], settings: &[f64; SETTINGS_LEN]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for v in vehicle.iter().chain(settings.iter()) {
        for b in v.to_bits().to_le_bytes() {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    h
}

/// The first way two outputs differ in what the solver decides (status, iterations,
/// every state and control bit), or `None` when they are bit-identical; timings and
/// stamps are ignored.
pub fn first_difference(recorded: &PlanOutput, replayed: &PlanOutput) -> Option<String> {
    if recorded.status != replayed.status {
        return Some(format!("status {} vs {}", recorded.status, replayed.status));
    }
    if recorded.iterations != replayed.iterations {
        return Some(format!(
            "iterations {} vs {}",
            recorded.iterations, replayed.iterations
        ));
    }
    if recorded.states.len() != replayed.states.len()
        || recorded.controls.len() != replayed.controls.len()
    {
        return Some("trajectory lengths differ".into());
    }
    for (k, (a, b)) in recorded.states.iter().zip(&replayed.states).enumerate() {
        for (i, (x, y)) in a.iter().zip(b).enumerate() {
            if x.to_bits() != y.to_bits() {
                return Some(format!("state {}[{k}]: {x:e} vs {y:e}", STATE_NAMES[i]));
            }
        }
    }
    for (k, (a, b)) in recorded.controls.iter().zip(&replayed.controls).enumerate() {
        for (i, (x, y)) in a.iter().zip(b).enumerate() {
            if x.to_bits() != y.to_bits() {
                return Some(format!("control {}[{k}]: {x:e} vs {y:e}", CONTROL_NAMES[i]));
            }
        }
    }
    let scalars = [
        ("objective", recorded.objective, replayed.objective),
        (
            "max_violation",
            recorded.max_violation,
            replayed.max_violation,
        ),
    ];
    for (name, x, y) in scalars {
        if x.to_bits() != y.to_bits() {
            return Some(format!("{name} {x:e} vs {y:e}"));
        }
    }
    None
}
