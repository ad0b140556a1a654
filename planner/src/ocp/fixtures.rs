//! Test fixtures built in code: the oval's spec without reading its scenario file, and a
//! reader for the committed peer reference solution.

use super::spec::{InitialState, OcpSpec};
use crate::model::params::lc500;

/// Breakpoints [s_start, kappa] of the oval's piecewise-constant curvature
/// (`scenarios/oval.toml`; right-continuous, the last piece runs to the end).
pub const OVAL_KAPPA_PIECES: [(f64, f64); 5] = [
    (0.0, 0.0),
    (50.0, 0.04),
    (128.5398163, 0.0),
    (178.5398163, 0.04),
    (257.0796327, 0.0),
];

/// Oval curvature k_ref(s) (right-continuous pieces).
pub fn oval_kappa(s: f64) -> f64 {
    let mut kappa = 0.0;
    for &(s0, k) in OVAL_KAPPA_PIECES.iter() {
        if s >= s0 {
            kappa = k;
        }
    }
    kappa
}

/// Test fixture: the oval scenario (N = 100, 260 m, |e| <= 4 m, V in [5, 40] m/s, tire
/// saturation on, free initial state) with the LC 500, and the paper's pure minimum-time
/// objective (no steering-slew term; `config/scenarios/oval.toml` has one).
#[doc(hidden)]
pub fn oval_spec() -> OcpSpec {
    let n = 100;
    let length = 260.0;
    let ds = length / n as f64;
    OcpSpec {
        name: "oval".to_string(),
        n_intervals: n,
        length,
        kappa: (0..=n).map(|k| oval_kappa(k as f64 * ds)).collect(),
        e_min: vec![-4.0; n + 1],
        e_max: vec![4.0; n + 1],
        v_min: 5.0,
        v_max: 40.0,
        enforce_tire_saturation: true,
        saturation_at_end: false,
        steering_slew_weight: 0.0,
        v_end_max: f64::INFINITY,
        soft_lane: crate::ocp::SoftLane::OFF,
        initial: InitialState::Free,
        vehicle: lc500(),
    }
}

/// A trajectory read from a reference CSV (physical units), with every column by name.
#[doc(hidden)]
#[derive(Debug, Clone)]
pub struct ReferenceCsv {
    /// Column names of the header row.
    pub header: Vec<String>,
    /// One row of values per node.
    pub rows: Vec<Vec<f64>>,
}

impl ReferenceCsv {
    /// Reads a CSV with `#` comment lines, a header row and numeric rows.
    pub fn load(path: &std::path::Path) -> std::io::Result<Self> {
        let text = std::fs::read_to_string(path)?;
        let mut lines = text
            .lines()
            .filter(|l| !l.starts_with('#') && !l.trim().is_empty());
        let header: Vec<String> = lines
            .next()
            .unwrap_or_default()
            .split(',')
            .map(|s| s.trim().to_string())
            .collect();
        let rows = lines
            .map(|l| {
                l.split(',')
                    .map(|v| v.trim().parse().unwrap_or(f64::NAN))
                    .collect()
            })
            .collect();
        Ok(Self { header, rows })
    }

    /// Column `name` (panics if absent).
    pub fn col(&self, name: &str) -> Vec<f64> {
        let i = self
            .header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("column {name} missing"));
        self.rows.iter().map(|r| r[i]).collect()
    }

    /// States at every row and controls at rows 0..len-1 (the last row repeats u_{N-1}).
    pub fn trajectory(&self) -> (Vec<[f64; crate::model::NX]>, Vec<[f64; crate::model::NU]>) {
        use crate::model::{CONTROL_NAMES, STATE_NAMES};
        let xc: Vec<Vec<f64>> = STATE_NAMES.iter().map(|n| self.col(n)).collect();
        let uc: Vec<Vec<f64>> = CONTROL_NAMES.iter().map(|n| self.col(n)).collect();
        let n = self.rows.len();
        let xs = (0..n).map(|k| std::array::from_fn(|i| xc[i][k])).collect();
        let us = (0..n - 1)
            .map(|k| std::array::from_fn(|j| uc[j][k]))
            .collect();
        (xs, us)
    }
}

/// Path of the committed copy of the peer reference solution on the oval.
#[doc(hidden)]
pub fn oval_reference_path() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/reference/oval_ie_ipopt.csv")
}
