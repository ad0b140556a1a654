//! In-process closed loop (no IPC, synchronous replanning) for tuning the tracker.
use ipc::msg::*;
use ipc::plant::Plant;
use ipc::road::Scenario;
use ipc::tracker::*;
use planner::model::{ix, NX};
use planner::plan::{Planner, ReplanGuess};
use std::path::Path;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let replan_dt: f64 = a.get(1).and_then(|s| s.parse().ok()).unwrap_or(0.1);
    let mode: &str = a.get(2).map(|s| s.as_str()).unwrap_or("measured");
    let sc = Scenario::load(
        Path::new("config/scenarios/oval.toml"),
        Path::new("config/vehicles/lc500.toml"),
        Path::new("config/solver.toml"),
    )
    .unwrap();
    let mut settings = sc.settings;
    settings.max_time_s = 1.0;
    let mut pl = Planner::<HORIZON_N>::new(sc.spec.clone(), settings).unwrap();
    let mut plant = Plant::cruise(sc.spec.vehicle, 15.0);
    let g = Gains::default();
    let ds = sc.ds();
    let mut w = ipc::road::RoadWindow::default();
    let mut plan = Box::new(unsafe { std::mem::zeroed::<Trajectory>() });
    let mut next_plan = 0.0;
    let mut max_e: f64 = 0.0;
    while plant.x[ix::S] < 257.0 && plant.x[ix::T] < 40.0 {
        if plant.x[ix::T] >= next_plan {
            next_plan += replan_dt;
            sc.road.window(plant.x[ix::S], ds, 0.5, 20.0, &mut w);
            let mut x0 = plant.x;
            if mode == "planned" && plan.ds > 0.0 {
                if let Some(r) = reference(&plan, plant.x[ix::S] - plan.s_origin) {
                    x0 = r.x;
                    x0[ix::E] = plant.x[ix::E];
                    x0[ix::DPSI] = plant.x[ix::DPSI];
                    x0[ix::V] = plant.x[ix::V];
                }
            }
            x0[ix::S] = 0.0;
            x0[ix::T] = 0.0;
            let info = pl
                .replan(&w.kappa, &w.e_min, &w.e_max, x0, ReplanGuess::Equilibrium)
                .unwrap();
            println!("t {:6.2} s {:7.2} V {:5.2} e {:5.2} beta {:6.3} r {:6.3} vwr {:5.2} dfz {:7.1} -> {} {} its {:.0} ms, max_e {:.3}",
                plant.x[ix::T], plant.x[ix::S], plant.x[ix::V], plant.x[ix::E], plant.x[ix::BETA], plant.x[ix::R], plant.x[ix::VWR], plant.x[ix::DFZ],
                info.status.name(), info.iterations, info.times.total * 1e3, max_e);
            plan.ds = ds;
            plan.s_origin = plant.x[ix::S];
            for i in 0..=HORIZON_N {
                plan.x[i] = pl.states()[i];
            }
            for i in 0..HORIZON_N {
                plan.u[i] = pl.controls()[i];
            }
        }
        let r = reference(&plan, plant.x[ix::S] - plan.s_origin).unwrap();
        let (u, err) = track(&plant.params, &g, &plant.x, &r);
        max_e = max_e.max(err.e.abs());
        for _ in 0..4 {
            plant.step(u, &sc.road, 0.00025);
        }
        let _ = NX;
    }
    println!(
        "done s {:.1} t {:.2} max_e {:.3}",
        plant.x[ix::S],
        plant.x[ix::T],
        max_e
    );
}
