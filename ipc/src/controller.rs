//! The tracker's controller: feed-forward of the plan's controls plus speed-scheduled LQR
//! feedback on the measured tracking error,
//!
//!   u = u_ref(s + V t_p) - K(V) (y - x_ref(s)),
//!
//! where y is the measured (noisy) state, x_ref(s) the plan's state at the car's arc length
//! s (so the errors are lateral, heading, speed, sideslip, yaw-rate and wheel-speed errors
//! at the same place on the road), K(V) the LQR gain of [`crate::lqr`] at the measured speed,
//! and u_ref the plan's control a preview time t_p ahead: a command takes the actuator
//! latency (transport delay plus steering lag) to reach the tires, by when the car has
//! driven V t_p further. The heading error is wrapped into (-pi, pi], and the lateral error
//! enters as the distance across the planned path, (e - e_ref) cos(dpsi_ref + beta_ref):
//! the gain is designed around straight-line cruise, where the two agree, while a plan that
//! crosses the road at a hairpin's apex at 0.8 rad would otherwise feed back 1.4 times its
//! distance from the car. The feedback acts on
//! steering, rear torque and front brake (the plant clamps the brake to braking). The gain
//! is designed on the error augmented by the steering actuator's error delta_est - delta_ref(s), where
//! delta_est is the actuator's steering as the tracker's model of its own actuator gives it
//! (the commands sent, delayed by the transport delay and filtered by the first-order lag;
//! [`Controller::applied`]). Allocates nothing.

use planner::model::{iu, ix, VehicleParams, NU, NX};

use crate::lqr::{GainSchedule, Weights, NA, NV, NZ, V_INPUTS, Z_STATES};
use crate::msg::Trajectory;
use crate::tracker::{reference, Reference};

/// Position of the lateral error e in the error vector.
const Z_E: usize = 4;
/// Position of the heading error dpsi in the error vector.
const Z_DPSI: usize = 5;
const _: () = assert!(Z_STATES[Z_E] == ix::E && Z_STATES[Z_DPSI] == ix::DPSI);

/// Wraps an angle into (-pi, pi].
fn wrap(a: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    let r = a.rem_euclid(two_pi);
    if r > std::f64::consts::PI {
        r - two_pi
    } else {
        r
    }
}

/// Feed-forward plus LQR feedback.
#[derive(Debug, Clone)]
pub struct Controller {
    sched: GainSchedule,
    preview_s: f64,
    /// Steering commands on their way through the transport delay (ring buffer).
    delayed: Vec<f64>,
    next: usize,
    /// Steering at the road wheels by the actuator model \[rad\].
    delta_est: f64,
    /// Fraction of the gap the first-order lag closes in one control period.
    lag_step: f64,
    /// False until the first command (which, as in the plant, fills the delay line and the
    /// steering state: the car was driving with it).
    primed: bool,
}

/// The tracker's model of its own steering actuator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Actuator {
    /// First-order steering lag \[s\] (0: none).
    pub steering_lag_s: f64,
    /// Transport delay in whole control periods.
    pub delay_steps: usize,
}

impl Controller {
    /// A controller for the model `p` (the planner's vehicle) at control period
    /// `control_dt` \[s\], with feed-forward preview `preview_s` \[s\] and the steering
    /// `actuator` it commands (allocates the delay line once).
    pub fn new(
        p: &VehicleParams,
        control_dt: f64,
        preview_s: f64,
        actuator: Actuator,
    ) -> Result<Self, String> {
        let tau = actuator.steering_lag_s.max(0.0);
        Ok(Self {
            sched: GainSchedule::design(p, &Weights::default(), control_dt, tau)?,
            preview_s: preview_s.max(0.0),
            delayed: vec![0.0; actuator.delay_steps + 1],
            next: 0,
            delta_est: 0.0,
            lag_step: if tau > 0.0 {
                1.0 - (-control_dt / tau).exp()
            } else {
                1.0
            },
            primed: false,
        })
    }

    /// Records the steering command sent this control period (whatever produced it) and
    /// advances the actuator model by one period. Allocates nothing.
    pub fn applied(&mut self, delta_cmd: f64) {
        if !self.primed {
            self.primed = true;
            self.delayed.fill(delta_cmd);
            self.delta_est = delta_cmd;
        }
        let n = self.delayed.len();
        self.delayed[self.next] = delta_cmd;
        self.next = (self.next + 1) % n;
        // The oldest entry is the command that leaves the transport delay now.
        let arriving = self.delayed[self.next];
        self.delta_est += self.lag_step * (arriving - self.delta_est);
    }

    /// Feed-forward preview time \[s\].
    pub fn preview_s(&self) -> f64 {
        self.preview_s
    }

    /// The control for measured state `y` following `plan`, and the plan's reference at
    /// the car's arc length; `None` when the plan does not cover the car. Allocates nothing.
    pub fn control(&self, plan: &Trajectory, y: &[f64; NX]) -> Option<([f64; NU], Reference)> {
        let s_local = y[ix::S] - plan.s_origin;
        let r = reference(plan, s_local)?;
        let ahead = (s_local + y[ix::V].max(0.0) * self.preview_s).min(plan.length());
        let ff = reference(plan, ahead).map_or(r.u, |a| a.u);
        Some((self.feedback(y, &r.x, r.u[iu::DELTA], ff), r))
    }

    /// The feed-forward `ff` corrected by the LQR feedback on the error of `y` against the
    /// reference state `x_ref`, whose steering is `delta_ref`: u = ff - K(V) z_a. Allocates
    /// nothing.
    pub fn feedback(
        &self,
        y: &[f64; NX],
        x_ref: &[f64; NX],
        delta_ref: f64,
        ff: [f64; NU],
    ) -> [f64; NU] {
        let mut z = [0.0; NA];
        for (j, &i) in Z_STATES.iter().enumerate() {
            z[j] = y[i] - x_ref[i];
        }
        z[NZ] = self.delta_est - delta_ref;
        z[Z_DPSI] = wrap(z[Z_DPSI]);
        // The lateral error across the planned path, not along the road normal: the gain
        // is designed around straight-line cruise, where the two agree.
        z[Z_E] *= (x_ref[ix::DPSI] + x_ref[ix::BETA]).cos();
        let k = self.sched.gain(y[ix::V]);
        let mut u = ff;
        for m in 0..NV {
            let mut v = 0.0;
            for j in 0..NA {
                v += k[(m, j)] * z[j];
            }
            u[V_INPUTS[m]] -= v;
        }
        u
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mismatch::Mismatch;
    use crate::msg::HORIZON_N;
    use crate::plant::car::Car;
    use crate::road::ClosedRoad;

    /// A straight plan at speed `v` along the lane centre.
    fn straight_plan(v: f64) -> Trajectory {
        let mut x = [0.0; NX];
        x[ix::V] = v;
        x[ix::VWR] = v;
        Trajectory {
            ds: 2.5,
            x_from: x,
            x: [x; HORIZON_N + 1],
            ..Trajectory::zeroed()
        }
    }

    /// The car of the default mismatch in straight-line cruise at `v` (from the planner's
    /// vehicle `p`, noise seed 5) and a controller for it at 1 kHz with a 70 ms preview.
    fn mismatched_car_and_controller(p: &VehicleParams, v: f64) -> (Car, Controller) {
        let mismatch = Mismatch::from_arg("default").unwrap();
        let car = Car::new(
            p,
            &mismatch,
            crate::plant::Plant::cruise(*p, v).x,
            CONTROL_DT,
            5,
        );
        let actuator = Actuator {
            steering_lag_s: mismatch.actuator.steering_lag_s,
            delay_steps: car.delay_steps(),
        };
        let ctl = Controller::new(p, CONTROL_DT, 0.07, actuator).unwrap();
        (car, ctl)
    }

    /// Control period of the tests \[s\] and plant steps per period.
    const CONTROL_DT: f64 = 0.001;
    const SUBSTEPS: usize = 4;

    /// The lateral feedback acts on the distance across the planned path: 0.4 m off along
    /// the road normal from a plan crossing the road at 0.8 rad (heading 0.6 rad plus
    /// sideslip 0.2 rad) steers as 0.4 cos(0.8) m off a plan along the road does.
    #[test]
    fn the_lateral_feedback_acts_on_the_distance_across_an_inclined_plan() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let p = planner::config::load_vehicle(&root.join("config/vehicles/lc500.toml")).unwrap();
        let (_, ctl) = mismatched_car_and_controller(&p, 20.0);
        let along = straight_plan(20.0).x[0];
        let mut inclined = along;
        inclined[ix::DPSI] = 0.6;
        inclined[ix::BETA] = 0.2;
        let (offset, ff) = (0.4, [0.0; NU]);
        let mut y = inclined;
        y[ix::E] += offset;
        let u_inclined = ctl.feedback(&y, &inclined, 0.0, ff);
        let mut y = along;
        y[ix::E] += offset * 0.8f64.cos();
        let u_along = ctl.feedback(&y, &along, 0.0, ff);
        assert!(u_along[iu::DELTA].abs() > 1e-3, "{u_along:?}");
        for m in 0..NU {
            assert!(
                (u_inclined[m] - u_along[m]).abs() <= 1e-12 * u_along[m].abs().max(1.0),
                "control {m}: {} against {}",
                u_inclined[m],
                u_along[m]
            );
        }
    }

    /// From 0.5 m off a straight plan, with the default mismatch (the controller designed
    /// on the nominal model, fed the noisy state), the car is back within 0.1 m of the plan
    /// after 3 s, without overshooting by more than 0.1 m, and holds the plan's speed.
    #[test]
    fn the_car_returns_to_a_straight_plan_despite_the_default_mismatch() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let p = planner::config::load_vehicle(&root.join("config/vehicles/lc500.toml")).unwrap();
        let road = ClosedRoad::new(vec![(0.0, 0.0)], 10_000.0, -4.0, 4.0);
        let v = 20.0;
        let (mut car, mut ctl) = mismatched_car_and_controller(&p, v);
        car.plant.x[ix::E] = 0.5;
        let plan = straight_plan(v);
        let (mut lowest, mut last_second_max) = (f64::INFINITY, 0.0f64);
        for k in 0..3000 {
            let y = car.measure();
            let (u, _) = ctl.control(&plan, &y).expect("covered");
            ctl.applied(u[iu::DELTA]);
            car.drive(u, &road, SUBSTEPS, CONTROL_DT / SUBSTEPS as f64);
            let e = car.plant.x[ix::E];
            lowest = lowest.min(e);
            if k >= 2000 {
                last_second_max = last_second_max.max(e.abs());
            }
        }
        assert!(
            last_second_max < 0.1,
            "|e| up to {last_second_max} m in the last second"
        );
        assert!(lowest > -0.1, "overshoot to e = {lowest} m");
        assert!((car.plant.x[ix::V] - v).abs() < 0.3, "{:?}", car.plant.x);
    }

    /// A plan braking on the front brake alone at 4 m/s^2 from 30 m/s, driven by the car
    /// of the default mismatch (5 % heavier, so the plan's brake torque alone decelerates
    /// it 5 % less): the feedback holds the plan's speed within 0.075 m/s (0.085 m/s with
    /// the rear torque alone), and the front brake carries part of the correction (it
    /// brakes harder than the plan on average).
    #[test]
    fn a_heavier_car_holds_a_braking_plans_speed_with_the_front_brake() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let p = planner::config::load_vehicle(&root.join("config/vehicles/lc500.toml")).unwrap();
        let road = ClosedRoad::new(vec![(0.0, 0.0)], 10_000.0, -4.0, 4.0);
        let (v0, decel) = (30.0, 4.0);
        let t_bf = -p.m * decel * p.r_w;
        let mut plan = straight_plan(v0);
        for (k, x) in plan.x.iter_mut().enumerate() {
            let v = (v0 * v0 - 2.0 * decel * k as f64 * plan.ds).max(1.0).sqrt();
            x[ix::V] = v;
            x[ix::VWR] = v;
        }
        for u in plan.u.iter_mut() {
            u[iu::TBF] = t_bf;
        }
        let (mut car, mut ctl) = mismatched_car_and_controller(&p, v0);
        let (mut worst, mut brake_sum, mut n) = (0.0f64, 0.0, 0);
        for k in 0..2500 {
            let y = car.measure();
            let (u, r) = ctl.control(&plan, &y).expect("covered");
            ctl.applied(u[iu::DELTA]);
            car.drive(u, &road, SUBSTEPS, CONTROL_DT / SUBSTEPS as f64);
            if k >= 1500 {
                let truth = reference(&plan, car.plant.x[ix::S]).expect("covered");
                worst = worst.max((car.plant.x[ix::V] - truth.x[ix::V]).abs());
                brake_sum += u[iu::TBF] - r.u[iu::TBF];
                n += 1;
            }
        }
        assert!(
            worst < 0.075,
            "speed error up to {worst} m/s in the last second"
        );
        let extra = brake_sum / n as f64;
        assert!(
            extra < -20.0,
            "front brake beyond the plan's: {extra} N m on average"
        );
    }

    /// Behind the default mismatch's 20 ms transport delay (nothing else mismatched, no
    /// noise), the torque feedback holds a straight plan at top speed and beyond without
    /// ringing: the rear torque stays within 100 N m of the plan and the wheel speed within
    /// 0.1 m/s of the car's. (With the wheel speed weighted at 0.2 m/s the torque swings
    /// between its limits from 55 m/s on.)
    #[test]
    fn the_torque_feedback_does_not_ring_at_top_speed_behind_the_transport_delay() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let p = planner::config::load_vehicle(&root.join("config/vehicles/lc500.toml")).unwrap();
        let road = ClosedRoad::new(vec![(0.0, 0.0)], 10_000.0, -8.0, 8.0);
        let mut mismatch = Mismatch::from_arg("none").unwrap();
        mismatch.actuator.transport_delay_s = Mismatch::from_arg("default")
            .unwrap()
            .actuator
            .transport_delay_s;
        for v in [55.0, 70.0] {
            let x0 = crate::plant::Plant::cruise(p, v).x;
            let mut car = Car::new(&p, &mismatch, x0, CONTROL_DT, 5);
            let actuator = Actuator {
                steering_lag_s: 0.0,
                delay_steps: car.delay_steps(),
            };
            assert_eq!(actuator.delay_steps, 20);
            let mut ctl = Controller::new(&p, CONTROL_DT, 0.02, actuator).unwrap();
            car.plant.x[ix::E] = 0.5;
            let plan = straight_plan(v);
            let (mut torque, mut slip) = (0.0f64, 0.0f64);
            for k in 0..3000 {
                let y = car.measure();
                let (u, _) = ctl.control(&plan, &y).expect("covered");
                ctl.applied(u[iu::DELTA]);
                car.drive(u, &road, SUBSTEPS, CONTROL_DT / SUBSTEPS as f64);
                if k >= 2000 {
                    torque = torque.max(u[iu::TCOMB].abs());
                    slip = slip.max((car.plant.x[ix::VWR] - car.plant.x[ix::V]).abs());
                }
            }
            assert!(torque < 100.0, "{v} m/s: rear torque up to {torque} N m");
            assert!(slip < 0.1, "{v} m/s: wheel speed off by up to {slip} m/s");
        }
    }
}
