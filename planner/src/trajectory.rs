//! The planner's output: states and controls on the s grid in physical units, with the
//! road they were planned on; CSV export.

use std::io::Write;
use std::path::Path;

use crate::io::{write_atomic, WriteError};
use crate::model::{iu, ix, NU, NX};

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
}

/// Column names of the CSV written by [`Trajectory::write_csv`].
pub const CSV_COLUMNS: [&str; 17] = [
    "k", "s_grid", "kappa", "r", "V", "beta", "V_wr", "dFz", "e", "dpsi", "s", "t", "delta",
    "T_comb", "T_bf", "e_min", "e_max",
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
            writeln!(w, ",{:.6},{:.6}", self.e_min[k], self.e_max[k])?;
        }
        Ok(())
    }
}
