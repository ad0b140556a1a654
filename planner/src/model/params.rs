//! Vehicle parameters of the single-track model (paper eq. 1), in SI units.

/// Validated parameters of the single-track vehicle model, tires and actuator limits.
///
/// Built by [`crate::config`] from `config/vehicles/*.toml`; every field is finite and in
/// range once constructed there. Field names follow the vehicle file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VehicleParams {
    /// Vehicle mass m \[kg\].
    pub m: f64,
    /// Wheelbase L \[m\].
    pub l: f64,
    /// CG to front axle a \[m\].
    pub a: f64,
    /// CG to rear axle b \[m\].
    pub b: f64,
    /// CG height h_cg \[m\].
    pub h_cg: f64,
    /// Yaw inertia I_z [kg m^2].
    pub i_z: f64,
    /// Gravity g [m/s^2].
    pub g: f64,
    /// Effective wheel radius R_w \[m\] (both axles).
    pub r_w: f64,
    /// Lumped rear wheel inertia I_w [kg m^2].
    pub i_w: f64,
    /// Front axle cornering stiffness C_f [N/rad].
    pub c_f: f64,
    /// Rear axle slip stiffness C_r [N/rad].
    pub c_r: f64,
    /// Tire-road friction coefficient mu [-].
    pub mu: f64,
    /// Load transfer rate constant c_L [1/s].
    pub c_l: f64,
    /// Steering limit |delta| <= delta_max \[rad\].
    pub delta_max: f64,
    /// Upper bound of the combined rear torque T_comb [N m].
    pub t_comb_max: f64,
    /// Lower bound of the combined rear torque T_comb [N m] (negative: braking).
    pub t_comb_min: f64,
    /// Lower bound of the front brake torque T_bf [N m] (negative).
    pub t_bf_min: f64,
    /// Upper bound of the front brake torque T_bf [N m] (zero: brake only).
    pub t_bf_max: f64,
    /// Lower bound of the rear wheel speed V_wr [m/s] (R10).
    pub v_wr_min: f64,
    /// Steering rate bound [rad/s].
    pub delta_rate_max: f64,
    /// T_comb slew bound [N m/s].
    pub t_comb_rate_max: f64,
    /// T_bf slew bound [N m/s].
    pub t_bf_rate_max: f64,
    /// Slip smoothing epsilon (R6), tan-slip units.
    pub eps_sigma: f64,
    /// Tire saturation constraint epsilon (R5).
    pub eps_sat: f64,
    /// Floor of the de-rated front capacity as a fraction of mu F_zf,nom (R7).
    pub fmax_floor_frac: f64,
}

/// A vehicle parameter outside the domain the model relies on (field named as in the
/// vehicle file).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field} = {value}: {expected}")]
pub struct ParamError {
    /// The vehicle file's field name.
    pub field: &'static str,
    /// The value.
    pub value: f64,
    /// What it must be.
    pub expected: String,
}

/// The limits of a vehicle a planner may change between solves without changing its
/// problem's structure: the tire saturation bound (R5) and the grip (the tire-road friction
/// and the brake torque limits [`VehicleParams::scale_grip`] scales).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Tire saturation bound eps_sat (R5).
    pub eps_sat: f64,
    /// Tire-road friction coefficient mu [-].
    pub mu: f64,
    /// Lower bound of the front brake torque T_bf [N m].
    pub t_bf_min: f64,
    /// Lower bound of the combined rear torque T_comb [N m].
    pub t_comb_min: f64,
}

/// The grip scales a planner may plan with ([`VehicleParams::scale_grip`]).
pub const GRIP_SCALES: std::ops::RangeInclusive<f64> = 0.5..=1.0;

impl VehicleParams {
    /// Scales the grip by `f`: the tire-road friction and the two brake torque limits the
    /// vehicle file derives from it (`T_bf_min` = mu F_zf,static R_w, `T_comb_min` just
    /// above mu F_zr,static R_w). A planner that plans below the limit (f < 1) leaves the
    /// tracker authority to correct errors, in braking as in cornering; scaling only the
    /// friction would leave the plans braking at the full brake torques.
    pub fn scale_grip(&mut self, f: f64) {
        self.mu *= f;
        self.t_bf_min *= f;
        self.t_comb_min *= f;
    }

    /// The limits a planner may change in place ([`Limits`]).
    pub fn limits(&self) -> Limits {
        Limits {
            eps_sat: self.eps_sat,
            mu: self.mu,
            t_bf_min: self.t_bf_min,
            t_comb_min: self.t_comb_min,
        }
    }

    /// These parameters with `limits` in place of their own.
    pub fn with_limits(self, limits: Limits) -> Self {
        Self {
            eps_sat: limits.eps_sat,
            mu: limits.mu,
            t_bf_min: limits.t_bf_min,
            t_comb_min: limits.t_comb_min,
            ..self
        }
    }

    /// Checks the domain every model function relies on (finite values, positive sizes,
    /// stiffnesses and rate limits, ordered torque limits, a + b = L, delta_max < pi/2):
    /// what the vehicle file loader enforces, for parameters that come from elsewhere (a
    /// recording, a message).
    pub fn check(&self) -> Result<(), ParamError> {
        let err = |field, value, expected: &str| ParamError {
            field,
            value,
            expected: expected.into(),
        };
        for (field, v) in [
            ("chassis.m", self.m),
            ("chassis.L", self.l),
            ("chassis.a", self.a),
            ("chassis.b", self.b),
            ("chassis.h_cg", self.h_cg),
            ("chassis.I_z", self.i_z),
            ("chassis.g", self.g),
            ("wheel.R_w", self.r_w),
            ("wheel.I_w", self.i_w),
            ("tire.C_f", self.c_f),
            ("tire.C_r", self.c_r),
            ("tire.mu", self.mu),
            ("load_transfer.c_L", self.c_l),
            ("limits.delta_max", self.delta_max),
            ("limits.delta_rate_max", self.delta_rate_max),
            ("limits.T_comb_rate_max", self.t_comb_rate_max),
            ("limits.T_bf_rate_max", self.t_bf_rate_max),
            ("model.eps_sigma", self.eps_sigma),
            ("model.eps_sat", self.eps_sat),
            ("model.fmax_floor_frac", self.fmax_floor_frac),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(err(field, v, "must be a finite positive number"));
            }
        }
        for (field, v) in [
            ("limits.T_comb_max", self.t_comb_max),
            ("limits.T_comb_min", self.t_comb_min),
            ("limits.T_bf_min", self.t_bf_min),
            ("limits.T_bf_max", self.t_bf_max),
            ("limits.V_wr_min", self.v_wr_min),
        ] {
            if !v.is_finite() {
                return Err(err(field, v, "must be a finite number"));
            }
        }
        if (self.a + self.b - self.l).abs() > 1e-6 * self.l {
            return Err(ParamError {
                field: "chassis.a + chassis.b",
                value: self.a + self.b,
                expected: format!("must equal chassis.L = {} (within 1e-6 relative)", self.l),
            });
        }
        if self.delta_max >= std::f64::consts::FRAC_PI_2 {
            return Err(err(
                "limits.delta_max",
                self.delta_max,
                "must be below pi/2 rad",
            ));
        }
        if self.t_comb_min >= 0.0 {
            return Err(err(
                "limits.T_comb_min",
                self.t_comb_min,
                "must be negative (rear braking)",
            ));
        }
        if self.t_comb_max <= 0.0 {
            return Err(err(
                "limits.T_comb_max",
                self.t_comb_max,
                "must be positive (drive)",
            ));
        }
        if self.t_bf_max > 0.0 {
            return Err(err(
                "limits.T_bf_max",
                self.t_bf_max,
                "must be <= 0 (the front axle only brakes)",
            ));
        }
        if self.t_bf_min >= self.t_bf_max {
            return Err(ParamError {
                field: "limits.T_bf_min",
                value: self.t_bf_min,
                expected: format!("must be below limits.T_bf_max = {}", self.t_bf_max),
            });
        }
        if self.fmax_floor_frac >= 1.0 {
            return Err(err(
                "model.fmax_floor_frac",
                self.fmax_floor_frac,
                "must lie in (0, 1)",
            ));
        }
        Ok(())
    }

    /// Checks the physical ranges a vehicle file is accepted in ([`PHYSICAL_RANGES`]):
    /// wide enough for any road or race car, narrow enough that the model's scaling
    /// (nominal magnitudes of states, controls and residuals) and the equilibrium guess
    /// stay meaningful. The error names the key and gives the accepted range.
    pub fn check_ranges(&self) -> Result<(), ParamError> {
        for &(field, lo, hi, unit) in PHYSICAL_RANGES.iter() {
            let v = self.value_of(field);
            if !(lo..=hi).contains(&v) {
                return Err(ParamError {
                    field,
                    value: v,
                    expected: format!("must lie within the accepted range [{lo:e}, {hi:e}] {unit}"),
                });
            }
        }
        Ok(())
    }

    /// The value of a [`PHYSICAL_RANGES`] key (NaN for any other name).
    fn value_of(&self, field: &str) -> f64 {
        match field {
            "chassis.m" => self.m,
            "chassis.L" => self.l,
            "chassis.h_cg" => self.h_cg,
            "chassis.I_z" => self.i_z,
            "chassis.g" => self.g,
            "wheel.R_w" => self.r_w,
            "wheel.I_w" => self.i_w,
            "tire.C_f" => self.c_f,
            "tire.C_r" => self.c_r,
            "tire.mu" => self.mu,
            "load_transfer.c_L" => self.c_l,
            "limits.T_comb_max" => self.t_comb_max,
            "limits.T_comb_min" => self.t_comb_min,
            "limits.T_bf_min" => self.t_bf_min,
            "limits.V_wr_min" => self.v_wr_min,
            "limits.delta_rate_max" => self.delta_rate_max,
            "limits.T_comb_rate_max" => self.t_comb_rate_max,
            "limits.T_bf_rate_max" => self.t_bf_rate_max,
            "model.eps_sigma" => self.eps_sigma,
            "model.eps_sat" => self.eps_sat,
            _ => f64::NAN,
        }
    }

    /// Static front axle load F_z,nom,f = m g b / L \[N\].
    pub fn fz_nom_front(&self) -> f64 {
        self.m * self.g * self.b / self.l
    }
    /// Static rear axle load F_z,nom,r = m g a / L \[N\].
    pub fn fz_nom_rear(&self) -> f64 {
        self.m * self.g * self.a / self.l
    }
}

/// Accepted range of each scaled vehicle-file key: (key, lowest, highest, unit). Checked
/// by [`VehicleParams::check_ranges`] when a vehicle file is loaded.
pub const PHYSICAL_RANGES: [(&str, f64, f64, &str); 20] = [
    ("chassis.m", 50.0, 1e5, "kg"),
    ("chassis.L", 0.5, 20.0, "m"),
    ("chassis.h_cg", 0.05, 5.0, "m"),
    ("chassis.I_z", 1.0, 1e7, "kg m^2"),
    ("chassis.g", 1.0, 30.0, "m/s^2"),
    ("wheel.R_w", 0.05, 2.0, "m"),
    ("wheel.I_w", 1e-2, 1e4, "kg m^2"),
    ("tire.C_f", 1e3, 1e8, "N/rad"),
    ("tire.C_r", 1e3, 1e8, "N/rad"),
    ("tire.mu", 0.05, 3.0, "-"),
    ("load_transfer.c_L", 0.1, 1e3, "1/s"),
    ("limits.T_comb_max", 1.0, 1e6, "N m"),
    ("limits.T_comb_min", -1e6, -1.0, "N m"),
    ("limits.T_bf_min", -1e6, -1.0, "N m"),
    ("limits.V_wr_min", -1.0, 10.0, "m/s"),
    ("limits.delta_rate_max", 1e-2, 100.0, "rad/s"),
    ("limits.T_comb_rate_max", 1.0, 1e8, "N m/s"),
    ("limits.T_bf_rate_max", 1.0, 1e8, "N m/s"),
    ("model.eps_sigma", 1e-8, 0.1, "-"),
    ("model.eps_sat", 1e-6, 1.0, "-"),
];

/// Test fixture: the Lexus LC 500 values of `vehicles/lc500.toml`, built in code (no file
/// read).
#[doc(hidden)]
pub fn lc500() -> VehicleParams {
    VehicleParams {
        m: 1970.0,
        l: 2.87,
        a: 1.378,
        b: 1.492,
        h_cg: 0.47,
        i_z: 4000.0,
        g: 9.81,
        r_w: 0.35,
        i_w: 3.6,
        c_f: 160000.0,
        c_r: 190000.0,
        mu: 1.0,
        c_l: 10.0,
        delta_max: 0.55,
        t_comb_max: 4500.0,
        t_comb_min: -3500.0,
        t_bf_min: -3500.0,
        t_bf_max: 0.0,
        v_wr_min: 0.0,
        delta_rate_max: 1.0,
        t_comb_rate_max: 20000.0,
        t_bf_rate_max: 30000.0,
        eps_sigma: 1.0e-3,
        eps_sat: 0.01,
        fmax_floor_frac: 0.01,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scaling_the_grip_scales_the_friction_and_the_brake_torques_only() {
        let p = lc500();
        let mut q = p;
        q.scale_grip(0.9);
        assert_eq!(q.mu, 0.9 * p.mu);
        assert_eq!(q.t_bf_min, 0.9 * p.t_bf_min);
        assert_eq!(q.t_comb_min, 0.9 * p.t_comb_min);
        let mut back = q;
        (back.mu, back.t_bf_min, back.t_comb_min) = (p.mu, p.t_bf_min, p.t_comb_min);
        assert_eq!(back, p, "nothing else changes");
        assert_eq!(q.check(), Ok(()));
    }

    #[test]
    fn the_lc500_passes_and_broken_parameters_are_named() {
        assert_eq!(lc500().check(), Ok(()));
        let field = |f: &dyn Fn(&mut VehicleParams)| {
            let mut p = lc500();
            f(&mut p);
            p.check().expect_err("must be refused").field
        };
        assert_eq!(field(&|p| p.m = f64::NAN), "chassis.m");
        assert_eq!(field(&|p| p.mu = -1.0), "tire.mu");
        assert_eq!(field(&|p| p.v_wr_min = f64::INFINITY), "limits.V_wr_min");
        assert_eq!(field(&|p| p.a = 2.0), "chassis.a + chassis.b");
        assert_eq!(field(&|p| p.t_bf_min = 10.0), "limits.T_bf_min");
        assert_eq!(field(&|p| p.delta_max = 2.0), "limits.delta_max");
    }

    #[test]
    fn the_lc500_lies_in_the_physical_ranges_and_extreme_masses_do_not() {
        assert_eq!(lc500().check_ranges(), Ok(()));
        for (key, _, _, _) in PHYSICAL_RANGES {
            assert!(!lc500().value_of(key).is_nan(), "{key} has no value");
        }
        for m in [1e300, 1e-6] {
            let p = VehicleParams { m, ..lc500() };
            let e = p.check_ranges().expect_err("must be refused");
            assert_eq!(e.field, "chassis.m");
            assert!(e.expected.contains("[5e1, 1e5] kg"), "{e}");
        }
    }
}
