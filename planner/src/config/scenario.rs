//! Scenario files (`config/scenarios/*.toml`) → validated [`OcpSpec`].
//!
//! Three schemas, told apart by their top-level tables (see `config/scenarios/README.md`):
//! a single road with `[horizon]` and `[track]` (the oval), `[[segments]]` cut from
//! closed tracks, and `[[scenarios]]` on a straight road with obstacle bound overrides
//! (collision avoidance).

use super::fields::{parse_toml, read_text, Fields};
use super::tracks::{TrackInfo, TrackToml};
use super::ConfigError;
use crate::model::{ix, VehicleParams, NX};
use crate::ocp::spec::InitialDomain;
use crate::ocp::{InitialState, OcpSpec, MAX_STEERING_SLEW_WEIGHT};
use crate::track::{piecewise_constant, BoundsOverride, Profile, Road, Segment};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The data root of a scenario file: the parent of the folder holding it
/// (`config/scenarios/oval.toml` → `config`). Paths inside scenario files resolve against it.
pub fn data_root_of(scenario_path: &Path) -> PathBuf {
    let dir = match scenario_path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if dir.file_name().is_none() {
        // ".", ".." or a root: go up literally.
        return dir.join("..");
    }
    match dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

// ---------------------------------------------------------------- file schemas

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case)]
struct InitialStateToml {
    mode: Option<String>,
    s_m: Option<f64>,
    t_s: Option<f64>,
    V_mps: Option<f64>,
    e_m: Option<f64>,
    beta_rad: Option<f64>,
    r_radps: Option<f64>,
    dpsi_rad: Option<f64>,
    V_wr_mps: Option<f64>,
    dFz_N: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SingleFile {
    name: Option<String>,
    objective: Option<String>,
    geometry: Option<Geometry>,
    horizon: Option<Horizon>,
    track: Option<SingleTrack>,
    bounds: Option<Bounds>,
    options: Option<Options>,
    initial_state: Option<InitialStateToml>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Geometry {
    shape: Option<String>,
    direction: Option<String>,
    straight_length_m: Option<f64>,
    radius_m: Option<f64>,
    lap_length_m: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Horizon {
    length_m: Option<f64>,
    n_intervals: Option<i64>,
    ds_m: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SingleTrack {
    kappa_pieces: Option<Vec<Vec<f64>>>,
    /// The same curvature sampled every 1 m; informational (the pieces are exact).
    #[allow(dead_code)]
    profile_csv: Option<String>,
    e_min_m: Option<f64>,
    e_max_m: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Bounds {
    v_min_mps: Option<f64>,
    v_max_mps: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Options {
    enforce_tire_saturation: Option<bool>,
    steering_slew_weight: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SegmentsFile {
    defaults: Option<SegmentDefaults>,
    tracks: Option<Vec<TrackToml>>,
    segments: Option<Vec<SegmentToml>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SegmentDefaults {
    objective: Option<String>,
    length_m: Option<f64>,
    n_intervals: Option<i64>,
    ds_m: Option<f64>,
    v_min_mps: Option<f64>,
    v_max_mps: Option<f64>,
    edge_margin_m: Option<f64>,
    enforce_tire_saturation: Option<bool>,
    steering_slew_weight: Option<f64>,
    initial_state: Option<InitialStateToml>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SegmentToml {
    name: Option<String>,
    track: Option<String>,
    profile_csv: Option<String>,
    s_start_m: Option<f64>,
    length_m: Option<f64>,
    n_intervals: Option<i64>,
    ds_m: Option<f64>,
    #[allow(dead_code)]
    description: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ObstacleFile {
    objective: Option<String>,
    common: Option<ObstacleCommon>,
    scenarios: Option<Vec<ObstacleScenario>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ObstacleCommon {
    horizon_length_m: Option<f64>,
    n_intervals: Option<i64>,
    ds_m: Option<f64>,
    kappa_1pm: Option<f64>,
    road_e_min_m: Option<f64>,
    road_e_max_m: Option<f64>,
    v_min_mps: Option<f64>,
    v_max_mps: Option<f64>,
    enforce_tire_saturation: Option<bool>,
    steering_slew_weight: Option<f64>,
    initial_state: Option<InitialStateToml>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ObstacleScenario {
    name: Option<String>,
    #[allow(dead_code)]
    description: Option<String>,
    bounds_override: Option<Vec<Vec<f64>>>,
    #[allow(dead_code)]
    expected: Option<String>,
}

/// Which of the three schemas a file uses.
enum Kind {
    Single,
    Segments,
    Obstacles,
}

fn kind_of(f: Fields<'_>, text: &str) -> Result<Kind, ConfigError> {
    let table: toml::Table = parse_toml(f.file, text)?;
    if table.contains_key("segments") {
        Ok(Kind::Segments)
    } else if table.contains_key("scenarios") {
        Ok(Kind::Obstacles)
    } else if table.contains_key("horizon") {
        Ok(Kind::Single)
    } else {
        let keys: Vec<&str> = table.keys().map(String::as_str).collect();
        Err(f.invalid(
            "(top level)",
            format!("[{}]", keys.join(", ")),
            "not a scenario file: expected a [horizon] table, [[segments]] or [[scenarios]]",
        ))
    }
}

// ---------------------------------------------------------------- public entry points

/// Names that `select` can take in `load_scenario` (segment or scenario names); empty for
/// a single-road file such as the oval.
pub fn list_selections(path: &Path) -> Result<Vec<String>, ConfigError> {
    let text = read_text(path)?;
    let f = Fields::new(path);
    Ok(match kind_of(f, &text)? {
        Kind::Single => Vec::new(),
        Kind::Segments => {
            let file: SegmentsFile = parse_toml(path, &text)?;
            names(
                f,
                file.segments
                    .unwrap_or_default()
                    .iter()
                    .map(|s| s.name.clone()),
                "segments",
            )?
        }
        Kind::Obstacles => {
            let file: ObstacleFile = parse_toml(path, &text)?;
            names(
                f,
                file.scenarios
                    .unwrap_or_default()
                    .iter()
                    .map(|s| s.name.clone()),
                "scenarios",
            )?
        }
    })
}

/// Loads one OCP instance from a scenario file.
///
/// `select` names the segment (`"S01"`) or scenario (`"critical"`) in a multi-entry file;
/// it may be `None` when the file holds exactly one. Track files named inside resolve
/// against [`data_root_of`]`(path)`.
pub fn load_scenario(
    path: &Path,
    select: Option<&str>,
    vehicle: VehicleParams,
) -> Result<OcpSpec, ConfigError> {
    let text = read_text(path)?;
    let f = Fields::new(path);
    match kind_of(f, &text)? {
        Kind::Single => single(f, parse_toml(path, &text)?, select, vehicle),
        Kind::Segments => segments(f, parse_toml(path, &text)?, select, vehicle),
        Kind::Obstacles => obstacles(f, parse_toml(path, &text)?, select, vehicle),
    }
}

// ---------------------------------------------------------------- shared pieces

/// Entry names of an array of tables, each required and unique.
fn names(
    f: Fields<'_>,
    names: impl Iterator<Item = Option<String>>,
    array: &str,
) -> Result<Vec<String>, ConfigError> {
    let mut out: Vec<String> = Vec::new();
    for (i, n) in names.enumerate() {
        let n = f.req(n, &format!("{array}[{i}].name"))?;
        if out.contains(&n) {
            return Err(f.invalid(
                &format!("{array}[{i}].name"),
                format!("\"{n}\""),
                "duplicate name",
            ));
        }
        out.push(n);
    }
    if out.is_empty() {
        return Err(f.invalid(array, "[]", "needs at least one entry"));
    }
    Ok(out)
}

/// The selected entry of an array of named tables (`array`, entries called `what`), with
/// its name; names must be present and unique.
fn pick<T>(
    f: Fields<'_>,
    entries: Vec<T>,
    name_of: impl Fn(&T) -> Option<String>,
    array: &str,
    what: &str,
    select: Option<&str>,
) -> Result<(String, T), ConfigError> {
    let available = names(f, entries.iter().map(name_of), array)?;
    let idx = select_index(f, &available, select, what)?;
    let entry = entries
        .into_iter()
        .nth(idx)
        .ok_or_else(|| f.invalid(array, idx, "index out of range"))?;
    Ok((available[idx].clone(), entry))
}

/// Index of the selected entry among `available`.
fn select_index(
    f: Fields<'_>,
    available: &[String],
    select: Option<&str>,
    what: &str,
) -> Result<usize, ConfigError> {
    let err = |message: String| ConfigError::Selection {
        file: f.file.to_path_buf(),
        message,
        available: available.to_vec(),
    };
    match select {
        Some(s) => available
            .iter()
            .position(|a| a == s)
            .ok_or_else(|| err(format!("no {what} named \"{s}\""))),
        None if available.len() == 1 => Ok(0),
        None => Err(err(format!(
            "the file holds {} {what}s: select one by name",
            available.len()
        ))),
    }
}

fn objective(f: Fields<'_>, v: Option<&str>, field: &str) -> Result<(), ConfigError> {
    f.one_of(v, field, &["min_time"]).map(|_| ())
}

/// The optional steering-slew weight [1/s] of the objective ([`OcpSpec::steering_slew_weight`]):
/// absent is 0, the paper's pure minimum time.
fn slew_weight(f: Fields<'_>, v: Option<f64>, field: &str) -> Result<f64, ConfigError> {
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

/// Validated horizon: (length, N). `ds` is a check value: length / N within 1e-9 relative.
fn horizon(
    f: Fields<'_>,
    length: (Option<f64>, &str),
    n: (Option<i64>, &str),
    ds: (Option<f64>, &str),
) -> Result<(f64, usize), ConfigError> {
    let l = f.pos(length.0, length.1)?;
    let n_int = f.count(n.0, n.1)?;
    let ds_v = f.pos(ds.0, ds.1)?;
    let want = l / n_int as f64;
    if (ds_v - want).abs() > 1e-9 * want {
        return Err(f.invalid(
            ds.1,
            ds_v,
            format!("must equal {} / {} = {want}", length.1, n.1),
        ));
    }
    Ok((l, n_int))
}

/// Validated speed bounds (v_min > 0, v_max > v_min).
fn speeds(
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
fn initial_state(
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

/// Finite values everywhere and e_min < e_max at every node of the road of scenario `name`.
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
    }
    Ok(())
}

// ---------------------------------------------------------------- the three schemas

fn single(
    f: Fields<'_>,
    file: SingleFile,
    select: Option<&str>,
    vehicle: VehicleParams,
) -> Result<OcpSpec, ConfigError> {
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
        (h.ds_m, "horizon.ds_m"),
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
}

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

fn segments(
    f: Fields<'_>,
    file: SegmentsFile,
    select: Option<&str>,
    vehicle: VehicleParams,
) -> Result<OcpSpec, ConfigError> {
    let entries = file.segments.unwrap_or_default();
    let (name, seg) = pick(
        f,
        entries,
        |s| s.name.clone(),
        "segments",
        "segment",
        select,
    )?;
    let at = |k: &str| format!("segments[{name}].{k}");

    let d = f.req(file.defaults, "defaults")?;
    objective(f, d.objective.as_deref(), "defaults.objective")?;
    let (length, n) = horizon(
        f,
        seg.length_m.map_or((d.length_m, "defaults.length_m"), |v| {
            (Some(v), "segments.length_m")
        }),
        seg.n_intervals
            .map_or((d.n_intervals, "defaults.n_intervals"), |v| {
                (Some(v), "segments.n_intervals")
            }),
        seg.ds_m
            .map_or((d.ds_m, "defaults.ds_m"), |v| (Some(v), "segments.ds_m")),
    )
    .map_err(|e| in_segment(e, &name))?;
    let (v_min, v_max) = speeds(
        f,
        (d.v_min_mps, "defaults.v_min_mps"),
        (d.v_max_mps, "defaults.v_max_mps"),
    )?;
    let margin = f.non_neg(d.edge_margin_m, "defaults.edge_margin_m")?;
    let sat = f.req(
        d.enforce_tire_saturation,
        "defaults.enforce_tire_saturation",
    )?;
    let slew = slew_weight(f, d.steering_slew_weight, "defaults.steering_slew_weight")?;

    let root = data_root_of(f.file);
    let mut tracks: Vec<TrackInfo> = Vec::new();
    for (i, t) in file.tracks.unwrap_or_default().into_iter().enumerate() {
        tracks.push(t.resolve(f, i, &root)?);
    }
    let track_name = f.req(seg.track, &at("track"))?;
    let track = tracks
        .iter()
        .find(|t| t.name == track_name)
        .ok_or_else(|| {
            let list: Vec<&str> = tracks.iter().map(|t| t.name.as_str()).collect();
            f.invalid(
                &at("track"),
                format!("\"{track_name}\""),
                format!("must name a [[tracks]] entry (have: {})", list.join(", ")),
            )
        })?;
    if let Some(p) = &seg.profile_csv {
        if root.join(p) != track.profile_csv {
            return Err(f.invalid(
                &at("profile_csv"),
                format!("\"{p}\""),
                format!("must match tracks[{}].profile_csv", track.name),
            ));
        }
    }
    let s_start = f.num(seg.s_start_m, &at("s_start_m"))?;
    let profile = Profile::load(&track.profile_csv, track.lap_length)?;
    let road = Segment {
        s_start,
        length,
        n_intervals: n,
    }
    .sample(&profile, margin);
    finish(
        f,
        name,
        length,
        road,
        (v_min, v_max),
        (sat, slew),
        (d.initial_state, "defaults.initial_state"),
        vehicle,
    )
}

/// Rewrites a `segments.key` field to `segments[name].key`.
fn in_segment(e: ConfigError, name: &str) -> ConfigError {
    match e {
        ConfigError::Invalid {
            file,
            field,
            value,
            expected,
        } => ConfigError::Invalid {
            file,
            field: field.replacen("segments.", &format!("segments[{name}]."), 1),
            value,
            expected,
        },
        other => other,
    }
}

fn obstacles(
    f: Fields<'_>,
    file: ObstacleFile,
    select: Option<&str>,
    vehicle: VehicleParams,
) -> Result<OcpSpec, ConfigError> {
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
        (c.ds_m, "common.ds_m"),
    )?;
    let kappa = f.num(c.kappa_1pm, "common.kappa_1pm")?;
    let e_min = f.num(c.road_e_min_m, "common.road_e_min_m")?;
    let e_max = f.num(c.road_e_max_m, "common.road_e_max_m")?;
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
    road.apply_overrides(&overrides);
    finish(
        f,
        name,
        length,
        road,
        (v_min, v_max),
        (sat, slew),
        (c.initial_state, "common.initial_state"),
        vehicle,
    )
}

/// Checks the road (finite, e_min < e_max at every node), reads the initial state
/// against it and assembles the spec.
#[allow(clippy::too_many_arguments)]
fn finish(
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
        steering_slew_weight,
        initial,
        vehicle,
    })
}
