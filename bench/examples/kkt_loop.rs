//! Runs K Riccati (or sparse) factorizations + solves of the oval KKT system, for CPU-time
//! measurements (`perf stat -e task-clock`) that a loaded machine distorts less than wall
//! time. Usage: kkt_loop [riccati|sparse] [K]

use bench::OvalKkt;
use planner::ip::kkt::KktSolver;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let which = args.get(1).map(String::as_str).unwrap_or("riccati");
    let k: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1000);
    let sys = OvalKkt::new(if which == "sparse" { -1e-10 } else { 0.0 });
    let values = sys.values();
    let mut kkt: Box<dyn KktSolver> = if which == "sparse" {
        Box::new(sys.sparse())
    } else {
        Box::new(sys.riccati())
    };
    let (mut bx, mut by) = (vec![0.0; sys.n], vec![0.0; sys.m]);
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
