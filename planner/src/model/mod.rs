//! Single-track vehicle model in curvilinear coordinates (paper eq. 1) with coupled-slip
//! Fiala tires, written once, generic over the scalar type so exact derivatives come from
//! the same code.

pub mod dynamics;
pub mod params;
pub mod tire;

pub use dynamics::{spatial_derivatives, time_derivatives, TimeDerivatives};
pub use params::{Limits, ParamError, VehicleParams, GRIP_SCALES};
pub use tire::{saturation, tire_forces, TireForces};

/// Number of states x = [r, V, beta, V_wr, dFz, e, dpsi, s, t] (paper eq. 1).
pub const NX: usize = 9;
/// Number of controls u = [delta, T_comb, T_bf].
pub const NU: usize = 3;

/// Names of the states in x order.
pub const STATE_NAMES: [&str; NX] = ["r", "V", "beta", "V_wr", "dFz", "e", "dpsi", "s", "t"];
/// Names of the controls in u order.
pub const CONTROL_NAMES: [&str; NU] = ["delta", "T_comb", "T_bf"];

/// Index of each state in x.
pub mod ix {
    /// Yaw rate r [rad/s].
    pub const R: usize = 0;
    /// Speed V [m/s].
    pub const V: usize = 1;
    /// Sideslip beta \[rad\].
    pub const BETA: usize = 2;
    /// Rear wheel speed V_wr [m/s].
    pub const VWR: usize = 3;
    /// Load transfer dFz \[N\].
    pub const DFZ: usize = 4;
    /// Lateral error e \[m\].
    pub const E: usize = 5;
    /// Heading error dpsi \[rad\].
    pub const DPSI: usize = 6;
    /// Arc length s \[m\].
    pub const S: usize = 7;
    /// Time t \[s\].
    pub const T: usize = 8;
}

/// Index of each control in u.
pub mod iu {
    /// Steering angle delta \[rad\].
    pub const DELTA: usize = 0;
    /// Combined rear torque T_comb [N m].
    pub const TCOMB: usize = 1;
    /// Front brake torque T_bf [N m].
    pub const TBF: usize = 2;
}
