//! The validated pieces every schema shares: objective, horizon, speed bounds, the initial
//! state and the road, and the assembled [`OcpSpec`].

use super::schema::InitialStateToml;
use crate::config::fields::Fields;
use crate::config::ConfigError;
use crate::model::{ix, VehicleParams, NX};
use crate::ocp::spec::InitialDomain;
use crate::ocp::{InitialState, OcpSpec, MAX_STEERING_SLEW_WEIGHT};
use crate::track::{beyond_curvature_centre, Road};

pub(super) fn objective(f: Fields<'_>, v: Option<&str>, field: &str) -> Result<(), ConfigError> {
    f.one_of(v, field, &["min_time"]).map(|_| ())
}

/// The optional steering-slew weight [1/s] of the objective ([`OcpSpec::steering_slew_weight`]):
/// absent is 0, the paper's pure minimum time.
pub(super) fn slew_weight(f: Fields<'_>, v: Option<f64>, field: &str) -> Result<f64, ConfigError> {
    let Some(w) = v else { return Ok(0.0) };
    let w = f.non_neg(Some(w), field)?;
    if w > MAX_STEERING_SLEW_WEIGHT {
        return Err(f.invalid(
            field,
            w,
            format!("must be at most {MAX_STEERING_SLEW_WEIGHT}"),
        ));
    }
    Ok(w)
}

/// Largest node spacing length / N a horizon may have \[m\]. The implicit-Euler steps
/// treat curvature, bounds and controls as constant over one spacing; beyond a few metres
/// a step jumps across corner entries and the plan describes no real drive.
pub const MAX_NODE_SPACING_M: f64 = 5.0;

/// Validated horizon: (length, N), N equal to the required horizon if `f` names one, and
/// the node spacing length / N at most [`MAX_NODE_SPACING_M`]. `ds`, when given, is a check
/// value: length / N within 1e-9 relative.
pub(super) fn horizon(
    f: Fields<'_>,
    length: (Option<f64>, &str),
    n: (Option<i64>, &str),
    ds: Option<(Option<f64>, &str)>,
) -> Result<(f64, usize), ConfigError> {
    let l = f.pos(length.0, length.1)?;
    let n_int = f.count(n.0, n.1)?;
    if let Some(want) = f.horizon.filter(|&want| want != n_int) {
        return Err(f.invalid(
            n.1,
            n_int,
            format!("must be {want}, the horizon N the planner is built for"),
        ));
    }
    let want = l / n_int as f64;
    if let Some(ds) = ds {
        let ds_v = f.pos(ds.0, ds.1)?;
        if (ds_v - want).abs() > 1e-9 * want {
            return Err(f.invalid(
                ds.1,
                ds_v,
                format!("must equal {} / {} = {want}", length.1, n.1),
            ));
        }
    }
    if want > MAX_NODE_SPACING_M {
        return Err(f.invalid(length.1, l, spacing_refusal(want, n_int)));
    }
    Ok((l, n_int))
}

/// Why a horizon with node spacing `ds` over `n` intervals is refused, in words.
pub(crate) fn spacing_refusal(ds: f64, n: usize) -> String {
    format!(
        "puts the {} nodes {ds:.3} m apart; over {MAX_NODE_SPACING_M} m the model steps across \
         corners with one curvature, bound and control per step and the plan is meaningless \
         (keep length_m at most {} m for N = {n}, or plan a long stretch as several horizons)",
        n + 1,
        MAX_NODE_SPACING_M * n as f64
    )
}

/// Validated speed bounds (v_min > 0, v_max > v_min).
pub(super) fn speeds(
    f: Fields<'_>,
    v_min: (Option<f64>, &str),
    v_max: (Option<f64>, &str),
) -> Result<(f64, f64), ConfigError> {
    let lo = f.pos(v_min.0, v_min.1)?;
    let hi = f.num(v_max.0, v_max.1)?;
    if hi <= lo {
        return Err(f.invalid(v_max.1, hi, format!("must exceed {} = {lo}", v_min.1)));
    }
    Ok((lo, hi))
}

/// The initial-state table. A fixed state is checked against the model's domain
/// ([`InitialDomain`]) on the road at node 0, the speed bounds and the vehicle.
pub(super) fn initial_state(
    f: Fields<'_>,
    t: Option<InitialStateToml>,
    prefix: &str,
    domain: InitialDomain<'_>,
) -> Result<InitialState, ConfigError> {
    let t = f.req(t, prefix)?;
    let at = |k: &str| format!("{prefix}.{k}");
    let mode = f.one_of(t.mode.as_deref(), &at("mode"), &["free", "fixed"])?;
    let given = [
        ("s_m", t.s_m),
        ("t_s", t.t_s),
        ("V_mps", t.V_mps),
        ("e_m", t.e_m),
        ("beta_rad", t.beta_rad),
        ("r_radps", t.r_radps),
        ("dpsi_rad", t.dpsi_rad),
        ("V_wr_mps", t.V_wr_mps),
        ("dFz_N", t.dFz_N),
    ];
    if mode == 0 {
        if let Some((k, v)) = given.iter().find_map(|(k, v)| v.map(|v| (k, v))) {
            return Err(f.invalid(&at(k), v, "only allowed with mode = \"fixed\""));
        }
        return Ok(InitialState::Free);
    }
    let mut x = [0.0; NX];
    let keys = [
        ("r_radps", ix::R),
        ("V_mps", ix::V),
        ("beta_rad", ix::BETA),
        ("V_wr_mps", ix::VWR),
        ("dFz_N", ix::DFZ),
        ("e_m", ix::E),
        ("dpsi_rad", ix::DPSI),
        ("s_m", ix::S),
        ("t_s", ix::T),
    ];
    for (k, idx) in keys {
        let v = given.iter().find(|(n, _)| *n == k).and_then(|(_, v)| *v);
        x[idx] = f.num(v, &at(k))?;
    }
    if let Some((i, problem)) = domain.problem(&x) {
        let key = keys
            .iter()
            .find(|(_, idx)| *idx == i)
            .map_or("?", |(k, _)| k);
        return Err(f.invalid(&at(key), x[i], problem));
    }
    Ok(InitialState::Fixed(x))
}

/// `field` = `kappa` refused unless the lane `e_min..e_max` stays short of its curvature
/// centre ([`beyond_curvature_centre`]).
pub(super) fn curvature(
    f: Fields<'_>,
    field: &str,
    kappa: f64,
    (e_min, e_max): (f64, f64),
) -> Result<(), ConfigError> {
    match beyond_curvature_centre(kappa, e_min, e_max) {
        None => Ok(()),
        Some((bound, room)) => Err(f.invalid(
            field,
            format!("{kappa:?}"),
            format!(
                "puts the lane's {bound} at or beyond the curvature centre (1 - kappa e = {room:?}); \
                 |kappa| must stay below 1 / |e| for e_min = {e_min}, e_max = {e_max}"
            ),
        )),
    }
}

/// Finite values everywhere, e_min < e_max and both bounds short of the curvature centre
/// ([`beyond_curvature_centre`]) at every node of the road of scenario `name`.
fn check_road(f: Fields<'_>, name: &str, road: &Road) -> Result<(), ConfigError> {
    for k in 0..road.kappa.len() {
        let (kap, lo, hi) = (road.kappa[k], road.e_min[k], road.e_max[k]);
        let field = format!("{name} at node {k} (s = {})", road.node_s(k));
        if !(kap.is_finite() && lo.is_finite() && hi.is_finite()) {
            return Err(f.invalid(
                &field,
                format!("kappa {kap}, e_min {lo}, e_max {hi}"),
                "must be finite",
            ));
        }
        if lo >= hi {
            return Err(f.invalid(
                &field,
                format!("e_min {lo}, e_max {hi}"),
                "lateral bounds must satisfy e_min < e_max",
            ));
        }
        if let Some((bound, room)) = beyond_curvature_centre(kap, lo, hi) {
            return Err(f.invalid(
                &field,
                format!("kappa {kap:?}, e_min {lo}, e_max {hi}"),
                format!(
                    "{bound} is at or beyond the curvature centre (1 - kappa e = {room:?}); \
                     the lane must stay short of 1/kappa"
                ),
            ));
        }
    }
    Ok(())
}

/// Checks the road (finite, e_min < e_max and short of the curvature centre at every
/// node), reads the initial state
/// against it and assembles the spec.
#[allow(clippy::too_many_arguments)]
pub(super) fn finish(
    f: Fields<'_>,
    name: String,
    length: f64,
    road: Road,
    (v_min, v_max): (f64, f64),
    (enforce_tire_saturation, steering_slew_weight): (bool, f64),
    (initial, initial_field): (Option<InitialStateToml>, &str),
    vehicle: VehicleParams,
) -> Result<OcpSpec, ConfigError> {
    check_road(f, &name, &road)?;
    let domain = InitialDomain {
        vehicle: Some(&vehicle),
        v: (v_min, v_max),
        e0: (road.e_min[0], road.e_max[0]),
        kappa0: road.kappa.first().copied(),
    };
    let initial = initial_state(f, initial, initial_field, domain)?;
    Ok(OcpSpec {
        name,
        n_intervals: road.n_intervals(),
        length,
        kappa: road.kappa,
        e_min: road.e_min,
        e_max: road.e_max,
        v_min,
        v_max,
        enforce_tire_saturation,
        saturation_at_end: false,
        steering_slew_weight,
        v_end_max: f64::INFINITY,
        soft_lane: crate::ocp::SoftLane::OFF,
        initial,
        vehicle,
    })
}
