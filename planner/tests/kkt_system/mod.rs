//! The KKT systems of the oval NLP that the Riccati backend tests factorize: Hessian,
//! Jacobian and random diagonals at a perturbed starting point.
#![allow(dead_code)]

use std::path::Path;

use planner::config::{load_scenario, load_vehicle};
use planner::ip::kkt::backend::VehicleRiccati;
use planner::ip::kkt::KktValues;
use planner::ip::Nlp;
use planner::ocp::transcription::ImplicitEulerNlp;
use planner::ocp::OcpSpec;

use crate::common::Rng;

pub fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"))
}

pub fn oval_spec() -> OcpSpec {
    let vehicle = load_vehicle(&root().join("vehicles/lc500.toml")).unwrap();
    load_scenario(&root().join("scenarios/oval.toml"), None, vehicle).unwrap()
}

/// A KKT system of the oval NLP at its starting point with random multipliers and
/// diagonals: Hessian, Jacobian, D_x > 0, D_c = -delta_c on equalities and < 0 otherwise.
#[derive(Clone)]
pub struct System {
    pub n: usize,
    pub m: usize,
    pub hr: Vec<usize>,
    pub hc: Vec<usize>,
    pub jr: Vec<usize>,
    pub jc: Vec<usize>,
    pub hess: Vec<f64>,
    pub jac: Vec<f64>,
    pub dx: Vec<f64>,
    pub dc: Vec<f64>,
}

pub fn system<const N: usize>(
    nlp: &mut ImplicitEulerNlp<N>,
    rng: &mut Rng,
    delta_c: f64,
    sparse_diag: bool,
) -> System {
    let d = nlp.dims();
    let (n, m) = (d.n, d.m);
    let mut hr = vec![0; d.nnz_hess];
    let mut hc = vec![0; d.nnz_hess];
    let mut jr = vec![0; d.nnz_jac];
    let mut jc = vec![0; d.nnz_jac];
    nlp.hess_structure(&mut hr, &mut hc);
    nlp.jac_structure(&mut jr, &mut jc);
    let mut x = vec![0.0; n];
    nlp.initial_point(&mut x);
    for v in x.iter_mut() {
        *v *= rng.range(0.9, 1.1);
    }
    let lambda: Vec<f64> = (0..m).map(|_| rng.range(-1.0, 1.0)).collect();
    let mut hess = vec![0.0; d.nnz_hess];
    let mut jac = vec![0.0; d.nnz_jac];
    nlp.eval_hess(&x, 1.0, &lambda, &mut hess);
    nlp.eval_jac_g(&x, &mut jac);
    let (mut xl, mut xu, mut gl, mut gu) = (vec![0.0; n], vec![0.0; n], vec![0.0; m], vec![0.0; m]);
    nlp.bounds(&mut xl, &mut xu, &mut gl, &mut gu);
    // Barrier terms only on some variables (the others have no bounds) when `sparse_diag`.
    let dx = (0..n)
        .map(|_| {
            if sparse_diag && rng.next() < 0.5 {
                0.0
            } else {
                10f64.powf(rng.range(-1.0, 2.0))
            }
        })
        .collect();
    let dc = (0..m)
        .map(|i| {
            if gl[i] == gu[i] {
                -delta_c
            } else {
                -(10f64.powf(rng.range(-2.0, 2.0)))
            }
        })
        .collect();
    System {
        n,
        m,
        hr,
        hc,
        jr,
        jc,
        hess,
        jac,
        dx,
        dc,
    }
}

impl System {
    /// The KKT values as the backends take them.
    pub fn values(&self) -> KktValues<'_> {
        KktValues {
            hess: &self.hess,
            jac: &self.jac,
            primal_diag: &self.dx,
            dual_diag: &self.dc,
        }
    }
}

/// The Riccati backend for a system's pattern.
pub fn riccati_for(structure: &planner::ip::kkt::StageStructure, s: &System) -> VehicleRiccati {
    VehicleRiccati::new(structure, s.n, &s.hr, &s.hc, &s.jr, &s.jc).unwrap()
}
