//! Scenario files (`config/scenarios/*.toml`) → validated [`OcpSpec`].
//!
//! Three schemas, told apart by their top-level tables (see `config/scenarios/README.md`):
//! a single road with `[horizon]` and `[track]` (the oval), `[[segments]]` cut from
//! closed tracks, and `[[scenarios]]` on a straight road with obstacle bound overrides
//! (collision avoidance).

mod checks;
mod obstacles;
mod schema;
mod segments;
mod select;
mod single;
mod stretch;

use super::fields::{parse_toml, read_text, Fields};
use super::ConfigError;
use crate::model::VehicleParams;
use crate::ocp::OcpSpec;
use schema::{ObstacleFile, SegmentsFile};
use select::names;
use std::path::{Path, PathBuf};
pub use stretch::{load_stretch, Stretch};

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
    load(Fields::new(path), select, vehicle)
}

/// [`load_scenario`] for a planner built for `n_intervals` intervals (such as
/// [`crate::HORIZON`]): a file with another interval count is refused with the file and
/// its key named.
pub fn load_scenario_for_horizon(
    path: &Path,
    select: Option<&str>,
    vehicle: VehicleParams,
    n_intervals: usize,
) -> Result<OcpSpec, ConfigError> {
    let mut f = Fields::new(path);
    f.horizon = Some(n_intervals);
    load(f, select, vehicle)
}

fn load(
    f: Fields<'_>,
    select: Option<&str>,
    vehicle: VehicleParams,
) -> Result<OcpSpec, ConfigError> {
    let path = f.file;
    let text = read_text(path)?;
    match kind_of(f, &text)? {
        Kind::Single => single::load(f, parse_toml(path, &text)?, select, vehicle),
        Kind::Segments => segments::load(f, parse_toml(path, &text)?, select, vehicle),
        Kind::Obstacles => obstacles::load(f, parse_toml(path, &text)?, select, vehicle),
    }
}
