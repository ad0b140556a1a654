//! The planner process's command-line options and the defaults of its lane margin.

use std::path::PathBuf;

/// Distance over which the lane margin ramps in from the lane edge \[m\].
pub const MARGIN_RAMP_M: f64 = 20.0;

/// Closest to an edge the drift allowance takes a plan's margin ramp \[m\]
/// (`--margin-floor-m`, `StartRamp::floor_m`).
pub const MARGIN_FLOOR_M: f64 = 0.3;

/// Lateral acceleration the start ramp assumes a car uses to stop moving toward an edge
/// \[m/s^2\] (`ClosedRoad::window_from`; about the car's grip). Without the allowance, a
/// car at the margin heading out at 1-2 m/s made the plan locally infeasible (all seven
/// failures of three oval laps with the default mismatch); 4 m/s^2 also solves them but
/// lets the plans ride closer to the edge (docs/closed-loop.md).
pub const ARREST_LATERAL_ACCEL_MPS2: f64 = 8.0;

impl PlannerArgs {
    /// The grip scale of a relaxed plan: `--relaxed-friction-scale`, else the nominal
    /// plans' `--friction-scale`.
    pub fn relaxed_grip(&self) -> f64 {
        self.relaxed_friction_scale.unwrap_or(self.friction_scale)
    }
}

/// Command-line options of `planner_proc`.
// clap prints these doc comments as the --help text, which would show the escapes of
// the unit brackets verbatim: the brackets stay as they are, and rustdoc keeps them as text.
#[allow(rustdoc::broken_intra_doc_links)]
#[derive(clap::Args, Debug, Clone)]
pub struct PlannerArgs {
    /// Scenario file (a closed road, or an obstacle file with --segment).
    #[arg(long, default_value = "config/scenarios/oval.toml")]
    pub scenario: PathBuf,
    /// The road options (--track, --track-profile, --segment, ...).
    #[command(flatten)]
    pub road: crate::road::RoadArgs,
    /// Vehicle file.
    #[arg(long, default_value = "config/vehicles/lc500.toml")]
    pub vehicle: PathBuf,
    /// Solver settings file.
    #[arg(long, default_value = "config/solver.toml")]
    pub solver: PathBuf,
    /// iceoryx2 service-name prefix (unique per closed loop).
    #[arg(long, default_value = crate::services::DEFAULT_PREFIX)]
    pub service_prefix: String,
    /// Replanning rate [Hz].
    #[arg(long, default_value_t = 10.0)]
    pub rate_hz: f64,
    /// Wall-clock budget of one cycle's solve [ms] (overrides the solver file's
    /// max_time_s; default: 80 % of the period 1 / --rate-hz).
    #[arg(long)]
    pub budget_ms: Option<f64>,
    /// Budget of the solves until the first plan is sent [ms] (at least --budget-ms; the
    /// tracker waits for its first plan). Among obstacles the car does not wait, and the
    /// first solve gets --budget-ms.
    #[arg(long, default_value_t = 1000.0)]
    pub first_budget_ms: f64,
    /// Alias of --budget-ms in seconds.
    #[arg(long, hide = true, conflicts_with = "budget_ms")]
    pub max_solve_s: Option<f64>,
    /// Lane margin the plan keeps from each edge [m] (room for tracking error).
    #[arg(long, default_value_t = 0.5)]
    pub lane_margin_m: f64,
    /// Smallest arc-length scale 1 - kappa e of the road frame a plan may use, in [0, 0.9]
    /// (0: the lane edges only; `ClosedRoad::with_min_path_scale`): keeps the plans out
    /// of the stiff, near-singular part of the curvilinear model on the inside of a
    /// curve whose centre of curvature lies close to the edge (Austin's turn 1).
    #[arg(long, default_value_t = 0.0)]
    pub min_path_scale: f64,
    /// Lane margin of a relaxed plan [m] (capped at --lane-margin-m): after a cycle without a
    /// plan of its own, the next cycles on a closed road plan with this margin and the tire
    /// saturation bound --relaxed-saturation (docs/closed-loop.md). 0.6 m leaves the
    /// tracker 0.4 m of lateral error before the CG comes within 0.2 m of an edge.
    #[arg(long, default_value_t = 0.6)]
    pub relaxed_margin_m: f64,
    /// Distance over which a plan's lane margin ramps in from the car's own distance inside
    /// an edge [m] (`RoadWindow` of `ClosedRoad::window_from`; the free-start solve and the
    /// startup budget keep 20 m).
    #[arg(long, default_value_t = MARGIN_RAMP_M)]
    pub margin_ramp_m: f64,
    /// Closest to an edge a plan's margin ramp starts for a car moving toward that edge
    /// [m] (or the car's own distance, when smaller): the room its sideways motion needs
    /// to stop is granted down to this floor, not to the edge (negative: past the edge, for
    /// plans with a soft lane, --soft-lane-m, that pulls them back).
    #[arg(long, default_value_t = MARGIN_FLOOR_M, allow_hyphen_values = true)]
    pub margin_floor_m: f64,
    /// Soft lane margin from each edge of a closed road [m] (0: none): a plan that comes
    /// closer by d pays about --soft-lane-weight x d^2 seconds instead of being refused,
    /// so a car a tracking error put there is planned back out rather than made
    /// infeasible; --lane-margin-m stays the hard bound (`planner::ocp::soft_lane`,
    /// docs/closed-loop.md).
    #[arg(long, default_value_t = 0.0)]
    pub soft_lane_m: f64,
    /// Bound the speed at each plan's last node by the speed from which the car can still
    /// brake for the closed road's curves past the window (`on`; `road::envelope`,
    /// docs/closed-loop.md): with it a plan never ends closer to a curve than its braking
    /// distance, whatever --track-v-max-mps allows. `off`: the end state is free.
    #[arg(long, default_value = "off", value_parser = ["on", "off"])]
    pub end_speed_envelope: String,
    /// Weight of the soft lane's penalty [s/m^2] (at 10 the oval's plan keeps within 2 cm
    /// of its soft lane).
    #[arg(long, default_value_t = 10.0)]
    pub soft_lane_weight: f64,
    /// Tire saturation bound of a relaxed plan (sigma - sigma_sl <= this; at least the
    /// vehicle file's eps_sat).
    #[arg(long, default_value_t = 0.05)]
    pub relaxed_saturation: f64,
    /// Fraction of the vehicle file's friction and brake torques a relaxed plan uses (0.5
    /// to 1, at least --friction-scale; default: --friction-scale, the nominal plans'
    /// grip). Above it, a car that no plan at --friction-scale can recover is planned with
    /// the grip the nominal plans leave over, which a plant with less grip than the file
    /// says may not have (docs/closed-loop.md).
    #[arg(long)]
    pub relaxed_friction_scale: Option<f64>,
    /// Relaxed cycles in a row that sent their own plan before the nominal problem resumes
    /// (0: never relax).
    #[arg(long, default_value_t = 10)]
    pub relaxed_cycles: u32,
    /// Fraction of the vehicle file's tire-road friction and of its brake torques the
    /// plans use (0.5 to 1): the grip left over is the tracker's authority to correct
    /// errors and the margin for a road that grips less than the file says
    /// (docs/plant-and-tracker.md).
    #[arg(long, default_value_t = 1.0)]
    pub friction_scale: f64,
    /// Guess of a cold (not warm-started) solve: `equilibrium` (paper eq. 8, constant
    /// speed) or `road_speed` (the equilibrium capped by the speeds the window's curvature
    /// allows, `planner::guess::fill_road_speed`).
    #[arg(long, default_value = "equilibrium", value_parser = ["equilibrium", "road_speed"])]
    pub cold_guess: String,
    /// Warm-start from the previous plan shifted in s, primal and dual, with a barrier
    /// parameter matched to the shifted point (`Planner::replan_warm`, docs/solver.md);
    /// `off` starts every plan from the cold guess.
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    pub warm_start: String,
    /// Hold the tires within their slip limits at each plan's last node too, (x_N,
    /// u_{N-1}), where implicit Euler takes the last interval's forces
    /// (`OcpSpec::saturation_at_end`, docs/modelling.md); `off`: the paper's rows only.
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    pub saturation_at_end: String,
    /// How a warm start's first barrier parameter is matched to the shifted point:
    /// `geometric` (`--warm-mu-factor` times the geometric mean of the complementarity
    /// products) or `mean` (their average; docs/solver.md).
    #[arg(long, default_value = "geometric", value_parser = ["geometric", "mean"])]
    pub warm_mu: String,
    /// Multiple of the geometric mean for `--warm-mu geometric` (finite, > 0).
    #[arg(long, default_value_t = 30.0)]
    pub warm_mu_factor: f64,
    /// Iterations a warm-started solve may take before it falls back to the cold guess
    /// with what is left of the cycle's caps, in 1..=100000 (default: none, the solver's
    /// cap; `WarmOptions::max_iter`). A warm start from a plan the car has left behind can
    /// stall for the whole budget; a cap leaves the fall-back time to converge.
    #[arg(long, value_name = "K")]
    pub warm_max_iter: Option<usize>,
    /// Iterations a warm-started solve may take in a cycle after one whose solve did not
    /// succeed, in 1..=100000 (at most `--warm-max-iter`). Such a warm start shifts a plan
    /// a cycle older; where the car has left it, the warm solve stalls cycle after cycle
    /// while the cold guess converges in 30-50 iterations, so 40 leaves the fall-back
    /// about half of an 80 ms budget on a 2-core machine.
    #[arg(long, value_name = "K", default_value_t = 40)]
    pub warm_max_iter_after_failure: usize,
    /// Lockstep with the tracker (`crate::lockstep`): plan from each state the tracker
    /// flags, at once, instead of on the wall clock, with each solve bounded by
    /// iterations, --budget-ms / --lockstep-ms-per-iter, instead of by time; a run then
    /// repeats bit for bit on any machine.
    #[arg(long)]
    pub lockstep: bool,
    /// Modelled time of one solver iteration in lockstep [ms] (> 0, at most the period).
    #[arg(long, default_value_t = crate::lockstep::MS_PER_ITER)]
    pub lockstep_ms_per_iter: f64,
    /// Stop when stdin reaches EOF (used by `trajopt closed-loop`).
    #[arg(long)]
    pub exit_on_stdin_eof: bool,
    /// Stop after this many seconds (0: run until stopped).
    #[arg(long, default_value_t = 0.0)]
    pub max_runtime_s: f64,
    /// Record every plan's input and output to this MCAP file (copied into a preallocated
    /// slot after the plan is published, outside the timed solve; one MCAP chunk per plan,
    /// so a killed planner loses at most the plan being written; `replay run` re-solves
    /// them). A warm-started plan also records its shifted guess and multipliers, so it
    /// replays on its own.
    #[arg(long)]
    pub record: Option<PathBuf>,
}

#[cfg(test)]
mod tests {
    use super::PlannerArgs;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: PlannerArgs,
    }

    fn parse(extra: &[&str]) -> PlannerArgs {
        let argv = std::iter::once("planner_proc").chain(extra.iter().copied());
        Cli::try_parse_from(argv).expect("options parse").args
    }

    #[test]
    fn relaxed_plans_keep_the_nominal_grip_unless_given_their_own() {
        assert_eq!(parse(&[]).relaxed_grip(), 1.0);
        assert_eq!(parse(&["--friction-scale", "0.9"]).relaxed_grip(), 0.9);
        let own = parse(&[
            "--friction-scale",
            "0.9",
            "--relaxed-friction-scale",
            "0.95",
        ]);
        assert_eq!(own.relaxed_grip(), 0.95);
    }
}
