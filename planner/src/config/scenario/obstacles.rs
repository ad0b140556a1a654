//! The collision-avoidance schema: `[[scenarios]]` on a straight road of constant
//! curvature, each with bound overrides that put obstacles into the lateral bounds.

use super::checks::{curvature, finish, horizon, objective, slew_weight, speeds};
use super::schema::ObstacleFile;
use super::select::pick;
use super::Layout;
use crate::config::fields::Fields;
use crate::config::ConfigError;
use crate::model::VehicleParams;
use crate::ocp::OcpSpec;
use crate::track::{BoundsOverride, Road};

/// The spec of the selected scenario of an obstacle file.
pub(super) fn load(
    f: Fields<'_>,
    file: ObstacleFile,
    select: Option<&str>,
    vehicle: VehicleParams,
) -> Result<(OcpSpec, Layout), ConfigError> {
    let entries = file.scenarios.unwrap_or_default();
    let (name, sc) = pick(
        f,
        entries,
        |s| s.name.clone(),
        "scenarios",
        "scenario",
        select,
    )?;

    objective(f, file.objective.as_deref(), "objective")?;
    let c = f.req(file.common, "common")?;
    let (length, n) = horizon(
        f,
        (c.horizon_length_m, "common.horizon_length_m"),
        (c.n_intervals, "common.n_intervals"),
        Some((c.ds_m, "common.ds_m")),
    )?;
    let kappa = f.num(c.kappa_1pm, "common.kappa_1pm")?;
    let e_min = f.num(c.road_e_min_m, "common.road_e_min_m")?;
    let e_max = f.num(c.road_e_max_m, "common.road_e_max_m")?;
    curvature(f, "common.kappa_1pm", kappa, (e_min, e_max))?;
    let (v_min, v_max) = speeds(
        f,
        (c.v_min_mps, "common.v_min_mps"),
        (c.v_max_mps, "common.v_max_mps"),
    )?;
    let sat = f.req(c.enforce_tire_saturation, "common.enforce_tire_saturation")?;
    let slew = slew_weight(f, c.steering_slew_weight, "common.steering_slew_weight")?;

    let field = format!("scenarios[{name}].bounds_override");
    let mut overrides: Vec<BoundsOverride> = Vec::new();
    for (i, o) in sc.bounds_override.unwrap_or_default().iter().enumerate() {
        let field = format!("{field}[{i}]");
        let &[s_from, s_to, lo, hi] = o.as_slice() else {
            return Err(f.invalid(
                &field,
                format!("{o:?}"),
                "expected [s_from_m, s_to_m, e_min_m, e_max_m]",
            ));
        };
        if !o.iter().all(|v| v.is_finite()) {
            return Err(f.invalid(&field, format!("{o:?}"), "must be finite"));
        }
        if s_from > s_to || lo >= hi {
            return Err(f.invalid(
                &field,
                format!("{o:?}"),
                "needs s_from_m <= s_to_m and e_min_m < e_max_m",
            ));
        }
        if let Some(prev) = overrides
            .iter()
            .find(|p| s_from <= p.s_to && p.s_from <= s_to)
        {
            return Err(f.invalid(
                &field,
                format!("{o:?}"),
                format!(
                    "overlaps [{}, {}]: intervals must not overlap",
                    prev.s_from, prev.s_to
                ),
            ));
        }
        overrides.push(BoundsOverride {
            s_from,
            s_to,
            e_min: lo,
            e_max: hi,
        });
    }
    let mut road = Road::uniform(length, n, kappa, e_min, e_max);
    let layout = Layout {
        lane_e_min: road.e_min.clone(),
        lane_e_max: road.e_max.clone(),
        placement: None,
        track: None,
    };
    road.apply_overrides(&overrides);
    let spec = finish(
        f,
        name,
        length,
        road,
        (v_min, v_max),
        (sat, slew),
        (c.initial_state, "common.initial_state"),
        vehicle,
    )?;
    Ok((spec, layout))
}
