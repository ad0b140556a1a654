//! Splits decoupled *chain states* off a stage-structured KKT system before a Riccati
//! backend sees it.
//!
//! A chain state i is one that no Hessian entry and no path row touches, whose initial row
//! is `a x_0[i] = b` and whose dynamics rows are `j_k x_k[i] + e_k x_{k+1}[i] = b_k`, with
//! no other row on its variables (the vehicle OCP's arc length s: ds/ds = 1). Its variables
//! and rows form a block of the KKT matrix that couples to nothing else,
//!
//! ```text
//! [ D   A^T ] [x     ]   [r_x]
//! [ A   C   ] [lambda] = [r_c]      A: (N+1) x (N+1) lower bidiagonal, D >= 0, C <= 0,
//! ```
//!
//! solved here in O(N) by a block LDL^T of 2 x 2 pivots (see `Chain`); with C <= 0 and
//! D >= 0 its inertia is (N+1, N+1).
//! The rest, one state fewer per stage, goes to the Riccati backend, whose blocks are then
//! 8 states wide for the vehicle (two whole 4-wide vectors per column instead of 2 + 1).

use super::riccati::SKIP_ENTRY;
use super::structure::{RowRole, StageStructure};
use super::{Inertia, KktError, KktSolver, KktValues};

/// One chain state's variables, rows and per-factorization values (all length N + 1).
///
/// Ordered as pairs (lambda_k, x_k), the chain block is tridiagonal: pair k's block is
/// B_k = [[c_k, a_k], [a_k, d_k]] (a_k the diagonal of A) and only x_k couples to the next
/// pair, through lambda_{k+1} (A's subdiagonal b_{k+1}). Block LDL^T with 2 x 2 pivots:
/// S_0 = B_0, S_{k+1} = B_{k+1} - b_{k+1}^2 (S_k^-1)_xx e_lambda e_lambda^T. With c <= 0 and
/// d >= 0 every pivot has det <= -a_k^2 < 0 (one positive and one negative eigenvalue), so
/// the elimination is stable for any dual regularization, zero included.
#[derive(Debug, Clone)]
struct Chain {
    /// `x_k[i]`, k = 0..=N.
    vars: Vec<usize>,
    /// Row k: the initial row (k = 0) or the dynamics row of interval k - 1.
    rows: Vec<usize>,
    /// Jacobian entry of row k on x_k (a_k, the diagonal of A).
    diag_q: Vec<usize>,
    /// Jacobian entry of row k on x_{k-1} (b_k, the subdiagonal of A; unused at k = 0).
    sub_q: Vec<usize>,
    /// a_k, b_k, d_k of the last factorization.
    a: Vec<f64>,
    b: Vec<f64>,
    d: Vec<f64>,
    /// Pivot k: [[p_k, a_k], [a_k, d_k]] and its determinant.
    p: Vec<f64>,
    det: Vec<f64>,
}

impl Chain {
    /// Reads and factorizes this chain's block; returns its inertia, or `NonFinite` /
    /// `Singular` (a zero pivot determinant), which the solver answers like any backend's:
    /// the backend does not hand those to the sparse one, and its inertia correction
    /// raises the shifts (for the vehicle a_k = 1, so det <= -1 whatever they are).
    fn factorize(&mut self, v: &KktValues<'_>) -> Result<Inertia, KktError> {
        let len = self.vars.len();
        let mut inertia = Inertia::default();
        for k in 0..len {
            let a = v.jac[self.diag_q[k]];
            let d = v.primal_diag[self.vars[k]];
            let c = v.dual_diag[self.rows[k]];
            let mut p = c;
            if k > 0 {
                let b = v.jac[self.sub_q[k]];
                // (S_{k-1}^-1)_xx = p_{k-1} / det_{k-1}.
                p -= b * b * (self.p[k - 1] / self.det[k - 1]);
                self.b[k] = b;
            }
            let det = p * d - a * a;
            if !(a.is_finite() && d.is_finite() && p.is_finite() && det.is_finite()) {
                return Err(KktError::NonFinite);
            }
            if det == 0.0 {
                return Err(KktError::Singular);
            }
            if det < 0.0 {
                inertia.positive += 1;
                inertia.negative += 1;
            } else if p + d > 0.0 {
                inertia.positive += 2;
            } else {
                inertia.negative += 2;
            }
            (self.a[k], self.d[k], self.p[k], self.det[k]) = (a, d, p, det);
        }
        Ok(inertia)
    }

    /// S_k^-1 (l, x).
    #[inline]
    fn pivot_solve(&self, k: usize, l: f64, x: f64) -> (f64, f64) {
        let (p, a, d, det) = (self.p[k], self.a[k], self.d[k], self.det[k]);
        ((d * l - a * x) / det, (p * x - a * l) / det)
    }

    /// Solves this chain's block in place in `rhs_x` / `rhs_y`.
    fn solve(&self, rhs_x: &mut [f64], rhs_y: &mut [f64]) {
        let len = self.vars.len();
        let (xv, rv) = (&self.vars, &self.rows);
        // Forward: r_{k+1,lambda} -= b_{k+1} (S_k^-1 r_k)_x.
        for k in 0..len - 1 {
            let (_, tx) = self.pivot_solve(k, rhs_y[rv[k]], rhs_x[xv[k]]);
            rhs_y[rv[k + 1]] -= self.b[k + 1] * tx;
        }
        // Backward: u_k = S_k^-1 (r_k - (0, b_{k+1} lambda_{k+1})).
        let mut next_lambda = 0.0;
        for k in (0..len).rev() {
            let mut x = rhs_x[xv[k]];
            if k + 1 < len {
                x -= self.b[k + 1] * next_lambda;
            }
            let (l, x) = self.pivot_solve(k, rhs_y[rv[k]], x);
            rhs_x[xv[k]] = x;
            rhs_y[rv[k]] = l;
            next_lambda = l;
        }
    }
}

/// What [`Reduced::detect`] found: the reduced problem for the inner backend and the
/// maps back.
#[derive(Debug, Clone)]
pub struct Reduced {
    /// Stage structure without the chain states and rows.
    pub structure: StageStructure,
    /// Number of reduced variables.
    pub n: usize,
    /// Hessian rows in reduced indices (same entries, same order).
    pub hess_rows: Vec<usize>,
    /// Hessian columns in reduced indices.
    pub hess_cols: Vec<usize>,
    /// Jacobian rows in reduced indices, chain entries as [`SKIP_ENTRY`] (same length:
    /// the inner backend reads the full values array).
    pub jac_rows: Vec<usize>,
    /// Jacobian columns in reduced indices (chain entries: [`SKIP_ENTRY`]).
    pub jac_cols: Vec<usize>,
    var_keep: Vec<usize>,
    row_keep: Vec<usize>,
    chains: Vec<Chain>,
}

/// A stage-structured KKT backend `K` on the system without its chain states, plus the
/// chains' O(N) solves.
#[derive(Debug)]
pub struct ChainSplit<K> {
    inner: K,
    var_keep: Vec<usize>,
    row_keep: Vec<usize>,
    chains: Vec<Chain>,
    primal: Vec<f64>,
    dual: Vec<f64>,
    rx: Vec<f64>,
    ry: Vec<f64>,
}

/// Stage and local index of variable `v` when it is a state of stage 0..=N.
fn state_of(st: &StageStructure, v: usize) -> Option<(usize, usize)> {
    let (s, l) = st.locate(v);
    (l < st.nx && s <= st.n_stages).then_some((s, l))
}

/// The Jacobian entries (entry index, column) of every non-path row; `None` when an
/// entry lies outside the `m` x `n` Jacobian.
fn row_entries(
    st: &StageStructure,
    n: usize,
    jac_rows: &[usize],
    jac_cols: &[usize],
) -> Option<Vec<Vec<(usize, usize)>>> {
    let m = st.rows.len();
    // Entries per row (only rows that can be chain rows matter).
    let mut row_entries: Vec<Vec<(usize, usize)>> = vec![Vec::new(); m];
    for (q, (&r, &c)) in jac_rows.iter().zip(jac_cols).enumerate() {
        if r >= m || c >= n {
            return None;
        }
        if !matches!(st.rows[r], RowRole::Path) {
            row_entries[r].push((q, c));
        }
    }
    Some(row_entries)
}

/// Which states are chain states (no Hessian entry; only their own dynamics rows with two
/// entries, and one initial row with one), and each state's initial row. `None` when a
/// Hessian entry lies outside `n` x `n`.
fn chain_states(
    st: &StageStructure,
    n: usize,
    hess_rows: &[usize],
    hess_cols: &[usize],
    jac_rows: &[usize],
    jac_cols: &[usize],
    row_entries: &[Vec<(usize, usize)>],
) -> Option<(Vec<bool>, Vec<Option<usize>>)> {
    let nx = st.nx;
    let mut chain_state = vec![true; nx];
    for (&r, &c) in hess_rows.iter().zip(hess_cols) {
        if r >= n || c >= n {
            return None;
        }
        for v in [r, c] {
            if let Some((_, l)) = state_of(st, v) {
                chain_state[l] = false;
            }
        }
    }
    // Every entry on a state-i variable must sit in one of i's chain rows, and those
    // rows have exactly their two (initial: one) entries.
    let mut init_row = vec![None; nx];
    for (&r, &c) in jac_rows.iter().zip(jac_cols) {
        let Some((s, l)) = state_of(st, c) else {
            continue;
        };
        if !chain_state[l] {
            continue;
        }
        let ok = match st.rows[r] {
            RowRole::Dynamics { stage, index } => {
                index == l
                    && (s == stage || s == stage + 1)
                    && row_entries[r].len() == 2
                    && row_entries[r].iter().all(|&(_, v)| {
                        state_of(st, v)
                            .is_some_and(|(sv, lv)| lv == l && (sv == stage || sv == stage + 1))
                    })
                    && row_entries[r][0].1 != row_entries[r][1].1
            }
            RowRole::Initial => {
                let first = init_row[l].is_none() || init_row[l] == Some(r);
                if first {
                    init_row[l] = Some(r);
                }
                s == 0 && first && row_entries[r].len() == 1
            }
            RowRole::Path => false,
        };
        if !ok {
            chain_state[l] = false;
        }
    }
    // Dynamics rows of a chain state must not touch other states either (checked
    // above through their two entries); each needs its initial row.
    for l in 0..nx {
        if chain_state[l] && init_row[l].is_none() {
            chain_state[l] = false;
        }
    }
    Some((chain_state, init_row))
}

/// The chain of every chain state (its variables, rows and value positions) and which
/// rows are chain rows; `None` when a chain lacks a dynamics row or an entry is off the
/// chain's bidiagonal.
fn build_chains(
    st: &StageStructure,
    chain_state: &[bool],
    init_row: &[Option<usize>],
    row_entries: &[Vec<(usize, usize)>],
) -> Option<(Vec<Chain>, Vec<bool>)> {
    let (nx, nz, big) = (st.nx, st.nx + st.nu, st.n_stages);
    let mut dyn_row = vec![usize::MAX; big * nx];
    for (r, role) in st.rows.iter().enumerate() {
        if let RowRole::Dynamics { stage, index } = *role {
            if stage < big && index < nx {
                dyn_row[stage * nx + index] = r;
            }
        }
    }
    let mut chains = Vec::new();
    let mut is_chain_row = vec![false; st.rows.len()];
    for l in (0..nx).filter(|&l| chain_state[l]) {
        let len = big + 1;
        let vars: Vec<usize> = (0..len).map(|k| k * nz + l).collect();
        let mut rows = vec![init_row[l]?];
        for k in 0..big {
            let r = dyn_row[k * nx + l];
            if r == usize::MAX {
                return None;
            }
            rows.push(r);
        }
        let mut diag_q = vec![usize::MAX; len];
        let mut sub_q = vec![usize::MAX; len];
        for (k, &r) in rows.iter().enumerate() {
            for &(q, v) in &row_entries[r] {
                if v == vars[k] {
                    diag_q[k] = q;
                } else if k > 0 && v == vars[k - 1] {
                    sub_q[k] = q;
                } else {
                    return None;
                }
            }
            is_chain_row[r] = true;
        }
        if diag_q.contains(&usize::MAX) || sub_q[1..].contains(&usize::MAX) {
            return None;
        }
        let z = vec![0.0; len];
        chains.push(Chain {
            vars,
            rows,
            diag_q,
            sub_q,
            a: z.clone(),
            b: z.clone(),
            d: z.clone(),
            p: z.clone(),
            det: z,
        });
    }
    Some((chains, is_chain_row))
}

impl Reduced {
    /// Finds the chain states of `st` from the patterns; `None` when there are none (or the
    /// layout is not what the stage structure says).
    pub fn detect(
        st: &StageStructure,
        n: usize,
        hess_rows: &[usize],
        hess_cols: &[usize],
        jac_rows: &[usize],
        jac_cols: &[usize],
    ) -> Option<Self> {
        if st.n() != n || st.nx == 0 {
            return None;
        }
        let row_entries = row_entries(st, n, jac_rows, jac_cols)?;
        let (chain_state, init_row) = chain_states(
            st,
            n,
            hess_rows,
            hess_cols,
            jac_rows,
            jac_cols,
            &row_entries,
        )?;
        if !chain_state.contains(&true) {
            return None;
        }
        let (chains, is_chain_row) = build_chains(st, &chain_state, &init_row, &row_entries)?;
        Self::without_chains(
            st,
            n,
            &chain_state,
            &is_chain_row,
            chains,
            [hess_rows, hess_cols],
            [jac_rows, jac_cols],
        )
    }

    /// The problem without the chain states and rows: renumbered variables, rows and
    /// pattern entries (chain rows' Jacobian entries as [`SKIP_ENTRY`]).
    fn without_chains(
        st: &StageStructure,
        n: usize,
        chain_state: &[bool],
        is_chain_row: &[bool],
        chains: Vec<Chain>,
        [hess_rows, hess_cols]: [&[usize]; 2],
        [jac_rows, jac_cols]: [&[usize]; 2],
    ) -> Option<Self> {
        let (nx, nz, big) = (st.nx, st.nx + st.nu, st.n_stages);
        let m = st.rows.len();
        let nc = chain_state.iter().filter(|&&c| c).count();
        // Reduced indices.
        let nx_r = nx - nc;
        let nz_r = nz - nc;
        let local = |l: usize| {
            if l < nx {
                (!chain_state[l]).then(|| chain_state[..l].iter().filter(|&&c| !c).count())
            } else {
                Some(l - nc)
            }
        };
        let mut new_var = vec![usize::MAX; n];
        let mut var_keep = Vec::with_capacity(n);
        for v in 0..n {
            let (s, l) = st.locate(v);
            if let Some(lr) = local(l) {
                new_var[v] = s * nz_r + lr;
                var_keep.push(v);
            }
        }
        let mut new_row = vec![usize::MAX; m];
        let mut row_keep = Vec::with_capacity(m);
        let mut roles = Vec::with_capacity(m);
        for (r, role) in st.rows.iter().enumerate() {
            if is_chain_row[r] {
                continue;
            }
            new_row[r] = row_keep.len();
            row_keep.push(r);
            roles.push(match *role {
                RowRole::Dynamics { stage, index } => RowRole::Dynamics {
                    stage,
                    index: local(index)?,
                },
                other => other,
            });
        }
        let map_var = |v: usize| (new_var[v] != usize::MAX).then_some(new_var[v]);
        let mut hr = Vec::with_capacity(hess_rows.len());
        let mut hc = Vec::with_capacity(hess_rows.len());
        for (&r, &c) in hess_rows.iter().zip(hess_cols) {
            hr.push(map_var(r)?);
            hc.push(map_var(c)?);
        }
        let mut jr = Vec::with_capacity(jac_rows.len());
        let mut jc = Vec::with_capacity(jac_rows.len());
        for (&r, &c) in jac_rows.iter().zip(jac_cols) {
            if is_chain_row[r] {
                jr.push(SKIP_ENTRY);
                jc.push(SKIP_ENTRY);
            } else {
                jr.push(new_row[r]);
                jc.push(map_var(c)?);
            }
        }
        Some(Self {
            structure: StageStructure {
                n_stages: big,
                nx: nx_r,
                nu: st.nu,
                rows: roles,
            },
            n: var_keep.len(),
            hess_rows: hr,
            hess_cols: hc,
            jac_rows: jr,
            jac_cols: jc,
            var_keep,
            row_keep,
            chains,
        })
    }
}

impl<K: KktSolver> ChainSplit<K> {
    /// Wraps `inner`, built on `reduced`'s structure and patterns.
    pub fn new(reduced: Reduced, inner: K) -> Self {
        let (nr, mr) = (reduced.var_keep.len(), reduced.row_keep.len());
        Self {
            inner,
            var_keep: reduced.var_keep,
            row_keep: reduced.row_keep,
            chains: reduced.chains,
            primal: vec![0.0; nr],
            dual: vec![0.0; mr],
            rx: vec![0.0; nr],
            ry: vec![0.0; mr],
        }
    }

    /// Number of chain states split off.
    pub fn chain_states(&self) -> usize {
        self.chains.len()
    }

    /// The backend of the reduced system.
    pub fn inner(&self) -> &K {
        &self.inner
    }

    /// The backend of the reduced system, mutably.
    pub fn inner_mut(&mut self) -> &mut K {
        &mut self.inner
    }

    fn factorize_with(
        &mut self,
        v: &KktValues<'_>,
        expected: Option<Inertia>,
    ) -> Result<Inertia, KktError> {
        let mut chains = Inertia::default();
        for ch in &mut self.chains {
            let i = ch.factorize(v)?;
            chains.positive += i.positive;
            chains.negative += i.negative;
        }
        for (p, &j) in self.primal.iter_mut().zip(&self.var_keep) {
            *p = v.primal_diag[j];
        }
        for (d, &r) in self.dual.iter_mut().zip(&self.row_keep) {
            *d = v.dual_diag[r];
        }
        let reduced = KktValues {
            hess: v.hess,
            jac: v.jac,
            primal_diag: &self.primal,
            dual_diag: &self.dual,
        };
        let inner = match expected {
            Some(e) => {
                if e.positive < chains.positive || e.negative < chains.negative {
                    return Err(KktError::WrongInertia);
                }
                self.inner.factorize_expecting(
                    &reduced,
                    Inertia {
                        positive: e.positive - chains.positive,
                        negative: e.negative - chains.negative,
                        zero: e.zero,
                    },
                )?
            }
            None => self.inner.factorize(&reduced)?,
        };
        Ok(Inertia {
            positive: inner.positive + chains.positive,
            negative: inner.negative + chains.negative,
            zero: inner.zero,
        })
    }
}

impl<K: KktSolver> KktSolver for ChainSplit<K> {
    fn factorize(&mut self, v: &KktValues<'_>) -> Result<Inertia, KktError> {
        self.factorize_with(v, None)
    }

    fn factorize_expecting(
        &mut self,
        v: &KktValues<'_>,
        expected: Inertia,
    ) -> Result<Inertia, KktError> {
        self.factorize_with(v, Some(expected))
    }

    fn solve(&mut self, rhs_x: &mut [f64], rhs_y: &mut [f64]) {
        for (x, &j) in self.rx.iter_mut().zip(&self.var_keep) {
            *x = rhs_x[j];
        }
        for (y, &r) in self.ry.iter_mut().zip(&self.row_keep) {
            *y = rhs_y[r];
        }
        self.inner.solve(&mut self.rx, &mut self.ry);
        for ch in &self.chains {
            ch.solve(rhs_x, rhs_y);
        }
        for (&x, &j) in self.rx.iter().zip(&self.var_keep) {
            rhs_x[j] = x;
        }
        for (&y, &r) in self.ry.iter().zip(&self.row_keep) {
            rhs_y[r] = y;
        }
    }

    fn wants_dual_regularization(&self) -> bool {
        self.inner.wants_dual_regularization()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ip::kkt::RiccatiKkt;
    use nalgebra::{DMatrix, DVector};

    /// N = 3 stages of (x[0], x[1], u): x[1] is a chain (its own initial and dynamics rows
    /// only), x[0] has a Hessian, couples to u in its dynamics, and a path row on (x[0], u).
    struct Tiny {
        st: StageStructure,
        n: usize,
        hr: Vec<usize>,
        hc: Vec<usize>,
        jr: Vec<usize>,
        jc: Vec<usize>,
    }

    fn tiny(extra_hess_on_chain: bool, path_on_chain: bool) -> Tiny {
        let (big, nz) = (3usize, 3usize);
        let n = big * nz + 2;
        let x = |k: usize, i: usize| k * nz + i;
        let u = |k: usize| k * nz + 2;
        let mut rows = vec![RowRole::Initial, RowRole::Initial];
        let (mut jr, mut jc) = (vec![0, 1], vec![x(0, 0), x(0, 1)]);
        for k in 0..big {
            for (i, vars) in [vec![x(k, 0), u(k), x(k + 1, 0)], vec![x(k, 1), x(k + 1, 1)]]
                .into_iter()
                .enumerate()
            {
                let r = rows.len();
                rows.push(RowRole::Dynamics { stage: k, index: i });
                for v in vars {
                    jr.push(r);
                    jc.push(v);
                }
            }
            let r = rows.len();
            rows.push(RowRole::Path);
            jr.extend([r, r]);
            jc.extend([x(k, 0), u(k)]);
            if path_on_chain {
                jr.push(r);
                jc.push(x(k, 1));
            }
        }
        let (mut hr, mut hc) = (Vec::new(), Vec::new());
        for k in 0..=big {
            hr.push(x(k, 0));
            hc.push(x(k, 0));
            if k < big {
                hr.extend([u(k), u(k)]);
                hc.extend([u(k), x(k, 0)]);
            }
        }
        if extra_hess_on_chain {
            hr.push(x(1, 1));
            hc.push(x(1, 1));
        }
        Tiny {
            st: StageStructure {
                n_stages: big,
                nx: 2,
                nu: 1,
                rows,
            },
            n,
            hr,
            hc,
            jr,
            jc,
        }
    }

    fn detect(t: &Tiny) -> Option<Reduced> {
        Reduced::detect(&t.st, t.n, &t.hr, &t.hc, &t.jr, &t.jc)
    }

    #[test]
    fn finds_the_chain_state_and_only_it() {
        let red = detect(&tiny(false, false)).expect("x[1] is a chain");
        assert_eq!((red.structure.nx, red.structure.nu), (1, 1));
        assert_eq!(red.n, 3 * 2 + 1);
        assert_eq!(red.chains.len(), 1);
        assert_eq!(red.chains[0].vars, vec![1, 4, 7, 10]);
        // A Hessian entry or a path row on x[1] couples it: no chain left.
        assert!(detect(&tiny(true, false)).is_none());
        assert!(detect(&tiny(false, true)).is_none());
        // An out-of-range Hessian index is no structure, not a panic.
        let mut bad = tiny(false, false);
        bad.hr.push(bad.n);
        bad.hc.push(0);
        assert!(detect(&bad).is_none());
    }

    /// Steps and inertia of the split system against a dense solve and dense eigenvalues,
    /// with zero, uniform and mixed dual regularization on the chain rows, a negative path
    /// term, and (case 4) negative chain diagonals.
    #[test]
    fn split_steps_and_inertia_match_dense() {
        let t = tiny(false, false);
        let (n, m) = (t.n, t.st.rows.len());
        let mut seed = 11u64;
        let mut rnd = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for case in 0..5 {
            let hess: Vec<f64> = t.hr.iter().map(|_| rnd()).collect();
            let jac: Vec<f64> = t.jr.iter().map(|_| 1.0 + rnd()).collect();
            // Case 4: negative chain diagonals, so that some pivots have det > 0.
            let primal: Vec<f64> = (0..n)
                .map(|j| {
                    if case == 4 && j % 3 == 1 {
                        -3.0 + rnd()
                    } else {
                        0.5 + rnd()
                    }
                })
                .collect();
            let dual: Vec<f64> = (0..m)
                .map(|r| match (t.st.rows[r], case) {
                    (RowRole::Path, _) => -0.3 - rnd().abs(),
                    (_, 0) => 0.0,
                    (_, 1) => -1e-8,
                    (_, 2) | (_, 4) => -1.0,
                    _ => {
                        if r % 2 == 0 {
                            0.0
                        } else {
                            -1e-3
                        }
                    }
                })
                .collect();
            let mut k = DMatrix::<f64>::zeros(n + m, n + m);
            for ((&r, &c), &v) in t.hr.iter().zip(&t.hc).zip(&hess) {
                k[(r, c)] += v;
                if r != c {
                    k[(c, r)] += v;
                }
            }
            for ((&r, &c), &v) in t.jr.iter().zip(&t.jc).zip(&jac) {
                k[(n + r, c)] += v;
                k[(c, n + r)] += v;
            }
            for i in 0..n {
                k[(i, i)] += primal[i];
            }
            for i in 0..m {
                k[(n + i, n + i)] += dual[i];
            }
            let red = detect(&t).unwrap();
            let inner = RiccatiKkt::<1, 1, 2>::new(
                &red.structure,
                red.n,
                &red.hess_rows,
                &red.hess_cols,
                &red.jac_rows,
                &red.jac_cols,
            )
            .unwrap();
            let mut split = ChainSplit::new(red, inner);
            let v = KktValues {
                hess: &hess,
                jac: &jac,
                primal_diag: &primal,
                dual_diag: &dual,
            };
            let inertia = split.factorize(&v).unwrap();
            let eig = k.clone().symmetric_eigenvalues();
            let pos = eig.iter().filter(|&&e| e > 1e-12).count();
            let neg = eig.iter().filter(|&&e| e < -1e-12).count();
            assert_eq!(
                (inertia.positive, inertia.negative),
                (pos, neg),
                "case {case}"
            );
            let bx: Vec<f64> = (0..n).map(|_| rnd()).collect();
            let by: Vec<f64> = (0..m).map(|_| rnd()).collect();
            let exact = k
                .lu()
                .solve(&DVector::from_iterator(
                    n + m,
                    bx.iter().chain(&by).copied(),
                ))
                .unwrap();
            let (mut x, mut y) = (bx, by);
            split.solve(&mut x, &mut y);
            let diff = x
                .iter()
                .chain(&y)
                .zip(exact.iter())
                .fold(0.0f64, |d, (a, b)| d.max((a - b).abs()));
            assert!(diff <= 1e-10 * exact.amax(), "case {case}: diff {diff:e}");
        }
    }
}
