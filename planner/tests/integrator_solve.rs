//! The oval (N = 100) solved end to end through `planner::ip::Solver` with each new
//! transcription from the equilibrium guess; prints status, iterations and t_N.
//!
//! Explicit RK's derivatives come from the num-dual oracle and the collocation and
//! multistep schemes factorize with the sparse backend, so the wall-clock cap of the solver
//! file (`solver_min_time.toml`: the study's pure minimum time) is raised to 120 s; the
//! iteration cap is unchanged.

use std::path::Path;
use std::time::Instant;

use planner::config::{load_scenario, load_solver, load_vehicle, shipped_solver_file};
use planner::guess::{equilibrium, fill_equilibrium};
use planner::ip::{SolveInfo, Solver, Status};
use planner::model::{ix, NU, NX};
use planner::ocp::{
    CrankNicolson, DefectScheme, ExplicitRk2, ExplicitRk4, GaussLegendre2, LinearMultistep,
    Transcription,
};
use planner::plan::DEFAULT_GUESS_SPEED;

const N: usize = 100;
/// Crank-Nicolson optimum of the independent CasADi + IPOPT implementation (reference
/// README).
const T_REF_CN: f64 = 13.0200;
/// Implicit-Euler reference optimum (reference README); the higher-order schemes should
/// land near the CN value, all within ~1 % of this.
const T_REF_IE: f64 = 13.0699;

struct Outcome {
    info: SolveInfo,
    t_n: f64,
    secs: f64,
    max_iter: usize,
    states: Vec<[f64; NX]>,
}

fn solve_oval<S: DefectScheme>(scheme: S) -> Outcome {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let vehicle = load_vehicle(&root.join("vehicles/lc500.toml")).unwrap();
    let mut spec = load_scenario(&root.join("scenarios/oval.toml"), None, vehicle).unwrap();
    // The paper's integrator study solves its pure minimum time (eq. 3), as the references do.
    spec.steering_slew_weight = 0.0;
    let mut settings =
        load_solver(&root.join(shipped_solver_file(spec.steering_slew_weight))).unwrap();
    settings.max_time_s = 120.0;
    let max_iter = settings.max_iter;
    let eq = equilibrium(&spec.vehicle, spec.v_min, spec.v_max, DEFAULT_GUESS_SPEED).unwrap();
    let (mut xs, mut us) = (vec![[0.0; NX]; N + 1], vec![[0.0; NU]; N]);
    fill_equilibrium(&eq, spec.ds(), None, &mut xs, &mut us);
    let mut nlp = Transcription::<S, N>::with_scheme(spec, scheme).unwrap();
    nlp.set_initial_guess(&xs, &us);
    let mut solver = Solver::new(&nlp, settings).unwrap();
    let t0 = Instant::now();
    let info = solver.solve(&mut nlp);
    let secs = t0.elapsed().as_secs_f64();
    let (states, _) = nlp.trajectory_from(solver.x());
    let t_n = states[N][ix::T];
    println!(
        "| {} | {:?} | {} | {:.4} | {:.1} | {:.1e} |",
        nlp.scheme().name(),
        info.status,
        info.iterations,
        t_n,
        secs,
        info.max_violation
    );
    Outcome {
        info,
        t_n,
        secs,
        max_iter,
        states,
    }
}

/// Every solve ends with a finite iterate and a status that says what it is: a success
/// is feasible (to the acceptable level), and a failure is one of the failure statuses
/// with the violation it left reported (not `invalid_input`: the data is sound).
fn honest(o: &Outcome) {
    assert!(o.states.iter().flatten().all(|v| v.is_finite()));
    assert!(o.info.max_violation.is_finite() && o.info.objective.is_finite());
    if o.info.status.is_success() {
        assert!(o.info.max_violation <= 1e-4, "{:?}", o.info);
    } else {
        assert!(
            matches!(
                o.info.status,
                Status::IterationLimit
                    | Status::TimeLimit
                    | Status::LocallyInfeasible
                    | Status::NumericalFailure
            ),
            "{:?}",
            o.info
        );
    }
    if o.info.status == Status::IterationLimit {
        assert_eq!(o.info.iterations, o.max_iter);
    }
    let _ = o.secs;
}

/// Relative distance of t_N from a reference.
fn rel(t_n: f64, reference: f64) -> f64 {
    ((t_n - reference) / reference).abs()
}

#[test]
fn crank_nicolson_solves_the_oval() {
    let o = solve_oval(CrankNicolson);
    honest(&o);
    assert_eq!(o.info.status, Status::Optimal, "{:?}", o.info);
    assert!(o.info.max_violation < 1e-6);
    // The reference's 4-decimal rounding is 4e-6 relative; measured 13.0200.
    assert!(
        rel(o.t_n, T_REF_CN) < 3e-4,
        "t_N = {}, reference {T_REF_CN}",
        o.t_n
    );
}

/// Fourth order: lands on the continuous optimum, next to the CN value (measured 13.0190).
#[test]
fn gauss_legendre2_solves_the_oval() {
    let o = solve_oval(GaussLegendre2);
    honest(&o);
    assert_eq!(o.info.status, Status::Optimal, "{:?}", o.info);
    assert!(rel(o.t_n, T_REF_CN) < 5e-4, "t_N = {}", o.t_n);
    assert!(
        rel(o.t_n, T_REF_IE) > 2e-3,
        "t_N = {} is the first-order value",
        o.t_n
    );
}

/// Explicit midpoint (second order) is not A-stable, and its solve hangs on rounding: with
/// num-dual derivatives it converged near the CN value (13.0370 s, 134 iterations); with
/// the stage jets, equal to them within 2e-12 relative, it stays feasible but stops at the
/// iteration cap at 14.35 s (the paper's solvers all end RK2 sub-optimal). Either way it
/// must end honestly: converged near the CN optimum, or a cap's status, never a claimed
/// success elsewhere.
#[test]
fn rk2_oval_ends_honestly() {
    let o = solve_oval(ExplicitRk2);
    honest(&o);
    if o.info.status.is_success() {
        assert!(rel(o.t_n, T_REF_CN) < 3e-3, "t_N = {}", o.t_n);
    } else {
        assert!(
            matches!(o.info.status, Status::IterationLimit | Status::TimeLimit),
            "{:?}",
            o.info
        );
    }
}

#[test]
fn rk4_oval_ends_honestly() {
    // The reference implementation fails here (IPOPT Restoration_Failed), and so does
    // ours (numerical_failure after 317 iterations, violation 0.24): a failure status
    // with the violation it left, never a claimed success.
    let o = solve_oval(ExplicitRk4);
    honest(&o);
    if o.info.status.is_success() {
        assert!(rel(o.t_n, T_REF_CN) < 3e-3, "t_N = {}", o.t_n);
    } else {
        assert!(o.info.max_violation > 1e-4, "{:?}", o.info);
    }
}

/// The multistep schemes (start-up included) converge to the Crank-Nicolson optimum within
/// 0.1 % (last measured: BDF4 13.0210 s, BDF6 13.0247 s, AM3 13.0201 s).
#[test]
fn multistep_schemes_solve_the_oval() {
    for scheme in [
        LinearMultistep::BDF4,
        LinearMultistep::BDF6,
        LinearMultistep::ADAMS_MOULTON3,
    ] {
        let o = solve_oval(scheme);
        honest(&o);
        assert_eq!(o.info.status, Status::Optimal, "{scheme:?}: {:?}", o.info);
        assert!(rel(o.t_n, T_REF_CN) < 1e-3, "{scheme:?}: t_N = {}", o.t_n);
    }
}
