//! Option types several subcommands share: the on/off, guess, barrier and KKT choices, the
//! steering-slew weight, and the input files and objective of the studies.

use std::path::PathBuf;

use clap::ValueEnum;
use planner::guess::GuessKind;
use planner::ip::kkt::KktBackendKind;
use planner::ip::BarrierRule;

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum OnOff {
    On,
    Off,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum GuessArg {
    Equilibrium,
    Zero,
    #[value(name = "road_speed")]
    RoadSpeed,
}

impl GuessArg {
    /// The planner's guess of this choice.
    pub fn kind(self) -> GuessKind {
        match self {
            GuessArg::Equilibrium => GuessKind::Equilibrium,
            GuessArg::Zero => GuessKind::Zero,
            GuessArg::RoadSpeed => GuessKind::RoadSpeed,
        }
    }
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum BarrierArg {
    Monotone,
    Adaptive,
    Quality,
    Probing,
    Loqo,
    Fullmpc,
    Dampmpc,
}

impl BarrierArg {
    /// The solver's barrier rule of this choice.
    pub fn rule(self) -> BarrierRule {
        match self {
            BarrierArg::Monotone => BarrierRule::Monotone,
            BarrierArg::Dampmpc => BarrierRule::Dampmpc,
            BarrierArg::Fullmpc => BarrierRule::Fullmpc,
            BarrierArg::Loqo => BarrierRule::Loqo,
            BarrierArg::Adaptive => BarrierRule::Adaptive,
            BarrierArg::Quality => BarrierRule::Quality,
            BarrierArg::Probing => BarrierRule::Probing,
        }
    }
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum KktArg {
    Sparse,
    Riccati,
    Auto,
}

impl KktArg {
    /// The solver's KKT backend of this choice.
    pub fn kind(self) -> KktBackendKind {
        match self {
            KktArg::Sparse => KktBackendKind::Sparse,
            KktArg::Riccati => KktBackendKind::Riccati,
            KktArg::Auto => KktBackendKind::Auto,
        }
    }
}

/// `--steering-slew-weight`: a number in [0, MAX_STEERING_SLEW_WEIGHT].
pub fn slew_weight_arg(v: &str) -> Result<f64, String> {
    let max = planner::ocp::MAX_STEERING_SLEW_WEIGHT;
    match v.parse::<f64>() {
        Ok(w) if (0.0..=max).contains(&w) => Ok(w),
        _ => Err(format!("`{v}` is not a weight in [0, {max}] 1/s")),
    }
}

/// `--budget-ms`: a wall-clock budget in (0, 1000 MAX_TIME_S] milliseconds.
pub fn budget_ms_arg(v: &str) -> Result<f64, String> {
    let max = 1e3 * planner::ip::settings::MAX_TIME_S;
    match v.parse::<f64>() {
        Ok(ms) if ms > 0.0 && ms <= max => Ok(ms),
        _ => Err(format!("`{v}` is not a budget in (0, {max}] ms")),
    }
}

// The input files and output options of the single-scenario studies (integrators,
// stiffness).
#[derive(clap::Args, Debug)]
pub struct StudyFiles {
    /// Scenario file.
    #[arg(long, default_value = "config/scenarios/oval.toml")]
    pub scenario: PathBuf,
    /// Vehicle file.
    #[arg(long, default_value = "config/vehicles/lc500.toml")]
    pub vehicle: PathBuf,
    /// Solver settings file (default: the shipped one for the objective solved,
    /// config/solver_min_time.toml for the pure minimum time, else config/solver.toml).
    #[arg(long)]
    pub solver: Option<PathBuf>,
    /// Print exactly one JSON object on stdout (the table goes to stderr).
    #[arg(long)]
    pub json: bool,
    /// Folder for the PNG.
    #[arg(long, default_value = "out")]
    pub out_dir: PathBuf,
    #[command(flatten)]
    pub objective: StudyObjective,
}

/// The objective a study solves.
#[derive(clap::Args, Debug)]
pub struct StudyObjective {
    /// Weight [1/s] of the objective's steering-slew term. Studies reproduce the paper, so
    /// they solve its pure minimum time (0) unless this is given (1: the shipped scenarios').
    #[arg(long, value_parser = slew_weight_arg)]
    pub steering_slew_weight: Option<f64>,
}

impl StudyObjective {
    /// The studies' steering-slew weight: the paper's pure minimum time unless given.
    pub fn slew(&self) -> f64 {
        self.steering_slew_weight.unwrap_or(0.0)
    }
}

// The options of the repeated-solve studies (segments, barrier).
#[derive(clap::Args, Debug)]
pub struct StudyCommon {
    /// Vehicle file.
    #[arg(long, default_value = "config/vehicles/lc500.toml")]
    pub vehicle: PathBuf,
    /// Solver settings file (default: the shipped one for the objective solved,
    /// config/solver_min_time.toml for the pure minimum time, else config/solver.toml).
    #[arg(long)]
    pub solver: Option<PathBuf>,
    /// Solves per run; the median time is reported.
    #[arg(long, default_value_t = 10)]
    pub repeat: usize,
    /// Print exactly one JSON object on stdout (tables go to stderr).
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub objective: StudyObjective,
}
