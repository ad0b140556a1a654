//! General sparse backend: faer's simplicial LDL^T with AMD ordering; symbolic analysis
//! once at setup, numeric refactorization into preallocated memory every iteration. The
//! AMD permutation of the pattern is also done once: values go straight into the permuted
//! matrix (faer's own permuted layout, so the factorization does the same arithmetic).

use super::{Inertia, KktError, KktSolver, KktValues};
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::ldlt::factor::{LdltParams, LdltRegularization};
use faer::sparse::linalg::cholesky::supernodal::SupernodalLdltRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw,
    SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::utils::permute_self_adjoint_to_unsorted;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par, Side, Spec};

/// Where each source entry of the KKT system lands in the CSC value array.
#[derive(Debug, Clone)]
struct ValueMap {
    hess: Vec<usize>,
    jac: Vec<usize>,
    diag: Vec<usize>,
}

/// Sparse LDL^T backend over the upper triangle of the full KKT matrix (faer).
pub struct SparseLdlt {
    n: usize,
    m: usize,
    pattern: SymbolicSparseColMat<usize>,
    values: Vec<f64>,
    map: ValueMap,
    /// The AMD-permuted upper triangle P K P^T: pattern, values, and for each of its
    /// entries the index of the source entry in `values`.
    ppattern: SymbolicSparseColMat<usize>,
    pvalues: Vec<f64>,
    pmap: Vec<usize>,
    /// AMD permutation: permuted index i is original index `fwd[i]`; `inv` is its inverse.
    perm_fwd: Vec<usize>,
    perm_inv: Vec<usize>,
    /// Symbolic factorization of the permuted matrix (identity ordering).
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    mem: MemBuffer,
    rhs: Vec<f64>,
    b: Vec<f64>,
    resid: Vec<f64>,
    xperm: Vec<f64>,
    factorized: bool,
    refine_steps: usize,
}

impl std::fmt::Debug for SparseLdlt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseLdlt")
            .field("n", &self.n)
            .field("m", &self.m)
            .field("nnz", &self.values.len())
            .field("l_nnz", &self.l_values.len())
            .finish()
    }
}

/// Error building the symbolic structure.
#[derive(Debug, thiserror::Error)]
#[error("symbolic KKT analysis failed: {0}")]
pub struct SymbolicError(String);

/// The upper triangle (row <= col) of the KKT pattern with the full diagonal, sorted and
/// deduplicated, and where each source entry lands in its value array.
fn kkt_pattern(
    n: usize,
    m: usize,
    hess_rows: &[usize],
    hess_cols: &[usize],
    jac_rows: &[usize],
    jac_cols: &[usize],
) -> Result<(SymbolicSparseColMat<usize>, ValueMap), SymbolicError> {
    let dim = n + m;
    // Upper-triangle (row <= col) coordinates of every source entry.
    let mut coords: Vec<(usize, usize)> =
        Vec::with_capacity(hess_rows.len() + jac_rows.len() + dim);
    for (&r, &c) in hess_rows.iter().zip(hess_cols) {
        if r >= n || c >= n {
            return Err(SymbolicError(format!(
                "Hessian entry ({r},{c}) out of range"
            )));
        }
        coords.push((r.min(c), r.max(c)));
    }
    for (&r, &c) in jac_rows.iter().zip(jac_cols) {
        if r >= m || c >= n {
            return Err(SymbolicError(format!(
                "Jacobian entry ({r},{c}) out of range"
            )));
        }
        coords.push((c, n + r));
    }
    for i in 0..dim {
        coords.push((i, i));
    }
    // Unique sorted by (col, row).
    let mut keys: Vec<(usize, usize)> = coords.iter().map(|&(r, c)| (c, r)).collect();
    keys.sort_unstable();
    keys.dedup();
    let mut col_ptr = vec![0usize; dim + 1];
    let mut row_idx = Vec::with_capacity(keys.len());
    for &(c, r) in &keys {
        col_ptr[c + 1] += 1;
        row_idx.push(r);
    }
    for c in 0..dim {
        col_ptr[c + 1] += col_ptr[c];
    }
    let find = |r: usize, c: usize| -> usize {
        // keys is sorted by (col,row): binary search.
        keys.binary_search(&(c, r)).unwrap_or(usize::MAX)
    };
    let nh = hess_rows.len();
    let nj = jac_rows.len();
    let map = ValueMap {
        hess: coords[..nh].iter().map(|&(r, c)| find(r, c)).collect(),
        jac: coords[nh..nh + nj]
            .iter()
            .map(|&(r, c)| find(r, c))
            .collect(),
        diag: (0..dim).map(|i| find(i, i)).collect(),
    };
    let pattern = SymbolicSparseColMat::new_checked(dim, dim, col_ptr, None, row_idx);
    Ok((pattern, map))
}

/// The AMD permutation of a pattern and the permuted upper triangle P K P^T.
struct AmdPermuted {
    perm_fwd: Vec<usize>,
    perm_inv: Vec<usize>,
    /// Permuted pattern (faer's own permuted layout).
    ppattern: SymbolicSparseColMat<usize>,
    /// For each permuted entry, the index of its source entry.
    pmap: Vec<usize>,
}

/// Orders `pattern` by AMD and permutes it once, carrying each entry's source index.
fn amd_permuted(
    pattern: &SymbolicSparseColMat<usize>,
    params_sym: CholeskySymbolicParams<'_>,
) -> Result<AmdPermuted, SymbolicError> {
    let dim = pattern.ncols();
    let nnz = pattern.row_idx().len();
    let amd = factorize_symbolic_cholesky(
        pattern.as_ref(),
        Side::Upper,
        SymmetricOrdering::Amd,
        params_sym,
    )
    .map_err(|e| SymbolicError(format!("{e:?}")))?;
    let (perm_fwd, perm_inv): (Vec<usize>, Vec<usize>) = match amd.perm() {
        Some(p) => (p.arrays().0.to_vec(), p.arrays().1.to_vec()),
        None => ((0..dim).collect(), (0..dim).collect()),
    };
    // Permute once, carrying each entry's source index as its value (exact in f64).
    let slots: Vec<f64> = (0..nnz).map(|i| i as f64).collect();
    let mut pslots = vec![0.0; nnz];
    let mut pcol_ptr = vec![0usize; dim + 1];
    let mut prow_idx = vec![0usize; nnz];
    {
        let perm = faer::perm::PermRef::new_checked(&perm_fwd, &perm_inv, dim);
        let mut mem = MemBuffer::new(StackReq::new::<usize>(dim));
        permute_self_adjoint_to_unsorted(
            &mut pslots,
            &mut pcol_ptr,
            &mut prow_idx,
            SparseColMatRef::new(pattern.as_ref(), &slots),
            perm,
            Side::Upper,
            Side::Upper,
            MemStack::new(&mut mem),
        );
    }
    let pmap: Vec<usize> = pslots.iter().map(|&v| v as usize).collect();
    let ppattern = SymbolicSparseColMat::new_unsorted_checked(dim, dim, pcol_ptr, None, prow_idx);
    Ok(AmdPermuted {
        perm_fwd,
        perm_inv,
        ppattern,
        pmap,
    })
}

impl SparseLdlt {
    /// Builds the KKT pattern from the Hessian (lower triangle) and Jacobian coordinates and
    /// runs the symbolic analysis. Allocates; call once at setup.
    pub fn new(
        n: usize,
        m: usize,
        hess_rows: &[usize],
        hess_cols: &[usize],
        jac_rows: &[usize],
        jac_cols: &[usize],
    ) -> Result<Self, SymbolicError> {
        let dim = n + m;
        let (pattern, map) = kkt_pattern(n, m, hess_rows, hess_cols, jac_rows, jac_cols)?;
        let nnz = pattern.row_idx().len();
        let params_sym = CholeskySymbolicParams {
            // Simplicial: faster than supernodal on these KKT systems.
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL,
            ..Default::default()
        };
        let amd = amd_permuted(&pattern, params_sym)?;
        let symbolic = factorize_symbolic_cholesky(
            amd.ppattern.as_ref(),
            Side::Upper,
            SymmetricOrdering::Identity,
            params_sym,
        )
        .map_err(|e| SymbolicError(format!("{e:?}")))?;
        let params: Spec<LdltParams, f64> = Default::default();
        let mem = MemBuffer::new(StackReq::any_of(&[
            symbolic.factorize_numeric_ldlt_scratch::<f64>(Par::Seq, params),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
        ]));
        let l_values = vec![0.0; symbolic.len_val()];
        Ok(Self {
            n,
            m,
            pattern,
            values: vec![0.0; nnz],
            map,
            ppattern: amd.ppattern,
            pvalues: vec![0.0; nnz],
            pmap: amd.pmap,
            perm_fwd: amd.perm_fwd,
            perm_inv: amd.perm_inv,
            symbolic,
            l_values,
            mem,
            rhs: vec![0.0; dim],
            b: vec![0.0; dim],
            resid: vec![0.0; dim],
            xperm: vec![0.0; dim],
            factorized: false,
            refine_steps: 1,
        })
    }

    /// Number of stored entries of the upper triangle of the KKT matrix.
    pub fn nnz(&self) -> usize {
        self.values.len()
    }

    /// Number of stored entries of the factor L.
    pub fn factor_nnz(&self) -> usize {
        self.l_values.len()
    }

    /// Sets the cap on iterative-refinement steps per solve (0 disables refinement).
    pub fn set_refine_steps(&mut self, steps: usize) {
        self.refine_steps = steps;
    }

    /// out = K x with the upper-triangle CSC values of the last factorized matrix.
    fn matvec(pattern: &SymbolicSparseColMat<usize>, values: &[f64], x: &[f64], out: &mut [f64]) {
        out.iter_mut().for_each(|v| *v = 0.0);
        let col_ptr = pattern.col_ptr();
        let row_idx = pattern.row_idx();
        for j in 0..x.len() {
            for k in col_ptr[j]..col_ptr[j + 1] {
                let i = row_idx[k];
                let v = values[k];
                out[i] += v * x[j];
                if i != j {
                    out[j] += v * x[i];
                }
            }
        }
    }

    /// rhs <- K^-1 rhs: permute, solve with the factors of P K P^T, permute back (as
    /// faer's own permuted solve does).
    fn solve_raw(&mut self) {
        let dim = self.n + self.m;
        for (x, &f) in self.xperm.iter_mut().zip(&self.perm_fwd) {
            *x = self.rhs[f];
        }
        let ldlt = faer::sparse::linalg::cholesky::LdltRef::new(&self.symbolic, &self.l_values);
        let x = MatMut::from_column_major_slice_mut(&mut self.xperm, dim, 1);
        ldlt.solve_in_place_with_conj(Conj::No, x, Par::Seq, MemStack::new(&mut self.mem));
        for (r, &i) in self.rhs.iter_mut().zip(&self.perm_inv) {
            *r = self.xperm[i];
        }
    }

    fn inertia(&self) -> Inertia {
        let mut inertia = Inertia::default();
        let mut count = |d: f64| {
            if !d.is_finite() || d == 0.0 {
                inertia.zero += 1;
            } else if d > 0.0 {
                inertia.positive += 1;
            } else {
                inertia.negative += 1;
            }
        };
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(s) => {
                let col_ptr = s.col_ptr();
                for k in 0..self.n + self.m {
                    count(self.l_values[col_ptr[k]]);
                }
            }
            SymbolicCholeskyRaw::Supernodal(s) => {
                let ldlt = SupernodalLdltRef::new(s, &self.l_values);
                for sn in 0..s.n_supernodes() {
                    let block = ldlt.supernode(sn).val();
                    let width = s.supernode_end()[sn] - s.supernode_begin()[sn];
                    for j in 0..width {
                        count(block[(j, j)]);
                    }
                }
            }
        }
        inertia
    }
}

impl KktSolver for SparseLdlt {
    fn factorize(&mut self, v: &KktValues<'_>) -> Result<Inertia, KktError> {
        self.values.iter_mut().for_each(|x| *x = 0.0);
        for (k, &h) in v.hess.iter().enumerate() {
            self.values[self.map.hess[k]] += h;
        }
        for (k, &j) in v.jac.iter().enumerate() {
            self.values[self.map.jac[k]] += j;
        }
        for (i, &d) in v.primal_diag.iter().enumerate() {
            self.values[self.map.diag[i]] += d;
        }
        for (i, &d) in v.dual_diag.iter().enumerate() {
            self.values[self.map.diag[self.n + i]] += d;
        }
        // Gather into the permuted matrix; x * 0 is NaN exactly for NaN and +-inf.
        let mut nonfinite = 0.0;
        for (pv, &src) in self.pvalues.iter_mut().zip(&self.pmap) {
            let x = self.values[src];
            *pv = x;
            nonfinite += x * 0.0;
        }
        if nonfinite != 0.0 || nonfinite.is_nan() {
            self.factorized = false;
            return Err(KktError::NonFinite);
        }
        let a = SparseColMatRef::new(self.ppattern.as_ref(), &self.pvalues);
        let res = self.symbolic.factorize_numeric_ldlt(
            &mut self.l_values,
            a,
            Side::Upper,
            LdltRegularization::default(),
            Par::Seq,
            MemStack::new(&mut self.mem),
            Default::default(),
        );
        match res {
            Ok(_) => {
                self.factorized = true;
                let inertia = self.inertia();
                if inertia.zero > 0 {
                    self.factorized = false;
                    return Err(KktError::Singular);
                }
                Ok(inertia)
            }
            Err(_) => {
                self.factorized = false;
                Err(KktError::Singular)
            }
        }
    }

    fn solve(&mut self, rhs_x: &mut [f64], rhs_y: &mut [f64]) {
        let n = self.n;
        self.rhs[..n].copy_from_slice(rhs_x);
        self.rhs[n..].copy_from_slice(rhs_y);
        if self.factorized {
            // x = K^-1 b, then iterative refinement against the same matrix: the
            // quasi-definite LDL^T without pivoting loses digits when a small dual
            // regularization is pivoted early.
            self.b.copy_from_slice(&self.rhs);
            self.solve_raw();
            let b_norm = self.b.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            for _ in 0..self.refine_steps {
                Self::matvec(&self.pattern, &self.values, &self.rhs, &mut self.resid);
                let mut r_norm: f64 = 0.0;
                for (r, b) in self.resid.iter_mut().zip(&self.b) {
                    *r = b - *r;
                    r_norm = r_norm.max(r.abs());
                }
                if r_norm <= 1e-15 * b_norm.max(1e-300) {
                    break;
                }
                // The correction: solve with the residual in `rhs`, x held in `resid`.
                std::mem::swap(&mut self.rhs, &mut self.resid);
                self.solve_raw();
                for (x, d) in self.resid.iter_mut().zip(&self.rhs) {
                    *x += d;
                }
                std::mem::swap(&mut self.rhs, &mut self.resid);
            }
        }
        rhs_x.copy_from_slice(&self.rhs[..n]);
        rhs_y.copy_from_slice(&self.rhs[n..]);
    }
}
