//! Braking to a stop when there is no plan to follow (the plan is stale, or the planner
//! says no drivable plan exists).
//!
//! The car brakes along the road at a deceleration a: at least `Gains::stop_decel`, more
//! when a curve ahead must be entered slower, at most what the friction circle leaves next
//! to the current curve's lateral acceleration.
//!
//! The brake force m a is split in proportion to the axle loads at that deceleration,
//! F_zf = m g b / L + m a h / L on the front and the rest on the rear, so that both axles
//! use the same share of their grip (the ideal brake distribution); the front share is
//! capped at its brake's torque limit and the rear takes what the front cannot. The front
//! force is open loop (F_xf = T_bf / R_w, R1). The rear force needs a rear slip: the wheel
//! is held at the speed V_x (1 + kappa*) at which the Fiala tire gives that force, kappa*
//! found by bisection at the car's current rear load and slip angle, within 80 % of the
//! sliding slip (99 % of the peak force) so that the wheel does not lock. Holding it at free
//! rolling instead keeps it off the slip the force needs and, at 25 m/s, gives up a sixth
//! of the stop's deceleration.
//!
//! The stop is a reference like a plan's, and the tracker's LQR ([`Controller::feedback`])
//! holds the car on it: the road's kinematic steering L kappa and the two brake torques
//! (the rear's with the wheel's own deceleration, I_w a / R_w) as feed-forward, around the
//! state r = kappa V, beta = 0, the target wheel speed, the held lateral offset and zero
//! heading error, at the car's own speed. Under hard braking the unloaded, braked rear loses
//! cornering stiffness and the yaw mode of a fast car goes unstable; fixed steering gains
//! spun the car from 47 m/s on Montreal's straight, the LQR's yaw-rate and sideslip feedback
//! holds it.

use planner::model::{ix, tire_forces, VehicleParams, NU, NX};

use super::Gains;
use crate::controller::Controller;
use crate::road::ClosedRoad;

/// Share of the rear's full-sliding slip its target slip stays within: the Fiala force
/// there is 1 - 0.2^3 = 99.2 % of its peak, and past sliding the braked wheel locks.
const REAR_SLIP_SHARE: f64 = 0.8;

/// Bisection steps for the rear target slip (the bracket shrinks by 2^-30).
const SLIP_STEPS: usize = 30;

/// Deceleration for braking to a stop [m/s^2]: at least `stop_decel`, more when a curve
/// ahead must be entered slower (looked ahead to the stopping distance), and at most what
/// the friction circle leaves next to the current curve's lateral acceleration.
fn stop_decel(p: &VehicleParams, g: &Gains, x: &[f64; NX], road: &ClosedRoad, kappa: f64) -> f64 {
    let a_grip = 0.8 * p.mu * p.g;
    let v2 = x[ix::V] * x[ix::V];
    let mut need = g.stop_decel;
    let reach = (v2 / (2.0 * g.stop_decel)).min(200.0);
    let mut d = 1.0;
    while d <= reach {
        let k = road.kappa(x[ix::S] + d).abs();
        // Enter a curve with half the grip left for braking in it.
        let v_c2 = 0.75 * a_grip / k.max(1e-9);
        if v2 > v_c2 {
            need = need.max((v2 - v_c2) / (2.0 * d));
        }
        d += 1.0;
    }
    let a_lat = v2 * kappa.abs();
    let avail = (a_grip * a_grip - a_lat * a_lat).max(0.0).sqrt();
    need.min(avail.max(1.0)).min(a_grip)
}

/// Braking to a stop along the road when there is no usable plan: kinematic steering for
/// the road curvature, feedback to `e_hold` and zero heading error, and the stop's brake
/// force split over the axles by their loads, the rear wheel held at the slip its share
/// needs (module docs). Allocates nothing.
pub fn brake_to_stop(
    p: &VehicleParams,
    g: &Gains,
    ctl: &Controller,
    x: &[f64; NX],
    road: &ClosedRoad,
    e_hold: f64,
) -> [f64; NU] {
    let kappa = road.kappa(x[ix::S]);
    let delta = p.l * kappa;
    let a = stop_decel(p, g, x, road, kappa);
    let (f_front, f_rear) = brake_split(p, a);
    // I_w dV_wr/dt = R_w (T_comb - R_w F_xr) with dV_wr/dt = -a and F_xr = -f_rear.
    let t_rear = -f_rear * p.r_w - p.i_w * a / p.r_w;
    let mut x_ref = *x;
    x_ref[ix::R] = kappa * x[ix::V];
    x_ref[ix::BETA] = 0.0;
    x_ref[ix::VWR] = rear_wheel_speed_for(p, x, -f_rear);
    x_ref[ix::E] = e_hold;
    x_ref[ix::DPSI] = 0.0;
    ctl.feedback(x, &x_ref, delta, [delta, t_rear, -f_front * p.r_w])
}

/// Front and rear brake forces [N] (both >= 0) for a deceleration `a`: the total m a in
/// proportion to the axle loads at that deceleration, the front capped at its brake's
/// torque limit.
fn brake_split(p: &VehicleParams, a: f64) -> (f64, f64) {
    let force = p.m * a;
    let front_share = ((p.fz_nom_front() + p.m * a * p.h_cg / p.l) / (p.m * p.g)).clamp(0.0, 1.0);
    let front_max = (-p.t_bf_min / p.r_w).max(0.0);
    let f_front = (front_share * force).clamp(0.0, front_max);
    (f_front, force - f_front)
}

/// Rear wheel speed [m/s] at which the rear tire gives the longitudinal force `fx` (<= 0,
/// braking) at the state's speed, sideslip, yaw rate and load transfer; the slip is kept
/// within [`REAR_SLIP_SHARE`] of the full-sliding slip, so a force past the tire's grip
/// gets the wheel speed of its near-peak force. Free rolling (V_x) when the car is almost
/// stopped or the rear slides sideways already.
fn rear_wheel_speed_for(p: &VehicleParams, x: &[f64; NX], fx: f64) -> f64 {
    let (sb, cb) = x[ix::BETA].sin_cos();
    let vx = x[ix::V] * cb;
    // A car almost stopped gets free rolling (and a NaN speed 0).
    if vx.is_nan() || vx <= 0.1 {
        return vx.max(0.0);
    }
    let tan_alpha = (x[ix::V] * sb - p.b * x[ix::R]) / vx;
    let fmax = p.mu * (p.fz_nom_rear() + x[ix::DFZ]);
    let sigma_sl = REAR_SLIP_SHARE * 3.0 * fmax / p.c_r;
    let room = sigma_sl * sigma_sl - tan_alpha * tan_alpha - p.eps_sigma * p.eps_sigma;
    if fmax.is_nan() || room.is_nan() || fmax <= 0.0 || room <= 0.0 {
        return vx;
    }
    let force_at = |kappa: f64| {
        let mut y = *x;
        y[ix::VWR] = vx * (1.0 + kappa);
        tire_forces(p, &y, &[0.0; NU]).fxr
    };
    // F_xr rises with kappa on [-sqrt(room), 0]: bisect for F_xr(kappa) = fx.
    let (mut lo, mut hi) = (-room.sqrt(), 0.0);
    if force_at(lo) >= fx {
        return vx * (1.0 + lo);
    }
    for _ in 0..SLIP_STEPS {
        let mid = 0.5 * (lo + hi);
        if force_at(mid) < fx {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    vx * (1.0 + 0.5 * (lo + hi))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::controller::Actuator;
    use crate::plant::Plant;
    use crate::road::{RoadArgs, Scenario};
    use planner::model::iu;

    /// The repository root.
    fn root() -> std::path::PathBuf {
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
    }

    /// The shipped oval with the shipped vehicle and solver files.
    fn oval() -> Scenario {
        let root = root();
        Scenario::load(
            &root.join("config/scenarios/oval.toml"),
            &root.join("config/vehicles/lc500.toml"),
            &root.join("config/solver.toml"),
        )
        .expect("oval scenario")
    }

    /// A shipped track with the shipped vehicle and solver files.
    fn track(name: &str) -> Scenario {
        let root = root();
        let args = RoadArgs {
            track: Some(name.into()),
            tracks_index: root.join("config/tracks/tracks.toml"),
            track_profile: None,
            lap_length_m: None,
            segment: None,
            tire_saturation: None,
            obstacle_reach_m: 0.0,
            track_v_max_mps: crate::road::TRACK_SPEEDS_MPS.1,
        };
        Scenario::load_with(
            &root.join("config/scenarios/oval.toml"),
            &args,
            &root.join("config/vehicles/lc500.toml"),
            &root.join("config/solver.toml"),
        )
        .expect("track scenario")
    }

    /// Control period of the tests \[s\] and plant steps per period.
    const CONTROL_DT: f64 = 0.001;
    const SUBSTEPS: usize = 4;

    /// Brakes `plant` to a stop on `sc`'s road with gains `g` and the LQR of the model's
    /// car (no actuator lag or delay), calling `each` after every control period with the
    /// plant and the command; false when the car has not stopped within 100 s.
    fn stop(
        sc: &Scenario,
        g: &Gains,
        plant: &mut Plant,
        mut each: impl FnMut(&Plant, &[f64; NU]),
    ) -> bool {
        let p = sc.spec.vehicle;
        let none = Actuator {
            steering_lag_s: 0.0,
            delay_steps: 0,
        };
        let mut ctl = Controller::new(&p, CONTROL_DT, 0.0, none).expect("LQR design");
        for _ in 0..100_000 {
            if plant.stopped {
                return true;
            }
            let u = brake_to_stop(&p, g, &ctl, &plant.x, &sc.road, 0.0);
            ctl.applied(u[iu::DELTA]);
            for _ in 0..SUBSTEPS {
                plant.step(u, &sc.road, CONTROL_DT / SUBSTEPS as f64);
            }
            each(plant, &u);
        }
        plant.stopped
    }

    /// Braking to a stop from a straight-line cruise at several points of the oval
    /// (straights, curve entries, curves) stops the car inside the lane (+-4 m, 1 m to
    /// spare), for every speed the curve allows (V^2 kappa <= mu g). Without rear slip
    /// control the car spun out of the lane at curve entry.
    #[test]
    fn brake_to_stop_keeps_the_lane() {
        let sc = oval();
        let g = Gains::default();
        for s0 in [
            0.0, 20.0, 40.0, 60.0, 80.0, 100.0, 130.0, 160.0, 200.0, 240.0,
        ] {
            for v0 in [10.0, 15.0, 20.0] {
                let p = &sc.spec.vehicle;
                if v0 * v0 * sc.road.kappa(s0).abs() > p.mu * p.g {
                    continue; // no controller can hold this curve
                }
                let mut plant = Plant::cruise(sc.spec.vehicle, v0);
                plant.x[ix::S] = s0;
                let (mut lo, mut hi) = (0.0f64, 0.0f64);
                let stopped = stop(&sc, &g, &mut plant, |pl, _| {
                    lo = lo.min(pl.x[ix::E]);
                    hi = hi.max(pl.x[ix::E]);
                });
                assert!(stopped, "s0 {s0} v0 {v0}: not stopped");
                assert!(lo > -3.0 && hi < 3.0, "s0 {s0} v0 {v0}: e in [{lo}, {hi}]");
            }
        }
    }

    /// The emergency stop on a straight delivers what it commands to the model's car (no
    /// actuator lag) at every speed: from 25 m/s, each 5 m/s of the stop down to 5 m/s
    /// takes the time 0.8 mu g gives it within 5 %. Slip control around free rolling gave
    /// 6.5 m/s^2 at 25 m/s against 7.85 commanded.
    #[test]
    fn an_emergency_stop_from_25_mps_decelerates_as_commanded() {
        let sc = oval();
        let p = sc.spec.vehicle;
        let g = Gains::default().emergency_stop(&p);
        let want = 0.8 * p.mu * p.g;
        // The oval's first 50 m are straight; the stop from 25 m/s at 0.8 mu g takes 40 m.
        let mut plant = Plant::cruise(p, 25.0);
        let (mut crossed, mut t) = (vec![0.0], 0.0);
        let stopped = stop(&sc, &g, &mut plant, |pl, _| {
            t += CONTROL_DT;
            let next = 25.0 - 5.0 * crossed.len() as f64;
            if next >= 5.0 && pl.x[ix::V] <= next {
                crossed.push(t);
            }
        });
        assert!(stopped, "not stopped");
        assert_eq!(crossed.len(), 5, "crossed 20, 15, 10, 5 m/s at {crossed:?}");
        for (k, w) in crossed.windows(2).enumerate() {
            let got = 5.0 / (w[1] - w[0]);
            let from = 25.0 - 5.0 * k as f64;
            assert!(
                (got - want).abs() < 0.05 * want,
                "{from}..{} m/s: {got:.2} m/s^2 against {want:.2} commanded",
                from - 5.0
            );
        }
    }

    /// The split gives the front its load share at the deceleration, never past its brake's
    /// torque limit, and the two forces add up to m a.
    #[test]
    fn the_brake_split_follows_the_loads_within_the_front_limit() {
        let p = oval().spec.vehicle;
        for a in [1.0, 4.0, 7.85, 12.0] {
            let (f, r) = brake_split(&p, a);
            assert!((f + r - p.m * a).abs() < 1e-9 * p.m * a, "a {a}: {f} + {r}");
            assert!(f * p.r_w <= -p.t_bf_min + 1e-9, "a {a}: front {f} N");
            let share = (p.fz_nom_front() + p.m * a * p.h_cg / p.l) / (p.m * p.g);
            if share * p.m * a * p.r_w < -p.t_bf_min {
                assert!((f - share * p.m * a).abs() < 1e-9 * p.m * a, "a {a}: {f}");
            }
        }
    }

    /// A stale plan at top speed before Montreal's hairpin (kappa 0.065 1/m at s = 2018 m):
    /// the comfort stop from 40 to 55 m/s, 130 to 200 m before the hairpin's entry
    /// (wherever 0.8 mu g can slow the car to the hairpin's speed in time), stays at least
    /// 1 m inside the edges on the model's car (2.9-3.9 m measured). With fixed steering gains the car
    /// spun from 47 m/s on the straight (the rear, unloaded and braked, loses cornering
    /// stiffness and the yaw mode goes unstable); the stop steers with the LQR.
    #[test]
    fn a_stop_from_top_speed_before_montreals_hairpin_keeps_the_lane() {
        let sc = track("Montreal");
        let g = Gains::default();
        let (mut entry, mut kmax) = (0.0, 0.0f64);
        let mut s = 0.0;
        while s < sc.road.lap() {
            if sc.road.kappa(s).abs() > kmax {
                (kmax, entry) = (sc.road.kappa(s).abs(), s);
            }
            s += 1.0;
        }
        while sc.road.kappa(entry - 1.0).abs() > 0.2 * kmax {
            entry -= 1.0;
        }
        for v0 in [40.0, 47.0, 55.0] {
            for before in [130.0, 160.0, 200.0] {
                let p = sc.spec.vehicle;
                // The hairpin's speed as the stop law enters a curve (half the grip left).
                let v_c2 = 0.75 * 0.8 * p.mu * p.g / kmax;
                if v0 * v0 - v_c2 > 2.0 * 0.8 * p.mu * p.g * before {
                    continue; // no stop at 0.8 mu g slows to it in time
                }
                let mut plant = Plant::cruise(p, v0);
                plant.x[ix::S] = entry - before;
                let mut inside = f64::INFINITY;
                let stopped = stop(&sc, &g, &mut plant, |pl, _| {
                    let (lo, hi) = sc.road.edges(pl.x[ix::S]);
                    inside = inside.min((pl.x[ix::E] - lo).min(hi - pl.x[ix::E]));
                });
                assert!(stopped, "{v0} m/s, {before} m before: not stopped");
                assert!(
                    inside > 1.0,
                    "{v0} m/s, {before} m before: {inside:.2} m inside an edge"
                );
            }
        }
    }
}
