//! Raw closed centerline (TUMFTM racetrack-database CSV) → smooth periodic [`Profile`].
//!
//! Same method as `config/tracks/make_profiles.py`: a periodic cubic P-spline fit of x(u),
//! y(u) over chord length u (knots every ~5 m, third-order cyclic difference penalty,
//! lambda = 10), analytic curvature, arc length by the trapezoid rule on a 0.02 m
//! parameter grid, resampling at whole metres, and widths re-referenced to the smoothed
//! line.

use super::csv::{read_rows, Row};
use super::Profile;
use super::TrackFileError;
use crate::elementary::hypot;
use std::path::Path;

/// Target knot spacing of the periodic cubic B-spline \[m\].
pub const KNOT_SPACING_M: f64 = 5.0;
/// Weight of the third-order cyclic difference penalty.
pub const PENALTY_LAMBDA: f64 = 10.0;
/// Output row spacing \[m\].
const DS_OUT_M: f64 = 1.0;
/// Parameter step of the arc-length quadrature \[m\].
const DU_DENSE_M: f64 = 0.02;
/// Columns of a raw centerline file (given in a `#` comment line upstream).
pub(crate) const RAW_COLUMNS: [&str; 4] = ["x_m", "y_m", "w_tr_right_m", "w_tr_left_m"];
/// Coefficients of D^T D for the cyclic third-order forward difference D, offsets 0..=3.
const PENALTY_STENCIL: [f64; 4] = [20.0, -15.0, 6.0, -1.0];
/// Half-bandwidth of the cyclic normal matrix.
const BW: usize = 3;

/// Uniform cubic B-spline weights of the 4 active basis functions at local t in [0, 1),
/// and their first and second derivatives with respect to t.
fn bspline_weights(t: f64) -> [[f64; 4]; 3] {
    let (t2, t3) = (t * t, t * t * t);
    [
        [
            (1.0 - t).powi(3) / 6.0,
            (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
            (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0,
            t3 / 6.0,
        ],
        [
            -(1.0 - t).powi(2) / 2.0,
            (9.0 * t2 - 12.0 * t) / 6.0,
            (-9.0 * t2 + 6.0 * t + 3.0) / 6.0,
            t2 / 2.0,
        ],
        [1.0 - t, 3.0 * t - 2.0, -3.0 * t + 1.0, t],
    ]
}

/// Periodic uniform cubic B-spline curve in the plane.
struct PeriodicSpline {
    period: f64,
    h: f64,
    coef: Vec<[f64; 2]>,
}

impl PeriodicSpline {
    /// Indices of the 4 active basis functions and the local coordinate at parameter u.
    fn locate(period: f64, m: usize, u: f64) -> ([usize; 4], f64) {
        let v = u.rem_euclid(period) / (period / m as f64);
        let j = (v.floor() as usize).min(m - 1);
        let t = v - j as f64;
        ([(j + m - 1) % m, j, (j + 1) % m, (j + 2) % m], t)
    }

    /// Penalised least-squares fit of `points` at parameters `u` with `m` knot intervals.
    fn fit(period: f64, m: usize, u: &[f64], points: &[[f64; 2]], lambda: f64) -> Option<Self> {
        // Lower band of the cyclic normal matrix: band[i][d] = N[i][(i + m - d) % m].
        let mut band = vec![[0.0; BW + 1]; m];
        let mut rhs = vec![[0.0; 2]; m];
        for (&ui, p) in u.iter().zip(points) {
            let (idx, t) = Self::locate(period, m, ui);
            let w = bspline_weights(t)[0];
            for a in 0..4 {
                rhs[idx[a]][0] += w[a] * p[0];
                rhs[idx[a]][1] += w[a] * p[1];
                for b in 0..=a {
                    // idx[a] is idx[b] shifted forward by a - b (cyclically).
                    band[idx[a]][a - b] += w[a] * w[b];
                }
            }
        }
        for row in band.iter_mut() {
            for (d, c) in PENALTY_STENCIL.iter().enumerate() {
                row[d] += lambda * c;
            }
        }
        let entry = |i: usize, j: usize| -> f64 {
            // j <= i; cyclic offset of j behind i is either i - j or i + m - j.
            let d1 = i - j;
            let d2 = j + m - i;
            if d1 <= BW {
                band[i][d1]
            } else if d2 <= BW {
                band[j][d2]
            } else {
                0.0
            }
        };
        let chol = Skyline::factor(
            m,
            |i| if i + BW >= m { 0 } else { i.saturating_sub(BW) },
            entry,
        )?;
        let mut coef = vec![[0.0; 2]; m];
        for c in 0..2 {
            let mut b: Vec<f64> = rhs.iter().map(|r| r[c]).collect();
            chol.solve(&mut b);
            for (k, v) in b.into_iter().enumerate() {
                coef[k][c] = v;
            }
        }
        Some(PeriodicSpline {
            period,
            h: period / m as f64,
            coef,
        })
    }

    /// Value (`der` = 0), first or second derivative with respect to u at parameter u.
    fn eval(&self, u: f64, der: usize) -> [f64; 2] {
        let (idx, t) = Self::locate(self.period, self.coef.len(), u);
        let w = bspline_weights(t)[der];
        let scale = self.h.powi(-(der as i32));
        let mut out = [0.0; 2];
        for a in 0..4 {
            out[0] += w[a] * self.coef[idx[a]][0] * scale;
            out[1] += w[a] * self.coef[idx[a]][1] * scale;
        }
        out
    }

    /// Signed curvature (x'y'' - y'x'') / |r'|^3 at parameter u.
    fn curvature(&self, u: f64) -> f64 {
        let (d1, d2) = (self.eval(u, 1), self.eval(u, 2));
        (d1[0] * d2[1] - d1[1] * d2[0]) / hypot(d1[0], d1[1]).powi(3)
    }
}

/// Cholesky factor L of a symmetric positive definite matrix stored by rows from the
/// first non-zero column `first[i]` (envelope storage; no fill outside the envelope).
struct Skyline {
    first: Vec<usize>,
    rows: Vec<Vec<f64>>,
}

impl Skyline {
    /// Factors the matrix with lower entries `a(i, j)` (j <= i) inside the envelope
    /// `first(i) <= j`; `None` if it is not positive definite.
    fn factor(
        n: usize,
        first: impl Fn(usize) -> usize,
        a: impl Fn(usize, usize) -> f64,
    ) -> Option<Self> {
        let first: Vec<usize> = (0..n).map(first).collect();
        let mut rows: Vec<Vec<f64>> = Vec::with_capacity(n);
        for i in 0..n {
            let fi = first[i];
            let mut row = vec![0.0; i - fi + 1];
            for j in fi..i {
                let fj = first[j];
                let mut sum = a(i, j);
                for k in fi.max(fj)..j {
                    sum -= row[k - fi] * rows[j][k - fj];
                }
                row[j - fi] = sum / rows[j][j - fj];
            }
            let diag = a(i, i) - row[..i - fi].iter().map(|v| v * v).sum::<f64>();
            if diag.is_nan() || diag <= 0.0 {
                return None;
            }
            row[i - fi] = diag.sqrt();
            rows.push(row);
        }
        Some(Skyline { first, rows })
    }

    /// Solves L L^T x = b in place.
    fn solve(&self, b: &mut [f64]) {
        let n = b.len();
        for i in 0..n {
            let fi = self.first[i];
            let row = &self.rows[i];
            let sum: f64 = (fi..i).map(|k| row[k - fi] * b[k]).sum();
            b[i] = (b[i] - sum) / row[i - fi];
        }
        for i in (0..n).rev() {
            let fi = self.first[i];
            let row = &self.rows[i];
            b[i] /= row[i - fi];
            let xi = b[i];
            for k in fi..i {
                b[k] -= row[k - fi] * xi;
            }
        }
    }
}

/// Interval `i` and fraction `t` of `x` in increasing `xs` (x = xs[i] + t (xs[i+1] - xs[i])),
/// searching forward from `*hint` (monotone queries); clamped to the range.
fn locate_walk(xs: &[f64], x: f64, hint: &mut usize) -> (usize, f64) {
    while *hint + 2 < xs.len() && xs[*hint + 1] < x {
        *hint += 1;
    }
    let i = *hint;
    (i, ((x - xs[i]) / (xs[i + 1] - xs[i])).clamp(0.0, 1.0))
}

/// Linear interpolation between `v[i]` and `v[i + 1]`.
fn lerp(v: &[f64], (i, t): (usize, f64)) -> f64 {
    v[i] + t * (v[i + 1] - v[i])
}

/// The raw points of a closed centerline, parametrized by chord length.
struct ChordParameters {
    /// The points (x, y) \[m\].
    points: Vec<[f64; 2]>,
    /// Chord-length parameter u of every point (u_0 = 0) \[m\].
    u_raw: Vec<f64>,
    /// Total chord length, the closing chord back to the first point included \[m\].
    period: f64,
}

/// The points of the raw rows with their chord-length parameters (widths positive, no
/// point repeating its predecessor).
fn chord_parameters(path: &Path, rows: &[Row<4>]) -> Result<ChordParameters, TrackFileError> {
    let mut points = Vec::with_capacity(rows.len());
    let mut u_raw = Vec::with_capacity(rows.len());
    let mut period = 0.0;
    for (i, r) in rows.iter().enumerate() {
        let [x, y, wr, wl] = r.values;
        if !(wr > 0.0 && wl > 0.0) {
            return Err(TrackFileError::csv(
                path,
                r.line,
                "track widths must be positive",
            ));
        }
        if i > 0 {
            let [px, py] = points[i - 1];
            let chord = hypot(x - px, y - py);
            if chord <= 0.0 {
                return Err(TrackFileError::csv(
                    path,
                    r.line,
                    "point repeats the previous one",
                ));
            }
            period += chord;
        }
        u_raw.push(period);
        points.push([x, y]);
    }
    let [x0, y0] = points[0];
    let [xl, yl] = points[points.len() - 1];
    period += hypot(x0 - xl, y0 - yl);
    Ok(ChordParameters {
        points,
        u_raw,
        period,
    })
}

/// Arc length s(u) of the spline on a dense uniform u grid over one period (trapezoid rule),
/// with the grid step du.
fn arc_length(spline: &PeriodicSpline, period: f64) -> (Vec<f64>, f64) {
    let n_dense = (period / DU_DENSE_M).ceil() as usize;
    let du = period / n_dense as f64;
    let speed = |k: usize| {
        let d = spline.eval(k as f64 * du, 1);
        hypot(d[0], d[1])
    };
    let mut s_dense = Vec::with_capacity(n_dense + 1);
    s_dense.push(0.0);
    let mut prev = speed(0);
    for k in 1..=n_dense {
        let v = speed(k);
        s_dense.push(s_dense[k - 1] + 0.5 * (prev + v) * du);
        prev = v;
    }
    (s_dense, du)
}

/// The right and left track widths at s = 0, 1, 2, ... (`n_out` rows): the raw widths
/// re-referenced to the smoothed line, then interpolated periodically in s (`s_dense`: the
/// arc length on the u grid of step `du`, ending at the lap length).
fn smoothed_widths(
    spline: &PeriodicSpline,
    rows: &[Row<4>],
    points: &[[f64; 2]],
    u_raw: &[f64],
    s_dense: &[f64],
    du: f64,
    n_out: usize,
) -> (Vec<f64>, Vec<f64>) {
    let n_dense = s_dense.len() - 1;
    let lap = s_dense[n_dense];
    let mut s_raw = Vec::with_capacity(points.len());
    let mut w_right_raw = Vec::with_capacity(points.len());
    let mut w_left_raw = Vec::with_capacity(points.len());
    for ((&u, p), r) in u_raw.iter().zip(points).zip(rows) {
        let c = spline.eval(u, 0);
        let d1 = spline.eval(u, 1);
        // Signed offset of the raw point from the smoothed line along the left normal.
        let d_lat = ((p[0] - c[0]) * -d1[1] + (p[1] - c[1]) * d1[0]) / hypot(d1[0], d1[1]);
        // s(u) on the uniform u grid.
        let k = ((u / du).floor() as usize).min(n_dense - 1);
        s_raw.push(lerp(s_dense, (k, u / du - k as f64)));
        w_right_raw.push(r.values[2] - d_lat);
        w_left_raw.push(r.values[3] + d_lat);
    }
    // Close the loop: the first raw point again at s = lap.
    s_raw.push(lap);
    w_right_raw.push(w_right_raw[0]);
    w_left_raw.push(w_left_raw[0]);
    let mut w_right = Vec::with_capacity(n_out);
    let mut w_left = Vec::with_capacity(n_out);
    let mut hint = 0;
    for i in 0..n_out {
        let s = i as f64 * DS_OUT_M;
        let at = locate_walk(&s_raw, s, &mut hint);
        w_right.push(lerp(&w_right_raw, at));
        w_left.push(lerp(&w_left_raw, at));
    }
    (w_right, w_left)
}

/// What smoothing measured about a centerline (the statistics of the track index).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CenterlineStats {
    /// Largest |kappa| on a 0.1 m parameter grid [1/m].
    pub max_abs_kappa: f64,
    /// Largest |dkappa/ds| between neighbours of that grid [1/m^2].
    pub max_abs_dkappa_ds: f64,
    /// Lap integral of the 1 m curvature rows over 2 pi: +1 counter-clockwise, -1
    /// clockwise, 0 for a figure eight.
    pub winding: f64,
    /// Largest distance of a raw point from the smoothed line \[m\].
    pub max_centerline_shift: f64,
    /// Smallest left width of the profile \[m\].
    pub min_w_left: f64,
    /// Smallest right width of the profile \[m\].
    pub min_w_right: f64,
}

/// A raw centerline smoothed: its profile, statistics and the pose at s = 0.
#[derive(Debug, Clone, PartialEq)]
pub struct SmoothedCenterline {
    /// The 1 m curvature/width profile.
    pub profile: Profile,
    /// The statistics of the track index.
    pub stats: CenterlineStats,
    /// Position (x, y) \[m\] and heading \[rad\] of the smoothed centerline at s = 0, in the
    /// raw file's frame.
    pub start_pose: [f64; 3],
}

/// Curvature statistics on a 0.1 m parameter grid: (max |kappa|, max |dkappa/ds|), with s
/// interpolated on the arc-length table `s_dense` (u step `du`).
fn curvature_stats(spline: &PeriodicSpline, period: f64, s_dense: &[f64], du: f64) -> (f64, f64) {
    let n_dense = s_dense.len() - 1;
    let n_fine = (period / 0.1).ceil() as usize;
    let (mut max_k, mut max_dk) = (0.0_f64, 0.0_f64);
    let mut prev: Option<(f64, f64)> = None;
    for i in 0..n_fine {
        let u = i as f64 * 0.1;
        let k = spline.curvature(u);
        let j = ((u / du).floor() as usize).min(n_dense - 1);
        let s = lerp(s_dense, (j, u / du - j as f64));
        max_k = max_k.max(k.abs());
        if let Some((k0, s0)) = prev {
            max_dk = max_dk.max(((k - k0) / (s - s0)).abs());
        }
        prev = Some((k, s));
    }
    (max_k, max_dk)
}

/// Smooths a raw closed centerline CSV (`# x_m,y_m,w_tr_right_m,w_tr_left_m`, the last point
/// joins the first) into a periodic profile on a 1 m grid, with the index statistics.
pub fn smooth_centerline(path: &Path) -> Result<SmoothedCenterline, TrackFileError> {
    let rows = read_rows(path, &RAW_COLUMNS, false)?;
    smooth_rows(path, &rows)
}

/// [`smooth_centerline`] of rows already read from `path`.
pub(crate) fn smooth_rows(
    path: &Path,
    rows: &[Row<4>],
) -> Result<SmoothedCenterline, TrackFileError> {
    let ChordParameters {
        points,
        u_raw,
        period,
    } = chord_parameters(path, rows)?;
    let m = (period / KNOT_SPACING_M).round() as usize;
    if period > 1.0e6 {
        return Err(TrackFileError::csv(
            path,
            0,
            format!("closed centerline of {period:.1} m is longer than 1000 km"),
        ));
    }
    if m < 8 || points.len() < 4 {
        return Err(TrackFileError::csv(
            path,
            0,
            format!(
                "closed centerline too short ({period:.1} m, {} points) to smooth: \
                 at least 4 points and 40 m are needed",
                points.len()
            ),
        ));
    }
    let spline =
        PeriodicSpline::fit(period, m, &u_raw, &points, PENALTY_LAMBDA).ok_or_else(|| {
            TrackFileError::csv(
                path,
                0,
                "smoothing system is singular (degenerate centerline)",
            )
        })?;
    let (s_dense, du) = arc_length(&spline, period);
    let lap = s_dense[s_dense.len() - 1];

    // Resample curvature at s = 0, 1, 2, ... < lap.
    let n_out = ((lap - 1e-9) / DS_OUT_M).ceil() as usize;
    let mut kappa = Vec::with_capacity(n_out);
    let mut hint = 0;
    for i in 0..n_out {
        let (k, t) = locate_walk(&s_dense, i as f64 * DS_OUT_M, &mut hint);
        let u = (k as f64 + t) * du;
        kappa.push(spline.curvature(u));
    }

    let (w_right, w_left) = smoothed_widths(&spline, rows, &points, &u_raw, &s_dense, du, n_out);
    if let Some(i) = (0..n_out).find(|&i| !kappa[i].is_finite()) {
        return Err(TrackFileError::csv(
            path,
            0,
            format!("curvature is not finite at s = {i} m (degenerate centerline)"),
        ));
    }
    if let Some(i) = (0..n_out).find(|&i| !(w_right[i] > 0.0 && w_left[i] > 0.0)) {
        return Err(TrackFileError::csv(
            path,
            0,
            format!("a track width becomes non-positive at s = {i} m after smoothing"),
        ));
    }
    let (max_abs_kappa, max_abs_dkappa_ds) = curvature_stats(&spline, period, &s_dense, du);
    let max_centerline_shift = u_raw
        .iter()
        .zip(&points)
        .map(|(&u, p)| {
            let c = spline.eval(u, 0);
            hypot(p[0] - c[0], p[1] - c[1])
        })
        .fold(0.0, f64::max);
    let stats = CenterlineStats {
        max_abs_kappa,
        max_abs_dkappa_ds,
        winding: kappa.iter().sum::<f64>() * DS_OUT_M / (2.0 * std::f64::consts::PI),
        max_centerline_shift,
        min_w_left: w_left.iter().copied().fold(f64::INFINITY, f64::min),
        min_w_right: w_right.iter().copied().fold(f64::INFINITY, f64::min),
    };
    let c0 = spline.eval(0.0, 0);
    let d0 = spline.eval(0.0, 1);
    Ok(SmoothedCenterline {
        profile: Profile::from_parts(DS_OUT_M, lap, kappa, w_right, w_left),
        stats,
        start_pose: [c0[0], c0[1], d0[1].atan2(d0[0])],
    })
}

impl Profile {
    /// Builds a smooth periodic profile on a 1 m grid from a raw closed centerline CSV
    /// (`# x_m,y_m,w_tr_right_m,w_tr_left_m`, the last point joins the first); see
    /// [`smooth_centerline`].
    pub fn from_centerline(path: &Path) -> Result<Profile, TrackFileError> {
        smooth_centerline(path).map(|s| s.profile)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn skyline_matches_dense_cholesky_on_cyclic_band() {
        let m = 12;
        let entry = |i: usize, j: usize| -> f64 {
            let d = (i as isize - j as isize).rem_euclid(m as isize) as usize;
            let d = d.min(m - d);
            match d {
                0 => 30.0 + i as f64,
                1 => -4.0 - 0.1 * (i.min(j) as f64),
                2 => 1.5,
                3 => -0.5,
                _ => 0.0,
            }
        };
        let chol = Skyline::factor(
            m,
            |i| if i + BW >= m { 0 } else { i.saturating_sub(BW) },
            entry,
        )
        .expect("positive definite");
        let dense = nalgebra::DMatrix::from_fn(m, m, |i, j| entry(i.max(j), i.min(j)));
        let b: Vec<f64> = (0..m).map(|i| (i as f64).sin() + 0.3).collect();
        let want = dense
            .cholesky()
            .expect("positive definite")
            .solve(&nalgebra::DVector::from_vec(b.clone()));
        let mut got = b;
        chol.solve(&mut got);
        for i in 0..m {
            assert!(
                (got[i] - want[i]).abs() < 1e-12,
                "row {i}: {} vs {}",
                got[i],
                want[i]
            );
        }
    }

    #[test]
    fn spline_fit_reproduces_a_circle() {
        // 400 points on a circle of radius 100 m (ccw): curvature +0.01 away from smoothing bias.
        let n = 400;
        let r = 100.0;
        let pts: Vec<[f64; 2]> = (0..n)
            .map(|i| {
                let a = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
                [r * a.cos(), r * a.sin()]
            })
            .collect();
        let chord = 2.0 * r * (std::f64::consts::PI / n as f64).sin();
        let u: Vec<f64> = (0..n).map(|i| i as f64 * chord).collect();
        let period = chord * n as f64;
        let m = (period / KNOT_SPACING_M).round() as usize;
        let sp = PeriodicSpline::fit(period, m, &u, &pts, PENALTY_LAMBDA).expect("fit");
        for k in 0..50 {
            let kap = sp.curvature(k as f64 * period / 50.0);
            assert!((kap - 0.01).abs() < 1e-4, "kappa {kap}");
        }
    }
}
