//! The planner cycle's IPC and road work allocate nothing after start-up: publishing and
//! receiving a vehicle state, waiting on its event, validating it, sampling the road
//! window, the domain check of the initial state, and loaning, writing, sending and
//! receiving a trajectory. iceoryx2 0.10 allocates on every loan (`../shared/notes/
//! crates.md`): this test re-checks the pinned 0.9.3, and any later upgrade. It found that
//! 0.9.3's timed listener wait allocates on every call, hence `services::wait_events`.

use std::path::Path;
use std::time::Duration;

use ipc::msg::{Trajectory, VehicleState, HORIZON_N, MSG_VERSION};
use ipc::road::{RoadWindow, Scenario, StartRamp};
use ipc::services::{publish_state, wait_events, Services};
use planner::model::{ix, NX};

#[test]
fn the_ipc_and_road_part_of_a_planner_cycle_allocates_nothing() {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let sc = Scenario::load(
        &root.join("scenarios/oval.toml"),
        &root.join("vehicles/lc500.toml"),
        &root.join("solver.toml"),
    )
    .unwrap();
    let prefix = format!("trajopt_alloc_test_{}", std::process::id());
    let svc = Services::open(&prefix, "alloc_test").unwrap();
    let state_pub = svc.state_publisher().unwrap();
    let state_sub = svc.state_subscriber().unwrap();
    let state_not = svc.state_notifier().unwrap();
    let state_lis = svc.state_listener().unwrap();
    let traj_pub = svc.traj_publisher().unwrap();
    let traj_sub = svc.traj_subscriber().unwrap();
    let traj_not = svc.traj_notifier().unwrap();
    let ds = sc.spec.ds();
    let mut window = RoadWindow::default();
    let mut x = [0.0; NX];
    x[ix::V] = 15.0;
    x[ix::VWR] = 15.0;
    let mut plan = Trajectory {
        version: MSG_VERSION,
        road_id: sc.id,
        ds,
        x_from: x,
        x: [x; HORIZON_N + 1],
        ..Trajectory::zeroed()
    };

    let mut received = 0u64;
    let mut cycle = |seq: u64, plan: &mut Trajectory, window: &mut RoadWindow| {
        let mut state_x = x;
        state_x[ix::S] = seq as f64;
        publish_state(
            &state_pub,
            &state_not,
            VehicleState::new(sc.id, seq, 0, state_x),
        )
        .unwrap();
        wait_events(&state_lis, Duration::from_millis(100)).unwrap();
        let mut latest = None;
        while let Some(sample) = state_sub.receive().unwrap() {
            let m: &VehicleState = sample.payload();
            m.validate(sc.id).unwrap();
            latest = Some(*m);
        }
        let state = latest.expect("the state arrives");
        sc.road.window(state.x[ix::S], ds, 0.0, 10.0, window);
        let mut x0 = state.x;
        x0[ix::S] = 0.0;
        x0[ix::T] = 0.0;
        sc.spec
            .initial_domain(&window.kappa, &window.e_min, &window.e_max)
            .check(&x0)
            .unwrap();
        plan.seq = seq;
        plan.from_state_seq = state.seq;
        let sample = traj_pub.loan_uninit().unwrap();
        sample.write_payload(*plan).send().unwrap();
        traj_not.notify().unwrap();
        while let Some(t) = traj_sub.receive().unwrap() {
            assert_eq!(t.payload().seq, seq);
            received += 1;
        }
    };
    // Start-up: every lazily sized buffer is sized here.
    for seq in 0..5 {
        cycle(seq, &mut plan, &mut window);
    }
    let info = allocation_counter::measure(|| {
        for seq in 5..105 {
            cycle(seq, &mut plan, &mut window);
        }
    });
    assert_eq!(info.count_total, 0, "{info:?}");
    assert_eq!(received, 105);
    // An empty wait (the timeout path) allocates nothing either.
    let idle = allocation_counter::measure(|| {
        for _ in 0..20 {
            wait_events(&state_lis, Duration::from_micros(200)).unwrap();
        }
    });
    assert_eq!(idle.count_total, 0, "{idle:?}");
    // The counter does see allocations (the test can fail).
    let seen = allocation_counter::measure(|| {
        std::hint::black_box(vec![1u8; 16]);
    });
    assert!(seen.count_total > 0);
}

/// The `--record` part of the cycle copies the road window, the start state, the plan and,
/// for every other plan, a warm start (shifted guess and multipliers) into a preallocated
/// slot and queues it: nothing is allocated on the planner's thread (the writer thread
/// allocates as it encodes, which the counter, per thread, leaves out), and what reaches
/// the file equals the records built the allocating way.
#[test]
fn recording_a_plan_in_the_cycle_allocates_nothing() {
    use ipc::planner_proc::{CycleRecorder, WarmRecord};
    use planner::guess::GuessKind;
    use planner::ocp::InitialState;
    use planner::plan::Planner;
    use planner::plan::WarmOptions;
    use planner::record::{plan_input, plan_output};

    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let sc = Scenario::load(
        &root.join("scenarios/oval.toml"),
        &root.join("vehicles/lc500.toml"),
        &root.join("solver.toml"),
    )
    .unwrap();
    let mut planner = Planner::<HORIZON_N>::new(sc.spec.clone(), sc.settings).unwrap();
    let info = planner.solve(GuessKind::Equilibrium);
    let (xs, us) = (planner.states(), planner.controls());
    let dir = std::env::temp_dir().join(format!("trajopt_alloc_record_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("cycle.mcap");
    let ws = planner.solver().workspace();
    // Every third plan is recorded as a relaxed one (a raised saturation bound).
    let mut relaxed = sc.spec.clone();
    relaxed.vehicle.eps_sat = 0.05;
    let rec = CycleRecorder::create(
        &file,
        (&sc.spec, Some(&relaxed)),
        &sc.settings,
        planner::guess::GuessKind::Equilibrium,
        (ws.n, ws.m),
    )
    .unwrap();
    let ds = sc.spec.ds();
    let mut window = RoadWindow::default();
    let mut x0 = xs[0];
    let cycle = |seq: u64, window: &mut RoadWindow, x0: &mut [f64; NX]| {
        sc.road.window(seq as f64, ds, 0.0, 10.0, window);
        x0[ix::E] = 1e-3 * seq as f64;
        let warm = (seq % 2 == 1).then(|| WarmRecord {
            shift: 2.5,
            opts: WarmOptions::default(),
            guess: (xs, us),
            duals: planner.warm_duals(),
        });
        let problem = (&*window, seq % 3 == 2);
        let queued = rec.record((seq, 1_000 + seq), problem, *x0, &info, (xs, us), warm);
        // One plan per millisecond at most, so the writer keeps up and nothing is dropped.
        std::thread::sleep(Duration::from_millis(1));
        queued
    };
    for seq in 0..5 {
        assert!(cycle(seq, &mut window, &mut x0));
    }
    let mut queued = 0;
    let measured = allocation_counter::measure(|| {
        for seq in 5..105 {
            queued += u64::from(cycle(seq, &mut window, &mut x0));
        }
    });
    assert_eq!(measured.count_total, 0, "{measured:?}");
    let stats = rec.finish().unwrap();
    assert_eq!(stats.inputs, 5 + queued);
    // 105 plans, 52 of them warm-started: 2 messages each, 3 for a warm one.
    let messages = stats.inputs + stats.outputs + stats.warm_starts + stats.dropped;
    assert_eq!(messages, 2 * 105 + 52, "{stats:?}");
    assert!(queued >= 50, "{queued} of 100 plans queued");

    let back = plan_record::Recording::read(&file).unwrap();
    assert!(back.complete());
    let (input, output) = (back.inputs.last().unwrap(), back.outputs.last().unwrap());
    // Plan 104 is a relaxed one.
    let mut spec = relaxed.clone();
    spec.kappa = window.kappa.to_vec();
    spec.e_min = window.e_min.to_vec();
    spec.e_max = window.e_max.to_vec();
    spec.initial = InitialState::Fixed(x0);
    let fresh = plan_input(&spec, &sc.settings, GuessKind::Equilibrium, 104, 1_104);
    assert_eq!(input, &fresh);
    let fresh = plan_output(104, output.stamp_ns, &info, xs, us);
    assert_eq!(output, &fresh);
    for input in &back.inputs {
        let (spec, _, _) = planner::record::problem_from(input).unwrap();
        let eps = if input.seq % 3 == 2 {
            0.05
        } else {
            sc.spec.vehicle.eps_sat
        };
        assert_eq!(spec.vehicle.eps_sat, eps, "plan {}", input.seq);
    }
    let warm = back.warm_starts.last().expect("warm starts were recorded");
    assert_eq!(warm.seq % 2, 1);
    assert_eq!((warm.states.len(), warm.y.len()), (xs.len(), ws.m));
    assert_eq!(
        back.inputs.iter().filter(|i| i.guess == "warm").count(),
        back.warm_starts.len()
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The tracker's 1 kHz step allocates nothing with the default plant mismatch: measuring
/// (noise draw), filtering the measurement (the estimator's model steps), the feed-forward
/// plus LQR control (gain interpolation, plan lookup) and driving the car (delay line,
/// steering lag, plant RK4 substeps); so does braking to a stop without a plan (the rear
/// target slip's bisection, the LQR on the stop's reference).
#[test]
fn the_tracker_step_with_mismatch_allocates_nothing() {
    use ipc::controller::Controller;
    use ipc::mismatch::Mismatch;
    use ipc::plant::car::Car;

    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let sc = Scenario::load(
        &root.join("scenarios/oval.toml"),
        &root.join("vehicles/lc500.toml"),
        &root.join("solver.toml"),
    )
    .unwrap();
    let mismatch = Mismatch::from_arg("default").unwrap();
    let (control_dt, substeps) = (0.001, 4);
    let p = sc.spec.vehicle;
    let mut car = Car::new(
        &p,
        &mismatch,
        ipc::plant::Plant::cruise(p, 15.0).x,
        control_dt,
        3,
    );
    let actuator = ipc::controller::Actuator {
        steering_lag_s: 0.05,
        delay_steps: 20,
    };
    let mut controller = Controller::new(&p, control_dt, 0.07, actuator).unwrap();
    let mut x = [0.0; NX];
    x[ix::V] = 15.0;
    x[ix::VWR] = 15.0;
    let mut plan = Trajectory {
        version: MSG_VERSION,
        road_id: sc.id,
        ds: sc.spec.ds(),
        x_from: x,
        ..Trajectory::zeroed()
    };
    for (k, node) in plan.x.iter_mut().enumerate() {
        *node = x;
        node[ix::S] = k as f64 * plan.ds;
    }
    let mut steps = 0u64;
    let mut estimator = ipc::estimator::Estimator::new(p, 0.02, control_dt);
    let mut step = |car: &mut Car| {
        let y = car.measure();
        let y = estimator.update(
            &y,
            car.measured_controls(),
            &sc.road,
            (substeps, control_dt / substeps as f64),
        );
        let (u, _) = controller
            .control(&plan, &y)
            .expect("the plan covers the car");
        controller.applied(u[planner::model::iu::DELTA]);
        car.drive(u, &sc.road, substeps, control_dt / substeps as f64);
        steps += 1;
    };
    for _ in 0..10 {
        step(&mut car);
    }
    let info = allocation_counter::measure(|| {
        for _ in 0..2000 {
            step(&mut car);
        }
    });
    assert_eq!(info.count_total, 0, "{info:?}");
    assert_eq!(steps, 2010);
    assert!(
        car.plant.x[ix::S] > 20.0,
        "the car drove: {:?}",
        car.plant.x
    );
    // The stop without a plan (the target rear slip's bisection, the LQR on its reference).
    let gains = ipc::tracker::Gains::default().emergency_stop(&p);
    let v_before = car.plant.x[ix::V];
    let info = allocation_counter::measure(|| {
        for _ in 0..500 {
            let y = car.measure();
            let u = ipc::tracker::brake_to_stop(&p, &gains, &controller, &y, &sc.road, 0.0);
            controller.applied(u[planner::model::iu::DELTA]);
            car.drive(u, &sc.road, substeps, control_dt / substeps as f64);
        }
    });
    assert_eq!(info.count_total, 0, "{info:?}");
    assert!(
        car.plant.x[ix::V] < v_before - 2.0,
        "the car braked: {:?}",
        car.plant.x
    );
}

/// Sampling a track's road window (profile lookups, varying bounds, the margin ramp from
/// the car's position, the wrap at the lap's end), its soft lane and end-speed bound
/// written into a planner, the relaxed plans' limits switched in and out, and the domain
/// check of the start state allocate nothing.
#[test]
fn sampling_a_track_window_across_the_lap_end_allocates_nothing() {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let road_args = ipc::road::RoadArgs {
        track: Some("Austin".into()),
        tracks_index: root.join("tracks/tracks.toml"),
        ..Default::default()
    };
    let sc = Scenario::load_with(
        &root.join("scenarios/oval.toml"),
        &road_args,
        &root.join("vehicles/lc500.toml"),
        &root.join("solver.toml"),
    )
    .unwrap();
    let lap = sc.road.lap();
    let ds = sc.ds();
    let mut spec = sc.spec.clone();
    spec.soft_lane = planner::ocp::SoftLane::new(10.0, spec.e_min.clone(), spec.e_max.clone());
    let mut relaxed = spec.vehicle;
    relaxed.eps_sat = 0.05;
    spec.vehicle.scale_grip(0.9);
    let limits = [spec.vehicle.limits(), relaxed.limits()];
    let mut planner = planner::plan::Planner::<HORIZON_N>::new(spec, sc.settings).unwrap();
    let env = ipc::road::envelope::SpeedEnvelope::new(&sc.road, 7.0, 6.0, 70.0).unwrap();
    let mut window = RoadWindow::default();
    let mut x0 = [0.0; NX];
    x0[ix::V] = 20.0;
    x0[ix::VWR] = 20.0;
    let mut sample = |k: usize, window: &mut RoadWindow| {
        let s = lap - 150.0 + k as f64 * 1.7;
        sc.road.window_from(
            s,
            (0.3, -1.5),
            ds,
            &StartRamp {
                margin: 0.5,
                length_m: 20.0,
                arrest_accel: 4.0,
                floor_m: 0.3,
            },
            window,
        );
        sc.road.soft_window(s, ds, 0.7, window);
        planner
            .set_soft_lane(&window.soft_e_min, &window.soft_e_max)
            .unwrap();
        window.v_end_max = env.at(s + HORIZON_N as f64 * ds);
        planner.set_end_speed_cap(window.v_end_max).unwrap();
        planner.set_limits(limits[k % 2]).unwrap();
        sc.spec
            .initial_domain(&window.kappa, &window.e_min, &window.e_max)
            .check(&x0)
            .unwrap();
    };
    sample(0, &mut window);
    let info = allocation_counter::measure(|| {
        for k in 0..200 {
            sample(k, &mut window);
        }
    });
    assert_eq!(info.count_total, 0, "{info:?}");
}

/// The tracker's drive log (lap crossings, edge margin, obstacle clearance of the
/// footprint, the driven trace and the plan log) allocates nothing per step up to its cap.
#[test]
fn logging_a_tracker_step_allocates_nothing() {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let road_args = ipc::road::RoadArgs {
        segment: Some("forgiving".into()),
        ..Default::default()
    };
    let sc = Scenario::load_with(
        &root.join("scenarios/collision_avoidance.toml"),
        &road_args,
        &root.join("vehicles/lc500.toml"),
        &root.join("solver.toml"),
    )
    .unwrap();
    let mut log = ipc::tracker_proc::RunLog::new(&sc.road, 0.0, 1, 10.0);
    let plan = Trajectory {
        ds: 1.25,
        ..Trajectory::zeroed()
    };
    let mut x = [0.0; NX];
    x[ix::V] = 25.0;
    let info = allocation_counter::measure(|| {
        for k in 0..20_000 {
            x[ix::T] = k as f64 * 0.001;
            x[ix::S] = 25.0 * x[ix::T];
            log.step(&x, &sc.road, 0.0);
            if k % 100 == 0 {
                log.plan(&plan, x[ix::S]);
            }
        }
    });
    assert_eq!(info.count_total, 0, "{info:?}");
    assert!(log.laps_done());
}
