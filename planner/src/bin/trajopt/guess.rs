//! `trajopt guess`: the equilibrium initial guess of a vehicle (paper eq. 8).

use std::path::PathBuf;

use planner::config::load_vehicle;

use crate::out::outln;
use crate::paths::resolve;

#[derive(clap::Args, Debug)]
pub struct GuessArgs {
    /// Vehicle file.
    #[arg(long, default_value = "config/vehicles/lc500.toml")]
    vehicle: PathBuf,
    /// Speed bounds and start speed [m/s].
    #[arg(long, default_value_t = 5.0)]
    v_min: f64,
    /// Upper speed bound [m/s].
    #[arg(long, default_value_t = 40.0)]
    v_max: f64,
    /// Start speed of the least-squares problem [m/s].
    #[arg(long, default_value_t = planner::plan::DEFAULT_GUESS_SPEED)]
    v_start: f64,
    /// JSON output.
    #[arg(long)]
    json: bool,
}

/// Computes the guess and prints it (one JSON object with `--json`).
pub fn run(args: GuessArgs) -> Result<(), String> {
    let vehicle = load_vehicle(&resolve(&args.vehicle)).map_err(|e| e.to_string())?;
    if !(args.v_min > 0.0 && args.v_max > args.v_min && args.v_start.is_finite()) {
        return Err("need 0 < v_min < v_max and a finite v_start".into());
    }
    let eq = planner::guess::equilibrium(&vehicle, args.v_min, args.v_max, args.v_start)
        .map_err(|e| e.to_string())?;
    if args.json {
        outln!("{}", serde_json::json!(eq));
    } else {
        let n = planner::model::STATE_NAMES;
        let c = planner::model::CONTROL_NAMES;
        outln!(
            "equilibrium guess ({}, {} iterations, cost {:.2e}):",
            eq.status,
            eq.iterations,
            eq.cost
        );
        for (name, v) in n.iter().zip(&eq.x).take(5) {
            outln!("  {name:>6} = {v:.6}");
        }
        for (name, v) in c.iter().zip(&eq.u) {
            outln!("  {name:>6} = {v:.6}");
        }
    }
    Ok(())
}
