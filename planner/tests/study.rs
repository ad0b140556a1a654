//! The study library: the shipped segment reference table, the NRMSE
//! definition, eigen-analysis of eq. (7) with participation factors on matrices with known
//! answers, and the stiffness of the model at a real state.

use planner::model::params::lc500;
use planner::model::{NX, STATE_NAMES};
use planner::study::integrators::{nrmse_pct, Integrator};
use planner::study::segments;
use planner::study::stiffness::{analyze, analyze_jacobian, spatial_jacobian};

#[test]
fn nrmse_is_rms_error_over_reference_range() {
    let s = [0.0, 1.0, 2.0, 3.0];
    let r = [0.0, 2.0, 4.0, 2.0]; // range 4
    let u = [1.0, 1.0, 5.0, 1.0]; // errors 1, -1, 1, -1: RMS 1
    assert!((nrmse_pct(&s, &u, &s, &r) - 25.0).abs() < 1e-12);
    assert_eq!(nrmse_pct(&s, &r, &s, &r), 0.0);
    // A reference on a finer grid is interpolated linearly in s.
    let s_fine = [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0];
    let r_fine = [0.0, 1.0, 2.0, 3.0, 4.0, 3.0, 2.0];
    assert!(nrmse_pct(&s, &r, &s_fine, &r_fine).abs() < 1e-12);
    // No range: undefined.
    assert!(nrmse_pct(&s, &u, &s, &[1.0; 4]).is_nan());
}

#[test]
fn integrator_names_round_trip() {
    for i in Integrator::ALL {
        assert_eq!(Integrator::from_name(i.name()).unwrap(), i);
    }
    let e = Integrator::from_name("rk45").unwrap_err().to_string();
    assert!(e.contains("rk45") && e.contains("gauss_legendre3"), "{e}");
    assert_eq!(
        Integrator::ALL.iter().filter(|i| i.a_stable()).count(),
        4,
        "IE, CN, GL2, GL3"
    );
}

/// A block-diagonal Jacobian with known eigenvalues: -1 (state r), -1000 (state beta, but
/// coupled to V so that the eigenvectors are not the unit vectors), exact zeros (s, t).
#[test]
fn stiffness_ratio_and_participation_on_a_known_matrix() {
    let mut j = [[0.0; NX]; NX];
    j[0][0] = -1.0;
    // [V, beta] block [[-2, 0], [5, -1000]]: eigenvalues -2 (mostly V), -1000 (beta only).
    j[1][1] = -2.0;
    j[2][1] = 5.0;
    j[2][2] = -1000.0;
    j[3][3] = -3.0;
    j[4][4] = -4.0;
    j[5][5] = -5.0;
    j[6][6] = -6.0;
    let n = analyze_jacobian(3, 7.5, &j).unwrap();
    let ratio = n.ratio.unwrap();
    assert!((ratio - 1000.0).abs() < 1e-9, "{ratio}");
    assert_eq!(n.dominant_state, Some("beta"));
    let sum: f64 = n.participation.iter().sum();
    assert!((sum - 1.0).abs() < 1e-12);
    // The -1000 mode's right eigenvector is e_beta, so beta participates fully.
    assert!(
        (n.participation[2] - 1.0).abs() < 1e-9,
        "{:?}",
        n.participation
    );
    let (re, im) = n.fastest.unwrap();
    assert!((re + 1000.0).abs() < 1e-9 && im.abs() < 1e-12);
    let (re, _) = n.slowest.unwrap();
    assert!((re + 1.0).abs() < 1e-9);
    // The zero eigenvalues of s and t are not in S; the dynamic sub-Jacobian has 1000 / 1.
    assert!((n.dynamic_ratio.unwrap() - 1000.0).abs() < 1e-9);
    assert_eq!(n.dynamic_dominant_state, Some("beta"));
    assert_eq!(n.mode_states.len(), NX);
}

/// An undamped oscillation (Re = 0) plus one decaying mode: S has one element, ratio 1;
/// no decaying mode at all: no ratio.
#[test]
fn stiffness_ratio_excludes_non_decaying_modes() {
    let mut j = [[0.0; NX]; NX];
    j[0][1] = 1.0;
    j[1][0] = -4.0;
    j[3][3] = -7.0;
    let n = analyze_jacobian(0, 0.0, &j).unwrap();
    assert_eq!(n.ratio, Some(1.0));
    assert_eq!(n.dominant_state, Some("V_wr"));
    j[3][3] = 0.5;
    let n = analyze_jacobian(0, 0.0, &j).unwrap();
    assert_eq!(n.ratio, None);
    assert_eq!(n.dominant_state, None);
}

/// The model's spatial Jacobian matches central differences of dx/ds, and at a cornering
/// state the analysis finds decaying modes and names a dominant state.
#[test]
fn model_jacobian_and_analysis_at_a_cornering_state() {
    let p = lc500();
    let x = [0.35, 25.0, -0.02, 25.4, 800.0, 0.5, 0.03, 10.0, 1.0];
    let u = [0.04, 400.0, 0.0];
    let kappa = 0.014;
    let jac = spatial_jacobian(&p, &x, &u, kappa);
    for l in 0..NX {
        let h = 1e-6 * x[l].abs().max(1.0);
        let (mut xp, mut xm) = (x, x);
        xp[l] += h;
        xm[l] -= h;
        let fp = planner::model::spatial_derivatives(&p, &xp, &u, kappa);
        let fm = planner::model::spatial_derivatives(&p, &xm, &u, kappa);
        for i in 0..NX {
            let fd = (fp[i] - fm[i]) / (2.0 * h);
            assert!(
                (fd - jac[i][l]).abs() <= 1e-5 * (1.0 + fd.abs()),
                "d{}/d{}: {} vs {fd}",
                STATE_NAMES[i],
                STATE_NAMES[l],
                jac[i][l]
            );
        }
    }
    let study = analyze(&p, &[x, x], &[u], &[kappa, kappa], 2.6).unwrap();
    assert_eq!(study.nodes.len(), 2);
    assert!(study.peak_ratio.unwrap() >= 1.0);
    assert!(study.peak_dominant_state.is_some());
    // Length mismatch is an error, not a panic.
    assert!(analyze(&p, &[x], &[u], &[kappa], 2.6).is_err());
}

#[test]
fn shipped_reference_lists_ten_segments() {
    let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"))
        .join(segments::REFERENCE_CSV);
    let rows = segments::load_reference(&path).expect("shipped reference loads");
    assert_eq!(rows.len(), 10);
    assert_eq!(rows[0].0, "S01");
    assert!((rows[0].1 - 9.2046).abs() < 1e-9);
    assert!(rows.iter().all(|(_, t, it)| *t > 1.0 && *it > 0));
}

#[test]
fn malformed_reference_is_a_typed_error() {
    let path = std::env::temp_dir().join(format!("bad-ref-{}.csv", std::process::id()));
    std::fs::write(&path, "segment,t_N,iterations,status\nS01,abc,3,x\n").unwrap();
    let err = segments::load_reference(&path).unwrap_err();
    assert!(err.to_string().contains("line 2"), "{err}");
    let _ = std::fs::remove_file(&path);
}
