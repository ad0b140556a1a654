//! The single-road schema (the oval): a `[horizon]` and a `[track]` whose curvature is
//! piecewise constant, with constant lateral bounds.

use super::checks::{curvature, finish, horizon, objective, slew_weight, speeds};
use super::schema::{Geometry, SingleFile};
use crate::config::fields::Fields;
use crate::config::ConfigError;
use crate::model::VehicleParams;
use crate::ocp::OcpSpec;
use crate::track::{piecewise_constant, Road};

/// The spec of a single-road file (`select`, if given, must be its name).
pub(super) fn load(
    f: Fields<'_>,
    file: SingleFile,
    select: Option<&str>,
    vehicle: VehicleParams,
) -> Result<(OcpSpec, super::Layout), ConfigError> {
    let name = f.req(file.name, "name")?;
    if let Some(s) = select {
        if s != name {
            return Err(ConfigError::Selection {
                file: f.file.to_path_buf(),
                message: format!("no scenario named \"{s}\" (the file holds one road)"),
                available: vec![name],
            });
        }
    }
    objective(f, file.objective.as_deref(), "objective")?;
    if let Some(g) = file.geometry {
        check_geometry(f, g)?;
    }
    let h = f.req(file.horizon, "horizon")?;
    let (length, n) = horizon(
        f,
        (h.length_m, "horizon.length_m"),
        (h.n_intervals, "horizon.n_intervals"),
        Some((h.ds_m, "horizon.ds_m")),
    )?;
    let t = f.req(file.track, "track")?;
    let raw_pieces = f.req(t.kappa_pieces, "track.kappa_pieces")?;
    let mut pieces: Vec<(f64, f64)> = Vec::with_capacity(raw_pieces.len());
    for (i, p) in raw_pieces.iter().enumerate() {
        let field = format!("track.kappa_pieces[{i}]");
        let &[s, k] = p.as_slice() else {
            return Err(f.invalid(&field, format!("{p:?}"), "expected [s_start_m, kappa_1pm]"));
        };
        if !(s.is_finite() && k.is_finite()) {
            return Err(f.invalid(&field, format!("{p:?}"), "must be finite"));
        }
        if let Some(&(prev, _)) = pieces.last() {
            if s <= prev {
                return Err(f.invalid(
                    &field,
                    format!("{p:?}"),
                    "s_start_m must increase strictly",
                ));
            }
        } else if s != 0.0 {
            return Err(f.invalid(
                &field,
                format!("{p:?}"),
                "the first piece must start at s = 0",
            ));
        }
        pieces.push((s, k));
    }
    if pieces.is_empty() {
        return Err(f.invalid("track.kappa_pieces", "[]", "needs at least one piece"));
    }
    let e_min = f.num(t.e_min_m, "track.e_min_m")?;
    let e_max = f.num(t.e_max_m, "track.e_max_m")?;
    for (i, &(_, k)) in pieces.iter().enumerate() {
        curvature(f, &format!("track.kappa_pieces[{i}]"), k, (e_min, e_max))?;
    }
    let b = f.req(file.bounds, "bounds")?;
    let (v_min, v_max) = speeds(
        f,
        (b.v_min_mps, "bounds.v_min_mps"),
        (b.v_max_mps, "bounds.v_max_mps"),
    )?;
    let o = f.req(file.options, "options")?;
    let sat = f.req(o.enforce_tire_saturation, "options.enforce_tire_saturation")?;
    let slew = slew_weight(f, o.steering_slew_weight, "options.steering_slew_weight")?;
    let road = Road::from_fn(length, n, |s| {
        (piecewise_constant(&pieces, s), e_min, e_max)
    });
    finish(
        f,
        name,
        length,
        road,
        (v_min, v_max),
        (sat, slew),
        (file.initial_state, "initial_state"),
        vehicle,
    )
    .map(|spec| {
        let layout = super::Layout::of(&spec);
        (spec, layout)
    })
}

/// Checks the optional oval geometry: lap length = 2 straight + 2 pi radius.
fn check_geometry(f: Fields<'_>, g: Geometry) -> Result<(), ConfigError> {
    if g.shape.is_some() {
        f.one_of(g.shape.as_deref(), "geometry.shape", &["oval"])?;
    }
    if g.direction.is_some() {
        f.one_of(g.direction.as_deref(), "geometry.direction", &["ccw", "cw"])?;
    }
    let (Some(st), Some(r), Some(lap)) = (g.straight_length_m, g.radius_m, g.lap_length_m) else {
        return Ok(());
    };
    let st = f.pos(Some(st), "geometry.straight_length_m")?;
    let r = f.pos(Some(r), "geometry.radius_m")?;
    let lap = f.pos(Some(lap), "geometry.lap_length_m")?;
    let want = 2.0 * st + 2.0 * std::f64::consts::PI * r;
    if (lap - want).abs() > 1e-6 * want {
        return Err(f.invalid(
            "geometry.lap_length_m",
            lap,
            format!("must equal 2 straight_length_m + 2 pi radius_m = {want}"),
        ));
    }
    Ok(())
}
