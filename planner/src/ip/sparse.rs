//! Products with the sparse constraint Jacobian J and the Lagrangian Hessian H, stored as
//! coordinate triplets (row, column, value): J v, J^T v and H v with H symmetric (lower
//! triangle stored). They know only slices, no solver state.

/// out += J^T v over the x part (`out` has length n).
pub fn jac_t_mul(ws_rows: &[usize], ws_cols: &[usize], jac: &[f64], v: &[f64], out: &mut [f64]) {
    for ((&r, &c), &a) in ws_rows.iter().zip(ws_cols).zip(jac) {
        out[c] += a * v[r];
    }
}

/// The Jacobian's entries grouped by column (stable: a column keeps its entries' order), for
/// J^T v as a gather per column: the scatter of [`jac_t_mul`] stored to `out` once per entry.
#[derive(Debug, Clone, Default)]
pub struct ColumnJacobian {
    /// Entries of column c: `entries[start[c]..start[c + 1]]`.
    start: Vec<u32>,
    /// (row, index into the values) per entry.
    entries: Vec<(u32, u32)>,
}

impl ColumnJacobian {
    /// Groups the pattern (`rows`, `cols`) of n columns; allocates (setup). Entries outside
    /// the n columns are left out (the KKT backends reject such a pattern at setup).
    pub fn new(rows: &[usize], cols: &[usize], n: usize) -> Self {
        let mut order: Vec<usize> = (0..cols.len()).collect();
        order.sort_by_key(|&q| cols[q]);
        let mut start = vec![0u32; n + 1];
        for &c in cols {
            if c < n {
                start[c + 1] += 1;
            }
        }
        for c in 0..n {
            start[c + 1] += start[c];
        }
        let entries = order
            .iter()
            .filter(|&&q| cols[q] < n)
            .map(|&q| (rows[q] as u32, q as u32))
            .collect();
        Self { start, entries }
    }

    /// out += J^T v with the bits of [`jac_t_mul`] (each `out[c]` takes its terms in the
    /// pattern's order; a NaN's sign and payload aside).
    pub fn t_mul(&self, jac: &[f64], v: &[f64], out: &mut [f64]) {
        for (c, o) in out.iter_mut().enumerate() {
            let (a, b) = (self.start[c] as usize, self.start[c + 1] as usize);
            let mut acc = *o;
            for &(r, q) in &self.entries[a..b] {
                acc += jac[q as usize] * v[r as usize];
            }
            *o = acc;
        }
    }
}

/// out += J v (`out` has length m).
pub fn jac_mul(ws_rows: &[usize], ws_cols: &[usize], jac: &[f64], v: &[f64], out: &mut [f64]) {
    for ((&r, &c), &a) in ws_rows.iter().zip(ws_cols).zip(jac) {
        out[r] += a * v[c];
    }
}

/// out += H v for a symmetric H stored as its lower triangle.
pub fn hess_mul(rows: &[usize], cols: &[usize], hess: &[f64], v: &[f64], out: &mut [f64]) {
    for ((&r, &c), &h) in rows.iter().zip(cols).zip(hess) {
        out[r] += h * v[c];
        if r != c {
            out[c] += h * v[r];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic pseudo-random numbers for the patterns.
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> u64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            self.0 >> 33
        }
    }

    /// The per-column gather gives the bits of the scatter over random patterns (duplicate
    /// entries, empty columns and entries outside the n columns included).
    #[test]
    fn column_gather_has_the_scatter_bits() {
        let mut rng = Lcg(7);
        for case in 0..200 {
            let (n, m) = (1 + case % 17, 1 + case % 13);
            let nnz = (rng.next() % 60) as usize;
            let rows: Vec<usize> = (0..nnz).map(|_| (rng.next() % m as u64) as usize).collect();
            let cols: Vec<usize> = (0..nnz)
                .map(|_| (rng.next() % (n as u64 + 2)) as usize)
                .collect();
            let val = |rng: &mut Lcg| (rng.next() % 2001) as f64 / 7.0 - 140.0;
            let jac: Vec<f64> = (0..nnz).map(|_| val(&mut rng)).collect();
            let v: Vec<f64> = (0..m).map(|_| val(&mut rng)).collect();
            let start: Vec<f64> = (0..n).map(|_| val(&mut rng)).collect();
            // The scatter, restricted to the n columns as the gather is.
            let (mut sr, mut sc, mut sj) = (Vec::new(), Vec::new(), Vec::new());
            for q in 0..nnz {
                if cols[q] < n {
                    sr.push(rows[q]);
                    sc.push(cols[q]);
                    sj.push(jac[q]);
                }
            }
            let mut want = start.clone();
            jac_t_mul(&sr, &sc, &sj, &v, &mut want);
            let mut got = start.clone();
            ColumnJacobian::new(&rows, &cols, n).t_mul(&jac, &v, &mut got);
            let bits = |x: &[f64]| x.iter().map(|a| a.to_bits()).collect::<Vec<u64>>();
            assert_eq!(bits(&got), bits(&want), "case {case}");
        }
    }
}
