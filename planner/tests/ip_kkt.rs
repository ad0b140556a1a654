//! The sparse LDL^T KKT backend against a dense solve and a dense eigen-decomposition.

use nalgebra::{DMatrix, DVector};
use planner::ip::kkt::{KktError, KktSolver, KktValues, SparseLdlt};

/// Deterministic pseudo-random numbers in [-1, 1) (xorshift).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

struct Case {
    n: usize,
    m: usize,
    hr: Vec<usize>,
    hc: Vec<usize>,
    hv: Vec<f64>,
    jr: Vec<usize>,
    jc: Vec<usize>,
    jv: Vec<f64>,
    dx: Vec<f64>,
    dc: Vec<f64>,
}

fn case(seed: u64, n: usize, m: usize, hess_shift: f64) -> Case {
    let mut rng = Rng(seed);
    let (mut hr, mut hc, mut hv) = (vec![], vec![], vec![]);
    for i in 0..n {
        for j in 0..=i {
            if i == j || rng.next() > 0.4 {
                hr.push(i);
                hc.push(j);
                hv.push(rng.next() + if i == j { hess_shift } else { 0.0 });
            }
        }
    }
    // A repeated entry, summed by the backend.
    hr.push(n - 1);
    hc.push(0);
    hv.push(0.25);
    let (mut jr, mut jc, mut jv) = (vec![], vec![], vec![]);
    for i in 0..m {
        jr.push(i);
        jc.push(i);
        jv.push(1.0 + rng.next().abs());
        for j in 0..n {
            if j != i && rng.next() > 0.6 {
                jr.push(i);
                jc.push(j);
                jv.push(rng.next());
            }
        }
    }
    let dx = (0..n).map(|_| 0.1 + rng.next().abs()).collect();
    let dc = (0..m)
        .map(|i| {
            if i % 2 == 0 {
                -1e-8
            } else {
                -0.5 * rng.next().abs() - 1e-3
            }
        })
        .collect();
    Case {
        n,
        m,
        hr,
        hc,
        hv,
        jr,
        jc,
        jv,
        dx,
        dc,
    }
}

fn dense(c: &Case) -> DMatrix<f64> {
    let d = c.n + c.m;
    let mut k = DMatrix::zeros(d, d);
    for ((&r, &cc), &v) in c.hr.iter().zip(&c.hc).zip(&c.hv) {
        k[(r, cc)] += v;
        if r != cc {
            k[(cc, r)] += v;
        }
    }
    for ((&r, &cc), &v) in c.jr.iter().zip(&c.jc).zip(&c.jv) {
        k[(c.n + r, cc)] += v;
        k[(cc, c.n + r)] += v;
    }
    for i in 0..c.n {
        k[(i, i)] += c.dx[i];
    }
    for i in 0..c.m {
        k[(c.n + i, c.n + i)] += c.dc[i];
    }
    k
}

#[test]
fn sparse_step_matches_dense_solve_and_inertia_matches_eigenvalues() {
    for (seed, shift) in [(7u64, 3.0), (11, 0.0), (23, -1.5)] {
        let c = case(seed, 12, 5, shift);
        let mut kkt = SparseLdlt::new(c.n, c.m, &c.hr, &c.hc, &c.jr, &c.jc).unwrap();
        let vals = KktValues {
            hess: &c.hv,
            jac: &c.jv,
            primal_diag: &c.dx,
            dual_diag: &c.dc,
        };
        let inertia = kkt.factorize(&vals).expect("nonsingular");
        let k = dense(&c);
        let eig = k.clone().symmetric_eigen().eigenvalues;
        let pos = eig.iter().filter(|&&e| e > 0.0).count();
        let neg = eig.iter().filter(|&&e| e < 0.0).count();
        assert_eq!(
            (inertia.positive, inertia.negative),
            (pos, neg),
            "seed {seed}"
        );

        let mut rng = Rng(seed + 1);
        let rhs: Vec<f64> = (0..c.n + c.m).map(|_| rng.next()).collect();
        let mut rx = rhs[..c.n].to_vec();
        let mut ry = rhs[c.n..].to_vec();
        kkt.solve(&mut rx, &mut ry);
        let want = k.lu().solve(&DVector::from_vec(rhs)).unwrap();
        let got: Vec<f64> = rx.into_iter().chain(ry).collect();
        let scale = want.amax().max(1.0);
        for (a, b) in got.iter().zip(want.iter()) {
            assert!((a - b).abs() < 1e-9 * scale, "seed {seed}: {a} vs {b}");
        }
    }
}

#[test]
fn singular_matrix_is_reported() {
    // Two identical constraint rows with no dual regularization: singular.
    let hr = vec![0, 1];
    let hc = vec![0, 1];
    let jr = vec![0, 0, 1, 1];
    let jc = vec![0, 1, 0, 1];
    let mut kkt = SparseLdlt::new(2, 2, &hr, &hc, &jr, &jc).unwrap();
    let res = kkt.factorize(&KktValues {
        hess: &[1.0, 1.0],
        jac: &[1.0, 2.0, 1.0, 2.0],
        primal_diag: &[0.0, 0.0],
        dual_diag: &[0.0, 0.0],
    });
    // Either a zero pivot is reported, or the inertia counts one: anything claiming a
    // nonsingular matrix (no zero eigenvalue) is wrong.
    match res {
        Err(e) => assert_eq!(e, KktError::Singular, "{e}"),
        Ok(i) => assert!(i.zero > 0, "inertia {i:?} claims nonsingular"),
    }
}
