//! Track entries: `tracks/tracks.toml` and the `[[tracks]]` table of a segments file.

use super::fields::{parse_toml, read_text, Fields};
use super::ConfigError;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Driving direction of a closed track (sign of its lap curvature integral).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Counter-clockwise: lap integral of kappa = +2 pi.
    Ccw,
    /// Clockwise: lap integral of kappa = -2 pi.
    Cw,
    /// Figure-eight: lap integral of kappa = 0.
    FigureEight,
}

impl Direction {
    /// Winding number: +1, -1 or 0.
    pub fn winding(self) -> f64 {
        match self {
            Direction::Ccw => 1.0,
            Direction::Cw => -1.0,
            Direction::FigureEight => 0.0,
        }
    }
}

/// One closed track with its files resolved against the data root.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackInfo {
    /// Track name, e.g. `Austin`.
    pub name: String,
    /// Canonical 1 m profile CSV.
    pub profile_csv: PathBuf,
    /// Raw centerline CSV, if named.
    pub raw_csv: Option<PathBuf>,
    /// Lap length \[m\] (period of the profile).
    pub lap_length: f64,
    /// Driving direction.
    pub direction: Direction,
    /// Pose of the smoothed centerline at s = 0 in the raw file's frame: x \[m\], y \[m\],
    /// heading \[rad\] (`start_pose`; absent in a hand-written entry, then the origin).
    pub start_pose: [f64; 3],
}

/// A `[[tracks]]` entry as written (shared by `tracks.toml` and segments files).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct TrackToml {
    name: Option<String>,
    raw_csv: Option<String>,
    profile_csv: Option<String>,
    lap_length_m: Option<f64>,
    direction: Option<String>,
    start_pose: Option<Vec<f64>>,
    // Statistics written by make_profiles.py: informational, not used.
    #[allow(dead_code)]
    n_rows: Option<i64>,
    #[allow(dead_code)]
    max_abs_kappa_1pm: Option<f64>,
    #[allow(dead_code)]
    max_abs_dkappa_ds_1pm2: Option<f64>,
    #[allow(dead_code)]
    max_centerline_shift_m: Option<f64>,
    #[allow(dead_code)]
    min_w_left_m: Option<f64>,
    #[allow(dead_code)]
    min_w_right_m: Option<f64>,
}

impl TrackToml {
    /// Validates entry `index` of `[[tracks]]` and resolves its paths against `root`.
    pub(crate) fn resolve(
        self,
        f: Fields<'_>,
        index: usize,
        root: &Path,
    ) -> Result<TrackInfo, ConfigError> {
        let at = |key: &str| format!("tracks[{index}].{key}");
        let name = f.req(self.name, &at("name"))?;
        let at = |key: &str| format!("tracks[{name}].{key}");
        let profile_csv = root.join(f.req(self.profile_csv, &at("profile_csv"))?);
        let raw_csv = self.raw_csv.map(|p| root.join(p));
        let lap_length = f.pos(self.lap_length_m, &at("lap_length_m"))?;
        let direction = match f.one_of(
            self.direction.as_deref(),
            &at("direction"),
            &["ccw", "cw", "figure-eight"],
        )? {
            0 => Direction::Ccw,
            1 => Direction::Cw,
            _ => Direction::FigureEight,
        };
        let start_pose = match self.start_pose {
            None => [0.0; 3],
            Some(v) => match v.as_slice() {
                &[x, y, h] if v.iter().all(|c| c.is_finite()) => [x, y, h],
                _ => {
                    return Err(f.invalid(
                        &at("start_pose"),
                        format!("{v:?}"),
                        "must be [x_m, y_m, heading_rad], three finite numbers",
                    ))
                }
            },
        };
        Ok(TrackInfo {
            name,
            profile_csv,
            raw_csv,
            lap_length,
            direction,
            start_pose,
        })
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct IndexFile {
    tracks: Option<Vec<TrackToml>>,
}

/// Reads a track index (`tracks/tracks.toml`); paths resolve against the data root, the
/// parent of the folder holding the index.
pub fn load_track_index(path: &Path) -> Result<Vec<TrackInfo>, ConfigError> {
    let text = read_text(path)?;
    let raw: IndexFile = parse_toml(path, &text)?;
    let f = Fields::new(path);
    let root = super::data_root_of(path);
    let entries = f.req(raw.tracks, "tracks")?;
    let mut out: Vec<TrackInfo> = Vec::with_capacity(entries.len());
    for (i, t) in entries.into_iter().enumerate() {
        let info = t.resolve(f, i, &root)?;
        if out.iter().any(|o| o.name == info.name) {
            return Err(f.invalid(
                &format!("tracks[{i}].name"),
                format!("\"{}\"", info.name),
                "duplicate track name",
            ));
        }
        out.push(info);
    }
    Ok(out)
}
