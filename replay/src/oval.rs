//! `replay record-oval`: a 10 Hz replanning drive along the oval, recorded with the
//! [`plan_record::Recorder`] in one process (no IPC planner and tracker processes needed).
//!
//! The oval is solved once from a free start; plan i then starts at the state that
//! trajectory reaches at t = i / rate (linear interpolation between nodes), with that
//! state fixed (s and t reset to 0) and the road ahead taken from the exact piecewise
//! curvature shifted by its arc length, wrapping around the lap.
//!
//! With warm start (the planner process's default), plan i > 0 starts from plan i - 1
//! shifted by the arc length driven, primal and dual (`Planner::replan_warm`), and is
//! recorded with that start, so `replay run` re-solves it bit for bit; without, every plan
//! starts from the equilibrium guess in a fresh planner.

use std::path::{Path, PathBuf};
use std::time::Instant;

use plan_record::{now_ns, Record, RecordStats, Recorder};
use plan_record::{PlanWarmStart, WARM_GUESS};
use planner::config::{load_scenario_for_horizon, load_solver, load_vehicle};
use planner::guess::GuessKind;
use planner::model::{ix, NX};
use planner::ocp::{InitialState, OcpSpec};
use planner::plan::{shift_plan, Planner, WarmOptions};
use planner::record::{plan_input, plan_output, write_warm};
use planner::track::piecewise_constant;

use crate::N;

/// What to record.
#[derive(Debug, Clone)]
pub struct OvalOptions {
    /// Scenario file (the oval).
    pub scenario: PathBuf,
    /// Vehicle file.
    pub vehicle: PathBuf,
    /// Solver settings file.
    pub solver: PathBuf,
    /// Number of plans.
    pub plans: usize,
    /// Replanning rate \[Hz\].
    pub rate_hz: f64,
    /// Output file.
    pub out: PathBuf,
    /// Warm-start each plan from the previous one.
    pub warm_start: bool,
    /// Tire saturation rows at each plan's last node too (`OcpSpec::saturation_at_end`).
    pub saturation_at_end: bool,
    /// How a warm start's first barrier parameter is matched to the shifted point.
    pub mu_match: planner::ip::MuMatch,
    /// Guess of a cold plan: the first, and every plan without warm start.
    pub cold_guess: GuessKind,
}

/// Why the drive could not be recorded.
#[derive(Debug, thiserror::Error)]
pub enum OvalError {
    /// A config file is invalid.
    #[error(transparent)]
    Config(#[from] planner::config::ConfigError),
    /// The scenario file lacks the oval's exact curvature.
    #[error("{file}: field `{field}`: {problem}")]
    Track {
        /// The file.
        file: PathBuf,
        /// The field.
        field: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// The options are out of range.
    #[error("{0}")]
    Options(String),
    /// A planner could not be built.
    #[error(transparent)]
    Plan(#[from] planner::plan::PlanError),
    /// The first (free-start) lap did not solve.
    #[error("the free-start lap ended {0}; cannot drive along it")]
    Lap(&'static str),
    /// The recorder failed.
    #[error(transparent)]
    Record(#[from] plan_record::RecordError),
}

/// What was recorded.
#[derive(Debug, Clone)]
pub struct OvalSummary {
    /// Recorder counts.
    pub stats: RecordStats,
    /// Solve latency per plan while recording \[ms\].
    pub latency_ms: Vec<f64>,
    /// Status per plan.
    pub statuses: Vec<&'static str>,
}

struct Track {
    pieces: Vec<(f64, f64)>,
    lap: f64,
}

fn read_track(path: &Path) -> Result<Track, OvalError> {
    let bad = |field, problem: String| OvalError::Track {
        file: path.to_path_buf(),
        field,
        problem,
    };
    let text = std::fs::read_to_string(path).map_err(|e| bad("file", e.to_string()))?;
    let v: toml::Table = toml::from_str(&text).map_err(|e| bad("file", e.to_string()))?;
    let lap = v
        .get("geometry")
        .and_then(|g| g.get("lap_length_m"))
        .and_then(toml::Value::as_float)
        .filter(|l| *l > 0.0)
        .ok_or_else(|| bad("geometry.lap_length_m", "missing or not positive".into()))?;
    let raw = v
        .get("track")
        .and_then(|t| t.get("kappa_pieces"))
        .and_then(toml::Value::as_array)
        .ok_or_else(|| bad("track.kappa_pieces", "missing".into()))?;
    let mut pieces = Vec::with_capacity(raw.len());
    for (i, p) in raw.iter().enumerate() {
        let pair = p
            .as_array()
            .filter(|a| a.len() == 2)
            .and_then(|a| {
                let f = |x: &toml::Value| x.as_float().or(x.as_integer().map(|i| i as f64));
                Some((f(&a[0])?, f(&a[1])?))
            })
            .ok_or_else(|| bad("track.kappa_pieces", format!("entry {i} is not [s, kappa]")))?;
        pieces.push(pair);
    }
    Ok(Track { pieces, lap })
}

/// The planned state at time t (linear between nodes), or None past the end.
fn state_at(xs: &[[f64; NX]], t: f64) -> Option<[f64; NX]> {
    let k = xs.windows(2).position(|w| w[1][ix::T] >= t)?;
    let (a, b) = (&xs[k], &xs[k + 1]);
    let w = ((t - a[ix::T]) / (b[ix::T] - a[ix::T])).clamp(0.0, 1.0);
    let mut x = [0.0; NX];
    for i in 0..NX {
        x[i] = a[i] + w * (b[i] - a[i]);
    }
    Some(x)
}

/// The problem of plan i: start state fixed, road ahead from arc length s0.
fn shifted_spec(base: &OcpSpec, track: &Track, s0: f64, x: [f64; NX]) -> OcpSpec {
    let mut spec = base.clone();
    let ds = base.ds();
    for (k, kappa) in spec.kappa.iter_mut().enumerate() {
        *kappa = piecewise_constant(&track.pieces, (s0 + k as f64 * ds).rem_euclid(track.lap));
    }
    let mut x0 = x;
    x0[ix::S] = 0.0;
    x0[ix::T] = 0.0;
    spec.initial = InitialState::Fixed(x0);
    spec.name = format!("oval@{s0:.1}m");
    spec
}

/// Plan `spec` (its road and fixed start) warm-started on `planner` from its last
/// successful plan, `xs` and `us`, shifted by `shift` metres: the solve, its time \[ms\]
/// and the warm start to record (as plan `seq` stamped `stamp`).
fn warm_plan(
    planner: &mut Planner<N>,
    spec: &OcpSpec,
    (shift, mu_match): (f64, planner::ip::MuMatch),
    (seq, stamp): (u64, u64),
) -> Result<(planner::ip::SolveInfo, f64, PlanWarmStart), OvalError> {
    let InitialState::Fixed(x0) = spec.initial else {
        return Err(OvalError::Options("a drive plan has a fixed start".into()));
    };
    let (mut gx, mut gu) = (vec![[0.0; NX]; N + 1], vec![[0.0; planner::model::NU]; N]);
    let Some((xs, us)) = planner.warm_source() else {
        return Err(OvalError::Options(format!(
            "plan {seq}: no successful plan to warm-start from"
        )));
    };
    shift_plan(xs, us, spec.ds(), shift, &x0, &mut gx, &mut gu);
    let opts = WarmOptions {
        mu_match,
        ..WarmOptions::default()
    };
    let t0 = Instant::now();
    let r = planner.replan_warm(
        &spec.kappa,
        &spec.e_min,
        &spec.e_max,
        x0,
        (&gx, &gu),
        shift,
        opts,
    )?;
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    let mut w = PlanWarmStart::with_capacity(N, 0, 0);
    write_warm(
        &mut w,
        (seq, stamp, shift),
        &opts,
        (&gx, &gu),
        planner.warm_duals(),
    );
    Ok((r.info, ms, w))
}

/// Records the drive; `progress` is called after each plan with (i, latency_ms, status).
pub fn record_oval(
    opts: &OvalOptions,
    mut progress: impl FnMut(usize, f64, &str),
) -> Result<OvalSummary, OvalError> {
    if opts.plans == 0 || !(opts.rate_hz > 0.0 && opts.rate_hz.is_finite()) {
        return Err(OvalError::Options(
            "--plans must be at least 1 and --rate-hz positive".into(),
        ));
    }
    let vehicle = load_vehicle(&opts.vehicle)?;
    let base = load_scenario_for_horizon(&opts.scenario, None, vehicle, planner::HORIZON)?;
    if base.n_intervals != N {
        return Err(OvalError::Options(format!(
            "scenario has n_intervals = {}, this build solves N = {N}",
            base.n_intervals
        )));
    }
    let settings = load_solver(&opts.solver)?;
    let track = read_track(&opts.scenario)?;
    let guess = opts.cold_guess;

    let mut lap = Planner::<N>::new(base.clone(), settings)?;
    let info = lap.solve(GuessKind::Equilibrium);
    if !info.status.is_success() {
        return Err(OvalError::Lap(info.status.name()));
    }
    let xs = lap.states().to_vec();
    let t_end = xs.last().map_or(0.0, |x| x[ix::T]);
    let dt = 1.0 / opts.rate_hz;
    if (opts.plans - 1) as f64 * dt > t_end {
        return Err(OvalError::Options(format!(
            "{} plans at {} Hz need {:.1} s, the planned lap lasts {t_end:.2} s",
            opts.plans,
            opts.rate_hz,
            (opts.plans - 1) as f64 * dt
        )));
    }

    let recorder = Recorder::create(&opts.out, 64)?;
    let start = now_ns();
    let mut latency_ms = Vec::with_capacity(opts.plans);
    let mut statuses = Vec::with_capacity(opts.plans);
    // The planner of the previous plans and the arc length its last successful plan (the
    // warm start's source) started at.
    let mut previous: Option<(Planner<N>, f64)> = None;
    for i in 0..opts.plans {
        let t = i as f64 * dt;
        let x = state_at(&xs, t)
            .ok_or_else(|| OvalError::Options(format!("t = {t} s past the lap")))?;
        let mut spec = shifted_spec(&base, &track, x[ix::S], x);
        spec.saturation_at_end = opts.saturation_at_end;
        // Stamps on the drive's 10 Hz clock, so the file's duration is the drive's.
        let stamp = start + (t * 1e9).round() as u64;
        let mut input = plan_input(&spec, &settings, guess, i as u64, stamp);
        let s_src_before = previous.as_ref().map(|(_, s)| *s);
        let (planner, info, ms, warm) = match previous.take() {
            Some((mut planner, s_src)) if opts.warm_start && planner.warm_source().is_some() => {
                input.guess = WARM_GUESS.into();
                let shift = x[ix::S] - s_src;
                let (info, ms, w) = warm_plan(
                    &mut planner,
                    &spec,
                    (shift, opts.mu_match),
                    (i as u64, stamp),
                )?;
                (planner, info, ms, Some(w))
            }
            _ => {
                let mut planner = Planner::<N>::new(spec, settings)?;
                let t0 = Instant::now();
                let info = planner.solve(guess);
                (planner, info, t0.elapsed().as_secs_f64() * 1e3, None)
            }
        };
        let done = stamp + (ms * 1e6) as u64;
        let output = plan_output(i as u64, done, &info, planner.states(), planner.controls());
        recorder.record(Record::Input(Box::new(input)));
        if let Some(w) = warm {
            recorder.record(Record::Warm(Box::new(w)));
        }
        recorder.record(Record::Output(Box::new(output)));
        latency_ms.push(ms);
        statuses.push(info.status.name());
        progress(i, ms, info.status.name());
        let s_src = if info.status.is_success() {
            x[ix::S]
        } else {
            s_src_before.unwrap_or(x[ix::S])
        };
        previous = Some((planner, s_src));
    }
    let stats = recorder.finish()?;
    Ok(OvalSummary {
        stats,
        latency_ms,
        statuses,
    })
}
