//! The track in the plane: poses (x, y, heading) rebuilt from curvature, and the corners.
//!
//! Heading obeys psi'(s) = kappa(s). Between two samples kappa is taken as the mean of its
//! end values, so each step is an exact circular arc: its chord has length
//! ds sin(a) / a, a = dpsi / 2, along the mean heading psi + a. Starting from the smoothed
//! centerline's pose at s = 0 (the index's `start_pose`), this rebuilds the centerline in
//! the raw file's frame to within the accuracy stated in `config/tracks/README.md`.
//!
//! A corner is a maximal stretch where |kappa| exceeds [`CORNER_KAPPA`] with one sign and
//! the heading turns by at least [`CORNER_MIN_TURN`]; it is reported at its peak curvature.

use super::Profile;

/// Curvature above which the track counts as turning [1/m] (radius 200 m).
pub const CORNER_KAPPA: f64 = 1.0 / 200.0;

/// Smallest heading change of a corner \[rad\] (15 degrees).
pub const CORNER_MIN_TURN: f64 = 15.0 * std::f64::consts::PI / 180.0;

/// Poses at samples `ds` apart with curvatures `kappa`, from `start` = (x, y, heading).
pub fn integrate_poses(kappa: &[f64], ds: f64, start: [f64; 3]) -> Vec<[f64; 3]> {
    let mut out = Vec::with_capacity(kappa.len());
    let [mut x, mut y, mut psi] = start;
    if !kappa.is_empty() {
        out.push([x, y, psi]);
    }
    for w in kappa.windows(2) {
        let dpsi = 0.5 * (w[0] + w[1]) * ds;
        let a = 0.5 * dpsi;
        let chord = if a.abs() < 1e-6 {
            ds * (1.0 - a * a / 6.0)
        } else {
            ds * a.sin() / a
        };
        x += chord * (psi + a).cos();
        y += chord * (psi + a).sin();
        psi += dpsi;
        out.push([x, y, psi]);
    }
    out
}

/// The centerline of a closed track in the plane, one pose per profile row.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackMap {
    /// Poses (x \[m\], y \[m\], heading \[rad\]) at the profile rows s = i step, and one more
    /// at s = lap length (the closing pose, equal to the first up to the rebuilding error).
    pub poses: Vec<[f64; 3]>,
    /// Row spacing \[m\].
    pub step: f64,
    /// Lap length \[m\].
    pub lap: f64,
}

impl TrackMap {
    /// Rebuilds the centerline of `profile` from the pose `start` at s = 0.
    pub fn new(profile: &Profile, start: [f64; 3]) -> Self {
        let n = profile.n_rows();
        let k = profile.kappa();
        let mut poses = integrate_poses(k, profile.step(), start);
        // The closing step, at most one row step, back to row 0 at s = lap.
        let h = profile.lap_length() - (n - 1) as f64 * profile.step();
        let tail = integrate_poses(&[k[n - 1], k[0]], h, poses[n - 1]);
        poses.push(tail[1]);
        TrackMap {
            poses,
            step: profile.step(),
            lap: profile.lap_length(),
        }
    }

    /// Pose at track arc length `s` (wrapped modulo the lap): the row at or before s,
    /// advanced along a circular arc with that row's step curvature.
    pub fn pose_at(&self, s: f64) -> [f64; 3] {
        let n = self.poses.len() - 1;
        let u = s.rem_euclid(self.lap);
        let i = ((u / self.step).floor() as usize).min(n - 1);
        let [x0, y0, p0] = self.poses[i];
        let [_, _, p1] = self.poses[i + 1];
        let s_i = i as f64 * self.step;
        let s_j = if i + 1 < n { s_i + self.step } else { self.lap };
        let h = s_j - s_i;
        let d = (u - s_i).clamp(0.0, h);
        let k = if h > 0.0 { (p1 - p0) / h } else { 0.0 };
        let dpsi = k * d;
        let a = 0.5 * dpsi;
        let chord = if a.abs() < 1e-6 { d } else { d * a.sin() / a };
        [
            x0 + chord * (p0 + a).cos(),
            y0 + chord * (p0 + a).sin(),
            p0 + dpsi,
        ]
    }
}

/// Places local poses (from (0, 0, 0)) in the frame where the local origin has pose `origin`.
pub fn place(local: &[[f64; 3]], origin: [f64; 3]) -> Vec<[f64; 3]> {
    let [ox, oy, oh] = origin;
    let (c, s) = (oh.cos(), oh.sin());
    local
        .iter()
        .map(|&[x, y, h]| [ox + c * x - s * y, oy + s * x + c * y, oh + h])
        .collect()
}

/// One corner of a track.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Corner {
    /// Number along the lap from s = 0, starting at 1.
    pub number: usize,
    /// Where |kappa| first exceeds [`CORNER_KAPPA`] \[m\].
    pub s_start: f64,
    /// Where it falls below again \[m\] (past the lap end for a corner across s = 0).
    pub s_end: f64,
    /// Arc length of the peak curvature \[m\] (within [0, lap)).
    pub s_peak: f64,
    /// Peak curvature [1/m], signed (positive: a left turn).
    pub kappa_peak: f64,
    /// Heading change through the corner \[rad\], signed.
    pub turn: f64,
}

impl Corner {
    /// `"left"` or `"right"`.
    pub fn direction(&self) -> &'static str {
        if self.kappa_peak > 0.0 {
            "left"
        } else {
            "right"
        }
    }
}

/// The corners of a closed track, numbered in order of their peak from s = 0.
pub fn corners(profile: &Profile) -> Vec<Corner> {
    let k = profile.kappa();
    let n = k.len();
    let step = profile.step();
    let sign = |v: f64| {
        if v > CORNER_KAPPA {
            1
        } else if v < -CORNER_KAPPA {
            -1
        } else {
            0
        }
    };
    // Start the scan at a straight row so no corner is split by the lap end.
    let Some(first) = (0..n).find(|&i| sign(k[i]) == 0) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    let mut i = 0;
    while i < n {
        let r = (first + i) % n;
        let sg = sign(k[r]);
        if sg == 0 {
            i += 1;
            continue;
        }
        let start = i;
        let (mut peak, mut turn) = (r, 0.0);
        while i < n && sign(k[(first + i) % n]) == sg {
            let q = (first + i) % n;
            if k[q].abs() > k[peak].abs() {
                peak = q;
            }
            turn += k[q] * step;
            i += 1;
        }
        if turn.abs() >= CORNER_MIN_TURN {
            let s0 = ((first + start) % n) as f64 * step;
            out.push(Corner {
                number: 0,
                s_start: s0,
                s_end: s0 + (i - start) as f64 * step,
                s_peak: peak as f64 * step,
                kappa_peak: k[peak],
                turn,
            });
        }
    }
    out.sort_by(|a, b| a.s_peak.total_cmp(&b.s_peak));
    for (j, c) in out.iter_mut().enumerate() {
        c.number = j + 1;
    }
    out
}
