//! Stiffness of the vehicle dynamics along a trajectory (paper Sec. IV, eq. 7, Fig. 3).
//!
//! **Which Jacobian.** Paper eq. (7) linearises `x'(s) = f(x(s), u(s))` with f the map of
//! eq. (1), i.e. the *spatial* dynamics dx/ds: that is the ODE every transcription
//! integrates with step ds, so h lambda = ds lambda decides the stability of a scheme. We
//! therefore use J_k = d(dx/ds)/dx at (x_k, u_k; k_ref(s_k)), exact by num-dual through
//! [`spatial_derivatives`]. (The time-domain Jacobian differs by the factor 1/sdot and a
//! rank-one term; the ratio of eq. 7 is nearly the same in both, the eigenvalues are not:
//! [1/m] here, [1/s] there.) The controls are inputs and are held (u_N = u_{N-1}).
//!
//! **Stiffness ratio (eq. 7).** With the eigenvalues lambda_j of J_k and
//! S = { j : Re lambda_j < -tol }, SR_k = max_S |Re lambda_j| / min_S |Re lambda_j|.
//! f reads neither s nor t (k_ref is grid data, R8), so J_k always has two exact zero
//! eigenvalues, and on straights (k_ref = 0) e does not feed back either, so (e, dpsi)
//! form a Jordan chain whose double zero eigenvalue the eigensolver returns split into
//! +-sqrt(eps |J|) ~ +-1e-8. `tol = 1e-6 max_j |lambda_j|` keeps this rounding noise out of
//! S (a -2e-8 "eigenvalue" would otherwise fake a ratio of 1e8). SR is undefined (None)
//! when S is empty. Because the slowest decaying mode is often a nearly undamped
//! path-kinematics mode (|Re lambda| ~ 1e-3 1/m), eq. (7) is governed as much by that
//! denominator as by the fast mode; [`NodeStiffness::dynamic_ratio`] therefore also gives
//! the ratio of the five vehicle-dynamics states alone (r, V, beta, V_wr, dFz: the x_dyn of
//! paper eq. 8), whose sub-Jacobian excludes the path kinematics.
//!
//! **Participation factors.** With right eigenvectors V (J V = V Lambda) and left
//! eigenvectors W = V^{-1} (W J = Lambda W, W V = I), the participation of state i in
//! mode j is p_ij = |W_ji V_ij|, normalised over i to sum to 1 (Perez-Arriaga et al.;
//! sum_i W_ji V_ij = 1, scale-invariant). The dominant state of the fastest mode (largest
//! |Re lambda| in S) is the state that makes the node stiff.

use serde::Serialize;

use super::StudyError;
use crate::model::{spatial_derivatives, VehicleParams, NU, NX, STATE_NAMES};
use crate::ocp::ad::{grad, seed1};
use num_dual::DualSVec64;

/// Stiffness data of one node.
#[derive(Debug, Clone, Serialize)]
pub struct NodeStiffness {
    /// Node index k.
    pub k: usize,
    /// Arc length s_k \[m\].
    pub s: f64,
    /// Stiffness ratio of eq. (7) (None if no eigenvalue has a negative real part).
    pub ratio: Option<f64>,
    /// Eigenvalues of J_k as (re, im) [1/m].
    pub eigenvalues: Vec<(f64, f64)>,
    /// The fastest-decaying eigenvalue (re, im) [1/m].
    pub fastest: Option<(f64, f64)>,
    /// The slowest-decaying eigenvalue (re, im) [1/m].
    pub slowest: Option<(f64, f64)>,
    /// Participation of each state in the fastest mode (sums to 1; zeros if none).
    pub participation: [f64; NX],
    /// State with the largest participation in the fastest mode.
    pub dominant_state: Option<&'static str>,
    /// State with the largest participation in the slowest decaying mode (the
    /// denominator of eq. 7).
    pub slowest_dominant_state: Option<&'static str>,
    /// Dominant state of every mode, in `eigenvalues` order.
    pub mode_states: Vec<&'static str>,
    /// Eq. (7) on the 5 x 5 sub-Jacobian of r, V, beta, V_wr, dFz (see the module docs).
    pub dynamic_ratio: Option<f64>,
    /// Dominant state of the fastest mode of that sub-Jacobian.
    pub dynamic_dominant_state: Option<&'static str>,
}

/// Eigen-analysis of a square Jacobian (row-major, `names.len()` states).
struct Modes {
    lam: Vec<(f64, f64)>,
    ratio: Option<f64>,
    fast: Option<usize>,
    slow: Option<usize>,
    /// participation[j][i]: state i in mode j (normalised over i).
    participation: Vec<Vec<f64>>,
}

fn modes(k: usize, j: &[Vec<f64>]) -> Result<Modes, StudyError> {
    let n = j.len();
    let m = faer::Mat::<f64>::from_fn(n, n, |r, c| j[r][c]);
    let eig = m
        .eigen()
        .map_err(|e| StudyError::Invalid(format!("eigendecomposition at node {k}: {e:?}")))?;
    let lam: Vec<(f64, f64)> = (0..n)
        .map(|i| {
            let c = eig.S().column_vector()[i];
            (c.re, c.im)
        })
        .collect();
    let vr = nalgebra::DMatrix::<nalgebra::Complex<f64>>::from_fn(n, n, |r, c| {
        let v = eig.U()[(r, c)];
        nalgebra::Complex::new(v.re, v.im)
    });
    // W = V^-1; None for a numerically defective Jacobian (then no participation factors,
    // the eigenvalues and the ratio stay valid).
    let wl = vr.clone().try_inverse();
    let scale = lam.iter().map(|(a, b)| a.hypot(*b)).fold(0.0, f64::max);
    let tol = 1e-6 * scale;
    let stable: Vec<usize> = (0..n).filter(|&i| lam[i].0 < -tol).collect();
    let by_rate = |a: &&usize, b: &&usize| lam[**a].0.abs().total_cmp(&lam[**b].0.abs());
    let fast = stable.iter().max_by(by_rate).copied();
    let slow = stable.iter().min_by(by_rate).copied();
    let ratio = match (fast, slow) {
        (Some(f), Some(sl)) => Some(lam[f].0.abs() / lam[sl].0.abs()),
        _ => None,
    };
    let participation = (0..n)
        .map(|mode| {
            let Some(wl) = &wl else {
                return vec![0.0; n];
            };
            let mut p: Vec<f64> = (0..n)
                .map(|i| (wl[(mode, i)] * vr[(i, mode)]).norm())
                .collect();
            let total: f64 = p.iter().sum();
            if total > 0.0 && total.is_finite() {
                p.iter_mut().for_each(|v| *v /= total);
            }
            p
        })
        .collect();
    Ok(Modes {
        lam,
        ratio,
        fast,
        slow,
        participation,
    })
}

/// Index of the largest entry (None if no entry is positive, e.g. no participation factors).
fn argmax(v: &[f64]) -> Option<usize> {
    (0..v.len())
        .max_by(|&a, &b| v[a].total_cmp(&v[b]))
        .filter(|&i| v[i] > 0.0)
}

/// The vehicle-dynamics states of the sub-Jacobian (paper eq. 8's x_dyn).
const DYNAMIC: [usize; 5] = [0, 1, 2, 3, 4];

/// The study along one trajectory.
#[derive(Debug, Clone, Serialize)]
pub struct StiffnessStudy {
    /// Which Jacobian: always "spatial" (d(dx/ds)/dx, see the module docs).
    pub jacobian: &'static str,
    /// State names, the order of every `participation`.
    pub states: [&'static str; NX],
    /// One entry per node k = 0..N.
    pub nodes: Vec<NodeStiffness>,
    /// Node of the largest ratio over k >= 1 (node 0 is a free, non-physical state,
    /// reference README finding c; its ratio is still listed in `nodes`).
    pub peak_node: Option<usize>,
    /// The peak ratio over k >= 1.
    pub peak_ratio: Option<f64>,
    /// Dominant state of the fastest mode at the peak.
    pub peak_dominant_state: Option<&'static str>,
    /// Dominant state of the slowest decaying mode at the peak.
    pub peak_slowest_state: Option<&'static str>,
    /// Nodes (k >= 1) whose ratio exceeds the classical stiff threshold 1e3.
    pub nodes_above_1e3: usize,
    /// Over nodes k >= 1 with a ratio: how often each state dominates the fastest mode.
    pub dominant_counts: [usize; NX],
    /// Node (k >= 1) of the largest vehicle-dynamics-only ratio.
    pub dynamic_peak_node: Option<usize>,
    /// That ratio.
    pub dynamic_peak_ratio: Option<f64>,
    /// Dominant state of its fastest mode.
    pub dynamic_peak_dominant_state: Option<&'static str>,
}

/// J = d(dx/ds)/dx at (x, u; kappa), row-major \[i\]\[l\].
pub fn spatial_jacobian(
    p: &VehicleParams,
    x: &[f64; NX],
    u: &[f64; NU],
    kappa: f64,
) -> [[f64; NX]; NX] {
    let xd: [DualSVec64<NX>; NX] = std::array::from_fn(|i| seed1::<NX>(x[i], i));
    let ud: [DualSVec64<NX>; NU] = std::array::from_fn(|j| DualSVec64::<NX>::from_re(u[j]));
    let f = spatial_derivatives(p, &xd, &ud, kappa);
    std::array::from_fn(|i| grad(&f[i]))
}

/// Eigen-analysis of one Jacobian (see the module docs). Errors if the eigendecomposition
/// fails; a singular eigenvector matrix (defective Jacobian) leaves the participation
/// factors at zero and the dominant states unnamed.
pub fn analyze_jacobian(
    k: usize,
    s: f64,
    j: &[[f64; NX]; NX],
) -> Result<NodeStiffness, StudyError> {
    let full: Vec<Vec<f64>> = j.iter().map(|r| r.to_vec()).collect();
    let m = modes(k, &full)?;
    let mut participation = [0.0; NX];
    if let Some(f) = m.fast {
        participation.copy_from_slice(&m.participation[f]);
    }
    let dominant_state = m
        .fast
        .and_then(|f| argmax(&m.participation[f]))
        .map(|i| STATE_NAMES[i]);
    let slowest_dominant_state = m
        .slow
        .and_then(|f| argmax(&m.participation[f]))
        .map(|i| STATE_NAMES[i]);
    let mode_states = m
        .participation
        .iter()
        .map(|p| argmax(p).map_or("-", |i| STATE_NAMES[i]))
        .collect();
    let sub: Vec<Vec<f64>> = DYNAMIC
        .iter()
        .map(|&r| DYNAMIC.iter().map(|&c| j[r][c]).collect())
        .collect();
    let d = modes(k, &sub)?;
    let dynamic_dominant_state = d
        .fast
        .and_then(|f| argmax(&d.participation[f]))
        .map(|i| STATE_NAMES[DYNAMIC[i]]);
    Ok(NodeStiffness {
        k,
        s,
        ratio: m.ratio,
        fastest: m.fast.map(|i| m.lam[i]),
        slowest: m.slow.map(|i| m.lam[i]),
        eigenvalues: m.lam,
        participation,
        dominant_state,
        slowest_dominant_state,
        mode_states,
        dynamic_ratio: d.ratio,
        dynamic_dominant_state,
    })
}

/// Runs the analysis at every node of a trajectory: states x_0..x_N, controls u_0..u_{N-1}
/// (u_N = u_{N-1}), k_ref at the nodes, node spacing ds.
pub fn analyze(
    p: &VehicleParams,
    xs: &[[f64; NX]],
    us: &[[f64; NU]],
    kappa: &[f64],
    ds: f64,
) -> Result<StiffnessStudy, StudyError> {
    if xs.is_empty() || us.is_empty() || kappa.len() != xs.len() || us.len() + 1 != xs.len() {
        return Err(StudyError::Invalid(format!(
            "need N + 1 states, N controls and N + 1 curvatures (got {}, {}, {})",
            xs.len(),
            us.len(),
            kappa.len()
        )));
    }
    let mut nodes = Vec::with_capacity(xs.len());
    for (k, x) in xs.iter().enumerate() {
        let u = us[k.min(us.len() - 1)];
        let jac = spatial_jacobian(p, x, &u, kappa[k]);
        if jac.iter().flatten().any(|v| !v.is_finite()) {
            return Err(StudyError::Invalid(format!(
                "node {k}: Jacobian is not finite"
            )));
        }
        nodes.push(analyze_jacobian(k, k as f64 * ds, &jac)?);
    }
    let mut peak: Option<(usize, f64)> = None;
    let mut dyn_peak: Option<(usize, f64)> = None;
    let mut dominant_counts = [0; NX];
    let mut above = 0;
    for n in nodes.iter().skip(1) {
        if let Some(r) = n.dynamic_ratio {
            if dyn_peak.is_none_or(|(_, pr)| r > pr) {
                dyn_peak = Some((n.k, r));
            }
        }
        if let Some(r) = n.ratio {
            if peak.is_none_or(|(_, pr)| r > pr) {
                peak = Some((n.k, r));
            }
            if r > 1e3 {
                above += 1;
            }
            if let Some(d) = n.dominant_state {
                if let Some(i) = STATE_NAMES.iter().position(|s| *s == d) {
                    dominant_counts[i] += 1;
                }
            }
        }
    }
    Ok(StiffnessStudy {
        jacobian: "spatial",
        states: STATE_NAMES,
        peak_node: peak.map(|p| p.0),
        peak_ratio: peak.map(|p| p.1),
        peak_dominant_state: peak.and_then(|(k, _)| nodes[k].dominant_state),
        peak_slowest_state: peak.and_then(|(k, _)| nodes[k].slowest_dominant_state),
        nodes_above_1e3: above,
        dominant_counts,
        dynamic_peak_node: dyn_peak.map(|p| p.0),
        dynamic_peak_ratio: dyn_peak.map(|p| p.1),
        dynamic_peak_dominant_state: dyn_peak.and_then(|(k, _)| nodes[k].dynamic_dominant_state),
        nodes,
    })
}
