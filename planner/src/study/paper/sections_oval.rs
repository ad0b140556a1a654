//! The report's oval sections: Table I and Fig. 4a (integrators), Fig. 3 (stiffness), the
//! initial infeasibility and Fig. 4b (the oval's iterates).

use std::fmt::Write as _;
use std::path::PathBuf;

use super::iterates::{violation_both, Recorder};
use super::{link, published, PaperConfig};
use crate::config::load_scenario_for_horizon;
use crate::guess::{equilibrium, fill_equilibrium, fill_zero, GuessKind};
use crate::ip::{Settings, SolveInfo, Solver};
use crate::model::{ix, NU, NX, STATE_NAMES};
use crate::ocp::{ImplicitEulerNlp, OcpSpec};
use crate::plan::{Planner, DEFAULT_GUESS_SPEED};
use crate::study::integrators::{run_study, Integrator, StudyConfig};
use crate::study::StudyError;
use crate::HORIZON;

/// One solve with its iterates.
pub(super) struct Recorded {
    /// The solve's summary.
    pub info: SolveInfo,
    /// Scaled decision vectors of the iterates (the start first, the returned point last).
    pub iterates: Vec<Vec<f64>>,
    /// Violation of the raw guess (before the bound push): (scaled, physical, row).
    pub guess_violation: (f64, f64, String),
    /// Violation where the iteration starts (after the push): (scaled, physical, row).
    pub start_violation: (f64, f64, String),
    /// Physical (states, controls) of every iterate.
    pub trajectories: Vec<super::plots::PhysTrajectory>,
}

/// Loads `select` of `file` for N = [`HORIZON`] with the pure minimum time.
pub(super) fn load(
    cfg: &PaperConfig,
    file: &std::path::Path,
    select: Option<&str>,
) -> Result<OcpSpec, StudyError> {
    let mut spec = load_scenario_for_horizon(file, select, cfg.vehicle, HORIZON)?;
    spec.steering_slew_weight = 0.0;
    Ok(spec)
}

/// Solves `spec` from `guess` and keeps every iterate.
pub(super) fn solve_recorded(
    spec: &OcpSpec,
    settings: Settings,
    guess: GuessKind,
) -> Result<Recorded, StudyError> {
    let (mut xs, mut us) = (vec![[0.0; NX]; HORIZON + 1], vec![[0.0; NU]; HORIZON]);
    match guess {
        GuessKind::Equilibrium => {
            let eq = equilibrium(&spec.vehicle, spec.v_min, spec.v_max, DEFAULT_GUESS_SPEED)?;
            fill_equilibrium(&eq, spec.ds(), None, &mut xs, &mut us);
        }
        GuessKind::Zero => fill_zero(None, &mut xs, &mut us),
        GuessKind::RoadSpeed => {
            let eq = equilibrium(&spec.vehicle, spec.v_min, spec.v_max, DEFAULT_GUESS_SPEED)?;
            let (ds, kappa, p) = (spec.ds(), &spec.kappa, &spec.vehicle);
            crate::guess::fill_road_speed(&eq, ds, kappa, p, None, &mut xs, &mut us);
        }
    }
    let mut nlp = ImplicitEulerNlp::<HORIZON>::new(spec.clone())?;
    nlp.set_initial_guess(&xs, &us);
    let mut z0 = vec![0.0; crate::ip::Nlp::dims(&nlp).n];
    crate::ip::Nlp::initial_point(&nlp, &mut z0);
    let guess_violation = violation_both(&mut nlp, &z0);
    let mut solver = Solver::new(&nlp, settings)?;
    let (info, iterates) = {
        let mut rec = Recorder::new(&mut nlp);
        let info = solver.solve(&mut rec);
        let mut it = rec.iterates;
        if it.last().is_none_or(|l| l.as_slice() != solver.x()) {
            it.push(solver.x().to_vec());
        }
        (info, it)
    };
    let start_violation = match iterates.first() {
        Some(z) => violation_both(&mut nlp, z),
        None => (f64::NAN, f64::NAN, "-".into()),
    };
    let trajectories = iterates.iter().map(|z| nlp.trajectory_from(z)).collect();
    Ok(Recorded {
        info,
        iterates,
        guess_violation,
        start_violation,
        trajectories,
    })
}

/// Table I and Fig. 4a.
pub(super) fn integrators(
    cfg: &PaperConfig,
    figures: &mut Vec<PathBuf>,
    progress: &mut dyn FnMut(&str),
) -> Result<String, StudyError> {
    let spec = load(cfg, &cfg.oval, None)?;
    let mut settings = cfg.settings;
    settings.max_time_s = 120.0;
    let config = StudyConfig {
        repeat: cfg.repeat(),
        integrators: Integrator::ALL
            .into_iter()
            .filter(|i| *i != Integrator::REFERENCE)
            .collect(),
        reference: Integrator::REFERENCE,
    };
    let study = run_study::<HORIZON>(&spec, &settings, &config, |r| {
        progress(&format!(
            "  {}: {} in {} iterations, {:.1} ms",
            r.integrator.name(),
            r.status,
            r.iterations,
            r.median_ms
        ))
    })?;
    let png = cfg.out_dir.join("fig4a_integrators.png");
    crate::study::figures::plot_integrator_study(&study, &png)?;
    figures.push(png.clone());
    let mut s = String::new();
    let _ = writeln!(s, "## Table I and Fig. 4a: integrators\n");
    let _ = writeln!(
        s,
        "The oval from the equilibrium guess with each integrator (median of {} solve(s)), \
         against the paper's CPU times (KNITRO / IPOPT / SNOPT, non-JIT; `*` = the paper's \
         red, sub-optimal; NS = no solution). NRMSE: the largest over the three controls of \
         100 % RMS(u - u*) / range(u*), u* the Gauss-Legendre 3 solution, over all N \
         intervals and over intervals 1..N-1 (interval 0 follows the free initial state).\n",
        cfg.repeat()
    );
    let _ = writeln!(
        s,
        "| integrator | A-stable | status | iter | ms | ms/iter | KKT backend | derivatives | \
         max NRMSE % (all / excl. 0) | paper KNITRO s | paper IPOPT s | paper SNOPT s |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|");
    for r in &study.runs {
        let paper = published::TABLE_I
            .iter()
            .find(|(n, _)| *n == r.integrator.name())
            .map(|(_, t)| {
                t.map(|c| {
                    c.map_or("NS".into(), |(v, red)| {
                        format!("{v}{}", if red { "*" } else { "" })
                    })
                })
            });
        let p = paper.unwrap_or_else(|| ["(ground truth)".into(), "-".into(), "-".into()]);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {:.1} | {:.3} | {} | {} | {:.3} / {:.3} | {} | {} | {} |",
            r.integrator.name(),
            if r.a_stable { "yes" } else { "no" },
            r.status,
            r.iterations,
            r.median_ms,
            r.ms_per_iteration,
            r.kkt_backend,
            r.derivatives,
            r.max_nrmse_pct,
            r.max_nrmse_pct_excl0,
            p[0],
            p[1],
            p[2]
        );
    }
    let _ = writeln!(
        s,
        "\nEvery scheme whose defect is linear in the states and in f at fixed points \
         (implicit Euler, BDF, Adams-Moulton, Crank-Nicolson, Gauss-Legendre) takes its exact \
         derivatives from the same hand-written jets of f at each point; explicit RK2 / RK4 \
         nest f inside f and carry lean jets through their stages (the derivatives column). The schemes that \
         couple more than two nodes or carry stage variables (BDF, Adams-Moulton, \
         Gauss-Legendre) are factorized by the sparse LDL^T instead of the Riccati recursion \
         (the backend column): that cost follows from the integrator's coupling and is part \
         of its price. The `schemes` group of `bench/benches/eval.rs` times one Jacobian plus \
         Hessian of each scheme with both derivative codes side by side.\n"
    );
    let _ = writeln!(
        s,
        "Fig. 4a (max NRMSE against time): ![Fig. 4a]({})\n",
        link(cfg, &png)
    );
    let _ = writeln!(s, "The paper's Fig. 4a, as its text states it:\n");
    for (name, band) in published::FIG_4A_NRMSE {
        let _ = writeln!(s, "- {name}: {band}");
    }
    s.push('\n');
    Ok(s)
}

/// Fig. 3: the stiffness ratio along the oval's optimum.
pub(super) fn stiffness(
    cfg: &PaperConfig,
    figures: &mut Vec<PathBuf>,
) -> Result<String, StudyError> {
    let spec = load(cfg, &cfg.oval, None)?;
    let mut planner = Planner::<HORIZON>::new(spec, cfg.settings)?;
    let info = planner.solve(GuessKind::Equilibrium);
    let spec = planner.spec().clone();
    let study = crate::study::stiffness::analyze(
        &spec.vehicle,
        planner.states(),
        planner.controls(),
        &spec.kappa,
        spec.ds(),
    )?;
    let png = cfg.out_dir.join("fig3_stiffness.png");
    crate::study::figures::plot_stiffness(&study, "oval: stiffness ratio along the optimum", &png)?;
    figures.push(png.clone());
    let mut s = String::new();
    let _ = writeln!(s, "## Fig. 3: stiffness\n");
    let fmt = |v: Option<f64>| v.map_or("none".to_string(), |r| format!("{r:.0}"));
    let peak_s = study.peak_node.map_or(f64::NAN, |k| study.nodes[k].s);
    let top = study
        .peak_node
        .map(|k| top_participation(&study.nodes[k].participation))
        .unwrap_or_default();
    let dominant: Vec<String> = STATE_NAMES
        .iter()
        .zip(study.dominant_counts)
        .filter(|(_, c)| *c > 0)
        .map(|(n, c)| format!("{n} at {c} nodes"))
        .collect();
    let _ = writeln!(s, "| quantity | here | paper |\n|---|---|---|");
    let _ = writeln!(
        s,
        "| peak stiffness ratio (nodes 1..N) | {} at node {} (s = {:.1} m) | > {} |",
        fmt(study.peak_ratio),
        study.peak_node.map_or("-".into(), |k| k.to_string()),
        peak_s,
        published::STIFFNESS_PEAK_ABOVE
    );
    let _ = writeln!(
        s,
        "| state of the fastest mode at the peak (participation) | {} | {} |",
        top,
        published::STIFFNESS_STATE
    );
    let _ = writeln!(
        s,
        "| dominant state of the fastest mode, node by node | {} | {} |",
        dominant.join(", "),
        published::STIFFNESS_STATE
    );
    let _ = writeln!(
        s,
        "| nodes above 1e3 | {} of {} | (peaks during aggressive manoeuvres) |",
        study.nodes_above_1e3,
        study.nodes.len().saturating_sub(1)
    );
    let _ = writeln!(
        s,
        "| vehicle dynamics only (r, V, beta, V_wr, dFz) | {} at node {}, {} | - |",
        fmt(study.dynamic_peak_ratio),
        study
            .dynamic_peak_node
            .map_or("-".into(), |k| k.to_string()),
        study.dynamic_peak_dominant_state.unwrap_or("-")
    );
    let modes = study
        .peak_node
        .map(|k| decaying_modes(&study.nodes[k]))
        .unwrap_or_default();
    let _ = writeln!(
        s,
        "\nThe optimum: {} in {} iterations. Eigenvalues are those of the spatial Jacobian \
         d(dx/ds)/dx \\[1/m\\] (the transcription integrates in s). Decaying modes at the peak \
         node, fastest first (real part, dominant state): {}. The fastest mode is the wheel \
         speed V_wr of `{}` (its wheel inertia and tire slip stiffness set the rate), then the \
         load transfer dFz; the paper's sideslip beta is not the fastest mode here. The peak \
         ratio is large because its denominator, the slowest decaying mode, is nearly zero \
         there.\n",
        info.status.name(),
        info.iterations,
        modes,
        cfg.vehicle_file
    );
    let _ = writeln!(s, "![Fig. 3]({})\n", link(cfg, &png));
    Ok(s)
}

/// "V_wr -0.945, dFz -0.282, ...": the decaying eigenvalues' real parts, fastest first,
/// with each mode's dominant state.
fn decaying_modes(node: &crate::study::stiffness::NodeStiffness) -> String {
    let mut modes: Vec<(f64, &str)> = node
        .eigenvalues
        .iter()
        .zip(&node.mode_states)
        .filter(|((re, _), _)| *re < 0.0)
        .map(|((re, _), st)| (*re, *st))
        .collect();
    modes.sort_by(|a, b| a.0.total_cmp(&b.0));
    modes
        .iter()
        .map(|(re, st)| format!("{st} {re:.3e}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// "beta 0.93, V_wr 0.05": the states with participation above 1 % in decreasing order.
fn top_participation(p: &[f64; NX]) -> String {
    let mut idx: Vec<usize> = (0..NX).filter(|&i| p[i] > 0.01).collect();
    idx.sort_by(|&a, &b| p[b].total_cmp(&p[a]));
    idx.iter()
        .map(|&i| format!("{} {:.2}", STATE_NAMES[i], p[i]))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The initial infeasibility (Sec. VI-B) and Fig. 4b (the oval's iterates).
pub(super) fn oval_iterates(
    cfg: &PaperConfig,
    figures: &mut Vec<PathBuf>,
) -> Result<String, StudyError> {
    let spec = load(cfg, &cfg.oval, None)?;
    let eq = solve_recorded(&spec, cfg.settings, GuessKind::Equilibrium)?;
    let zero = solve_recorded(&spec, cfg.settings, GuessKind::Zero)?;
    let mut s = String::new();
    let _ = writeln!(s, "## Initial infeasibility (Sec. VI-B)\n");
    let _ = writeln!(
        s,
        "Max constraint violation of the oval's starting point: scaled (the NLP the solver \
         sees) and in the paper's units (the unscaled NLP: defects in the states' SI units, \
         friction rows in N), at the guess itself and after the solver pushes it into the \
         variable bounds.\n"
    );
    let _ = writeln!(
        s,
        "| guess | scaled | physical (row) | after the bound push: scaled | physical (row) | paper |\n|---|---|---|---|---|---|"
    );
    for (name, r, paper) in [
        ("equilibrium", &eq, published::INITIAL_VIOLATION.0),
        ("zero", &zero, published::INITIAL_VIOLATION.1),
    ] {
        let _ = writeln!(
            s,
            "| {name} | {:.3e} | {:.3e} ({}) | {:.3e} | {:.3e} ({}) | {paper:.1e} |",
            r.guess_violation.0,
            r.guess_violation.1,
            r.guess_violation.2,
            r.start_violation.0,
            r.start_violation.1,
            r.start_violation.2
        );
    }
    let ratio = |a: f64, b: f64| if a > 0.0 { b / a } else { f64::NAN };
    let _ = writeln!(
        s,
        "\nZero over equilibrium: {:.1e} physical at the guess, {:.1e} after the push (the \
         paper: {:.1e}, \"four orders of magnitude\"). The zero guess has V = 0, where the \
         model divides by the speed, so its raw violation can be infinite; the solver starts \
         from the pushed point.\n",
        ratio(eq.guess_violation.1, zero.guess_violation.1),
        ratio(eq.start_violation.1, zero.start_violation.1),
        published::INITIAL_VIOLATION.1 / published::INITIAL_VIOLATION.0
    );
    let png = cfg.out_dir.join("fig4b_oval_iterates.png");
    super::plots::plot_iterates(&spec, &eq.trajectories, &png)?;
    figures.push(png.clone());
    let _ = writeln!(s, "## Fig. 4b: the oval's iterates\n");
    let _ = writeln!(
        s,
        "| | here | paper |\n|---|---|---|\n| iterations | {} ({}) | {} |\n| solve time | {:.1} ms \
         (one solve, iterates recorded) | {:.0} ms (JIT) |\n| t_N | {:.4} s | - |\n",
        eq.info.iterations,
        eq.info.status.name(),
        published::FIG_4B.0,
        eq.info.times.total * 1e3,
        published::FIG_4B.1 * 1e3,
        eq.trajectories
            .last()
            .map_or(f64::NAN, |(x, _)| x.last().map_or(f64::NAN, |x| x[ix::T]))
    );
    let _ = writeln!(
        s,
        "Every iterate from the guess (light) to the optimum (dark): path, speed, sideslip and \
         steering. ![Fig. 4b]({})\n",
        link(cfg, &png)
    );
    Ok(s)
}
