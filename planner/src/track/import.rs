//! Importing a raw centerline as a named track of a data root: the smoothed profile CSV,
//! a copy of the raw file, and the entry of the track index `tracks/tracks.toml`.
//!
//! The profile is [`smooth_centerline`](super::smooth_centerline)'s (the method of `config/tracks/README.md`), printed
//! with the digits of the shipped profiles: s to 0.1 m, kappa to 1e-8 1/m, widths to 1 mm.
//! Files are written whole or not at all ([`write_atomic`]), the index last, so a failed
//! import leaves the index as it was.

use super::centerline::{smooth_rows, SmoothedCenterline, RAW_COLUMNS};
use super::csv::read_rows;
use super::shape::check_loop;
use super::{Profile, TrackFileError, PROFILE_COLUMNS};
use crate::io::{write_atomic, WriteError};
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// Longest track name accepted \[characters\].
pub const MAX_NAME_LEN: usize = 64;

/// Why an import failed.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// The raw centerline is unreadable or unusable (names the file and line).
    #[error(transparent)]
    Track(#[from] TrackFileError),
    /// The track name cannot be a file name.
    #[error("track name `{0}`: use 1 to {MAX_NAME_LEN} letters, digits, `_` or `-`")]
    BadName(String),
    /// The index already lists the name and `force` was not given.
    #[error("{}: a track named `{name}` exists already (import with --force to replace it)", index.display())]
    Exists {
        /// The index file.
        index: PathBuf,
        /// The name.
        name: String,
    },
    /// The index file cannot be read or parsed.
    #[error("{}: {message}", index.display())]
    Index {
        /// The index file.
        index: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A file could not be written (nothing was left under its name).
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// What an import wrote.
#[derive(Debug, Clone)]
pub struct ImportedTrack {
    /// The track's name.
    pub name: String,
    /// The smoothed centerline.
    pub smoothed: SmoothedCenterline,
    /// `"ccw"`, `"cw"` or `"figure-eight"`.
    pub direction: &'static str,
    /// The files written: raw copy (when it was not already in place), profile, index.
    pub files: Vec<PathBuf>,
}

/// Whether `name` is usable as a track and file name.
pub fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= MAX_NAME_LEN
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// The direction word of a winding number (+1 ccw, -1 cw, about 0 figure eight).
pub fn direction_of(winding: f64) -> &'static str {
    if winding > 0.5 {
        "ccw"
    } else if winding < -0.5 {
        "cw"
    } else {
        "figure-eight"
    }
}

/// Reads, checks and smooths a raw centerline; `figure_eight` allows (and then requires)
/// a self-crossing loop whose curvature does not wind.
pub fn smooth_checked(
    raw: &Path,
    figure_eight: bool,
) -> Result<SmoothedCenterline, TrackFileError> {
    let rows = read_rows(raw, &RAW_COLUMNS, false)?;
    check_loop(raw, &rows, figure_eight)?;
    let smoothed = smooth_rows(raw, &rows)?;
    let w = smoothed.stats.winding;
    if figure_eight && direction_of(w) != "figure-eight" {
        return Err(TrackFileError::csv(
            raw,
            0,
            format!(
                "imported as a figure eight, but the curvature winds {w:.2} times around the lap \
                 (a figure eight winds 0 times): leave out --figure-eight"
            ),
        ));
    }
    if !figure_eight && direction_of(w) == "figure-eight" {
        return Err(TrackFileError::csv(
            raw,
            0,
            format!("the curvature winds {w:.2} times around the lap, not +1 or -1: is the loop closed?"),
        ));
    }
    Ok(smoothed)
}

/// The profile CSV text: the header and one row per metre with the shipped digits.
pub fn profile_csv_text(profile: &Profile) -> String {
    let mut out = String::with_capacity(40 * profile.n_rows() + 40);
    let _ = writeln!(out, "{}", PROFILE_COLUMNS.join(","));
    for i in 0..profile.n_rows() {
        let _ = writeln!(
            out,
            "{:.1},{:.8},{:.3},{:.3}",
            i as f64 * profile.step(),
            profile.kappa()[i],
            profile.w_right()[i],
            profile.w_left()[i]
        );
    }
    out
}

/// The `[[tracks]]` entry of the index for `name`, as written by the import.
pub fn index_entry(name: &str, smoothed: &SmoothedCenterline) -> String {
    let (p, st) = (&smoothed.profile, &smoothed.stats);
    let [x0, y0, h0] = smoothed.start_pose;
    format!(
        "[[tracks]]\n\
         name = \"{name}\"\n\
         raw_csv = \"tracks/{name}.csv\"\n\
         profile_csv = \"tracks/{name}_profile.csv\"\n\
         lap_length_m = {lap:.3}      # profile is periodic with this period\n\
         n_rows = {rows}                  # s = 0, 1, ..., n_rows-1\n\
         direction = \"{dir}\"\n\
         max_abs_kappa_1pm = {k:.4}\n\
         max_abs_dkappa_ds_1pm2 = {dk:.5}\n\
         max_centerline_shift_m = {shift:.3}   # smoothed vs raw centerline\n\
         min_w_left_m = {wl:.3}\n\
         min_w_right_m = {wr:.3}\n\
         start_pose = [{x0:.3}, {y0:.3}, {h0:.6}]   # smoothed centerline at s = 0: x_m, y_m, heading_rad\n",
        lap = p.lap_length(),
        rows = p.n_rows(),
        dir = direction_of(st.winding),
        k = st.max_abs_kappa,
        dk = st.max_abs_dkappa_ds,
        shift = st.max_centerline_shift,
        wl = st.min_w_left,
        wr = st.min_w_right,
    )
}

/// Header of a new index file.
const INDEX_HEADER: &str =
    "# Index of track profiles (`trajopt track import`). Paths are relative to the\n\
# folder that contains tracks/. See README.md for the column conventions.\n";

/// The index text with `entry` for `name` added (or, with `force`, put in place of the
/// existing entry of that name).
fn updated_index(
    index: &Path,
    text: &str,
    name: &str,
    entry: &str,
    force: bool,
) -> Result<String, ImportError> {
    let parsed: toml::Table = toml::from_str(text).map_err(|e| ImportError::Index {
        index: index.to_path_buf(),
        message: e.to_string().trim_end().to_string(),
    })?;
    let exists = parsed
        .get("tracks")
        .and_then(|t| t.as_array())
        .is_some_and(|a| {
            a.iter()
                .any(|t| t.get("name").and_then(|n| n.as_str()) == Some(name))
        });
    if exists && !force {
        return Err(ImportError::Exists {
            index: index.to_path_buf(),
            name: name.to_string(),
        });
    }
    // Split the text into the preamble and one block per `[[tracks]]` header line.
    let mut blocks: Vec<String> = vec![String::new()];
    for line in text.lines() {
        if line.trim() == "[[tracks]]" {
            blocks.push(String::new());
        }
        let last = blocks.len() - 1;
        blocks[last].push_str(line);
        blocks[last].push('\n');
    }
    let name_line = format!("name = \"{name}\"");
    let mut out = String::with_capacity(text.len() + entry.len() + 1);
    let mut placed = false;
    for (i, b) in blocks.iter().enumerate() {
        if i > 0 && b.lines().any(|l| l.trim() == name_line) {
            out.push_str(entry);
            out.push('\n');
            placed = true;
        } else {
            out.push_str(b);
        }
    }
    if !placed {
        if !out.is_empty() && !out.ends_with("\n\n") {
            out.push('\n');
        }
        out.push_str(entry);
    }
    Ok(out)
}

/// Imports the raw centerline `raw` as track `name` of the data root `data_root`: writes
/// `tracks/<name>.csv` (a copy of `raw`), `tracks/<name>_profile.csv` and the entry of
/// `tracks/tracks.toml` (created if missing). An existing name is refused unless `force`.
pub fn import_track(
    raw: &Path,
    data_root: &Path,
    name: &str,
    force: bool,
    figure_eight: bool,
) -> Result<ImportedTrack, ImportError> {
    if !valid_name(name) {
        return Err(ImportError::BadName(name.to_string()));
    }
    let tracks = data_root.join("tracks");
    let index = tracks.join("tracks.toml");
    let text = match std::fs::read_to_string(&index) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => INDEX_HEADER.to_string(),
        Err(e) => {
            return Err(ImportError::Index {
                index,
                message: format!("cannot read: {e}"),
            })
        }
    };
    // Refuse an existing name before the work of smoothing.
    updated_index(&index, &text, name, "", force)?;
    let smoothed = smooth_checked(raw, figure_eight)?;
    let entry = index_entry(name, &smoothed);
    let new_index = updated_index(&index, &text, name, &entry, force)?;

    std::fs::create_dir_all(&tracks).map_err(|source| WriteError {
        path: tracks.clone(),
        source,
    })?;
    let mut files = Vec::new();
    let raw_copy = tracks.join(format!("{name}.csv"));
    let same = match (raw.canonicalize(), raw_copy.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    if !same {
        let bytes = std::fs::read(raw).map_err(|source| TrackFileError::Io {
            file: raw.to_path_buf(),
            source,
        })?;
        write_atomic(&raw_copy, |w| w.write_all(&bytes))?;
        files.push(raw_copy);
    }
    let profile_path = tracks.join(format!("{name}_profile.csv"));
    let csv = profile_csv_text(&smoothed.profile);
    write_atomic(&profile_path, |w| w.write_all(csv.as_bytes()))?;
    files.push(profile_path);
    write_atomic(&index, |w| w.write_all(new_index.as_bytes()))?;
    files.push(index);
    Ok(ImportedTrack {
        name: name.to_string(),
        direction: direction_of(smoothed.stats.winding),
        smoothed,
        files,
    })
}
