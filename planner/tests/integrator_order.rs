//! Order and stability of the integrator formulas of `planner::ocp::transcription::steps`
//! (the same code the NLP defects run) on scalar and small linear test ODEs: the one-step
//! schemes, Gauss-Legendre 2 / 3 and the multistep formulas (BDF1-6, Adams-Moulton 1-3).

use planner::ocp::transcription::steps;

/// One-step defect of a single-step scheme on an M-dimensional ODE.
type Step<const M: usize> =
    fn(f64, &[f64; M], &[f64; M], &dyn Fn(&[f64; M], f64) -> [f64; M]) -> [f64; M];

fn ie<const M: usize>(
    h: f64,
    a: &[f64; M],
    b: &[f64; M],
    f: &dyn Fn(&[f64; M], f64) -> [f64; M],
) -> [f64; M] {
    steps::implicit_euler(h, a, b, f)
}
fn cn<const M: usize>(
    h: f64,
    a: &[f64; M],
    b: &[f64; M],
    f: &dyn Fn(&[f64; M], f64) -> [f64; M],
) -> [f64; M] {
    steps::crank_nicolson(h, a, b, f)
}
fn rk2<const M: usize>(
    h: f64,
    a: &[f64; M],
    b: &[f64; M],
    f: &dyn Fn(&[f64; M], f64) -> [f64; M],
) -> [f64; M] {
    steps::rk2_midpoint(h, a, b, f)
}
fn rk4<const M: usize>(
    h: f64,
    a: &[f64; M],
    b: &[f64; M],
    f: &dyn Fn(&[f64; M], f64) -> [f64; M],
) -> [f64; M] {
    steps::rk4(h, a, b, f)
}

/// Solves the affine system g(v) = 0 (g affine in v) by Gaussian elimination with partial
/// pivoting on J = [g(s e_i) - g(0)] / s, with s of the size of g(0) (so that huge
/// explicit-scheme values do not cancel).
fn solve_affine(n: usize, g: &dyn Fn(&[f64]) -> Vec<f64>) -> Vec<f64> {
    let zero = vec![0.0; n];
    let g0 = g(&zero);
    let s = 1.0 + g0.iter().map(|v| v.abs()).fold(0.0, f64::max);
    let mut a = vec![vec![0.0; n + 1]; n];
    for j in 0..n {
        let mut e = zero.clone();
        e[j] = s;
        let gj = g(&e);
        for i in 0..n {
            a[i][j] = (gj[i] - g0[i]) / s;
        }
    }
    for i in 0..n {
        a[i][n] = -g0[i];
    }
    for c in 0..n {
        let p = (c..n)
            .max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))
            .unwrap();
        a.swap(c, p);
        for r in 0..n {
            if r != c {
                let fct = a[r][c] / a[c][c];
                let pivot_row = a[c].clone();
                for (x, p) in a[r].iter_mut().zip(&pivot_row).skip(c) {
                    *x -= fct * p;
                }
            }
        }
    }
    (0..n).map(|i| a[i][n] / a[i][i]).collect()
}

/// GL2 with the stage states solved from the (linear-ODE) collocation rows; returns the
/// continuity defect at the given x1 and asserts the collocation rows vanish.
fn gl2<const M: usize>(
    h: f64,
    x0: &[f64; M],
    x1: &[f64; M],
    f: &dyn Fn(&[f64; M], f64) -> [f64; M],
) -> [f64; M] {
    let rows = |x1: &[f64; M], s1: &[f64; M], s2: &[f64; M]| {
        let mut out = vec![0.0; 3 * M];
        steps::gauss_legendre2(h, x0, x1, s1, s2, f, &mut out);
        out
    };
    let split = |v: &[f64]| -> ([f64; M], [f64; M]) {
        (
            std::array::from_fn(|i| v[i]),
            std::array::from_fn(|i| v[M + i]),
        )
    };
    let st = solve_affine(2 * M, &|v| {
        let (s1, s2) = split(v);
        rows(x1, &s1, &s2)[..2 * M].to_vec()
    });
    let (s1, s2) = split(&st);
    let out = rows(x1, &s1, &s2);
    let scale = 1.0 + x0.iter().map(|v| v.abs()).fold(0.0, f64::max);
    assert!(
        out[..2 * M].iter().all(|r| r.abs() < 1e-9 * scale),
        "{out:?}"
    );
    std::array::from_fn(|i| out[2 * M + i])
}

/// GL3 with the stage states solved from the (linear-ODE) collocation rows; returns the
/// continuity defect at the given x1 and asserts the collocation rows vanish.
fn gl3<const M: usize>(
    h: f64,
    x0: &[f64; M],
    x1: &[f64; M],
    f: &dyn Fn(&[f64; M], f64) -> [f64; M],
) -> [f64; M] {
    let rows = |x1: &[f64; M], v: &[f64]| {
        let xs: [[f64; M]; 3] = std::array::from_fn(|j| std::array::from_fn(|i| v[j * M + i]));
        let mut out = vec![0.0; 4 * M];
        steps::gauss_legendre3(h, x0, x1, &xs, f, &mut out);
        out
    };
    let st = solve_affine(3 * M, &|v| rows(x1, v)[..3 * M].to_vec());
    let out = rows(x1, &st);
    let scale = 1.0 + x0.iter().map(|v| v.abs()).fold(0.0, f64::max);
    assert!(
        out[..3 * M].iter().all(|r| r.abs() < 1e-9 * scale),
        "{out:?}"
    );
    std::array::from_fn(|i| out[3 * M + i])
}

/// Right-hand side f(y, t, h) of a scalar test ODE.
type ScalarRhs<'a> = dyn Fn(&[f64; 1], f64, f64) -> [f64; 1] + 'a;

/// A 2x2 matrix.
type Mat2 = [[f64; 2]; 2];

const SCHEMES: [(&str, Step<1>, i32); 6] = [
    ("implicit_euler", ie::<1>, 1),
    ("crank_nicolson", cn::<1>, 2),
    ("rk2", rk2::<1>, 2),
    ("rk4", rk4::<1>, 4),
    ("gauss_legendre2", gl2::<1>, 4),
    ("gauss_legendre3", gl3::<1>, 6),
];

/// Observed local order + 1: log2 of the one-step defect ratio between h and h/2, checked
/// at two step pairs.
fn check_local_order(
    name: &str,
    step: Step<1>,
    p: i32,
    t0: f64,
    exact: &dyn Fn(f64) -> f64,
    f: &ScalarRhs<'_>,
) {
    let defect = |h: f64| {
        let fh = |y: &[f64; 1], c: f64| f(y, t0 + c * h, h);
        step(h, &[exact(t0)], &[exact(t0 + h)], &fh)[0].abs()
    };
    // GL3's O(h^7) defect reaches rounding level at small steps: coarser steps for it.
    let hs = if p >= 6 { [0.14, 0.1] } else { [0.05, 0.025] };
    for h in hs {
        let (a, b) = (defect(h), defect(h / 2.0));
        let q = (a / b).log2();
        println!(
            "{name}: h = {h}: defect {a:.3e} -> {b:.3e}, slope {q:.2} (expected {})",
            p + 1
        );
        assert!(
            (q - (p + 1) as f64).abs() < 0.3,
            "{name}: observed {q}, expected {}",
            p + 1
        );
    }
}

#[test]
fn local_order_on_linear_decay() {
    let lambda = -1.3;
    for (name, step, p) in SCHEMES {
        check_local_order(name, step, p, 0.4, &|t| (lambda * t).exp(), &|y, _, _| {
            [lambda * y[0]]
        });
    }
}

#[test]
fn local_order_on_growth() {
    // Growing solution (lambda > 0).
    let lambda = 2.0;
    for (name, step, p) in SCHEMES {
        check_local_order(name, step, p, 0.1, &|t| (lambda * t).exp(), &|y, _, _| {
            [lambda * y[0]]
        });
    }
}

#[test]
fn local_order_on_time_dependent_rhs() {
    // y' = -y + cos(3 t): f depends on the stage position c (as k_ref does in the model),
    // so a wrong stage abscissa would lower the order. y = (cos 3t + 3 sin 3t)/10 + C e^-t.
    let exact = |t: f64| ((3.0 * t).cos() + 3.0 * (3.0 * t).sin()) / 10.0 + 0.7 * (-t).exp();
    for (name, step, p) in SCHEMES {
        check_local_order(name, step, p, 0.3, &exact, &|y, t, _| {
            [-y[0] + (3.0 * t).cos()]
        });
    }
}

/// One-step map R(z) = y_1 / y_0 of y' = lambda y, z = lambda h (the defect is affine in
/// y_1 and, for GL2, in the stage states).
fn stability_function(step: Step<1>, z: f64) -> f64 {
    let f = |y: &[f64; 1], _c: f64| [z * y[0]];
    solve_affine(1, &|v| step(1.0, &[1.0], &[v[0]], &f).to_vec())[0]
}

#[test]
fn a_stability_on_stiff_decay() {
    for z in [-0.5, -2.0, -10.0, -100.0, -1000.0] {
        for (name, step, _) in SCHEMES {
            println!("{name}: R({z}) = {:.4e}", stability_function(step, z));
        }
    }
    let z = -1000.0;
    for name in [
        "implicit_euler",
        "crank_nicolson",
        "gauss_legendre2",
        "gauss_legendre3",
    ] {
        let (_, step, _) = SCHEMES.iter().find(|s| s.0 == name).unwrap();
        for z in [-0.5, -2.0, -10.0, -100.0, -1000.0, -1e6] {
            let r = stability_function(*step, z);
            assert!(r.abs() <= 1.0, "{name}: |R({z})| = {r}");
        }
    }
    // Known closed forms at z = -1000.
    assert!((stability_function(ie::<1>, z) - 1.0 / 1001.0).abs() < 1e-12);
    assert!((stability_function(cn::<1>, z) - (-499.0 / 501.0)).abs() < 1e-12);
    let r4 = stability_function(rk4::<1>, z);
    let r4_exact = 1.0 + z + z * z / 2.0 + z.powi(3) / 6.0 + z.powi(4) / 24.0;
    assert!(
        ((r4 - r4_exact) / r4_exact).abs() < 1e-9,
        "{r4} vs {r4_exact}"
    );
    assert!(r4.abs() > 1e10, "RK4 |R(-1000)| = {r4}");
    assert!(stability_function(rk2::<1>, z).abs() > 1e5);
}

/// y' = A y with eigenvalues -1 and -1000 (stiffness ratio 1000), A = P diag P^-1.
fn stiff_system() -> (Mat2, impl Fn(f64, &[f64; 2]) -> [f64; 2]) {
    // P = [[1, 1], [1, -1]] (P^-1 = P / 2), eigenvalues (-1, -1000).
    let (l1, l2) = (-1.0, -1000.0);
    let a = [
        [(l1 + l2) / 2.0, (l1 - l2) / 2.0],
        [(l1 - l2) / 2.0, (l1 + l2) / 2.0],
    ];
    let exact = move |t: f64, y0: &[f64; 2]| {
        let (c1, c2) = ((y0[0] + y0[1]) / 2.0, (y0[0] - y0[1]) / 2.0);
        let (e1, e2) = (c1 * (l1 * t).exp(), c2 * (l2 * t).exp());
        [e1 + e2, e1 - e2]
    };
    (a, exact)
}

fn step_system(step: Step<2>, a: [[f64; 2]; 2], h: f64, y0: &[f64; 2]) -> [f64; 2] {
    let f = move |y: &[f64; 2], _c: f64| {
        [
            a[0][0] * y[0] + a[0][1] * y[1],
            a[1][0] * y[0] + a[1][1] * y[1],
        ]
    };
    let v = solve_affine(2, &|v| step(h, y0, &[v[0], v[1]], &f).to_vec());
    [v[0], v[1]]
}

#[test]
fn stiff_linear_system_order_and_stability() {
    let (a, exact) = stiff_system();
    let schemes: [(&str, Step<2>, i32, bool); 6] = [
        ("implicit_euler", ie::<2>, 1, true),
        ("crank_nicolson", cn::<2>, 2, true),
        ("rk2", rk2::<2>, 2, false),
        ("rk4", rk4::<2>, 4, false),
        ("gauss_legendre2", gl2::<2>, 4, true),
        ("gauss_legendre3", gl3::<2>, 6, true),
    ];
    let y0 = [1.0, 0.5];
    for (name, step, p, a_stable) in schemes {
        // Local order in the resolved regime (h |lambda_max| < 1).
        let err = |h: f64| {
            let y1 = step_system(step, a, h, &y0);
            let ye = exact(h, &y0);
            ((y1[0] - ye[0]).powi(2) + (y1[1] - ye[1]).powi(2)).sqrt()
        };
        // h lambda_max = -0.04 (GL3: -0.2, its O(h^7) error would sink into rounding).
        let h = if p >= 6 { 2e-4 } else { 4e-5 };
        let q = (err(h) / err(h / 2.0)).log2();
        println!("{name}: stiff system local error slope {q:.2}");
        assert!((q - (p + 1) as f64).abs() < 0.3, "{name}: slope {q}");
        // 20 steps of h = 1 (h lambda_max = -1000): A-stable schemes stay bounded.
        let mut y = y0;
        for _ in 0..20 {
            y = step_system(step, a, 1.0, &y);
        }
        let norm = y[0].hypot(y[1]);
        println!("{name}: |y_20| with h = 1: {norm:.3e}");
        if a_stable {
            assert!(norm <= y0[0].hypot(y0[1]), "{name}: {norm}");
        } else {
            assert!(norm > 1e20, "{name}: {norm}");
        }
    }
}

/// All multistep formulas of the transcriptions: the BDF start-up ladder up to BDF6 and the
/// Adams-Moulton ladder up to 3 steps.
fn multistep_formulas() -> Vec<(String, &'static steps::MultistepFormula)> {
    let mut v: Vec<_> = steps::BDF
        .iter()
        .map(|m| (format!("bdf{}", m.steps), m))
        .collect();
    v.extend(
        steps::ADAMS_MOULTON
            .iter()
            .map(|m| (format!("adams_moulton{}", m.steps), m)),
    );
    v
}

/// Defect of one multistep step of length h ending at t0 + h, with the exact solution as
/// history (nodes t0 + (1 - j) h, j = q..0).
fn multistep_defect<const M: usize>(
    m: &steps::MultistepFormula,
    h: f64,
    t0: f64,
    exact: &dyn Fn(f64) -> [f64; M],
    f: &dyn Fn(&[f64; M], f64) -> [f64; M],
) -> [f64; M] {
    let q = m.steps;
    let xs: Vec<[f64; M]> = (0..=q)
        .map(|i| exact(t0 + (i as f64 + 1.0 - q as f64) * h))
        .collect();
    steps::multistep(m, h, &xs, |y: &[f64; M], c: f64| f(y, t0 + c * h))
}

#[test]
fn multistep_coefficients_are_consistent() {
    for (name, m) in multistep_formulas() {
        assert_eq!(m.a.len(), m.steps + 1, "{name}");
        assert_eq!(m.b.len(), m.steps + 1, "{name}");
        // rho(1) = 0 and rho'(1) = sigma(1) (with a_j the coefficient of x_{n+1-j}).
        let rho1: f64 = m.a.iter().sum();
        let drho: f64 =
            m.a.iter()
                .enumerate()
                .map(|(j, a)| a * (m.steps - j) as f64)
                .sum();
        let sigma: f64 = m.b.iter().sum();
        assert!(rho1.abs() < 1e-14, "{name}: rho(1) = {rho1}");
        assert!((drho - sigma).abs() < 1e-14, "{name}: {drho} vs {sigma}");
    }
}

/// The defect vanishes exactly on polynomials up to the formula's order (a linear test ODE
/// y' = g'(t) with y = g a polynomial of that degree) and not on degree order + 1.
#[test]
fn multistep_defect_is_exact_on_polynomials_to_its_order() {
    for (name, m) in multistep_formulas() {
        let p = m.order as i32;
        for deg in 0..=p + 1 {
            let g = move |t: f64| [(1.0 + t).powi(deg)];
            let f = move |_y: &[f64; 1], t: f64| {
                [if deg == 0 {
                    0.0
                } else {
                    deg as f64 * (1.0 + t).powi(deg - 1)
                }]
            };
            let d = multistep_defect(m, 0.1, 0.3, &g, &f)[0].abs();
            if deg <= p {
                assert!(d < 1e-12, "{name}: degree {deg} defect {d}");
            } else {
                assert!(
                    d > 1e-8,
                    "{name}: degree {deg} defect {d} (order too high?)"
                );
            }
        }
    }
}

#[test]
fn multistep_local_order_on_linear_decay_and_growth() {
    for lambda in [-1.3, 2.0] {
        for (name, m) in multistep_formulas() {
            let p = m.order as i32;
            let exact = |t: f64| [(lambda * t).exp()];
            let f = |y: &[f64; 1], _t: f64| [lambda * y[0]];
            let h = if p >= 5 { 0.1 } else { 0.05 };
            let a = multistep_defect(m, h, 0.4, &exact, &f)[0].abs();
            let b = multistep_defect(m, h / 2.0, 0.4, &exact, &f)[0].abs();
            let q = (a / b).log2();
            println!("{name} (lambda {lambda}): defect {a:.3e} -> {b:.3e}, slope {q:.2}");
            assert!((q - (p + 1) as f64).abs() < 0.3, "{name}: slope {q}");
        }
    }
}

/// Solves the multistep step for the new state of y' = A y (2x2) from a history.
fn multistep_step2(m: &steps::MultistepFormula, a: Mat2, h: f64, hist: &[[f64; 2]]) -> [f64; 2] {
    let f = move |y: &[f64; 2], _c: f64| {
        [
            a[0][0] * y[0] + a[0][1] * y[1],
            a[1][0] * y[0] + a[1][1] * y[1],
        ]
    };
    let v = solve_affine(2, &|v| {
        let mut xs = hist.to_vec();
        xs.push([v[0], v[1]]);
        steps::multistep(m, h, &xs, f).to_vec()
    });
    [v[0], v[1]]
}

#[test]
fn multistep_on_the_stiff_system() {
    let (a, exact) = stiff_system();
    let y0 = [1.0, 0.5];
    for (name, m) in multistep_formulas() {
        let q = m.steps;
        // Local order with exact history, h lambda_max = -0.1 / -0.05.
        let err = |h: f64| {
            let hist: Vec<[f64; 2]> = (0..q).map(|i| exact(i as f64 * h, &y0)).collect();
            let y = multistep_step2(m, a, h, &hist);
            let ye = exact(q as f64 * h, &y0);
            (y[0] - ye[0]).hypot(y[1] - ye[1])
        };
        let slope = (err(1e-4) / err(5e-5)).log2();
        println!("{name}: stiff system local error slope {slope:.2}");
        assert!(
            (slope - (m.order + 1) as f64).abs() < 0.3,
            "{name}: slope {slope}"
        );
        // 60 steps of h = 1 (h lambda_max = -1000) from a constant history: BDF (stable on
        // the whole negative real axis) decays, Adams-Moulton with 2 or 3 steps (bounded
        // real stability interval) explodes; the trapezoid rule stays bounded.
        let mut hist: Vec<[f64; 2]> = vec![y0; q];
        for _ in 0..60 {
            let y = multistep_step2(m, a, 1.0, &hist);
            hist.remove(0);
            hist.push(y);
        }
        let norm = hist[q - 1][0].hypot(hist[q - 1][1]);
        println!("{name}: |y_60| with h = 1: {norm:.3e}");
        if name.starts_with("bdf") || name == "adams_moulton1" {
            assert!(norm <= 2.0 * y0[0].hypot(y0[1]), "{name}: {norm}");
        } else {
            assert!(norm > 1e10, "{name}: {norm}");
        }
    }
}
