//! Conversions between the planner's types and the flight-recorder records of
//! [`plan_record`]: what a solve acted on ([`plan_input`]) and produced ([`plan_output`]),
//! and back ([`problem_from`]) so a replay rebuilds the exact same problem; for a
//! warm-started solve also where it started ([`write_warm`], back with [`warm_from`]).

use plan_record::{
    config_hash, PlanInput, PlanOutput, PlanWarmStart, CONTROL_LEN, SETTINGS_FIELDS, SETTINGS_LEN,
    STATE_LEN, VEHICLE_LEN, WARM_GUESS,
};

use crate::guess::GuessKind;
use crate::ip::kkt::KktBackendKind;
use crate::ip::{BarrierRule, Globalization, MuMatch, Settings, SolveInfo};
use crate::model::{VehicleParams, NU, NX};
use crate::ocp::{InitialState, OcpSpec};
use crate::plan::{WarmDuals, WarmOptions};

const _: () = assert!(NX == STATE_LEN && NU == CONTROL_LEN);

/// Why a recorded input does not describe a valid problem.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RecordError {
    /// A field is out of its domain.
    #[error("recorded input {seq}: field `{field}`: {problem}")]
    Invalid {
        /// The input's seq.
        seq: u64,
        /// The field.
        field: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// The problem data it describes is outside its domain ([`OcpSpec::check`]).
    #[error("recorded input {seq}: {source}")]
    Spec {
        /// The input's seq.
        seq: u64,
        /// What is wrong.
        source: crate::ocp::SpecError,
    },
}

/// How a recorded solve started.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RecordedStart {
    /// From a guess of its own.
    Guess(GuessKind),
    /// Warm-started: from the [`PlanWarmStart`] of the same seq.
    Warm,
}

/// The vehicle as the recorded array (field order of `plan_record::VEHICLE_FIELDS`).
pub fn vehicle_to_array(p: &VehicleParams) -> [f64; VEHICLE_LEN] {
    [
        p.m,
        p.l,
        p.a,
        p.b,
        p.h_cg,
        p.i_z,
        p.g,
        p.r_w,
        p.i_w,
        p.c_f,
        p.c_r,
        p.mu,
        p.c_l,
        p.delta_max,
        p.t_comb_max,
        p.t_comb_min,
        p.t_bf_min,
        p.t_bf_max,
        p.v_wr_min,
        p.delta_rate_max,
        p.t_comb_rate_max,
        p.t_bf_rate_max,
        p.eps_sigma,
        p.eps_sat,
        p.fmax_floor_frac,
    ]
}

/// The vehicle from the recorded array.
pub fn vehicle_from_array(v: &[f64; VEHICLE_LEN]) -> VehicleParams {
    let [m, l, a, b, h_cg, i_z, g, r_w, i_w, c_f, c_r, mu, c_l, delta_max, t_comb_max, t_comb_min, t_bf_min, t_bf_max, v_wr_min, delta_rate_max, t_comb_rate_max, t_bf_rate_max, eps_sigma, eps_sat, fmax_floor_frac] =
        *v;
    VehicleParams {
        m,
        l,
        a,
        b,
        h_cg,
        i_z,
        g,
        r_w,
        i_w,
        c_f,
        c_r,
        mu,
        c_l,
        delta_max,
        t_comb_max,
        t_comb_min,
        t_bf_min,
        t_bf_max,
        v_wr_min,
        delta_rate_max,
        t_comb_rate_max,
        t_bf_rate_max,
        eps_sigma,
        eps_sat,
        fmax_floor_frac,
    }
}

fn barrier_index(b: BarrierRule) -> f64 {
    match b {
        BarrierRule::Monotone => 0.0,
        BarrierRule::Fullmpc => 1.0,
        BarrierRule::Dampmpc => 2.0,
        BarrierRule::Loqo => 3.0,
        BarrierRule::Quality => 4.0,
        BarrierRule::Probing => 5.0,
        BarrierRule::Adaptive => 6.0,
    }
}

/// The settings as the recorded array (integers, enum indices, booleans as exact f64).
pub fn settings_to_array(s: &Settings) -> [f64; SETTINGS_LEN] {
    [
        s.tol,
        s.constr_viol_tol,
        s.dual_inf_tol,
        s.compl_inf_tol,
        s.acceptable_tol,
        s.acceptable_constr_viol_tol,
        s.max_iter as f64,
        s.max_time_s,
        s.max_backtracks as f64,
        s.max_inertia_corrections as f64,
        s.max_ls_failures as f64,
        s.max_restoration_steps as f64,
        barrier_index(s.barrier),
        match s.globalization {
            Globalization::Filter => 0.0,
            Globalization::Merit => 1.0,
        },
        s.mu_floor_factor,
        s.mu_init,
        s.mu_min,
        s.bound_push,
        s.bound_frac,
        s.bound_relax,
        s.tau_min,
        s.armijo,
        if s.second_order_correction { 1.0 } else { 0.0 },
        s.penalty_init,
        s.delta_w_init,
        s.delta_w_max,
        s.delta_c_min,
        s.infeas_stat_tol,
        s.mu_max_decrease,
        s.mu_linear_decrease,
        s.mu_superlinear_power,
        s.barrier_tol_factor,
        s.delta_w_decrease,
        s.max_refactorizations as f64,
        match s.kkt {
            KktBackendKind::Auto => 0.0,
            KktBackendKind::Sparse => 1.0,
            KktBackendKind::Riccati => 2.0,
        },
    ]
}

/// An exact integer in 0..=max stored as f64, or the name of the offending field.
fn int_field(v: &[f64; SETTINGS_LEN], i: usize, max: usize) -> Result<usize, (usize, String)> {
    let x = v[i];
    if x.fract() == 0.0 && x >= 0.0 && x <= max as f64 {
        Ok(x as usize)
    } else {
        Err((i, format!("{x} is not an integer in 0..={max}")))
    }
}

/// The settings from the recorded array; errors give the index of the bad entry.
fn settings_from_array(v: &[f64; SETTINGS_LEN]) -> Result<Settings, (usize, String)> {
    let barrier = match int_field(v, 12, 6)? {
        0 => BarrierRule::Monotone,
        1 => BarrierRule::Fullmpc,
        2 => BarrierRule::Dampmpc,
        3 => BarrierRule::Loqo,
        4 => BarrierRule::Quality,
        5 => BarrierRule::Probing,
        _ => BarrierRule::Adaptive,
    };
    let globalization = match int_field(v, 13, 1)? {
        0 => Globalization::Filter,
        _ => Globalization::Merit,
    };
    let kkt = match int_field(v, 34, 2)? {
        0 => KktBackendKind::Auto,
        1 => KktBackendKind::Sparse,
        _ => KktBackendKind::Riccati,
    };
    Ok(Settings {
        tol: v[0],
        constr_viol_tol: v[1],
        dual_inf_tol: v[2],
        compl_inf_tol: v[3],
        acceptable_tol: v[4],
        acceptable_constr_viol_tol: v[5],
        max_iter: int_field(v, 6, 1_000_000)?,
        max_time_s: v[7],
        max_backtracks: int_field(v, 8, 1_000_000)?,
        max_inertia_corrections: int_field(v, 9, 1_000_000)?,
        max_ls_failures: int_field(v, 10, 1_000_000)?,
        max_restoration_steps: int_field(v, 11, 1_000_000)?,
        barrier,
        globalization,
        mu_floor_factor: v[14],
        mu_init: v[15],
        mu_min: v[16],
        bound_push: v[17],
        bound_frac: v[18],
        bound_relax: v[19],
        tau_min: v[20],
        armijo: v[21],
        second_order_correction: int_field(v, 22, 1)? == 1,
        penalty_init: v[23],
        delta_w_init: v[24],
        delta_w_max: v[25],
        delta_c_min: v[26],
        infeas_stat_tol: v[27],
        mu_max_decrease: v[28],
        mu_linear_decrease: v[29],
        mu_superlinear_power: v[30],
        barrier_tol_factor: v[31],
        delta_w_decrease: v[32],
        max_refactorizations: int_field(v, 33, 1_000_000)?,
        kkt,
        // Not recorded: any thread count gives the same bits.
        threads: 1,
    })
}

/// The record of what a solve acts on (allocates; build it outside the solve).
pub fn plan_input(
    spec: &OcpSpec,
    settings: &Settings,
    guess: GuessKind,
    seq: u64,
    stamp_ns: u64,
) -> PlanInput {
    let vehicle = vehicle_to_array(&spec.vehicle);
    let settings_arr = settings_to_array(settings);
    let (fixed, x0) = match spec.initial {
        InitialState::Fixed(x0) => (true, x0),
        InitialState::Free => (false, [0.0; NX]),
    };
    PlanInput {
        seq,
        stamp_ns,
        scenario: spec.name.clone(),
        guess: guess.name().into(),
        n_intervals: u32::try_from(spec.n_intervals).unwrap_or(u32::MAX),
        length_m: spec.length,
        v_min_mps: spec.v_min,
        v_max_mps: spec.v_max,
        v_end_max_mps: spec.v_end_max,
        steering_slew_weight: spec.steering_slew_weight,
        soft_lane_weight: spec.soft_lane.weight,
        enforce_tire_saturation: spec.enforce_tire_saturation,
        saturation_at_end: spec.saturation_at_end,
        initial_state_fixed: fixed,
        x0,
        kappa: spec.kappa.clone(),
        e_min: spec.e_min.clone(),
        e_max: spec.e_max.clone(),
        soft_e_min: spec.soft_lane.e_min.clone(),
        soft_e_max: spec.soft_lane.e_max.clone(),
        vehicle,
        settings: settings_arr,
        config_hash: config_hash(&vehicle, &settings_arr),
        settings_json: serde_json::to_string(settings).unwrap_or_default(),
    }
}

/// The record of what a solve produced (allocates; build it outside the solve).
pub fn plan_output(
    seq: u64,
    stamp_ns: u64,
    info: &SolveInfo,
    states: &[[f64; NX]],
    controls: &[[f64; NU]],
) -> PlanOutput {
    let mut out = PlanOutput::with_capacity(controls.len());
    write_output(&mut out, seq, stamp_ns, info, states, controls);
    out
}

/// Writes what a solve produced into `out` in place: allocates nothing when `out` has the
/// capacity (as [`PlanOutput::with_capacity`] gives it).
pub fn write_output(
    out: &mut PlanOutput,
    seq: u64,
    stamp_ns: u64,
    info: &SolveInfo,
    states: &[[f64; NX]],
    controls: &[[f64; NU]],
) {
    let sat = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
    out.seq = seq;
    out.stamp_ns = stamp_ns;
    out.status.clear();
    out.status.push_str(info.status.name());
    out.iterations = sat(info.iterations);
    out.objective = info.objective;
    out.max_violation = info.max_violation;
    out.t_final_s = states.last().map_or(0.0, |x| x[crate::model::ix::T]);
    out.factorizations = sat(info.factorizations);
    out.evaluations = sat(info.evaluations);
    out.time_evaluation_s = info.times.evaluation;
    out.time_factorization_s = info.times.factorization;
    out.time_solve_s = info.times.solve;
    out.time_line_search_s = info.times.line_search;
    out.time_total_s = info.times.total;
    out.states.clear();
    out.states.extend_from_slice(states);
    out.controls.clear();
    out.controls.extend_from_slice(controls);
}

/// Rewrites the fields of a recorded input that change from one replanning cycle to the
/// next (seq, stamp, the road ahead: k_ref, e_min, e_max and the soft lane's bounds, empty
/// without one; the last node's speed bound; the initial state) in place, leaving the problem's
/// constants (name, guess, horizon, bounds, vehicle, settings) as [`plan_input`] wrote
/// them: allocates nothing when the road vectors have the capacity. The result equals
/// [`plan_input`] of the spec with that road and initial state.
pub fn update_input(
    input: &mut PlanInput,
    seq: u64,
    stamp_ns: u64,
    (road, v_end_max): ([&[f64]; 5], f64),
    initial: InitialState,
) {
    input.seq = seq;
    input.stamp_ns = stamp_ns;
    input.v_end_max_mps = v_end_max;
    let fields = [
        &mut input.kappa,
        &mut input.e_min,
        &mut input.e_max,
        &mut input.soft_e_min,
        &mut input.soft_e_max,
    ];
    for (field, values) in fields.into_iter().zip(road) {
        field.clear();
        field.extend_from_slice(values);
    }
    (input.initial_state_fixed, input.x0) = match initial {
        InitialState::Fixed(x0) => (true, x0),
        InitialState::Free => (false, [0.0; NX]),
    };
}

/// Rebuilds the problem, settings and guess a recorded input describes, bit for bit.
pub fn problem_from(input: &PlanInput) -> Result<(OcpSpec, Settings, RecordedStart), RecordError> {
    let bad = |field: &'static str, problem: String| RecordError::Invalid {
        seq: input.seq,
        field,
        problem,
    };
    let hash = config_hash(&input.vehicle, &input.settings);
    if hash != input.config_hash {
        return Err(bad(
            "config_hash",
            format!(
                "{:#018x} does not match the recorded vehicle and settings ({hash:#018x})",
                input.config_hash
            ),
        ));
    }
    let n = input.n_intervals as usize;
    let guess = if input.guess == WARM_GUESS {
        RecordedStart::Warm
    } else {
        RecordedStart::Guess(GuessKind::parse(&input.guess).ok_or_else(|| {
            bad(
                "guess",
                format!(
                    "`{}` is not equilibrium, zero, road_speed or {WARM_GUESS}",
                    input.guess
                ),
            )
        })?)
    };
    let settings =
        settings_from_array(&input.settings).map_err(|(i, p)| bad(SETTINGS_FIELDS[i], p))?;
    settings
        .validate()
        .map_err(|e| bad(e.field, format!("{}: {}", e.value, e.expected)))?;
    let spec = OcpSpec {
        name: input.scenario.clone(),
        n_intervals: n,
        length: input.length_m,
        kappa: input.kappa.clone(),
        e_min: input.e_min.clone(),
        e_max: input.e_max.clone(),
        v_min: input.v_min_mps,
        v_max: input.v_max_mps,
        v_end_max: input.v_end_max_mps,
        enforce_tire_saturation: input.enforce_tire_saturation,
        saturation_at_end: input.saturation_at_end,
        steering_slew_weight: input.steering_slew_weight,
        soft_lane: crate::ocp::SoftLane::new(
            input.soft_lane_weight,
            input.soft_e_min.clone(),
            input.soft_e_max.clone(),
        ),
        initial: if input.initial_state_fixed {
            InitialState::Fixed(input.x0)
        } else {
            InitialState::Free
        },
        vehicle: vehicle_from_array(&input.vehicle),
    };
    spec.check().map_err(|source| RecordError::Spec {
        seq: input.seq,
        source,
    })?;
    Ok((spec, settings, guess))
}

/// Writes where a warm-started solve started into `out` in place: the shift, the options,
/// the primal guess and the multipliers ([`crate::plan::Planner::warm_duals`]). Allocates
/// nothing when `out` has the capacity (as [`PlanWarmStart::with_capacity`] gives it).
pub fn write_warm(
    out: &mut PlanWarmStart,
    (seq, stamp_ns, shift_m): (u64, u64, f64),
    opts: &WarmOptions,
    (states, controls): (&[[f64; NX]], &[[f64; NU]]),
    duals: WarmDuals<'_>,
) {
    out.seq = seq;
    out.stamp_ns = stamp_ns;
    out.shift_m = shift_m;
    out.warm_max_iter = u64::try_from(opts.max_iter).unwrap_or(u64::MAX);
    out.mu_floor = opts.mu_floor;
    out.mu_match.clear();
    out.mu_match.push_str(opts.mu_match.name());
    out.mu_match_factor = opts.mu_match.factor();
    out.cold_guess.clear();
    out.cold_guess.push_str(opts.cold.name());
    out.states.clear();
    out.states.extend_from_slice(states);
    out.controls.clear();
    out.controls.extend_from_slice(controls);
    for (to, from) in [
        (&mut out.y, duals.y),
        (&mut out.zl, duals.zl),
        (&mut out.zu, duals.zu),
    ] {
        to.clear();
        to.extend_from_slice(from);
    }
}

/// The options and multipliers a recorded warm start gives
/// [`crate::plan::Planner::solve_warm_from`] (with its `states` and `controls`).
pub fn warm_from(w: &PlanWarmStart) -> Result<(WarmOptions, WarmDuals<'_>), RecordError> {
    let bad = |field: &'static str, problem: String| RecordError::Invalid {
        seq: w.seq,
        field,
        problem,
    };
    let cold = GuessKind::parse(&w.cold_guess)
        .ok_or_else(|| bad("cold_guess", format!("`{}` is not a guess", w.cold_guess)))?;
    if !(w.mu_floor > 0.0 && w.mu_floor.is_finite()) {
        return Err(bad("mu_floor", format!("{} is not positive", w.mu_floor)));
    }
    let mu_match = MuMatch::parse(&w.mu_match, w.mu_match_factor).ok_or_else(|| {
        bad(
            "mu_match",
            format!(
                "`{}` with factor {} is not a rule (mean, or geometric with a positive factor)",
                w.mu_match, w.mu_match_factor
            ),
        )
    })?;
    let opts = WarmOptions {
        max_iter: usize::try_from(w.warm_max_iter).unwrap_or(usize::MAX),
        mu_floor: w.mu_floor,
        mu_match,
        cold,
    };
    let duals = WarmDuals {
        y: &w.y,
        zl: &w.zl,
        zu: &w.zu,
    };
    Ok((opts, duals))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A warm start written with the default options.
    fn written() -> PlanWarmStart {
        let mut w = PlanWarmStart::with_capacity(2, 4, 3);
        let duals = WarmDuals {
            y: &[0.0; 3],
            zl: &[1.0; 7],
            zu: &[1.0; 7],
        };
        let opts = WarmOptions::default();
        write_warm(
            &mut w,
            (7, 0, 1.5),
            &opts,
            (&[[0.0; NX]; 3], &[[0.0; NU]; 2]),
            duals,
        );
        w
    }

    /// The barrier rule goes into a recording and comes back as it was written.
    #[test]
    fn a_warm_starts_barrier_rule_round_trips_through_its_record() {
        let w = written();
        assert_eq!(
            (w.mu_match.as_str(), w.mu_match_factor),
            ("geometric", 30.0)
        );
        let (opts, _) = warm_from(&w).unwrap();
        assert_eq!(opts, WarmOptions::default());
    }

    /// A recorded rule that is not one, or a geometric factor that is not positive, is
    /// refused with the input's seq and the field.
    #[test]
    fn a_recorded_warm_start_with_a_bad_barrier_rule_is_refused_by_field() {
        for (name, factor) in [
            ("median", 30.0),
            ("geometric", 0.0),
            ("geometric", f64::NAN),
        ] {
            let mut w = written();
            w.mu_match = name.into();
            w.mu_match_factor = factor;
            let e = warm_from(&w).unwrap_err().to_string();
            assert!(e.contains("recorded input 7: field `mu_match`"), "{e}");
        }
        let mut w = written();
        (w.mu_match, w.mu_match_factor) = ("mean".into(), 1.0);
        assert_eq!(warm_from(&w).unwrap().0.mu_match, MuMatch::Mean);
    }
}
