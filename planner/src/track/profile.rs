//! Periodic curvature/width profile on a uniform arc-length grid.

use super::csv::read_rows;
use super::segment::beyond_curvature_centre;
use super::TrackFileError;
use std::path::Path;

/// Column names (and header line) of a canonical profile CSV.
pub const PROFILE_COLUMNS: [&str; 4] = ["s_m", "kappa_1pm", "w_right_m", "w_left_m"];

/// A closed track: curvature and track widths at s = 0, step, 2 step, ..., periodic with
/// the lap length.
///
/// Between rows, and from the last row to row 0 placed at s = lap length, values are
/// interpolated linearly (`tracks/README.md`).
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    step: f64,
    lap: f64,
    kappa: Vec<f64>,
    w_right: Vec<f64>,
    w_left: Vec<f64>,
}

impl Profile {
    /// Assembles a profile from rows at s = i * step; the caller guarantees the invariants.
    pub(crate) fn from_parts(
        step: f64,
        lap: f64,
        kappa: Vec<f64>,
        w_right: Vec<f64>,
        w_left: Vec<f64>,
    ) -> Self {
        Profile {
            step,
            lap,
            kappa,
            w_right,
            w_left,
        }
    }

    /// Loads a canonical profile CSV (`s_m,kappa_1pm,w_right_m,w_left_m`), periodic with
    /// `lap_length` \[m\].
    ///
    /// Checks the header, 4 finite numbers per row, s_0 = 0, s strictly increasing with a
    /// constant step, widths > 0, both track edges short of the curvature centre
    /// (1 - kappa w_left > 0 and 1 + kappa w_right > 0, where the model's spatial dynamics
    /// divide by 1 - kappa e), and `s_last < lap_length <= s_last + step`.
    pub fn load(path: &Path, lap_length: f64) -> Result<Self, TrackFileError> {
        let rows = read_rows(path, &PROFILE_COLUMNS, true)?;
        let first = &rows[0];
        if first.values[0] != 0.0 {
            return Err(TrackFileError::csv(
                path,
                first.line,
                format!("s_m = {}: the first row must be at s = 0", first.values[0]),
            ));
        }
        if rows.len() < 2 {
            return Err(TrackFileError::csv(
                path,
                0,
                "a profile needs at least two rows",
            ));
        }
        let step = rows[1].values[0];
        let n = rows.len();
        let (mut kappa, mut w_right, mut w_left) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        );
        for (i, r) in rows.iter().enumerate() {
            let [s, k, wr, wl] = r.values;
            if i > 0 {
                let prev = rows[i - 1].values[0];
                if s <= prev {
                    return Err(TrackFileError::csv(
                        path,
                        r.line,
                        format!("s_m = {s}: must be strictly increasing (previous row has {prev})"),
                    ));
                }
                if ((s - prev) - step).abs() > 1e-6 * step {
                    return Err(TrackFileError::csv(
                        path,
                        r.line,
                        format!(
                            "s_m = {s}: step {} differs from the first step {step} (the grid must be uniform)",
                            s - prev
                        ),
                    ));
                }
            }
            for (name, w) in [("w_right_m", wr), ("w_left_m", wl)] {
                if w.is_nan() || w <= 0.0 {
                    return Err(TrackFileError::csv(
                        path,
                        r.line,
                        format!("{name} = {w}: must be positive"),
                    ));
                }
            }
            if let Some((bound, room)) = beyond_curvature_centre(k, -wr, wl) {
                let (name, w) = if bound == "e_min" {
                    ("w_right_m", wr)
                } else {
                    ("w_left_m", wl)
                };
                return Err(TrackFileError::csv(
                    path,
                    r.line,
                    format!(
                        "kappa_1pm = {k:?}: the track edge {name} = {w} lies at or beyond the \
                         curvature centre (1 - kappa e = {room:?}); |kappa| must stay below 1 / {name}"
                    ),
                ));
            }
            kappa.push(k);
            w_right.push(wr);
            w_left.push(wl);
        }
        let s_last = (n - 1) as f64 * step;
        if !(lap_length.is_finite()
            && lap_length > s_last
            && lap_length <= s_last + step * (1.0 + 1e-9))
        {
            return Err(TrackFileError::invalid(
                path,
                "lap_length_m",
                lap_length,
                format!(
                    "lap length of this profile must lie in (s_last, s_last + step] = ({s_last}, {}]",
                    s_last + step
                ),
            ));
        }
        Ok(Profile::from_parts(
            step, lap_length, kappa, w_right, w_left,
        ))
    }

    /// (kappa [1/m], w_right \[m\], w_left \[m\]) at track arc length `s`, wrapped modulo the lap.
    pub fn sample(&self, s: f64) -> (f64, f64, f64) {
        let n = self.kappa.len();
        let u = s.rem_euclid(self.lap);
        // `as usize` saturates (NaN -> 0), the min keeps the index in range.
        let i = ((u / self.step).floor() as usize).min(n - 1);
        let s_i = i as f64 * self.step;
        let (j, s_j) = if i + 1 < n {
            (i + 1, s_i + self.step)
        } else {
            (0, self.lap)
        };
        let t = ((u - s_i) / (s_j - s_i)).clamp(0.0, 1.0);
        let lerp = |v: &[f64]| v[i] + t * (v[j] - v[i]);
        (lerp(&self.kappa), lerp(&self.w_right), lerp(&self.w_left))
    }

    /// Lap length \[m\] (the period).
    pub fn lap_length(&self) -> f64 {
        self.lap
    }

    /// Row spacing \[m\].
    pub fn step(&self) -> f64 {
        self.step
    }

    /// Number of rows (s = 0 .. (n_rows - 1) * step).
    pub fn n_rows(&self) -> usize {
        self.kappa.len()
    }

    /// Curvature at the rows [1/m].
    pub fn kappa(&self) -> &[f64] {
        &self.kappa
    }

    /// Right width at the rows \[m\].
    pub fn w_right(&self) -> &[f64] {
        &self.w_right
    }

    /// Left width at the rows \[m\].
    pub fn w_left(&self) -> &[f64] {
        &self.w_left
    }

    /// Lap integral of kappa \[rad\] (trapezoid rule over the closed loop): the net heading change.
    pub fn total_turning(&self) -> f64 {
        let n = self.kappa.len();
        let inner: f64 = (0..n - 1)
            .map(|i| 0.5 * (self.kappa[i] + self.kappa[i + 1]) * self.step)
            .sum();
        let last =
            0.5 * (self.kappa[n - 1] + self.kappa[0]) * (self.lap - (n - 1) as f64 * self.step);
        inner + last
    }
}
