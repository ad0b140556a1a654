//! Cross-check against the independent CasADi + IPOPT implementation: its optimal
//! implicit-Euler trajectory on the oval must satisfy OUR defects (up to the CSV's
//! rounding) and its tire columns must equal our tire model.

use planner::ip::Nlp;
use planner::model::{tire_forces, NX};
use planner::ocp::fixtures::{oval_reference_path, oval_spec, ReferenceCsv};
use planner::ocp::{ImplicitEulerNlp, RowKind};

/// The committed reference (`config/reference/`): a missing or unreadable file fails the
/// test instead of skipping the check.
fn load() -> Option<ReferenceCsv> {
    let path = oval_reference_path();
    match ReferenceCsv::load(&path) {
        Ok(c) => Some(c),
        Err(e) => panic!("reference {} not readable: {e}", path.display()),
    }
}

#[test]
fn reference_tire_columns_match_our_model() {
    let Some(csv) = load() else { return };
    let (xs, us) = csv.trajectory();
    let p = oval_spec().vehicle;
    let names = [
        "Fxf", "Fyf", "Fxr", "Fyr", "Fzf", "Fzr", "sig_f", "sig_r", "sig_sl_f", "sig_sl_r",
    ];
    let cols: Vec<Vec<f64>> = names.iter().map(|n| csv.col(n)).collect();
    let mut worst = [0.0f64; 10];
    for k in 0..xs.len() - 1 {
        let t = tire_forces(&p, &xs[k], &us[k]);
        let ours = [
            t.fxf,
            t.fyf,
            t.fxr,
            t.fyr,
            t.fzf,
            t.fzr,
            t.sigma_f,
            t.sigma_r,
            t.sigma_sl_f,
            t.sigma_sl_r,
        ];
        for c in 0..10 {
            let refv = cols[c][k];
            let scale = if c < 6 { 1e3 } else { 1e-1 };
            let err = (ours[c] - refv).abs() / (refv.abs() + scale);
            worst[c] = worst[c].max(err);
        }
    }
    println!(
        "worst relative tire-column errors: {:?}",
        names.iter().zip(worst).collect::<Vec<_>>()
    );
    for (n, w) in names.iter().zip(worst) {
        assert!(w < 1e-6, "{n}: relative error {w:.3e}");
    }
}

#[test]
fn reference_solution_satisfies_our_defects() {
    let Some(csv) = load() else { return };
    let (xs, us) = csv.trajectory();
    assert_eq!(xs.len(), 101);
    let mut nlp = ImplicitEulerNlp::<100>::new(oval_spec()).unwrap();
    let n = nlp.dims().n;
    let mut z = vec![0.0; n];
    nlp.pack(&xs, &us, &mut z);

    let t_n = nlp.eval_f(&z) * planner::ocp::scaling::OBJECTIVE_SCALE;
    println!("t_N = {t_n:.6}");
    assert!((t_n - 13.0699).abs() < 5e-5, "t_N = {t_n}");

    let mut g = vec![0.0; nlp.dims().m];
    nlp.eval_g(&z, &mut g);
    let mut worst = [0.0f64; NX];
    let mut worst_at = [0usize; NX];
    for (i, gi) in g.iter().enumerate() {
        let info = nlp.describe_row(i);
        if let RowKind::Defect { row } = info.kind {
            if gi.abs() > worst[row] {
                worst[row] = gi.abs();
                worst_at[row] = info.node;
            }
        }
    }
    println!(
        "max |scaled defect| per state (node): {:?}",
        worst.iter().zip(worst_at).collect::<Vec<_>>()
    );
    let max_defect = nlp.max_defect(&z);
    let viol = nlp.max_violation(&z);
    println!("max scaled defect {max_defect:.3e}, max violation {viol:.3e}");
    // Which non-defect row is worst (for the report).
    let (mut vi, mut vmax) = (0, 0.0);
    let (mut xl, mut xu, mut gl, mut gu) = (
        vec![0.0; n],
        vec![0.0; n],
        vec![0.0; g.len()],
        vec![0.0; g.len()],
    );
    nlp.bounds(&mut xl, &mut xu, &mut gl, &mut gu);
    for i in 0..g.len() {
        let v = (gl[i] - g[i]).max(g[i] - gu[i]);
        if v > vmax {
            vmax = v;
            vi = i;
        }
    }
    println!("worst row: {} ({vmax:.3e})", nlp.row_name(vi));
    assert!(max_defect < 5e-6, "max scaled defect {max_defect:.3e}");
    assert!(viol < 5e-6, "max violation {viol:.3e}");
}
