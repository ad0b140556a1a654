//! Actuator dynamics between the tracker's command and the plant: a transport delay of
//! D control periods on all controls (u_applied(t) = u_cmd(t - D T_c)), then a first-order
//! lag on the steering angle, delta_dot = (delta_cmd - delta) / tau, integrated exactly
//! for a command held over the step: delta <- delta + (1 - exp(-dt / tau)) (delta_cmd - delta).
//! The torques pass the delay only. The delay line is a ring buffer sized once at
//! construction: stepping allocates nothing.

use planner::model::{iu, NU};

/// Delay line plus steering lag.
#[derive(Debug, Clone)]
pub struct Actuator {
    /// The last D commands, oldest at `head` (empty: no delay).
    ring: Box<[[f64; NU]]>,
    head: usize,
    tau: f64,
    /// Delayed command being applied (held over the control period).
    delayed: [f64; NU],
    /// Steering angle the wheels have reached \[rad\].
    delta: f64,
    primed: bool,
}

impl Actuator {
    /// An actuator with a delay of `delay_steps` control periods and a steering lag of
    /// time constant `tau` \[s\] (0: none).
    pub fn new(delay_steps: usize, tau: f64) -> Self {
        Self {
            ring: vec![[0.0; NU]; delay_steps].into_boxed_slice(),
            head: 0,
            tau: tau.max(0.0),
            delayed: [0.0; NU],
            delta: 0.0,
            primed: false,
        }
    }

    /// Delay in control periods.
    pub fn delay_steps(&self) -> usize {
        self.ring.len()
    }

    /// Takes the command of this control period; the command of D periods before becomes
    /// the one applied. The first command also fills the delay line and the steering state
    /// (the car was driving with it). Allocates nothing.
    pub fn command(&mut self, u: [f64; NU]) {
        if !self.primed {
            self.primed = true;
            self.ring.fill(u);
            self.delta = u[iu::DELTA];
        }
        if self.ring.is_empty() {
            self.delayed = u;
            return;
        }
        self.delayed = self.ring[self.head];
        self.ring[self.head] = u;
        self.head = (self.head + 1) % self.ring.len();
    }

    /// Advances the steering lag by `dt` \[s\] and returns the control acting on the plant
    /// over that step (the lagged steering at the end of the step, the delayed torques).
    pub fn apply(&mut self, dt: f64) -> [f64; NU] {
        let cmd = self.delayed[iu::DELTA];
        self.delta = if self.tau > 0.0 {
            self.delta + (1.0 - (-dt / self.tau).exp()) * (cmd - self.delta)
        } else {
            cmd
        };
        let mut u = self.delayed;
        u[iu::DELTA] = self.delta;
        u
    }

    /// Steering angle the wheels have reached \[rad\].
    pub fn steering(&self) -> f64 {
        self.delta
    }

    /// The controls acting on the plant now: the steering the wheels have reached and the
    /// delayed torques. `None` before the first command.
    pub fn acting(&self) -> Option<[f64; NU]> {
        let mut u = self.delayed;
        u[iu::DELTA] = self.delta;
        self.primed.then_some(u)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A steering step of 0.1 rad at t = 0 reaches the wheels as the first-order response
    /// 0.1 (1 - exp(-(t - 0.02) / 0.05)) from t = 0.02 s on, and not at all before; the
    /// torque steps arrive 0.02 s late, unfiltered.
    #[test]
    fn a_step_arrives_as_the_first_order_response_shifted_by_the_delay() {
        let (control_dt, substeps) = (0.001, 4);
        let dt = control_dt / substeps as f64;
        let (delay, tau) = (0.02, 0.05);
        let mut a = Actuator::new((delay / control_dt) as usize, tau);
        a.command([0.0; NU]);
        let step = [0.1, 500.0, -200.0];
        let mut t = 0.0;
        let mut worst: f64 = 0.0;
        for k in 0..300 {
            a.command(step);
            for _ in 0..substeps {
                let u = a.apply(dt);
                t += dt;
                let lagged = t - delay;
                let want = if lagged <= 1e-12 {
                    0.0
                } else {
                    0.1 * (1.0 - (-lagged / tau).exp())
                };
                worst = worst.max((u[iu::DELTA] - want).abs());
                let torques_arrived = k >= 20;
                assert_eq!(u[iu::TCOMB], if torques_arrived { 500.0 } else { 0.0 });
                assert_eq!(u[iu::TBF], if torques_arrived { -200.0 } else { 0.0 });
            }
        }
        assert!(worst < 1e-12, "worst deviation {worst} rad");
        // After 6 time constants the steering has all but settled.
        assert!((a.steering() - 0.1).abs() < 0.1 * (-5.0f64).exp());
    }

    #[test]
    fn without_delay_and_lag_the_command_passes_unchanged() {
        let mut a = Actuator::new(0, 0.0);
        for u in [[0.01, 10.0, -5.0], [-0.02, -300.0, 0.0]] {
            a.command(u);
            assert_eq!(a.apply(0.00025), u);
        }
    }
}
