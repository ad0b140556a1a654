//! Runs K Riccati (or sparse) factorizations + solves of the oval KKT system, for
//! `perf stat -e cycles:u` measurements that a loaded machine does not distort.
//! Usage: kkt_loop [riccati|sparse] [K]

use bench::oval_nlp_at_reference;
use planner::ip::kkt::backend::VehicleRiccati;
use planner::ip::kkt::{KktSolver, KktValues, SparseLdlt};
use planner::ip::Nlp;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let which = args.get(1).map(String::as_str).unwrap_or("riccati");
    let k: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1000);
    let (mut nlp, z) = oval_nlp_at_reference();
    let d = nlp.dims();
    let (n, m) = (d.n, d.m);
    let (mut hr, mut hc) = (vec![0; d.nnz_hess], vec![0; d.nnz_hess]);
    let (mut jr, mut jc) = (vec![0; d.nnz_jac], vec![0; d.nnz_jac]);
    nlp.hess_structure(&mut hr, &mut hc);
    nlp.jac_structure(&mut jr, &mut jc);
    let lambda: Vec<f64> = (0..m).map(|i| ((i % 7) as f64 - 3.0) * 0.1).collect();
    let mut hess = vec![0.0; d.nnz_hess];
    let mut jac = vec![0.0; d.nnz_jac];
    nlp.eval_hess(&z, 1.0, &lambda, &mut hess);
    nlp.eval_jac_g(&z, &mut jac);
    let (mut xl, mut xu, mut gl, mut gu) = (vec![0.0; n], vec![0.0; n], vec![0.0; m], vec![0.0; m]);
    nlp.bounds(&mut xl, &mut xu, &mut gl, &mut gu);
    let dx: Vec<f64> = (0..n).map(|i| 1.0 + (i % 5) as f64).collect();
    let eq_reg = if which == "sparse" { -1e-10 } else { 0.0 };
    let dc: Vec<f64> = (0..m)
        .map(|i| {
            if gl[i] == gu[i] {
                eq_reg
            } else {
                -0.1 - (i % 3) as f64
            }
        })
        .collect();
    let values = KktValues {
        hess: &hess,
        jac: &jac,
        primal_diag: &dx,
        dual_diag: &dc,
    };
    let mut kkt: Box<dyn KktSolver> = if which == "sparse" {
        Box::new(SparseLdlt::new(n, m, &hr, &hc, &jr, &jc).expect("setup"))
    } else {
        let st = nlp.stage_structure().expect("structure");
        Box::new(VehicleRiccati::new(&st, n, &hr, &hc, &jr, &jc).expect("setup"))
    };
    let (mut bx, mut by) = (vec![0.0; n], vec![0.0; m]);
    let mut acc = 0.0;
    let t0 = std::time::Instant::now();
    for it in 0..k {
        kkt.factorize(&values).expect("factorizes");
        bx.iter_mut()
            .enumerate()
            .for_each(|(i, v)| *v = ((i + it) % 11) as f64 - 5.0);
        by.iter_mut()
            .enumerate()
            .for_each(|(i, v)| *v = ((i + it) % 13) as f64 - 6.0);
        kkt.solve(&mut bx, &mut by);
        acc += bx[0];
    }
    eprintln!(
        "{which}: {k} factorize+solve, {:.1} us each (wall), checksum {acc:.6e}",
        t0.elapsed().as_secs_f64() * 1e6 / k as f64
    );
}
