//! Top-view geometry and PNG output of `planner::plot`.

use std::f64::consts::PI;

use planner::model::{iu, ix, NU, NX};
use planner::plot::{centerline_xy, lane_edges_xy, path_xy, plot_trajectory, PlotError};
use planner::trajectory::Trajectory;

#[test]
fn constant_curvature_circle_closes() {
    let radius = 25.0;
    let n = 400;
    let ds = 2.0 * PI * radius / n as f64;
    let kappa = vec![1.0 / radius; n + 1];
    let c = centerline_xy(&kappa, ds);
    assert_eq!(c.len(), n + 1);
    let (x0, y0, psi0) = c[0];
    let (xn, yn, psin) = c[n];
    assert_eq!((x0, y0, psi0), (0.0, 0.0, 0.0));
    assert!(
        (xn - x0).hypot(yn - y0) < 1e-2,
        "end ({xn}, {yn}) not at start"
    );
    assert!(
        (psin - psi0 - 2.0 * PI).abs() < 1e-9,
        "heading change {psin}"
    );
    // Every node lies on the circle of radius 25 centred at (0, 25).
    for &(x, y, _) in &c {
        assert!((x.hypot(y - radius) - radius).abs() < 1e-9);
    }
}

#[test]
fn straight_centerline_and_offsets() {
    let c = centerline_xy(&[0.0; 11], 2.0);
    assert!((c[10].0 - 20.0).abs() < 1e-12 && c[10].1.abs() < 1e-12);
    assert!(centerline_xy(&[], 1.0).is_empty());
}

/// 101 nodes on an oval-like kappa profile (straight, half circle, straight, half
/// circle), speed slow in the bends and fast on the straights.
fn synthetic() -> Trajectory {
    let n = 100;
    let radius = 20.0;
    let straight = 40.0;
    let length = 2.0 * straight + 2.0 * PI * radius;
    let ds = length / n as f64;
    let mut traj = Trajectory {
        name: "synthetic oval".into(),
        ds,
        x: Vec::new(),
        u: Vec::new(),
        kappa: Vec::new(),
        e_min: Vec::new(),
        e_max: Vec::new(),
        lane_e_min: Vec::new(),
        lane_e_max: Vec::new(),
        placement: None,
    };
    let mut t = 0.0;
    for k in 0..=n {
        let s = k as f64 * ds;
        let lap = s % (straight + PI * radius);
        let in_bend = lap > straight;
        traj.kappa.push(if in_bend { 1.0 / radius } else { 0.0 });
        let v = 15.0 + 10.0 * (2.0 * PI * (s - 0.5 * straight) / (straight + PI * radius)).cos();
        if k > 0 {
            t += ds / v;
        }
        let mut x = [0.0; NX];
        x[ix::V] = v;
        x[ix::VWR] = v * 1.05;
        x[ix::R] = v / radius * f64::from(u8::from(in_bend));
        x[ix::BETA] = -0.1 * (s / 15.0).sin();
        x[ix::E] = 2.5 * (2.0 * PI * s / (straight + PI * radius)).sin();
        x[ix::S] = s;
        x[ix::T] = t;
        traj.x.push(x);
        traj.e_min.push(-3.5);
        traj.e_max.push(3.5);
        traj.lane_e_min.push(-3.5);
        traj.lane_e_max.push(3.5);
        if k < n {
            let mut u = [0.0; NU];
            u[iu::DELTA] = 0.08 * f64::from(u8::from(in_bend)) + 0.02 * (s / 10.0).sin();
            u[iu::TCOMB] = 2000.0 * (s / 20.0).cos();
            u[iu::TBF] = -1500.0 * f64::from(u8::from(in_bend));
            traj.u.push(u);
        }
    }
    traj
}

#[test]
fn path_and_edges_offset_from_centerline() {
    let traj = synthetic();
    let c = centerline_xy(&traj.kappa, traj.ds);
    let p = path_xy(&traj);
    let (right, left) = lane_edges_xy(&traj);
    assert_eq!(p.len(), traj.x.len());
    for k in 0..p.len() {
        let (x, y, _) = c[k];
        let e = traj.x[k][ix::E];
        assert!(((p[k].0 - x).hypot(p[k].1 - y) - e.abs()).abs() < 1e-9);
        assert!(((left[k].0 - right[k].0).hypot(left[k].1 - right[k].1) - 7.0).abs() < 1e-9);
    }
    // The left edge lies to the left of the start heading (+y).
    assert!(left[0].1 > 0.0 && right[0].1 < 0.0);
}

#[test]
fn plot_synthetic_trajectory_writes_png() {
    let traj = synthetic();
    let file = std::env::temp_dir().join(format!("planner_plot_test_{}.png", std::process::id()));
    plot_trajectory(&traj, &file).expect("plot");
    let bytes = std::fs::read(&file).expect("read png");
    assert!(bytes.len() > 1000, "png too small: {} bytes", bytes.len());
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    if std::env::var_os("PLANNER_KEEP_PLOT").is_none() {
        let _ = std::fs::remove_file(&file);
    }
}

#[test]
fn plot_rejects_bad_input() {
    let mut traj = synthetic();
    traj.kappa.pop();
    assert!(matches!(
        plot_trajectory(&traj, &std::env::temp_dir().join("planner_plot_bad.png")),
        Err(PlotError::Inconsistent(_))
    ));
    traj.x.clear();
    assert!(matches!(
        plot_trajectory(&traj, &std::env::temp_dir().join("planner_plot_bad.png")),
        Err(PlotError::Empty)
    ));
    let traj = synthetic();
    let dir = std::env::temp_dir()
        .join("planner_plot_no_such_dir")
        .join("x");
    // A file that cannot be written is an error naming it, with the OS reason.
    let e = plot_trajectory(&traj, &dir.join("a.png")).unwrap_err();
    assert!(matches!(e, PlotError::Write(_)), "{e}");
    assert!(
        e.to_string().contains("a.png: cannot write: No such file"),
        "{e}"
    );
}

#[test]
fn footprint_figure_with_an_obstacle_writes_png() {
    let mut t = synthetic();
    // An obstacle narrows the right side over five nodes.
    for k in 20..25 {
        t.e_min[k] += 2.0;
    }
    let dir = std::env::temp_dir().join(format!("plot-footprint-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("footprint.png");
    planner::plot::plot_footprint(&t, &png).unwrap();
    let bytes = std::fs::read(&png).unwrap();
    assert!(bytes.len() > 1000 && bytes.starts_with(b"\x89PNG"));
    let _ = std::fs::remove_dir_all(&dir);
    // Inconsistent input is an error, not a panic.
    t.e_max.pop();
    assert!(planner::plot::plot_footprint(&t, &png).is_err());
}

#[test]
fn only_bounds_overrides_count_as_obstacles_on_a_road_of_varying_width() {
    let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../config");
    let vehicle = planner::config::load_vehicle(&root.join("vehicles/lc500.toml")).unwrap();
    let blocked = |file: &str, select: &str| {
        let (spec, layout) =
            planner::config::load_scenario_layout(&root.join(file), Some(select), vehicle, None)
                .unwrap();
        let mut t = synthetic();
        t.e_min = spec.e_min.clone();
        t.e_max = spec.e_max.clone();
        layout.apply(&mut t);
        planner::plot::blocked_nodes(&t)
    };
    // A track segment narrows and widens, but nothing blocks it.
    assert!(blocked("scenarios/segments.toml", "S01")
        .iter()
        .all(|&(r, l)| !r && !l));
    // The critical scenario's obstacles block nodes, and only on one side at a time.
    let ca = blocked("scenarios/collision_avoidance.toml", "critical");
    assert!(ca.iter().any(|&(r, l)| r || l));
    assert!(ca.iter().filter(|&&(r, l)| r || l).count() < ca.len());
}
