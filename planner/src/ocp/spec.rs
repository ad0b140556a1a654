//! The problem data of one OCP instance (paper eq. 3): road sampled at the nodes, bounds,
//! options and the vehicle. Built from config + track; consumed by a transcription.

use crate::model::{VehicleParams, NX};

/// How the initial state x_0 is treated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum InitialState {
    /// Paper convention: s_0 = t_0 = dpsi_0 = 0 fixed, e_min <= e_0 <= e_max, rest free.
    Free,
    /// Every state of x_0 given (collision avoidance); s_0 and t_0 should be 0.
    Fixed([f64; NX]),
}

/// One minimum-time OCP instance on an s grid of `n_intervals` equal steps.
///
/// Node k sits at s_k = k * ds; every per-node vector has `n_intervals + 1` entries.
#[derive(Debug, Clone, PartialEq)]
pub struct OcpSpec {
    /// Human-readable name (scenario or segment).
    pub name: String,
    /// Number of intervals N (states x_0..x_N, controls u_0..u_{N-1}).
    pub n_intervals: usize,
    /// Horizon length [m]; s_N = length.
    pub length: f64,
    /// Reference curvature k_ref(s_k) at every node [1/m] (R8: evaluated at the grid).
    pub kappa: Vec<f64>,
    /// Right lateral bound e_min(s_k) at every node [m] (obstacles already applied).
    pub e_min: Vec<f64>,
    /// Left lateral bound e_max(s_k) at every node [m] (obstacles already applied).
    pub e_max: Vec<f64>,
    /// Speed lower bound [m/s].
    pub v_min: f64,
    /// Speed upper bound [m/s].
    pub v_max: f64,
    /// Add the tire saturation constraints (R5) when true.
    pub enforce_tire_saturation: bool,
    /// Initial state treatment.
    pub initial: InitialState,
    /// Vehicle parameters.
    pub vehicle: VehicleParams,
}

impl OcpSpec {
    /// Node spacing ds = length / N [m].
    pub fn ds(&self) -> f64 {
        self.length / self.n_intervals as f64
    }
}
