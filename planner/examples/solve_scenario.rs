//! Solves one shipped scenario with the planner library: the shortest path from the
//! configuration files to a minimum-time trajectory.
//!
//! The problem is paper eq. (3): minimize the final time t_N of the single-track vehicle
//! (paper eq. 1) over N = [`planner::HORIZON`] intervals of the road ahead, subject to the
//! dynamics, the lateral and speed bounds, the control rates and the tire limits. The
//! example
//!
//! 1. loads the vehicle (`config/vehicles/lc500.toml`) and a scenario (default
//!    `config/scenarios/oval.toml`) into an [`OcpSpec`](planner::ocp::OcpSpec),
//! 2. loads the solver settings shipped for the scenario's objective
//!    ([`planner::config::shipped_solver_file`]),
//! 3. builds a [`Planner`] (the implicit-Euler transcription, the interior-point solver and
//!    the equilibrium guess of paper eq. 8),
//! 4. solves from the equilibrium guess and prints the status, the iteration count, the
//!    final time t_N and a few rows (s, V, beta, delta) of the trajectory.
//!
//! ```text
//! cargo run -p planner --example solve_scenario
//! cargo run -p planner --example solve_scenario -- config/scenarios/segments.toml S01
//! ```
//!
//! The first argument is a scenario file, the second the segment or scenario to select in
//! a multi-entry file (see [`planner::config::list_selections`]). Every failure is returned
//! as an error, naming the file and the field at fault.

use planner::config::{
    data_root_of, load_scenario, load_solver, load_vehicle, shipped_solver_file,
};
use planner::guess::GuessKind;
use planner::model::{iu, ix};
use planner::plan::Planner;
use std::error::Error;
use std::fmt;
use std::path::PathBuf;

/// Nodes printed of the trajectory (evenly spread, first and last included).
const ROWS_SHOWN: usize = 6;

/// An error of any step, shown by its message: `main` prints an `Err` with `Debug`.
struct Failure(Box<dyn Error>);

impl<E: Error + 'static> From<E> for Failure {
    fn from(e: E) -> Self {
        Failure(Box::new(e))
    }
}

impl fmt::Debug for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

fn main() -> Result<(), Failure> {
    let mut args = std::env::args().skip(1);
    let scenario = match args.next() {
        Some(path) => PathBuf::from(path),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../config/scenarios/oval.toml"),
    };
    let select = args.next();
    let root = data_root_of(&scenario);

    let vehicle = load_vehicle(&root.join("vehicles/lc500.toml"))?;
    let spec = load_scenario(&scenario, select.as_deref(), vehicle)?;
    let settings = load_solver(&root.join(shipped_solver_file(spec.steering_slew_weight)))?;
    println!(
        "{}: {} m in N = {} intervals ({} m each), steering-slew weight {}",
        spec.name,
        spec.length,
        spec.n_intervals,
        spec.ds(),
        spec.steering_slew_weight
    );

    let mut planner = Planner::<{ planner::HORIZON }>::new(spec, settings)?;
    let info = planner.solve(GuessKind::Equilibrium);
    let trajectory = planner.trajectory();
    println!(
        "status {}, {} iterations, t_N = {:.4} s",
        info.status.name(),
        info.iterations,
        trajectory.t_final()
    );

    println!(
        "{:>9} {:>9} {:>10} {:>10}",
        "s [m]", "V [m/s]", "beta [rad]", "delta [rad]"
    );
    let n = trajectory.n_intervals();
    for i in 0..ROWS_SHOWN {
        let k = i * n / (ROWS_SHOWN - 1);
        let x = &trajectory.x[k];
        let u = trajectory.control_at(k);
        println!(
            "{:>9.2} {:>9.3} {:>10.5} {:>10.5}",
            x[ix::S],
            x[ix::V],
            x[ix::BETA],
            u[iu::DELTA]
        );
    }
    Ok(())
}
