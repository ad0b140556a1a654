//! Layout, bounds, row descriptions and guess round trip of the implicit-Euler transcription.

use planner::ip::Nlp;
use planner::ocp::fixtures::oval_spec;
use planner::ocp::layout::VarKind;
use planner::ocp::{ImplicitEulerNlp, RowKind, TranscriptionError};

/// The variable and row bounds (x_l, x_u, g_l, g_u) of `nlp`.
fn bounds<const N: usize>(nlp: &ImplicitEulerNlp<N>) -> [Vec<f64>; 4] {
    let d = nlp.dims();
    let [mut xl, mut xu] = [vec![0.0; d.n], vec![0.0; d.n]];
    let [mut gl, mut gu] = [vec![0.0; d.m], vec![0.0; d.m]];
    nlp.bounds(&mut xl, &mut xu, &mut gl, &mut gu);
    [xl, xu, gl, gu]
}

#[test]
fn wrong_n_is_rejected() {
    let err = ImplicitEulerNlp::<50>::new(oval_spec()).unwrap_err();
    assert_eq!(
        err,
        TranscriptionError::WrongN {
            expected: 50,
            got: 100
        }
    );
    let mut spec = oval_spec();
    spec.kappa.pop();
    assert!(matches!(
        ImplicitEulerNlp::<100>::new(spec),
        Err(TranscriptionError::BadLength { field: "kappa", .. })
    ));
}

#[test]
fn rows_bounds_and_names() {
    let nlp = ImplicitEulerNlp::<100>::new(oval_spec()).unwrap();
    let d = nlp.dims();
    let names = nlp.constraint_names();
    assert_eq!(names.len(), d.m);
    assert_eq!(names[0], "initial[s]@0");
    assert_eq!(names[8], "initial[e]@0");
    assert_eq!(names[9], "defect[r]@0");
    assert_eq!(
        nlp.describe_row(9 + 9).kind,
        RowKind::Friction { at_next: false }
    );
    assert_eq!(
        nlp.describe_row(9 + 11).kind,
        RowKind::Saturation { rear: false }
    );
    // Stage 1 ends with the six rate rows.
    let last_stage1 = (0..d.m)
        .filter(|&i| nlp.describe_row(i).node == 1)
        .max()
        .unwrap();
    assert_eq!(
        nlp.describe_row(last_stage1).kind,
        RowKind::RateLower { control: 2 }
    );
    // No terminal s_N row (implied by s_0 = 0 and the s defects).
    assert!(!names.iter().any(|n| n.contains("terminal")));

    let [xl, xu, _, gu] = bounds(&nlp);
    let lay = nlp.layout();
    assert_eq!((xl[lay.x(100, 1)], xu[lay.x(100, 1)]), (0.5, 4.0)); // V in [5, 40] / 10
    assert_eq!((xl[lay.x(3, 5)], xu[lay.x(3, 5)]), (-4.0, 4.0)); // e
    assert_eq!((xl[lay.x(3, 3)], xu[lay.x(3, 3)]), (0.0, f64::INFINITY)); // V_wr >= 0 (R10)
    assert_eq!((xl[lay.u(7, 0)], xu[lay.u(7, 0)]), (-5.5, 5.5)); // delta / 0.1
    assert_eq!((xl[lay.u(7, 2)], xu[lay.u(7, 2)]), (-3.5, 0.0)); // T_bf / 1000
    assert!(xl[lay.x(4, 0)].is_infinite() && xl[lay.x(4, 8)].is_infinite());
    for i in 0..d.n {
        assert!(
            xl[i] < xu[i],
            "variable {i} fixed or empty: use equality rows"
        );
    }
    // eps_sat / 3: the saturation row scale of a free start (0.1 with a fixed one).
    assert!((gu[9 + 11] - 0.01 / planner::ocp::scaling::SATURATION_SCALE_FREE).abs() < 1e-15);
}

#[test]
fn guess_round_trip_and_feasible_straight() {
    let mut nlp = ImplicitEulerNlp::<100>::new(oval_spec()).unwrap();
    let xs: Vec<[f64; 9]> = (0..=100)
        .map(|k| {
            let s = 2.6 * k as f64;
            [0.0, 20.0, 0.0, 20.0, 0.0, 0.0, 0.0, s, s / 20.0]
        })
        .collect();
    let us = vec![[0.0, 0.0, 0.0]; 100];
    nlp.set_initial_guess(&xs, &us);
    let mut z = vec![0.0; nlp.dims().n];
    nlp.initial_point(&mut z);
    let (xs2, us2) = nlp.trajectory_from(&z);
    for k in 0..=100 {
        for i in 0..9 {
            assert!((xs2[k][i] - xs[k][i]).abs() < 1e-12);
        }
    }
    assert_eq!(us2, us);
    // Straight-line equilibrium satisfies every defect on the straights (kappa = 0 at
    // s_{k+1}), and violates the e/dpsi defects in the turns.
    let m = nlp.dims().m;
    let mut g = vec![0.0; m];
    nlp.eval_g(&z, &mut g);
    for (i, gi) in g.iter().enumerate() {
        let info = nlp.describe_row(i);
        if let RowKind::Defect { .. } = info.kind {
            let kappa = nlp.spec().kappa[info.node + 1];
            if kappa == 0.0 {
                assert!(gi.abs() < 1e-12, "{} = {gi}", nlp.row_name(i));
            }
        }
    }
    assert!(nlp.max_violation(&z) > 0.1);
}

/// With `saturation_at_end` the last interval carries two more saturation rows, of node N:
/// they read x_N's states and u_{N-1}'s controls and have the same bound as every other
/// saturation row.
#[test]
fn the_last_nodes_saturation_rows_read_x_n_and_the_last_controls() {
    let mut spec = oval_spec();
    spec.saturation_at_end = true;
    let nlp = ImplicitEulerNlp::<100>::new(spec).unwrap();
    let plain = ImplicitEulerNlp::<100>::new(oval_spec()).unwrap();
    let (d, d0) = (nlp.dims(), plain.dims());
    assert_eq!(d.m, d0.m + 2);
    assert_eq!(d.n, d0.n);
    let end: Vec<usize> = (0..d.m)
        .filter(|&i| nlp.describe_row(i).node == 100)
        .collect();
    assert_eq!(end.len(), 2);
    assert_eq!(nlp.row_name(end[0]), "saturation[front]@100");
    assert_eq!(nlp.row_name(end[1]), "saturation[rear]@100");
    let (mut jr, mut jc) = (vec![0; d.nnz_jac], vec![0; d.nnz_jac]);
    nlp.jac_structure(&mut jr, &mut jc);
    let lay = nlp.layout();
    for &row in &end {
        let cols: Vec<usize> = jr
            .iter()
            .zip(&jc)
            .filter(|(r, _)| **r == row)
            .map(|(_, c)| *c)
            .collect();
        assert_eq!(cols.len(), 7, "row {row}");
        for c in cols {
            let (k, kind) = lay.describe(c);
            match kind {
                VarKind::State(_) => assert_eq!(k, 100, "column {c}"),
                VarKind::Control(_) => assert_eq!(k, 99, "column {c}"),
                VarKind::Stage(_) => panic!("stage variable {c}"),
            }
        }
    }
    let [_, _, gl, gu] = bounds(&nlp);
    let rear_99 = (0..d.m)
        .find(|&i| nlp.row_name(i) == "saturation[rear]@99")
        .unwrap();
    assert_eq!(gu[end[1]], gu[rear_99]);
    assert_eq!(gl[end[1]], f64::NEG_INFINITY);
}
