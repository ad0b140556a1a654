//! Physical sanity tests of the single-track model and the Fiala tire model.

mod common;

use common::{random_control, random_state, Rng};
use planner::model::params::lc500;
use planner::model::tire::{fiala_total, smooth_floor};
use planner::model::{ix, spatial_derivatives, time_derivatives, tire_forces, NU, NX};

#[test]
fn straight_line_steady_state_has_zero_rates() {
    let p = lc500();
    for v in [5.0, 15.0, 35.0] {
        let x: [f64; NX] = [0.0, v, 0.0, v, 0.0, 0.0, 0.0, 12.0, 3.0];
        let u: [f64; NU] = [0.0; NU];
        let td = time_derivatives(&p, &x, &u, 0.0);
        for i in 0..ix::E + 2 {
            assert!(td.dxdt[i].abs() < 1e-9, "state {i}: rate {}", td.dxdt[i]);
        }
        assert!((td.sdot - v).abs() < 1e-12);
        let f = spatial_derivatives(&p, &x, &u, 0.0);
        assert!((f[ix::S] - 1.0).abs() < 1e-15);
        assert!((f[ix::T] - 1.0 / v).abs() < 1e-15);
    }
    // A perturbation away from equilibrium must show up (the test can fail).
    let x = [0.0, 20.0, 0.0, 21.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let td = time_derivatives(&p, &x, &[0.0; NU], 0.0);
    assert!(td.dxdt[ix::V] > 1.0, "rear wheel slip must accelerate");
}

#[test]
fn mirrored_steering_mirrors_lateral_rates() {
    let p = lc500();
    let mut rng = Rng(3);
    for _ in 0..200 {
        let x = random_state(&mut rng);
        let u = random_control(&mut rng);
        let mut xm = x;
        xm[ix::R] = -x[ix::R];
        xm[ix::BETA] = -x[ix::BETA];
        xm[ix::E] = -x[ix::E];
        xm[ix::DPSI] = -x[ix::DPSI];
        let mut um = u;
        um[0] = -u[0];
        let a = time_derivatives(&p, &x, &u, 0.0).dxdt;
        let b = time_derivatives(&p, &xm, &um, 0.0).dxdt;
        let tol = |v: f64| 1e-9 * (1.0 + v.abs());
        for i in [ix::R, ix::BETA, ix::E, ix::DPSI] {
            assert!(
                (a[i] + b[i]).abs() < tol(a[i]),
                "state {i} not odd: {} vs {}",
                a[i],
                b[i]
            );
        }
        for i in [ix::V, ix::VWR, ix::DFZ] {
            assert!(
                (a[i] - b[i]).abs() < tol(a[i]),
                "state {i} not even: {} vs {}",
                a[i],
                b[i]
            );
        }
    }
}

#[test]
fn steering_left_yaws_left() {
    let p = lc500();
    let x = [0.0, 20.0, 0.0, 20.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let td = time_derivatives(&p, &x, &[0.05, 0.0, 0.0], 0.0);
    assert!(td.dxdt[ix::R] > 0.0);
    assert!(td.tires.fyf > 0.0);
}

#[test]
fn tire_forces_stay_inside_friction_limit() {
    let p = lc500();
    let mut rng = Rng(5);
    let mut n_sat = 0;
    let mut n_front = 0;
    for _ in 0..20000 {
        let x: [f64; NX] = random_state(&mut rng);
        let u = random_control(&mut rng);
        let t = tire_forces(&p, &x, &u);
        let tol = 1e-9 * t.fzr.abs() + 1e-9;
        let rear = t.fxr.hypot(t.fyr);
        assert!(
            rear <= p.mu * t.fzr + tol,
            "rear {rear} > mu Fzr {}",
            p.mu * t.fzr
        );
        // Front: the lateral force is limited by the de-rated capacity. The total obeys
        // mu F_zf only where the R9 constraint |T_bf|/R_w <= mu F_zf holds (the model applies
        // F_xf open-loop, R1); there the R7 floor adds at most 1.21 q_min to |F_f|^2
        // (q - d <= (1 + sqrt 2)/2 q_min for d >= 0), i.e. < 1 N here.
        assert!(t.fyf.abs() <= t.fmax_f + 1e-9);
        if t.fxf.abs() <= p.mu * t.fzf {
            let q_min = (p.fmax_floor_frac * p.mu * p.fz_nom_front()).powi(2);
            let front2 = t.fxf * t.fxf + t.fyf * t.fyf;
            let lim2 = (p.mu * t.fzf).powi(2);
            assert!(
                front2 <= lim2 + 1.21 * q_min,
                "front {} > mu Fzf {}",
                front2.sqrt(),
                lim2.sqrt()
            );
            n_front += 1;
        }
        if t.sigma_r >= t.sigma_sl_r {
            n_sat += 1;
        }
    }
    assert!(n_sat > 100, "sample should include sliding tires ({n_sat})");
    assert!(n_front > 10000, "too few R9-feasible samples ({n_front})");
}

#[test]
fn fiala_is_c2_at_full_sliding() {
    let (c, fmax) = (190000.0, 9000.0);
    let s_sl = 3.0 * fmax / c;
    let f = |s: f64| fiala_total(c, s, fmax);
    let h = 1e-5 * s_sl;
    let (below, above) = (s_sl - 1e-12, s_sl + 1e-12);
    assert!((f(below) - f(above)).abs() < 1e-6, "value jump");
    assert!((f(s_sl) - fmax).abs() < 1e-9);
    // Slope and curvature from one-sided differences vanish on both sides.
    let d1_left = (f(s_sl) - f(s_sl - h)) / h;
    let d2_left = (f(s_sl) - 2.0 * f(s_sl - h) + f(s_sl - 2.0 * h)) / (h * h);
    assert!(d1_left.abs() < 1e-3 * c, "slope {d1_left}");
    assert!(d2_left.abs() < 1e-2 * c * c / fmax, "curvature {d2_left}");
    // Initial slope is C (cornering stiffness).
    let d0 = f(1e-8) / 1e-8;
    assert!((d0 - c).abs() < 1e-3 * c);
    // Dual numbers: first and second derivative continuous at x = 1.
    use num_dual::{second_derivative, Dual2_64};
    let d = |s: f64| second_derivative(|ss: Dual2_64| fiala_total(c, ss, Dual2_64::from(fmax)), s);
    let (_, g1, h1) = d(s_sl * (1.0 - 1e-9));
    let (_, g2, h2) = d(s_sl * (1.0 + 1e-9));
    assert!((g1 - g2).abs() < 1e-3 && (h1 - h2).abs() < 1e-2 * c * c / fmax * 1e-3);
}

#[test]
fn smooth_pieces_are_continuous_at_zero_slip() {
    let p = lc500();
    // Lateral force passes through zero continuously and linearly as alpha crosses 0.
    let v = 20.0;
    let fy = |beta: f64| {
        tire_forces(
            &p,
            &[0.0, v, beta, v * beta.cos(), 0.0, 0.0, 0.0, 0.0, 0.0],
            &[0.0; NU],
        )
        .fyr
    };
    let e = 1e-9;
    assert!(fy(0.0).abs() < 1e-9);
    assert!((fy(e) + fy(-e)).abs() < 1e-9);
    // Effective cornering stiffness near zero slip is within a few % of C_r (R6 reduces it by
    // ~C eps/(3 Fmax) plus the tan/sigma factor for |tan a| ~ eps).
    let s = 0.02; // 20 eps: smoothing negligible
    let c_eff = -fy(s) / s.tan();
    let fmax = p.mu * p.fz_nom_rear();
    let expected =
        p.c_r * (1.0 - p.c_r * s / (3.0 * fmax) + (p.c_r * s).powi(2) / (27.0 * fmax * fmax));
    assert!(
        (c_eff - expected).abs() < 0.01 * expected,
        "{c_eff} vs {expected}"
    );
    // sigma never reaches zero (R6).
    let t = tire_forces(&p, &[0.0, v, 0.0, v, 0.0, 0.0, 0.0, 0.0, 0.0], &[0.0; NU]);
    assert!((t.sigma_f - p.eps_sigma).abs() < 1e-15 && (t.sigma_r - p.eps_sigma).abs() < 1e-15);
}

#[test]
fn front_capacity_floor_is_smooth_and_inactive_when_far() {
    let q_min = 1e4;
    // Far above the floor: q = d to relative (q_min/d)^2/4.
    let d = 200.0 * q_min;
    assert!(((smooth_floor(d, q_min) - d) / d).abs() < 1e-5);
    // Below zero it stays >= q_min and is continuous.
    assert!(smooth_floor(-1e9, q_min) >= q_min);
    let a = smooth_floor(q_min - 1e-9, q_min);
    let b = smooth_floor(q_min + 1e-9, q_min);
    assert!((a - b).abs() < 1e-8);
    // Braking reduces the front capacity as the friction circle says.
    let p = lc500();
    let x = [0.0, 20.0, 0.0, 20.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let t = tire_forces(&p, &x, &[0.0, 0.0, -2000.0]);
    let fxf = -2000.0 / p.r_w;
    let expect = ((p.mu * p.fz_nom_front()).powi(2) - fxf * fxf).sqrt();
    assert!((t.fmax_f - expect).abs() < 1e-3 * expect);
}
