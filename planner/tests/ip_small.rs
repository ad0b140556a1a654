//! Small NLPs with known solutions: the interior-point solver must find them, detect
//! infeasibility, and handle an indefinite Hessian.

use planner::ip::{BarrierRule, Nlp, NlpDims, Settings, Solver, Status};

type F = fn(&[f64]) -> f64;
type G = fn(&[f64], &mut [f64]);
type H = fn(&[f64], f64, &[f64], &mut [f64]);

/// A dense test problem: Jacobian m x n row-major, Hessian lower triangle row-major.
struct Dense {
    n: usize,
    m: usize,
    x0: Vec<f64>,
    x_l: Vec<f64>,
    x_u: Vec<f64>,
    g_l: Vec<f64>,
    g_u: Vec<f64>,
    f: F,
    grad: G,
    g: G,
    jac: G,
    hess: H,
}

impl Nlp for Dense {
    fn dims(&self) -> NlpDims {
        NlpDims {
            n: self.n,
            m: self.m,
            nnz_jac: self.n * self.m,
            nnz_hess: self.n * (self.n + 1) / 2,
        }
    }
    fn bounds(&self, x_l: &mut [f64], x_u: &mut [f64], g_l: &mut [f64], g_u: &mut [f64]) {
        x_l.copy_from_slice(&self.x_l);
        x_u.copy_from_slice(&self.x_u);
        g_l.copy_from_slice(&self.g_l);
        g_u.copy_from_slice(&self.g_u);
    }
    fn initial_point(&self, x: &mut [f64]) {
        x.copy_from_slice(&self.x0);
    }
    fn jac_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        let mut k = 0;
        for i in 0..self.m {
            for j in 0..self.n {
                rows[k] = i;
                cols[k] = j;
                k += 1;
            }
        }
    }
    fn hess_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        let mut k = 0;
        for i in 0..self.n {
            for j in 0..=i {
                rows[k] = i;
                cols[k] = j;
                k += 1;
            }
        }
    }
    fn eval_f(&mut self, x: &[f64]) -> f64 {
        (self.f)(x)
    }
    fn eval_grad_f(&mut self, x: &[f64], g: &mut [f64]) {
        (self.grad)(x, g)
    }
    fn eval_g(&mut self, x: &[f64], g: &mut [f64]) {
        (self.g)(x, g)
    }
    fn eval_jac_g(&mut self, x: &[f64], v: &mut [f64]) {
        (self.jac)(x, v)
    }
    fn eval_hess(&mut self, x: &[f64], s: f64, l: &[f64], v: &mut [f64]) {
        (self.hess)(x, s, l, v)
    }
}

const INF: f64 = f64::INFINITY;

fn hs071() -> Dense {
    Dense {
        n: 4,
        m: 2,
        x0: vec![1.0, 5.0, 5.0, 1.0],
        x_l: vec![1.0; 4],
        x_u: vec![5.0; 4],
        g_l: vec![25.0, 40.0],
        g_u: vec![INF, 40.0],
        f: |x| x[0] * x[3] * (x[0] + x[1] + x[2]) + x[2],
        grad: |x, g| {
            g[0] = x[3] * (2.0 * x[0] + x[1] + x[2]);
            g[1] = x[0] * x[3];
            g[2] = x[0] * x[3] + 1.0;
            g[3] = x[0] * (x[0] + x[1] + x[2]);
        },
        g: |x, g| {
            g[0] = x[0] * x[1] * x[2] * x[3];
            g[1] = x.iter().map(|v| v * v).sum();
        },
        jac: |x, v| {
            v[0] = x[1] * x[2] * x[3];
            v[1] = x[0] * x[2] * x[3];
            v[2] = x[0] * x[1] * x[3];
            v[3] = x[0] * x[1] * x[2];
            for j in 0..4 {
                v[4 + j] = 2.0 * x[j];
            }
        },
        hess: |x, s, l, v| {
            // Lower triangle row-major: (0,0) (1,0) (1,1) (2,0) (2,1) (2,2) (3,0) .. (3,3)
            let mut h = [[0.0; 4]; 4];
            h[0][0] = s * 2.0 * x[3];
            h[1][0] = s * x[3];
            h[2][0] = s * x[3];
            h[3][0] = s * (2.0 * x[0] + x[1] + x[2]);
            h[3][1] = s * x[0];
            h[3][2] = s * x[0];
            h[1][0] += l[0] * x[2] * x[3];
            h[2][0] += l[0] * x[1] * x[3];
            h[3][0] += l[0] * x[1] * x[2];
            h[2][1] += l[0] * x[0] * x[3];
            h[3][1] += l[0] * x[0] * x[2];
            h[3][2] += l[0] * x[0] * x[1];
            for (i, row) in h.iter_mut().enumerate() {
                row[i] += 2.0 * l[1];
            }
            let mut k = 0;
            for (i, row) in h.iter().enumerate() {
                for &val in row.iter().take(i + 1) {
                    v[k] = val;
                    k += 1;
                }
            }
        },
    }
}

fn solve(p: &mut Dense, barrier: BarrierRule) -> (planner::ip::SolveInfo, Vec<f64>) {
    let settings = Settings {
        barrier,
        ..Settings::default()
    };
    let mut solver = Solver::new(p, settings).expect("setup");
    let info = solver.solve(p);
    (info, solver.x().to_vec())
}

#[test]
fn hs071_every_barrier_rule() {
    for rule in BarrierRule::ALL {
        let mut p = hs071();
        let (info, x) = solve(&mut p, rule);
        assert_eq!(info.status, Status::Optimal, "{rule:?}: {info:?}");
        assert!(
            (info.objective - 17.014_017_3).abs() < 1e-5,
            "{rule:?}: f = {}",
            info.objective
        );
        let want = [1.0, 4.742_999_6, 3.821_150_0, 1.379_408_3];
        for (a, b) in x.iter().zip(want) {
            assert!((a - b).abs() < 1e-4, "{rule:?}: x = {x:?}");
        }
        println!("{rule:?}: {} iterations", info.iterations);
        assert!(
            info.iterations < 60,
            "{rule:?}: {} iterations",
            info.iterations
        );
    }
}

#[test]
fn active_bound_is_found() {
    // min (x - 3)^2 s.t. x <= 1: solution on the bound.
    let mut p = Dense {
        n: 1,
        m: 0,
        x0: vec![0.0],
        x_l: vec![-INF],
        x_u: vec![1.0],
        g_l: vec![],
        g_u: vec![],
        f: |x| (x[0] - 3.0).powi(2),
        grad: |x, g| g[0] = 2.0 * (x[0] - 3.0),
        g: |_, _| {},
        jac: |_, _| {},
        hess: |_, s, _, v| v[0] = 2.0 * s,
    };
    let (info, x) = solve(&mut p, BarrierRule::Dampmpc);
    assert_eq!(info.status, Status::Optimal);
    assert!((x[0] - 1.0).abs() < 1e-6, "x = {x:?}");
}

#[test]
fn indefinite_hessian_needs_inertia_correction() {
    // min x0^2 - x1^2 with x1 in [-1, 2]: the Hessian is indefinite everywhere; the local
    // minima are (0, 2) and (0, -1). Newton without inertia correction would climb to x1 = 0.
    let mut p = Dense {
        n: 2,
        m: 0,
        x0: vec![0.3, 0.2],
        x_l: vec![-INF, -1.0],
        x_u: vec![INF, 2.0],
        g_l: vec![],
        g_u: vec![],
        f: |x| x[0] * x[0] - x[1] * x[1],
        grad: |x, g| {
            g[0] = 2.0 * x[0];
            g[1] = -2.0 * x[1];
        },
        g: |_, _| {},
        jac: |_, _| {},
        hess: |_, s, _, v| {
            v[0] = 2.0 * s;
            v[1] = 0.0;
            v[2] = -2.0 * s;
        },
    };
    for rule in BarrierRule::ALL {
        let (info, x) = solve(&mut p, rule);
        assert_eq!(info.status, Status::Optimal, "{rule:?} {info:?}");
        assert!(x[0].abs() < 1e-6);
        assert!(
            (x[1] - 2.0).abs() < 1e-6 || (x[1] + 1.0).abs() < 1e-6,
            "{rule:?} x = {x:?}"
        );
        assert!(
            info.max_factorizations_per_iter > 1,
            "no inertia correction happened"
        );
    }
}

#[test]
fn nonconvex_objective_convex_on_constraint() {
    // min -x0 x1 s.t. x0 + x1 = 2: indefinite Hessian, positive on the tangent space.
    let mut p = Dense {
        n: 2,
        m: 1,
        x0: vec![0.0, 0.5],
        x_l: vec![-INF; 2],
        x_u: vec![INF; 2],
        g_l: vec![2.0],
        g_u: vec![2.0],
        f: |x| -x[0] * x[1],
        grad: |x, g| {
            g[0] = -x[1];
            g[1] = -x[0];
        },
        g: |x, g| g[0] = x[0] + x[1],
        jac: |_, v| {
            v[0] = 1.0;
            v[1] = 1.0;
        },
        hess: |_, s, _, v| {
            v[0] = 0.0;
            v[1] = -s;
            v[2] = 0.0;
        },
    };
    let (info, x) = solve(&mut p, BarrierRule::Dampmpc);
    assert_eq!(info.status, Status::Optimal, "{info:?}");
    assert!(
        (x[0] - 1.0).abs() < 1e-6 && (x[1] - 1.0).abs() < 1e-6,
        "x = {x:?}"
    );
}

#[test]
fn infeasible_problem_is_reported_locally_infeasible() {
    // x0^2 + x1^2 = 1 and x0 + x1 >= 3 cannot both hold (max of x0 + x1 on the circle is
    // sqrt 2).
    let mut p = Dense {
        n: 2,
        m: 2,
        x0: vec![0.5, 0.2],
        x_l: vec![-INF; 2],
        x_u: vec![INF; 2],
        g_l: vec![1.0, 3.0],
        g_u: vec![1.0, INF],
        f: |x| x[0] + 2.0 * x[1],
        grad: |_, g| {
            g[0] = 1.0;
            g[1] = 2.0;
        },
        g: |x, g| {
            g[0] = x[0] * x[0] + x[1] * x[1];
            g[1] = x[0] + x[1];
        },
        jac: |x, v| {
            v[0] = 2.0 * x[0];
            v[1] = 2.0 * x[1];
            v[2] = 1.0;
            v[3] = 1.0;
        },
        hess: |_, _, l, v| {
            v[0] = 2.0 * l[0];
            v[1] = 0.0;
            v[2] = 2.0 * l[0];
        },
    };
    for rule in BarrierRule::ALL {
        let (info, _) = solve(&mut p, rule);
        assert_eq!(info.status, Status::LocallyInfeasible, "{rule:?} {info:?}");
        assert!(info.max_violation > 0.1);
    }
}

#[test]
fn iteration_cap_gives_status_and_best_iterate() {
    let mut p = hs071();
    let settings = Settings {
        max_iter: 2,
        ..Settings::default()
    };
    let mut solver = Solver::new(&p, settings).unwrap();
    let info = solver.solve(&mut p);
    assert_eq!(info.status, Status::IterationLimit);
    assert!(info.objective.is_finite());
    assert!(solver.x().iter().all(|v| v.is_finite()));
}

#[test]
fn nan_start_is_invalid_input() {
    let mut p = hs071();
    p.x0[1] = f64::NAN;
    let (info, _) = solve(&mut p, BarrierRule::Dampmpc);
    assert_eq!(info.status, Status::InvalidInput);
}

#[test]
fn infinite_equality_bound_is_invalid_input() {
    let mut p = hs071();
    p.g_l[1] = INF;
    p.g_u[1] = INF;
    let (info, _) = solve(&mut p, BarrierRule::Monotone);
    assert_eq!(info.status, Status::InvalidInput);
}

/// A solve that stops before its first scored iterate (here: a NaN gradient at the start)
/// reports this solve's own start, not an older point (zeros on a fresh solver).
#[test]
fn failure_at_the_start_returns_the_start() {
    let mut p = hs071();
    p.grad = |_, g| g.fill(f64::NAN);
    let mut solver = Solver::new(&p, Settings::default()).unwrap();
    let info = solver.solve(&mut p);
    assert_eq!(info.status, Status::NumericalFailure);
    let x = solver.x();
    // The start (1, 5, 5, 1), pushed into [1, 5] by at most 1e-2 per entry.
    for (v, s) in x.iter().zip([1.0, 5.0, 5.0, 1.0]) {
        assert!((v - s).abs() < 0.05, "{x:?}");
    }
}

/// min x0^2 + x1^2 s.t. x0 + x1 >= 0 and x0 - x1 >= 0: both constraints active at the
/// optimum (0, 0) with zero multipliers (strict complementarity fails: degenerate).
fn degenerate_complementarity() -> Dense {
    Dense {
        n: 2,
        m: 2,
        x0: vec![1.0, 0.5],
        x_l: vec![-INF; 2],
        x_u: vec![INF; 2],
        g_l: vec![0.0, 0.0],
        g_u: vec![INF, INF],
        f: |x| x[0] * x[0] + x[1] * x[1],
        grad: |x, g| {
            g[0] = 2.0 * x[0];
            g[1] = 2.0 * x[1];
        },
        g: |x, g| {
            g[0] = x[0] + x[1];
            g[1] = x[0] - x[1];
        },
        jac: |_, v| {
            v[0] = 1.0;
            v[1] = 1.0;
            v[2] = 1.0;
            v[3] = -1.0;
        },
        hess: |_, s, _, v| {
            v[0] = 2.0 * s;
            v[1] = 0.0;
            v[2] = 2.0 * s;
        },
    }
}

/// min (x0 - 2)^2 + (x1 - 1)^2 s.t. x0 + x1 = 1 stated twice (LICQ fails: the Jacobian is
/// rank deficient, the multipliers are not unique). Optimum (1, 0).
fn redundant_equalities() -> Dense {
    Dense {
        n: 2,
        m: 2,
        x0: vec![0.0, 0.0],
        x_l: vec![-INF; 2],
        x_u: vec![INF; 2],
        g_l: vec![1.0, 2.0],
        g_u: vec![1.0, 2.0],
        f: |x| (x[0] - 2.0).powi(2) + (x[1] - 1.0).powi(2),
        grad: |x, g| {
            g[0] = 2.0 * (x[0] - 2.0);
            g[1] = 2.0 * (x[1] - 1.0);
        },
        g: |x, g| {
            g[0] = x[0] + x[1];
            g[1] = 2.0 * (x[0] + x[1]);
        },
        jac: |_, v| {
            v[0] = 1.0;
            v[1] = 1.0;
            v[2] = 2.0;
            v[3] = 2.0;
        },
        hess: |_, s, _, v| {
            v[0] = 2.0 * s;
            v[1] = 0.0;
            v[2] = 2.0 * s;
        },
    }
}

/// Rosenbrock's banana in the box [-2, 2] x [-1, 3] from (-1.2, 1): the Hessian is
/// indefinite at the start (nonconvex); optimum (1, 1), f = 0.
fn rosenbrock() -> Dense {
    Dense {
        n: 2,
        m: 0,
        x0: vec![-1.2, 1.0],
        x_l: vec![-2.0, -1.0],
        x_u: vec![2.0, 3.0],
        g_l: vec![],
        g_u: vec![],
        f: |x| (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2),
        grad: |x, g| {
            g[0] = -2.0 * (1.0 - x[0]) - 400.0 * x[0] * (x[1] - x[0] * x[0]);
            g[1] = 200.0 * (x[1] - x[0] * x[0]);
        },
        g: |_, _| {},
        jac: |_, _| {},
        hess: |x, s, _, v| {
            v[0] = s * (2.0 - 400.0 * (x[1] - 3.0 * x[0] * x[0]));
            v[1] = s * (-400.0 * x[0]);
            v[2] = s * 200.0;
        },
    }
}

#[test]
fn every_rule_solves_degenerate_problems() {
    for rule in BarrierRule::ALL {
        let (info, x) = solve(&mut degenerate_complementarity(), rule);
        assert_eq!(info.status, Status::Optimal, "{rule:?} degenerate {info:?}");
        assert!(x[0].abs() < 1e-3 && x[1].abs() < 1e-3, "{rule:?} x = {x:?}");
        let (info, x) = solve(&mut redundant_equalities(), rule);
        assert_eq!(info.status, Status::Optimal, "{rule:?} redundant {info:?}");
        assert!(
            (x[0] - 1.0).abs() < 1e-5 && x[1].abs() < 1e-5,
            "{rule:?} x = {x:?}"
        );
    }
}

#[test]
fn every_rule_solves_nonconvex_problems() {
    for rule in BarrierRule::ALL {
        let (info, x) = solve(&mut rosenbrock(), rule);
        assert_eq!(info.status, Status::Optimal, "{rule:?} rosenbrock {info:?}");
        assert!(
            (x[0] - 1.0).abs() < 1e-4 && (x[1] - 1.0).abs() < 1e-4,
            "{rule:?} x = {x:?}"
        );
        let mut q = Dense {
            n: 2,
            m: 1,
            x0: vec![0.0, 0.5],
            x_l: vec![-INF; 2],
            x_u: vec![INF; 2],
            g_l: vec![2.0],
            g_u: vec![2.0],
            f: |x| -x[0] * x[1],
            grad: |x, g| {
                g[0] = -x[1];
                g[1] = -x[0];
            },
            g: |x, g| g[0] = x[0] + x[1],
            jac: |_, v| {
                v[0] = 1.0;
                v[1] = 1.0;
            },
            hess: |_, s, _, v| {
                v[0] = 0.0;
                v[1] = -s;
                v[2] = 0.0;
            },
        };
        let (info, x) = solve(&mut q, rule);
        assert_eq!(info.status, Status::Optimal, "{rule:?} saddle {info:?}");
        assert!(
            (x[0] - 1.0).abs() < 1e-6 && (x[1] - 1.0).abs() < 1e-6,
            "{rule:?} x = {x:?}"
        );
    }
}

/// The merit-function line search (paper eq. 5) and the second-order correction are
/// alternatives to the default filter: each must solve the small problems too.
#[test]
fn merit_globalization_and_second_order_correction_solve_the_small_problems() {
    use planner::ip::Globalization;
    let variants = [
        ("merit", Globalization::Merit, false),
        ("filter + soc", Globalization::Filter, true),
        ("merit + soc", Globalization::Merit, true),
    ];
    for (name, globalization, soc) in variants {
        let settings = Settings {
            globalization,
            second_order_correction: soc,
            ..Settings::default()
        };
        let mut p = hs071();
        let mut solver = Solver::new(&p, settings).expect("setup");
        let info = solver.solve(&mut p);
        assert_eq!(info.status, Status::Optimal, "{name} hs071: {info:?}");
        assert!(
            (info.objective - 17.014_017_3).abs() < 1e-5,
            "{name}: f = {}",
            info.objective
        );
        let mut r = rosenbrock();
        let mut solver = Solver::new(&r, settings).expect("setup");
        let info = solver.solve(&mut r);
        let x = solver.x();
        assert_eq!(info.status, Status::Optimal, "{name} rosenbrock: {info:?}");
        assert!(
            (x[0] - 1.0).abs() < 1e-4 && (x[1] - 1.0).abs() < 1e-4,
            "{name}: x = {x:?}"
        );
    }
}

/// The refactorization cap: with room for a single inertia-correcting attempt, an
/// iteration whose Hessian is indefinite must take the convexified fallback step, never
/// factorize more often than the cap, and still converge.
#[test]
fn inertia_fallback_is_taken_at_the_cap_and_converges() {
    use planner::ip::StepKind;
    for rule in BarrierRule::ALL {
        // Double well in a free x0: H = 3 x0^2 - 1 < 0 at the start whatever mu is (no
        // barrier term on x0); minimizers x0 = +-1, x1 = 0, f = -1/4.
        let mut p = Dense {
            n: 2,
            m: 0,
            x0: vec![0.1, 1.0],
            x_l: vec![-INF, -5.0],
            x_u: vec![INF, 5.0],
            g_l: vec![],
            g_u: vec![],
            f: |x| 0.25 * x[0].powi(4) - 0.5 * x[0] * x[0] + x[1] * x[1],
            grad: |x, g| {
                g[0] = x[0].powi(3) - x[0];
                g[1] = 2.0 * x[1];
            },
            g: |_, _| {},
            jac: |_, _| {},
            hess: |x, s, _, v| {
                v[0] = s * (3.0 * x[0] * x[0] - 1.0);
                v[1] = 0.0;
                v[2] = 2.0 * s;
            },
        };
        let settings = Settings {
            barrier: rule,
            max_refactorizations: 2,
            ..Settings::default()
        };
        let mut solver = Solver::new(&p, settings).expect("setup");
        let info = solver.solve(&mut p);
        let log = solver.log();
        assert!(
            log.iter().any(|l| l.step == StepKind::Fallback),
            "{rule:?}: no fallback step in {log:?}"
        );
        assert!(info.fallback_steps > 0);
        assert!(log.iter().all(|l| l.factorizations <= 2), "{rule:?}");
        assert!(info.max_factorizations_per_iter <= 2, "{rule:?} {info:?}");
        assert_eq!(info.status, Status::Optimal, "{rule:?} {info:?}");
        let x = solver.x();
        assert!(
            (x[0].abs() - 1.0).abs() < 1e-5 && x[1].abs() < 1e-5,
            "{rule:?} x = {x:?}"
        );
        assert!((info.objective + 0.25).abs() < 1e-8, "{rule:?} {info:?}");
    }
}

#[test]
fn refactorization_cap_below_two_is_rejected() {
    let p = hs071();
    let settings = Settings {
        max_refactorizations: 1,
        ..Settings::default()
    };
    assert!(Solver::new(&p, settings).is_err());
}
