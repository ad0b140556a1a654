//! The bounds of a transcription, recomputed in place from the spec: the variable bounds
//! of [`variable_bounds`], the initial-condition rows ([`initial_row_bounds`]), defect rows
//! = 0, front friction rows >= 0 (R9), saturation rows <= eps_sat (R5, scaled) and the
//! control-rate rows ([`rate_row_bounds`]).
//!
//! A fixed start whose rear tire is already past its sliding slip by e_0 > eps_sat (a car
//! measured in a slide) cannot bring it back within one interval: the rear slip follows the
//! sideslip and yaw rate, which take several tenths of a second to turn. The rear rows of
//! the first [`SATURATION_RAMP_NODES`] nodes are therefore bounded by
//! eps_sat + (e_0 - eps_sat) (1 - k / K), from the start's own excess down to eps_sat,
//! as the lane margin ramps in from the car's own position. A start within eps_sat
//! changes no bound.

use super::error::check_node_vectors;
use super::{DefectScheme, Transcription, TranscriptionError};
use crate::model::ix;
use crate::ocp::path_constraints::{
    end_speed_upper, initial_row_bounds, rate_row_bounds, variable_bounds, FRICTION_ROWS,
    INITIAL_ROWS, RATE_ROWS, SATURATION_ROWS,
};
use crate::ocp::scaling::saturation_scale;
use crate::ocp::spec::InitialState;

/// Upper bound of the rear saturation row at node 0 with a fixed initial state (scaled;
/// sigma - sigma_sl <= 100, never active).
const SATURATION_FIXED_X0_BOUND: f64 = 1e3;

/// Nodes K over which the rear saturation bound ramps down from a sliding start's excess
/// to eps_sat (20 m at the closed loop's 2.5 m spacing: a slide of 0.3 rad sideslip at
/// 25 m/s takes several tenths of a second to catch).
pub const SATURATION_RAMP_NODES: usize = 8;

impl<S: DefectScheme, const N: usize> Transcription<S, N> {
    /// Recomputes the variable and row bounds from the spec in place (allocation-free).
    pub(super) fn refresh_bounds(&mut self) {
        let mut x_l = std::mem::take(&mut self.x_l);
        let mut x_u = std::mem::take(&mut self.x_u);
        let mut g_l = std::mem::take(&mut self.g_l);
        let mut g_u = std::mem::take(&mut self.g_u);
        self.compute_bounds(&mut x_l, &mut x_u, &mut g_l, &mut g_u);
        self.x_l = x_l;
        self.x_u = x_u;
        self.g_l = g_l;
        self.g_u = g_u;
    }

    /// Re-uses this instance for a new road of the same size: replaces k_ref, e_min and e_max
    /// at the N + 1 nodes in the spec and updates the bounds. Allocation-free; the
    /// constraint structure is unchanged (the solver reads bounds at the start of each
    /// solve). On a length mismatch nothing is changed.
    pub fn update_road(
        &mut self,
        kappa: &[f64],
        e_min: &[f64],
        e_max: &[f64],
    ) -> Result<(), TranscriptionError> {
        self.write_road(kappa, e_min, e_max)?;
        self.refresh_bounds();
        Ok(())
    }

    /// [`Self::update_road`] and [`Self::set_initial`] in one bounds update: a replanning
    /// cycle changes both, and the bounds depend on both (the lane rows on the road, the
    /// initial and saturation rows on the start). On a length mismatch nothing is changed.
    pub fn update_window(
        &mut self,
        kappa: &[f64],
        e_min: &[f64],
        e_max: &[f64],
        initial: InitialState,
    ) -> Result<(), TranscriptionError> {
        self.write_road(kappa, e_min, e_max)?;
        self.spec.initial = initial;
        self.refresh_bounds();
        Ok(())
    }

    /// Replaces the soft lane bounds ([`crate::ocp::SoftLane`]) at the N + 1 nodes of a
    /// spec whose soft lane is on (its weight fixed at construction). Allocation-free; on a
    /// length mismatch, or with the soft lane off, nothing is changed.
    pub fn update_soft_lane(
        &mut self,
        e_min: &[f64],
        e_max: &[f64],
    ) -> Result<(), TranscriptionError> {
        check_node_vectors::<N, _>([("soft e_min", e_min.len()), ("soft e_max", e_max.len())])?;
        let soft = &mut self.spec.soft_lane;
        if !soft.is_on() {
            return Err(TranscriptionError::SoftLaneOff);
        }
        soft.e_min.copy_from_slice(e_min);
        soft.e_max.copy_from_slice(e_max);
        Ok(())
    }

    /// Sets the speed bound of the last node ([`crate::ocp::OcpSpec::v_end_max`]) and
    /// updates that one variable bound in place (allocation-free; the other bounds do not
    /// depend on it). A bound that does not exceed v_min (or NaN) changes nothing and is
    /// refused.
    pub fn set_end_speed_cap(&mut self, v_end_max: f64) -> Result<(), TranscriptionError> {
        if v_end_max.is_nan() || v_end_max <= self.spec.v_min {
            return Err(TranscriptionError::EndSpeed {
                value: v_end_max,
                v_min: self.spec.v_min,
            });
        }
        self.spec.v_end_max = v_end_max;
        let i = self.layout.x(self.layout.n_intervals, ix::V);
        self.x_u[i] = end_speed_upper(&self.spec);
        Ok(())
    }

    /// Copies the road into the spec after checking the lengths (nothing changes on a
    /// mismatch); the bounds are left to the caller.
    fn write_road(
        &mut self,
        kappa: &[f64],
        e_min: &[f64],
        e_max: &[f64],
    ) -> Result<(), TranscriptionError> {
        check_node_vectors::<N, _>([
            ("kappa", kappa.len()),
            ("e_min", e_min.len()),
            ("e_max", e_max.len()),
        ])?;
        self.spec.kappa.copy_from_slice(kappa);
        self.spec.e_min.copy_from_slice(e_min);
        self.spec.e_max.copy_from_slice(e_max);
        Ok(())
    }

    /// Sets the tire saturation bound eps_sat (R5) of the spec's vehicle and updates the
    /// row bounds in place (allocation-free; the constraint structure is unchanged). A
    /// value the vehicle check refuses changes nothing.
    pub fn set_saturation_bound(&mut self, eps_sat: f64) -> Result<(), crate::model::ParamError> {
        let limits = crate::model::Limits {
            eps_sat,
            ..self.spec.vehicle.limits()
        };
        self.set_limits(limits)
    }

    /// Sets the spec vehicle's [`crate::model::Limits`] (saturation bound and grip) and
    /// updates the bounds in place (allocation-free; the constraint structure is unchanged,
    /// and the model functions read the friction from the spec at every evaluation).
    /// Limits the vehicle check refuses change nothing.
    pub fn set_limits(
        &mut self,
        limits: crate::model::Limits,
    ) -> Result<(), crate::model::ParamError> {
        let vehicle = self.spec.vehicle.with_limits(limits);
        vehicle.check()?;
        self.spec.vehicle = vehicle;
        self.refresh_bounds();
        Ok(())
    }

    /// Switches the initial-state treatment (Free or Fixed(x0)) without changing the
    /// constraint structure: all nine initial-condition rows always exist and only their
    /// bounds change (see [`initial_row_bounds`]). Allocation-free.
    pub fn set_initial(&mut self, initial: InitialState) {
        self.spec.initial = initial;
        self.refresh_bounds();
    }

    /// Writes the variable bounds and the row bounds of the spec.
    fn compute_bounds(&self, x_l: &mut [f64], x_u: &mut [f64], g_l: &mut [f64], g_u: &mut [f64]) {
        let p = &self.spec.vehicle;
        let rear_start = self.rear_start_excess();
        variable_bounds(&self.layout, &self.spec, x_l, x_u);
        for (r, &i) in INITIAL_ROWS.iter().enumerate() {
            (g_l[r], g_u[r]) = initial_row_bounds(&self.spec, i);
        }
        for (k, st) in self.stages.iter().enumerate() {
            g_l[st.row_defect..st.row_defect + S::ROWS].fill(0.0);
            g_u[st.row_defect..st.row_defect + S::ROWS].fill(0.0);
            g_l[st.row_friction..st.row_friction + FRICTION_ROWS].fill(0.0);
            g_u[st.row_friction..st.row_friction + FRICTION_ROWS].fill(f64::INFINITY);
            if st.sat_points > 0 {
                let sat = st.row_sat..st.row_sat + st.sat_points * SATURATION_ROWS;
                g_l[sat.clone()].fill(f64::NEG_INFINITY);
                g_u[sat].fill(p.eps_sat / saturation_scale(&self.spec.initial));
                // With a fixed (measured) x_0 the rear slip at node 0 depends on x_0 alone: a
                // car that is already sliding would make the problem infeasible whatever the
                // controls. That row gets a bound it never reaches (the front row stays: the
                // steering controls its slip).
                if k == 0 && matches!(self.spec.initial, InitialState::Fixed(_)) {
                    g_u[st.row_sat + 1] = SATURATION_FIXED_X0_BOUND;
                } else if k < SATURATION_RAMP_NODES && rear_start > p.eps_sat {
                    let w = 1.0 - k as f64 / SATURATION_RAMP_NODES as f64;
                    g_u[st.row_sat + 1] = (p.eps_sat + (rear_start - p.eps_sat) * w)
                        / saturation_scale(&self.spec.initial);
                }
            }
            if k >= 1 {
                rate_row_bounds(
                    &mut g_l[st.row_rate..st.row_rate + RATE_ROWS],
                    &mut g_u[st.row_rate..st.row_rate + RATE_ROWS],
                );
            }
        }
    }

    /// The rear tire's sigma - sigma_sl at a fixed start (it depends on the state alone;
    /// -inf for a free start or a start the model cannot evaluate).
    fn rear_start_excess(&self) -> f64 {
        match &self.spec.initial {
            InitialState::Fixed(x0) => {
                let e =
                    crate::model::saturation(&self.spec.vehicle, x0, &[0.0; crate::model::NU])[1];
                if e.is_finite() {
                    e
                } else {
                    f64::NEG_INFINITY
                }
            }
            InitialState::Free => f64::NEG_INFINITY,
        }
    }
}
