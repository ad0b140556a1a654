//! The planner's output: states and controls on the s grid in physical units, with the
//! road they were planned on; CSV export.
//!
//! The states live in the road's curvilinear frame (s along the reference path, e to its
//! left). The reference path's poses follow from heading' = kappa
//! ([`crate::track::map::integrate_poses`]) from the horizon's origin: the track pose at
//! its start for a stretch of a closed track ([`TrackPlacement`]), else (0, 0, 0). The car's
//! position is the path point moved by e along the left normal, and its yaw is the path
//! heading plus dpsi - beta.

use std::io::Write;
use std::path::Path;

use crate::io::{write_atomic, WriteError};
use crate::model::{iu, ix, NU, NX};
use crate::track::map::{integrate_poses, place};

/// Where a horizon lies on a closed track.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackPlacement {
    /// Track name.
    pub track: String,
    /// Track arc length of node 0 \[m\].
    pub s_start: f64,
    /// Lap length \[m\] (track s wraps modulo it).
    pub lap_length: f64,
    /// Pose of the track's centerline at node 0 in the track's frame: x \[m\], y \[m\],
    /// heading \[rad\].
    pub origin: [f64; 3],
}

/// A planned trajectory: N + 1 states and N controls (physical units) on s_k = k ds.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    /// Name of the scenario or segment.
    pub name: String,
    /// Node spacing ds \[m\].
    pub ds: f64,
    /// States x_0..x_N in the order of [`crate::model::ix`].
    pub x: Vec<[f64; NX]>,
    /// Controls u_0..u_{N-1} in the order of [`crate::model::iu`].
    pub u: Vec<[f64; NU]>,
    /// k_ref at every node [1/m].
    pub kappa: Vec<f64>,
    /// Right lane bound at every node \[m\].
    pub e_min: Vec<f64>,
    /// Left lane bound at every node \[m\].
    pub e_max: Vec<f64>,
    /// Right bound of the lane without obstacles at every node \[m\]: where `e_min` is
    /// tighter, an obstacle (a bounds override) blocks the road.
    pub lane_e_min: Vec<f64>,
    /// Left bound of the lane without obstacles at every node \[m\].
    pub lane_e_max: Vec<f64>,
    /// Where the horizon lies on a closed track, if it was cut from one.
    pub placement: Option<TrackPlacement>,
}

/// Column names of the CSV written by [`Trajectory::write_csv`].
///
/// `s_track` is the track arc length of the node (wrapped modulo the lap; `s_grid` off a
/// track); `x`, `y` \[m\] and `heading` \[rad\] are the car's CG position and yaw in the
/// track's frame (the raw centerline file's), or in the road's own frame off a track.
pub const CSV_COLUMNS: [&str; 21] = [
    "k", "s_grid", "kappa", "r", "V", "beta", "V_wr", "dFz", "e", "dpsi", "s", "t", "delta",
    "T_comb", "T_bf", "e_min", "e_max", "s_track", "x", "y", "heading",
];

impl Trajectory {
    /// Number of intervals N.
    pub fn n_intervals(&self) -> usize {
        self.u.len()
    }

    /// Final time t_N \[s\] (the objective, plus the steering-slew term when it is weighted).
    pub fn t_final(&self) -> f64 {
        self.x.last().map_or(f64::NAN, |x| x[ix::T])
    }

    /// Largest |beta| over the nodes \[rad\].
    pub fn max_abs_beta(&self) -> f64 {
        self.x.iter().fold(0.0, |a, x| a.max(x[ix::BETA].abs()))
    }

    /// Poses (x, y, heading) of the reference path at the nodes, in the track's frame when
    /// placed on a track, else from (0, 0, 0).
    pub fn reference_poses(&self) -> Vec<[f64; 3]> {
        let local = integrate_poses(&self.kappa, self.ds, [0.0; 3]);
        match &self.placement {
            Some(p) => place(&local, p.origin),
            None => local,
        }
    }

    /// Track arc length of node `k` (`k ds` off a track).
    pub fn s_track(&self, k: usize) -> f64 {
        let s = k as f64 * self.ds;
        match &self.placement {
            Some(p) => (p.s_start + s).rem_euclid(p.lap_length),
            None => s,
        }
    }

    /// The car's CG position and yaw at the nodes: (x, y, heading) in the frame of
    /// [`Trajectory::reference_poses`].
    pub fn car_poses(&self) -> Vec<[f64; 3]> {
        self.reference_poses()
            .iter()
            .zip(&self.x)
            .map(|(&[x, y, h], st)| {
                let e = st[ix::E];
                [
                    x - e * h.sin(),
                    y + e * h.cos(),
                    h + st[ix::DPSI] - st[ix::BETA],
                ]
            })
            .collect()
    }

    /// Control applied on [s_k, s_k+1); node N repeats u_{N-1} (as the reference CSVs do).
    pub fn control_at(&self, k: usize) -> [f64; NU] {
        self.u[k.min(self.u.len().saturating_sub(1))]
    }

    /// Writes one row per node (see [`CSV_COLUMNS`]), atomically
    /// ([`crate::io::write_atomic`]): `path` holds the whole table or is left as it was.
    pub fn write_csv(&self, path: &Path) -> Result<(), WriteError> {
        write_atomic(path, |w| self.write_rows(w))
    }

    /// The header and one row per node.
    fn write_rows(&self, w: &mut impl Write) -> std::io::Result<()> {
        writeln!(w, "{}", CSV_COLUMNS.join(","))?;
        let poses = self.car_poses();
        for (k, x) in self.x.iter().enumerate() {
            let u = self.control_at(k);
            write!(w, "{},{:.6},{:.8}", k, k as f64 * self.ds, self.kappa[k])?;
            for v in x {
                write!(w, ",{v:.10e}")?;
            }
            write!(
                w,
                ",{:.10e},{:.10e},{:.10e}",
                u[iu::DELTA],
                u[iu::TCOMB],
                u[iu::TBF]
            )?;
            write!(w, ",{:.6},{:.6}", self.e_min[k], self.e_max[k])?;
            let [px, py, ph] = poses.get(k).copied().unwrap_or([f64::NAN; 3]);
            writeln!(w, ",{:.6},{px:.6},{py:.6},{ph:.8}", self.s_track(k))?;
        }
        Ok(())
    }
}
