//! Structure-exploiting KKT backend: a Riccati-type block elimination over the stages of an
//! optimal-control NLP with fixed-size (nalgebra) blocks. Allocation-free after setup; the
//! inertia comes from the stage factorizations, so inertia correction stays cheap.
//!
//! With z_k = (x_k, u_k) (NZ = NX + NU entries), multipliers lambda_k of the dynamics rows
//! `J_k z_k + E_k x_{k+1}` of interval k, and the initial rows on x_0, the factorization is:
//!
//! 1. **Path rows** (inequalities, dual diagonal D_c < 0) are eliminated into the primal
//!    block: W = H + D_x + sum_r J_r^T J_r / |D_c,r|. Each adds one negative eigenvalue.
//! 2. **Backward sweep** k = N-1 .. 0 over what remains (a block-banded matrix):
//!    - the pair (x_{k+1}, lambda_k) is eliminated together. Its block
//!      M = [[P, E^T], [E, -Delta]] is congruent to [[P^, I], [I, -Delta]] with
//!      P^ = E^-T P E^-1, so it is nonsingular whenever E_k is (implicit Euler:
//!      E = I - ds df/dx, explicit schemes: E = I), and its inertia is (NX - t, NX + t)
//!      with t the negative eigenvalues of I + Delta^1/2 P^ Delta^1/2. The update this
//!      sends to z_k is the Riccati recursion's A^T P A with A = -E^-1 J.
//!    - u_k is eliminated (Q_uu, LDL^T without pivoting; the signs of its pivots are its
//!      inertia). Its fill goes to x_k and, through the control-rate rows, to z_{k-1}.
//! 3. The initial rows and x_0 form one dense block of size 2 NX, factorized by faer's
//!    Bunch-Kaufman LBL^T (inertia from its 1x1 and 2x2 pivots): its dual diagonal ranges
//!    from equality regularizations (1e-10) to inequality terms (1e6 and more).
//!
//! With the dual regularization Delta = 0 on the dynamics rows (what the solver passes this
//! backend) and J_k = [-I, G_k] (implicit Euler), the pair step is the plain Riccati update.
//! A large uniform Delta = delta I (restoration: delta = 1) eliminates lambda_k first,
//! through S_x = P + E^T E / delta, where the pair formula would lose digits.
//! Works for every single-step scheme whose dynamics Jacobian E_k is invertible; anything
//! else is [`KktError::Unsupported`] (the `auto` backend then uses the sparse one).

use super::claims::{Acquired, Claims, CHUNK};
use super::structure::{RowRole, StageStructure};
use super::{Inertia, KktError, KktSolver, KktValues};
use crate::worker::{self, SharedWorker};
use faer::diag::Diag;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::lblt;
use faer::{Conj, Mat, Par};
use nalgebra::{SMatrix, SVector};
use std::sync::atomic::{AtomicBool, Ordering};

/// No target in the block arena.
const NONE: u32 = u32::MAX;

/// Row and column of a Jacobian entry this backend ignores: the values array keeps its
/// slot (so a caller that split part of the system off passes its values unchanged).
pub const SKIP_ENTRY: usize = usize::MAX;

/// What a constraint row is to this backend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Row {
    /// Dynamics row (stage, index).
    Dynamics(u32, u16),
    /// Initial row number i (0..NX).
    Initial(u16),
    /// Path row number p.
    Path(u32),
}

/// A path row: its Jacobian entries in `path_entries` and (at setup) the range of its
/// outer product's terms among the path pairs.
#[derive(Debug, Clone, Copy)]
struct PathRow {
    start: usize,
    end: usize,
    pairs_start: usize,
    pairs_end: usize,
}

/// One term of J_r^T J_r: entries `a` and `b` of the row (local indices) add their
/// product to arena index `target` (lower triangle of W, or X).
#[derive(Debug, Clone, Copy)]
struct PathPair {
    a: u16,
    b: u16,
    target: u32,
}

/// One Jacobian entry of a path row: value index, stage, position in the stage.
#[derive(Debug, Clone, Copy)]
struct PathEntry {
    jac: usize,
    stage: u32,
    local: u16,
}

/// One assembly unit: the arena blocks the sweep reads at one of its stages, so the sweep can
/// run as soon as its unit is written (unit k < N: W_k, E_k, J_k and X_{k-1}; unit N: W_N and
/// X_{N-1}; E_N, the initial rows, rides with unit 0, read last). Ranges into the `u_*` op
/// lists, whose ops keep the order of the whole-arena assembly: every entry sums its terms in
/// the same order, so the bits do not depend on how the units are scheduled.
#[derive(Debug, Clone, Copy, Default)]
struct Unit {
    zero: (u32, u32),
    jac: (u32, u32),
    hess: (u32, u32),
    diag: (u32, u32),
    pairs: (u32, u32),
}

/// One term of a path row's J_r^T J_r / |D_c| by path-entry indices: adds
/// `path_wv[a] * path_vals[b]`, i.e. (w_r J_ra) J_rb, to arena entry `target`.
#[derive(Debug, Clone, Copy)]
struct UnitPair {
    a: u32,
    b: u32,
    target: u32,
}

/// E_k^-1, computed with unit k and reused while E_k keeps its bits (the
/// inertia-correcting refactorizations of an iteration change only diagonals).
#[derive(Debug, Clone)]
struct StageInverse<const NX: usize> {
    /// F^T = E_k^-T, the only copy kept: its columns are F's rows, which the sweep's
    /// products read as contiguous vectors (F's entries they only broadcast).
    ft: SMatrix<f64, NX, NX>,
    /// The E that `ft` inverts (NaN until the first success).
    e_in: SMatrix<f64, NX, NX>,
    /// Whether E_k of the current assembly is invertible (`ft` is its inverse's transpose).
    ok: bool,
    /// J_k = [-I, G] in the current assembly (see [`minus_identity_head`]).
    j_minus_identity: bool,
}

impl<const NX: usize> Default for StageInverse<NX> {
    fn default() -> Self {
        Self {
            ft: SMatrix::zeros(),
            e_in: SMatrix::repeat(f64::NAN),
            ok: false,
            j_minus_identity: false,
        }
    }
}

/// Factors of one stage, kept for the solves.
#[derive(Debug, Clone)]
struct StageFactor<const NX: usize, const NU: usize, const NZ: usize> {
    // J_k stays in the arena, and F^T = E_k^-T and whether J_k = [-I, G] in the stage's
    // [`StageInverse`], until the next assembly; the solves read them there.
    /// Delta_k = 0: [[P^, I], [I, 0]]^-1 = [[0, I], [I, -P^]] and a11, a12 are unused.
    zero_delta: bool,
    /// Blocks of [[P^, I], [I, -Delta]]^-1 = [[a11, a12], [a12^T, a22]].
    a11: SMatrix<f64, NX, NX>,
    a12: SMatrix<f64, NX, NX>,
    a22: SMatrix<f64, NX, NX>,
    /// Large uniform Delta = delta I (restoration): lambda_k was eliminated first and
    /// S_x = P + E^T E / delta = sx_l diag(sx_d) sx_l^T; `e` and `delta` kept for solves.
    lambda_first: bool,
    sx_l: SMatrix<f64, NX, NX>,
    sx_d: SVector<f64, NX>,
    e: SMatrix<f64, NX, NX>,
    delta: f64,
    /// Coupling Y of z_k to x_{k+1} at elimination time, stored transposed (Y^T, NX x NZ),
    /// and C^ = Y F.
    yt: SMatrix<f64, NX, NZ>,
    chat: SMatrix<f64, NZ, NX>,
    /// Q_uu = L D L^T (unit lower L).
    quu_l: SMatrix<f64, NU, NU>,
    quu_d: SVector<f64, NU>,
    /// Q_ux and the coupling R of u_k to z_{k-1}.
    q_ux: SMatrix<f64, NU, NX>,
    r: SMatrix<f64, NZ, NU>,
}

impl<const NX: usize, const NU: usize, const NZ: usize> Default for StageFactor<NX, NU, NZ> {
    fn default() -> Self {
        Self {
            zero_delta: true,
            lambda_first: false,
            sx_l: SMatrix::zeros(),
            sx_d: SVector::zeros(),
            e: SMatrix::zeros(),
            delta: 0.0,
            a11: SMatrix::zeros(),
            a12: SMatrix::zeros(),
            a22: SMatrix::zeros(),
            yt: SMatrix::zeros(),
            chat: SMatrix::zeros(),
            quu_l: SMatrix::zeros(),
            quu_d: SVector::zeros(),
            q_ux: SMatrix::zeros(),
            r: SMatrix::zeros(),
        }
    }
}

/// Why a [`StageStructure`] does not fit this backend.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum StructureError {
    /// Sizes disagree with the NLP or the compiled-in block sizes.
    #[error("stage structure does not match: {0}")]
    Size(String),
    /// An entry couples variables this backend cannot eliminate in stage order.
    #[error("entry ({row}, {col}) of the {what} breaks the stage structure")]
    Coupling {
        /// Which matrix.
        what: &'static str,
        /// Row.
        row: usize,
        /// Column.
        col: usize,
    },
}

/// The Riccati backend for NX states and NU controls per stage (NZ = NX + NU).
pub struct RiccatiKkt<const NX: usize, const NU: usize, const NZ: usize> {
    n: usize,
    m: usize,
    stages: usize,
    /// Jacobian entries have distinct targets: assigned, not summed, and the E, J
    /// regions need no zeroing.
    jac_assign: bool,
    /// With `jac_assign`: the Hessian entries also have distinct targets, so they are
    /// assigned (as 0 + h), and only the W, X entries that no Hessian value writes (the
    /// primal diagonal's and the path rows') are zeroed, not the whole W, X region.
    hess_assign: bool,
    /// Columns of Y_k^T that can be nonzero: entries of z_{k-1} that some Hessian or
    /// path-row entry couples to z_k (X block columns); the common stage computes
    /// C^^T = F^T Y^T only there ([`fast_stage`]). On the vehicle OCP: t and the controls.
    y_live: [bool; NZ],
    rows: Vec<Row>,
    path_rows: Vec<PathRow>,
    path_entries: Vec<PathEntry>,
    /// The solves' gather r_x += J_r^T r_c,r / |D_c| grouped by target: per target entry of
    /// `bz` (stage, position, end of its terms), and its terms (path entry, path row) in row
    /// order. Each target sums in a register from its old value, in the order of the
    /// row-by-row scatter (same bits) but without chains of stores and reloads.
    gather_targets: Vec<(u32, u16, u32)>,
    gather_terms: Vec<(u32, u32)>,
    /// Per path row: its right-hand side times its weight, during a solve.
    path_t: Vec<f64>,
    /// The assembly by units (see [`Unit`]): index k < N for stage k, index N (swept first)
    /// for W_N and X_{N-1}.
    units: Vec<Unit>,
    u_zero: Vec<(u32, u32)>,
    u_jac: Vec<(u32, u32)>,
    u_hess: Vec<(u32, u32)>,
    u_diag: Vec<(u32, u32)>,
    u_pairs: Vec<UnitPair>,
    inverses: Vec<StageInverse<NX>>,
    /// The helper thread of the pipelined factorization (`threads = 2`), if any.
    worker: Option<SharedWorker>,
    /// Who writes which units when the factorization is pipelined.
    claims: Claims,
    /// Test knob: the helper claims no unit (see [`Self::set_helper_idle`]).
    helper_idle: bool,
    /// All assembled blocks, column-major: W_k (k = 0..=N; W_N uses the NX x NX corner),
    /// X_k (rows z_{k+1}, columns z_k), E_k (index N: initial rows), J_k.
    arena: Vec<f64>,
    x_base: usize,
    e_base: usize,
    j_base: usize,
    /// Delta = -D_c of the dynamics rows (index N: initial rows).
    delta: Vec<SVector<f64, NX>>,
    /// 1 / |D_c| of the path rows.
    path_w: Vec<f64>,
    /// Jacobian values of the path rows (parallel to `path_entries`), kept for the solves.
    path_vals: Vec<f64>,
    /// Path-row Jacobian values times their row's weight (`path_w`), for the assembly.
    path_wv: Vec<f64>,
    factors: Vec<StageFactor<NX, NU, NZ>>,
    /// Dense initial block [[P_0, E^T], [E, -Delta]] and its LBL^T factors.
    init: Mat<f64>,
    init_diag: Diag<f64>,
    init_sub: Diag<f64>,
    init_perm: Vec<usize>,
    init_perm_inv: Vec<usize>,
    init_rhs: Mat<f64>,
    mem: MemBuffer,
    /// Right-hand sides per stage during a solve.
    bz: Vec<SVector<f64, NZ>>,
    bl: Vec<SVector<f64, NX>>,
    factorized: bool,
    /// Factorize and solve in code compiled for AVX2 (set from [`avx2_available`]).
    simd: bool,
}

impl<const NX: usize, const NU: usize, const NZ: usize> std::fmt::Debug for RiccatiKkt<NX, NU, NZ> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RiccatiKkt")
            .field("n", &self.n)
            .field("m", &self.m)
            .field("stages", &self.stages)
            .field("path_rows", &self.path_rows.len())
            .field("path_pairs", &self.u_pairs.len())
            .field("y_live", &self.y_live)
            .finish()
    }
}

impl<const NX: usize, const NU: usize, const NZ: usize> RiccatiKkt<NX, NU, NZ> {
    /// Builds the value maps from the NLP's sparsity structure and its stage structure.
    /// Allocates; call once at setup.
    pub fn new(
        st: &StageStructure,
        n: usize,
        hess_rows: &[usize],
        hess_cols: &[usize],
        jac_rows: &[usize],
        jac_cols: &[usize],
    ) -> Result<Self, StructureError> {
        if NZ != NX + NU || st.nx != NX || st.nu != NU {
            return Err(StructureError::Size(format!(
                "nx = {}, nu = {} against blocks of {NX} + {NU} = {NZ}",
                st.nx, st.nu
            )));
        }
        if st.n() != n {
            return Err(StructureError::Size(format!(
                "{} variables implied, NLP has {n}",
                st.n()
            )));
        }
        let big = st.n_stages;
        let x_base = (big + 1) * NZ * NZ;
        let e_base = x_base + big * NZ * NZ;
        let j_base = e_base + (big + 1) * NX * NX;
        let arena_len = j_base + big * NX * NZ;
        if big == 0 || arena_len >= NONE as usize {
            return Err(StructureError::Size(format!("{big} stages")));
        }
        let m = st.rows.len();
        let w_at = |s: usize, r: usize, c: usize| (s * NZ * NZ + c * NZ + r) as u32;
        let x_at = |s: usize, r: usize, c: usize| (x_base + s * NZ * NZ + c * NZ + r) as u32;
        let e_at = |s: usize, r: usize, c: usize| (e_base + s * NX * NX + c * NX + r) as u32;
        let j_at = |s: usize, r: usize, c: usize| (j_base + s * NX * NZ + c * NX + r) as u32;

        // Rows.
        let mut rows = Vec::with_capacity(m);
        let mut n_init = 0usize;
        let mut n_path = 0u32;
        let mut dyn_count = vec![0usize; big * NX];
        for role in &st.rows {
            rows.push(match *role {
                RowRole::Initial => {
                    n_init += 1;
                    Row::Initial((n_init - 1) as u16)
                }
                RowRole::Dynamics { stage, index } => {
                    if stage >= big || index >= NX {
                        return Err(StructureError::Size(format!(
                            "dynamics row ({stage}, {index}) out of range"
                        )));
                    }
                    dyn_count[stage * NX + index] += 1;
                    Row::Dynamics(stage as u32, index as u16)
                }
                RowRole::Path => {
                    n_path += 1;
                    Row::Path(n_path - 1)
                }
            });
        }
        if n_init != NX {
            return Err(StructureError::Size(format!(
                "{n_init} initial rows, need one per state ({NX})"
            )));
        }
        if dyn_count.iter().any(|&c| c != 1) {
            return Err(StructureError::Size(
                "every interval needs exactly one dynamics row per state".into(),
            ));
        }

        // Jacobian.
        let mut jac_map = Vec::with_capacity(jac_rows.len());
        let mut per_path: Vec<Vec<PathEntry>> = vec![Vec::new(); n_path as usize];
        for (q, (&r, &c)) in jac_rows.iter().zip(jac_cols).enumerate() {
            if r == SKIP_ENTRY && c == SKIP_ENTRY {
                // Not this backend's (see `SKIP_ENTRY`): its value is never read.
                jac_map.push(NONE);
                continue;
            }
            if r >= m || c >= n {
                return Err(StructureError::Size(format!(
                    "Jacobian entry ({r}, {c}) out of range"
                )));
            }
            let (s, l) = st.locate(c);
            let bad = StructureError::Coupling {
                what: "Jacobian",
                row: r,
                col: c,
            };
            jac_map.push(match rows[r] {
                Row::Dynamics(k, i) => {
                    let (k, i) = (k as usize, i as usize);
                    if s == k {
                        j_at(k, i, l)
                    } else if s == k + 1 && l < NX {
                        e_at(k, i, l)
                    } else {
                        return Err(bad);
                    }
                }
                Row::Initial(i) => {
                    if s != 0 || l >= NX {
                        return Err(bad);
                    }
                    e_at(big, i as usize, l)
                }
                Row::Path(p) => {
                    per_path[p as usize].push(PathEntry {
                        jac: q,
                        stage: s as u32,
                        local: l as u16,
                    });
                    NONE
                }
            });
        }
        let mut targets: Vec<u32> = jac_map.iter().copied().filter(|&t| t != NONE).collect();
        let n_targets = targets.len();
        targets.sort_unstable();
        targets.dedup();
        let jac_assign = targets.len() == n_targets;
        let mut path_rows = Vec::with_capacity(n_path as usize);
        let mut path_entries = Vec::new();
        let mut path_pairs = Vec::new();
        for (p, ents) in per_path.iter().enumerate() {
            if let (Some(lo), Some(hi)) = (
                ents.iter().map(|e| e.stage).min(),
                ents.iter().map(|e| e.stage).max(),
            ) {
                if hi > lo + 1 {
                    return Err(StructureError::Coupling {
                        what: "path rows",
                        row: p,
                        col: ents[0].jac,
                    });
                }
            }
            // Pairs index a row's entries by u16.
            if ents.len() > usize::from(u16::MAX) {
                return Err(StructureError::Size(format!(
                    "path row {p} has {} Jacobian entries (at most {})",
                    ents.len(),
                    u16::MAX
                )));
            }
            let start = path_entries.len();
            path_entries.extend_from_slice(ents);
            let pairs_start = path_pairs.len();
            for (ia, a) in ents.iter().enumerate() {
                for (ib, b) in ents.iter().enumerate() {
                    let (sa, la, sb, lb) = (
                        a.stage as usize,
                        a.local as usize,
                        b.stage as usize,
                        b.local as usize,
                    );
                    let target = if sa == sb && la >= lb {
                        w_at(sa, la, lb)
                    } else if sb == sa + 1 {
                        x_at(sa, lb, la)
                    } else {
                        continue;
                    };
                    path_pairs.push(PathPair {
                        a: ia as u16,
                        b: ib as u16,
                        target,
                    });
                }
            }
            path_rows.push(PathRow {
                start,
                end: path_entries.len(),
                pairs_start,
                pairs_end: path_pairs.len(),
            });
        }

        // The solves' gather by target (path rows in row order, entries in row order).
        let (gather_targets, gather_terms) = {
            let mut terms: Vec<(u32, u16, u32, u32)> = Vec::with_capacity(path_entries.len());
            for (p, pr) in path_rows.iter().enumerate() {
                for (e, ent) in path_entries.iter().enumerate().take(pr.end).skip(pr.start) {
                    terms.push((ent.stage, ent.local, e as u32, p as u32));
                }
            }
            // Stable: each target keeps its terms in row order.
            terms.sort_by_key(|&(stage, local, _, _)| (stage, local));
            let mut targets: Vec<(u32, u16, u32)> = Vec::new();
            for (i, &(stage, local, _, _)) in terms.iter().enumerate() {
                match targets.last_mut() {
                    Some(t) if (t.0, t.1) == (stage, local) => t.2 = i as u32 + 1,
                    _ => targets.push((stage, local, i as u32 + 1)),
                }
            }
            let terms = terms.iter().map(|&(_, _, e, p)| (e, p)).collect();
            (targets, terms)
        };

        // Hessian (lower triangle, row >= col).
        let mut hess_map = Vec::with_capacity(hess_rows.len());
        for (&r, &c) in hess_rows.iter().zip(hess_cols) {
            if r >= n || c >= n {
                return Err(StructureError::Size(format!(
                    "Hessian entry ({r}, {c}) out of range"
                )));
            }
            let (a, b) = (r.max(c), r.min(c));
            let (sa, la) = st.locate(a);
            let (sb, lb) = st.locate(b);
            hess_map.push(if sa == sb {
                w_at(sa, la.max(lb), la.min(lb))
            } else if sa == sb + 1 {
                x_at(sb, la, lb)
            } else {
                return Err(StructureError::Coupling {
                    what: "Hessian",
                    row: r,
                    col: c,
                });
            });
        }

        // Entries the Hessian does not write but the diagonal or the path rows add to.
        let mut hess_targets = hess_map.clone();
        hess_targets.sort_unstable();
        hess_targets.dedup();
        let hess_assign = jac_assign && hess_targets.len() == hess_map.len();
        let mut zero_targets: Vec<u32> = (0..n)
            .map(|i| w_at(i / NZ, i % NZ, i % NZ))
            .chain(path_pairs.iter().map(|pp| pp.target))
            .filter(|t| hess_targets.binary_search(t).is_err())
            .collect();
        zero_targets.sort_unstable();
        zero_targets.dedup();

        // X block targets: column (z_{k-1} entry) = offset within the block / NZ.
        let x_col = |t: u32| ((t as usize).wrapping_sub(x_base) % (NZ * NZ)) / NZ;
        let in_x = |t: u32| (x_base..e_base).contains(&(t as usize));
        let mut y_live = [false; NZ];
        for &t in hess_map
            .iter()
            .chain(path_pairs.iter().map(|pp| &pp.target))
        {
            if in_x(t) {
                y_live[x_col(t)] = true;
            }
        }
        // Assembly units (see `Unit`).
        let unit_of = |t: u32| -> usize {
            let t = t as usize;
            if t < x_base {
                t / (NZ * NZ)
            } else if t < e_base {
                (t - x_base) / (NZ * NZ) + 1
            } else if t < j_base {
                let s = (t - e_base) / (NX * NX);
                if s < big {
                    s
                } else {
                    0
                }
            } else {
                (t - j_base) / (NX * NZ)
            }
        };
        let mut zero_u: Vec<Vec<(u32, u32)>> = vec![Vec::new(); big + 1];
        if hess_assign {
            for &t in &zero_targets {
                zero_u[unit_of(t)].push((t, 1));
            }
        } else {
            let mut blocks: Vec<(usize, usize)> =
                (0..=big).map(|s| (s * NZ * NZ, NZ * NZ)).collect();
            blocks.extend((0..big).map(|s| (x_base + s * NZ * NZ, NZ * NZ)));
            if !jac_assign {
                blocks.extend((0..=big).map(|s| (e_base + s * NX * NX, NX * NX)));
                blocks.extend((0..big).map(|s| (j_base + s * NX * NZ, NX * NZ)));
            }
            for (start, len) in blocks {
                zero_u[unit_of(start as u32)].push((start as u32, len as u32));
            }
        }
        let mut jac_u: Vec<Vec<(u32, u32)>> = vec![Vec::new(); big + 1];
        for (q, &t) in jac_map.iter().enumerate() {
            if t != NONE {
                jac_u[unit_of(t)].push((q as u32, t));
            }
        }
        let mut hess_u: Vec<Vec<(u32, u32)>> = vec![Vec::new(); big + 1];
        for (q, &t) in hess_map.iter().enumerate() {
            hess_u[unit_of(t)].push((q as u32, t));
        }
        let mut diag_u: Vec<Vec<(u32, u32)>> = vec![Vec::new(); big + 1];
        for i in 0..n {
            let t = w_at(i / NZ, i % NZ, i % NZ);
            diag_u[unit_of(t)].push((i as u32, t));
        }
        let mut pairs_u: Vec<Vec<UnitPair>> = vec![Vec::new(); big + 1];
        for pr in &path_rows {
            for pp in &path_pairs[pr.pairs_start..pr.pairs_end] {
                pairs_u[unit_of(pp.target)].push(UnitPair {
                    a: (pr.start + pp.a as usize) as u32,
                    b: (pr.start + pp.b as usize) as u32,
                    target: pp.target,
                });
            }
        }
        fn flatten<T: Copy>(per: &[Vec<T>], out: &mut Vec<T>, k: usize) -> (u32, u32) {
            let start = out.len() as u32;
            out.extend_from_slice(&per[k]);
            (start, out.len() as u32)
        }
        let (mut u_zero, mut u_jac, mut u_hess, mut u_diag, mut u_pairs) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let units = (0..=big)
            .map(|k| Unit {
                zero: flatten(&zero_u, &mut u_zero, k),
                jac: flatten(&jac_u, &mut u_jac, k),
                hess: flatten(&hess_u, &mut u_hess, k),
                diag: flatten(&diag_u, &mut u_diag, k),
                pairs: flatten(&pairs_u, &mut u_pairs, k),
            })
            .collect();

        let dim = 2 * NX;
        let params = Default::default();
        let mem = MemBuffer::new(
            lblt::factor::cholesky_in_place_scratch::<usize, f64>(dim, Par::Seq, params).or(
                lblt::solve::solve_in_place_scratch::<usize, f64>(dim, 1, Par::Seq),
            ),
        );
        Ok(Self {
            n,
            m,
            stages: big,
            jac_assign,
            hess_assign,
            y_live,
            rows,
            path_w: vec![0.0; path_rows.len()],
            path_t: vec![0.0; path_rows.len()],
            gather_targets,
            gather_terms,
            path_vals: vec![0.0; path_entries.len()],
            path_wv: vec![0.0; path_entries.len()],
            path_rows,
            path_entries,
            units,
            u_zero,
            u_jac,
            u_hess,
            u_diag,
            u_pairs,
            inverses: vec![StageInverse::default(); big],
            worker: None,
            claims: Claims::new(big + 1),
            helper_idle: false,
            arena: vec![0.0; arena_len],
            x_base,
            e_base,
            j_base,
            delta: vec![SVector::zeros(); big + 1],
            factors: vec![StageFactor::default(); big],
            init: Mat::zeros(dim, dim),
            init_diag: Diag::zeros(dim),
            init_sub: Diag::zeros(dim),
            init_perm: vec![0; dim],
            init_perm_inv: vec![0; dim],
            init_rhs: Mat::zeros(dim, 1),
            mem,
            bz: vec![SVector::zeros(); big + 1],
            bl: vec![SVector::zeros(); big + 1],
            factorized: false,
            simd: crate::cpu::avx2_available(),
        })
    }

    /// The row terms of the KKT values (Delta of the dynamics and initial rows, the path
    /// rows' weights and Jacobian values); the blocks follow unit by unit
    /// ([`Self::assemble_unit`]). Returns the number of path rows (one negative eigenvalue
    /// each).
    #[inline(always)]
    fn prepare(&mut self, v: &KktValues<'_>) -> Result<usize, KktError> {
        let big = self.stages;
        for (r, &d) in v.dual_diag.iter().enumerate() {
            match self.rows[r] {
                Row::Dynamics(k, i) => self.delta[k as usize][i as usize] = -d,
                Row::Initial(i) => self.delta[big][i as usize] = -d,
                Row::Path(p) => {
                    if d.is_nan() || d >= 0.0 {
                        return Err(KktError::Unsupported);
                    }
                    self.path_w[p as usize] = -1.0 / d;
                }
            }
        }
        for (val, e) in self.path_vals.iter_mut().zip(&self.path_entries) {
            *val = v.jac[e.jac];
        }
        for (pr, &w) in self.path_rows.iter().zip(&self.path_w) {
            for (wv, &val) in self.path_wv[pr.start..pr.end]
                .iter_mut()
                .zip(&self.path_vals[pr.start..pr.end])
            {
                *wv = w * val;
            }
        }
        Ok(self.path_rows.len())
    }

    /// J_k in the arena, in place (the solves read it there: it keeps its values until the
    /// next assembly).
    #[inline(always)]
    fn j_in(arena: &[f64], j_base: usize, k: usize) -> &SMatrix<f64, NX, NZ> {
        let o = j_base + k * NX * NZ;
        block_ref(&arena[o..o + NX * NZ])
    }

    /// E_k (the arena's copy).
    #[inline(always)]
    fn e_block(&self, k: usize) -> SMatrix<f64, NX, NX> {
        let o = self.e_base + k * NX * NX;
        SMatrix::from_column_slice(&self.arena[o..o + NX * NX])
    }

    /// Eliminates the pair (x_{k+1}, lambda_k) (`fac` holds Y^T on entry; E_k, J_k and the
    /// stage inverse `inv` are read in place) and returns z_k's block after the update,
    /// Q = W~ - C M^-1 C^T.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn eliminate_pair(
        fac: &mut StageFactor<NX, NU, NZ>,
        p: &SMatrix<f64, NX, NX>,
        e: &SMatrix<f64, NX, NX>,
        inv: &StageInverse<NX>,
        j: &SMatrix<f64, NX, NZ>,
        delta: &SVector<f64, NX>,
        q: &mut SMatrix<f64, NZ, NZ>,
        inertia: &mut Inertia,
    ) -> Result<(), KktError> {
        let f = &inv.ft.transpose();
        let mut phat = mul_tn(f, &mul_nn(p, f));
        symmetrize(&mut phat);
        // C^ = Y F (Y is zero outside the few rows of z_k that couple to x_{k+1}).
        let y = fac.yt.transpose();
        fac.chat = mul_nn(&y, f);
        fac.zero_delta = delta.iter().all(|&d| d == 0.0);
        fac.lambda_first = false;
        if fac.zero_delta {
            // M^-1 = diag(F, I) [[0, I], [I, -P^]] diag(F^T, I): inertia (NX, NX).
            inertia.positive += NX;
            inertia.negative += NX;
            fac.a22 = -phat;
            if inv.j_minus_identity {
                // J = [-I, G]: Q = W~ - C^J - (C^J)^T + J^T P^ J written blockwise.
                let g: SMatrix<f64, NX, NU> = j.fixed_view::<NX, NU>(0, NX).into_owned();
                let cg = mul_nn(&fac.chat, &g);
                let pg = mul_nn(&phat, &g);
                let gpg = mul_tn(&g, &pg);
                for c in 0..NX {
                    for r in 0..NZ {
                        q[(r, c)] += fac.chat[(r, c)];
                        q[(c, r)] += fac.chat[(r, c)];
                    }
                }
                for c in 0..NU {
                    for r in 0..NZ {
                        q[(r, NX + c)] -= cg[(r, c)];
                        q[(NX + c, r)] -= cg[(r, c)];
                    }
                }
                for c in 0..NX {
                    for r in 0..NX {
                        q[(r, c)] += phat[(r, c)];
                    }
                }
                for c in 0..NU {
                    for r in 0..NX {
                        q[(r, NX + c)] -= pg[(r, c)];
                        q[(NX + c, r)] -= pg[(r, c)];
                    }
                    for r in 0..NU {
                        q[(NX + r, NX + c)] += gpg[(r, c)];
                    }
                }
            } else {
                let cj = fac.chat * j;
                *q -= cj + cj.transpose();
                *q += j.tr_mul(&(phat * j));
            }
            symmetrize(q);
            return Ok(());
        }
        // A large uniform Delta = delta I (the restoration phase's delta_c = 1): eliminate
        // lambda_k first, M^-1 through S_x = P + E^T E / delta; the pair formula below would
        // lose digits in K P^ when delta P^ is large.
        let d0 = delta[0];
        if d0 > 0.0 && delta.iter().all(|&d| d == d0) && d0 * phat.amax() > 1.0 {
            let mut sx = p + e.tr_mul(e) / d0;
            symmetrize(&mut sx);
            let (l, dd, neg) = ldlt_factor(&sx)?;
            inertia.positive += NX - neg;
            inertia.negative += NX + neg;
            // Q = W~ - V S_x^-1 V^T + J^T J / delta with V = Y + J^T E / delta.
            let v = y + j.tr_mul(e) / d0;
            let mut gvt = v.transpose();
            ldlt_solve_cols(&l, &dd, &mut gvt);
            *q -= v * gvt;
            *q += j.tr_mul(j) / d0;
            symmetrize(q);
            fac.lambda_first = true;
            fac.sx_l = l;
            fac.sx_d = dd;
            fac.e = *e;
            fac.delta = d0;
            return Ok(());
        }
        // Delta != 0 (a raised dual regularization): general blocks.
        let sqrt_d = delta.map(|d| d.max(0.0).sqrt());
        let mut ts = phat;
        for c in 0..NX {
            for r in 0..NX {
                ts[(r, c)] *= sqrt_d[r] * sqrt_d[c];
            }
            ts[(c, c)] += 1.0;
        }
        let (ts_l, ts_d, neg) = ldlt_factor(&ts)?;
        inertia.positive += NX - neg;
        inertia.negative += NX + neg;
        // K = (I + P^ Delta)^-1; [[Delta K, K^T], [K, -K P^]].
        let uniform = delta.iter().all(|&d| d == delta[0]);
        let k = if uniform {
            // Uniform Delta (the solver's case): I + P^ Delta = T_s, inverted through the
            // LDL^T already computed (no pivot threshold on a badly scaled P^).
            let mut k = SMatrix::<f64, NX, NX>::identity();
            ldlt_solve_cols(&ts_l, &ts_d, &mut k);
            k
        } else {
            let mut t = phat;
            for c in 0..NX {
                for r in 0..NX {
                    t[(r, c)] *= delta[c];
                }
                t[(c, c)] += 1.0;
            }
            invert(&t).ok_or(KktError::Singular)?
        };
        let mut a11 = k;
        for r in 0..NX {
            for c in 0..NX {
                a11[(r, c)] *= delta[r];
            }
        }
        symmetrize(&mut a11);
        let mut a22 = -(k * phat);
        symmetrize(&mut a22);
        fac.a11 = a11;
        fac.a12 = k.transpose();
        fac.a22 = a22;
        // S = C^ a11 C^T + C^ a12 J + J^T a12^T C^T + J^T a22 J.
        let cross = fac.chat * fac.a12 * j;
        *q -= fac.chat * a11 * fac.chat.transpose() + cross + cross.transpose();
        *q -= j.tr_mul(&(a22 * j));
        symmetrize(q);
        Ok(())
    }

    /// Applies the pair's M^-1 to (r1, r2): returns (x_{k+1}, lambda_k). `ft` is F^T.
    #[inline(always)]
    fn apply_pair(
        fac: &StageFactor<NX, NU, NZ>,
        ft: &SMatrix<f64, NX, NX>,
        r1: &SVector<f64, NX>,
        r2: &SVector<f64, NX>,
    ) -> (SVector<f64, NX>, SVector<f64, NX>) {
        if fac.lambda_first {
            // (P + E^T E / delta) x = r1 + E^T r2 / delta, lambda = (E x - r2) / delta.
            let mut x = r1 + mtv(&fac.e, r2) / fac.delta;
            ldlt_solve_vec(&fac.sx_l, &fac.sx_d, &mut x);
            let lambda = (mv(&fac.e, &x) - r2) / fac.delta;
            return (x, lambda);
        }
        // [[P^, I], [I, -Delta]]^-1 applied to (F^T r1, r2) gives (a, lambda), x = F a.
        let all = [true; NX];
        let q1 = mtv_t(ft, r1);
        if fac.zero_delta {
            (mv_rows_t(ft, r2, &all), q1 + mv(&fac.a22, r2))
        } else {
            let a = mv(&fac.a11, &q1) + mv(&fac.a12, r2);
            let b = mtv(&fac.a12, &q1) + mv(&fac.a22, r2);
            (mv_rows_t(ft, &a, &all), b)
        }
    }

    /// Steps 1 and 2: the units and the backward sweep. With a helper thread the two take
    /// the units in chunks, in sweep order ([`Claims`]): the helper writes the chunks it
    /// claims while this thread sweeps, and the sweep writes the ones the helper has not
    /// claimed when it reaches them. Without one each unit is written just before its
    /// stage. Same bits.
    #[inline(always)]
    fn factorize_blocks(
        &mut self,
        v: &KktValues<'_>,
        negative_path: usize,
        stop_on_excess: bool,
    ) -> Result<Inertia, KktError> {
        let big = self.stages;
        if self.worker.is_some() {
            self.claims.reset();
        }
        let claims = &self.claims;
        let asm = Assembly::<NX, NZ> {
            units: &self.units,
            zero: &self.u_zero,
            jac: &self.u_jac,
            hess: &self.u_hess,
            diag: &self.u_diag,
            pairs: &self.u_pairs,
            path_wv: &self.path_wv,
            path_vals: &self.path_vals,
            jac_assign: self.jac_assign,
            hess_assign: self.hess_assign,
            stages: big,
            x_base: self.x_base,
            e_base: self.e_base,
            j_base: self.j_base,
            arena: self.arena.as_mut_ptr(),
            inverses: self.inverses.as_mut_ptr(),
            simd: self.simd,
        };
        let sweep = Sweep {
            factors: &mut self.factors,
            delta: &self.delta,
            y_live: self.y_live,
            negative_path,
            stop_on_excess,
        };
        let (p, mut inertia) = match self.worker.as_mut() {
            None => sweep.run(&asm, |k| {
                // SAFETY: one thread; every unit is written once, before its stage reads it.
                unsafe { asm.unit_for_cpu(k, v) }
            })?,
            Some(shared) => {
                // Units in sweep order (N, N-1, .., 0), in chunks claimed by the helper or
                // taken by the sweep (see `Claims`); the sweep stops the helper when it stops
                // early.
                let cancel = AtomicBool::new(false);
                // Set if the helper's job panics, so the sweep stops waiting (and panics).
                let failed = AtomicBool::new(false);
                let chunk = |c: usize| {
                    // SAFETY: the thread that claimed or took chunk c is the only one
                    // writing its units, and the other reads them only after it is
                    // published (release/acquire on its flag) or, for the sweep's own
                    // chunks, after writing them itself.
                    for i in c * CHUNK..((c + 1) * CHUNK).min(big + 1) {
                        unsafe { asm.unit_for_cpu(big - i, v) };
                    }
                };
                let helper_idle = self.helper_idle;
                let mut job = || {
                    let _flag = PanicFlag(&failed);
                    if helper_idle {
                        return;
                    }
                    while let Some(c) = claims.claim() {
                        if cancel.load(Ordering::Relaxed) {
                            break;
                        }
                        chunk(c);
                        claims.publish(c);
                    }
                };
                let simd = self.simd;
                // The sweep can do every chunk itself, so a job the helper has not taken by
                // the end is withdrawn instead of waited for.
                worker::lock(shared).join_or_skip(&mut job, || {
                    // Stops the helper however the sweep ends (result, early stop or panic).
                    let _cancel = CancelOnDrop(&cancel);
                    let mut have = 0;
                    sweep.run_for_cpu(
                        &asm,
                        |k| {
                            let c = (big - k) / CHUNK;
                            if c < have {
                                return;
                            }
                            match claims.acquire(c, || failed.load(Ordering::Acquire)) {
                                Acquired::Ready => {}
                                Acquired::Mine => chunk(c),
                                Acquired::Failed => {
                                    panic!("the helper thread's assembly panicked")
                                }
                            }
                            have = c + 1;
                        },
                        simd,
                    )
                })?
            }
        };
        self.factorize_initial(&p, &mut inertia)?;
        Ok(inertia)
    }

    /// The initial block [[P_0, E^T], [E, -Delta]] by Bunch-Kaufman (step 3).
    #[inline(always)]
    fn factorize_initial(
        &mut self,
        p: &SMatrix<f64, NX, NX>,
        inertia: &mut Inertia,
    ) -> Result<(), KktError> {
        let big = self.stages;
        let e = self.e_block(big);
        let dl = self.delta[big];
        let a = &mut self.init;
        for c in 0..NX {
            for r in 0..NX {
                a[(r, c)] = p[(r, c)];
                a[(NX + r, c)] = e[(r, c)];
                a[(r, NX + c)] = e[(c, r)];
                a[(NX + r, NX + c)] = 0.0;
            }
            a[(NX + c, NX + c)] = -dl[c];
        }
        // faer leaves the subdiagonal entry of a pivot with a zero column untouched.
        self.init_sub.column_vector_mut().fill(0.0);
        lblt::factor::cholesky_in_place(
            self.init.as_mut(),
            self.init_sub.as_mut(),
            &mut self.init_perm,
            &mut self.init_perm_inv,
            Par::Seq,
            MemStack::new(&mut self.mem),
            Default::default(),
        );
        let dim = 2 * NX;
        let mut i = 0;
        while i < dim {
            let d = self.init[(i, i)];
            self.init_diag.column_vector_mut()[i] = d;
            let s = if i + 1 < dim {
                self.init_sub.column_vector()[i]
            } else {
                0.0
            };
            if s != 0.0 {
                let d2 = self.init[(i + 1, i + 1)];
                self.init_diag.column_vector_mut()[i + 1] = d2;
                let det = d * d2 - s * s;
                if !det.is_finite() || det == 0.0 {
                    return Err(KktError::Singular);
                } else if det < 0.0 {
                    inertia.positive += 1;
                    inertia.negative += 1;
                } else if d > 0.0 {
                    inertia.positive += 2;
                } else {
                    inertia.negative += 2;
                }
                i += 2;
            } else {
                if !d.is_finite() || d == 0.0 {
                    return Err(KktError::Singular);
                }
                if d > 0.0 {
                    inertia.positive += 1;
                } else {
                    inertia.negative += 1;
                }
                i += 1;
            }
        }
        // faer's solve wants the unit lower factor.
        for c in 0..dim {
            self.init[(c, c)] = 1.0;
            for r in 0..c {
                self.init[(r, c)] = 0.0;
            }
        }
        Ok(())
    }
}

impl<const NX: usize, const NU: usize, const NZ: usize> RiccatiKkt<NX, NU, NZ> {
    /// Runs factorizations and solves in the AVX2-compiled copy when `on` and the CPU has
    /// AVX2, else in the baseline one (the default is AVX2 where available). Both give the
    /// same bits: Rust never contracts a * b + c into an FMA, and the wider vectors only
    /// compute independent entries at once.
    pub fn set_simd(&mut self, on: bool) {
        self.simd = on && crate::cpu::avx2_available();
    }

    /// Whether factorizations and solves run in the AVX2-compiled copy.
    pub fn simd(&self) -> bool {
        self.simd
    }

    /// Pipelines the factorization over a second thread when `on`: a helper writes the
    /// stage blocks (and E_k^-1) in sweep order while this thread sweeps. Same bits as one
    /// thread. Starts the helper (allocates; call at setup) or stops it.
    pub fn set_pipelined(&mut self, on: bool) -> std::io::Result<()> {
        match (on, self.worker.is_some()) {
            (true, false) => self.worker = Some(worker::shared()?),
            (false, true) => self.worker = None,
            _ => {}
        }
        Ok(())
    }

    /// For tests: with `idle`, the pipelined factorization's helper claims no unit, so the
    /// sweep writes every chunk itself (the path a late or descheduled helper takes).
    #[doc(hidden)]
    pub fn set_helper_idle(&mut self, idle: bool) {
        self.helper_idle = idle;
    }

    /// The helper thread of the pipelined factorization, to share with other stage-parallel
    /// work of the same solve.
    pub fn worker(&self) -> Option<&SharedWorker> {
        self.worker.as_ref()
    }

    /// Whether a helper thread pipelines the factorization.
    pub fn pipelined(&self) -> bool {
        self.worker.is_some()
    }

    /// The factorization, inlined into both the baseline and the AVX2 entry point.
    #[inline(always)]
    fn factorize_body(
        &mut self,
        v: &KktValues<'_>,
        stop_on_excess: bool,
    ) -> Result<Inertia, KktError> {
        self.factorized = false;
        let finite = crate::ip::vector::all_finite;
        if !(finite(v.hess) && finite(v.jac) && finite(v.primal_diag) && finite(v.dual_diag)) {
            return Err(KktError::NonFinite);
        }
        let negative_path = self.prepare(v)?;
        let inertia = self.factorize_blocks(v, negative_path, stop_on_excess)?;
        self.factorized = true;
        Ok(inertia)
    }

    /// The solve, inlined into both entry points.
    #[inline(always)]
    fn solve_body(&mut self, rhs_x: &mut [f64], rhs_y: &mut [f64]) {
        if !self.factorized {
            return;
        }
        let big = self.stages;
        // Every path row's right-hand side is read into `path_t` below.
        debug_assert_eq!((rhs_x.len(), rhs_y.len()), (self.n, self.m), "rhs lengths");
        // Gather, the path rows eliminated: r_x += J_r^T r_c,r / |D_c|.
        for (b, chunk) in self.bz.iter_mut().zip(rhs_x.chunks(NZ)) {
            b.as_mut_slice()[..chunk.len()].copy_from_slice(chunk);
        }
        for (r, &v) in rhs_y.iter().enumerate() {
            match self.rows[r] {
                Row::Dynamics(k, i) => self.bl[k as usize][i as usize] = v,
                Row::Initial(i) => self.bl[big][i as usize] = v,
                Row::Path(p) => self.path_t[p as usize] = v * self.path_w[p as usize],
            }
        }
        let mut start = 0;
        for &(stage, local, end) in &self.gather_targets {
            let b = &mut self.bz[stage as usize][local as usize];
            let mut acc = *b;
            for &(e, p) in &self.gather_terms[start..end as usize] {
                acc += self.path_t[p as usize] * self.path_vals[e as usize];
            }
            *b = acc;
            start = end as usize;
        }
        // Forward substitution in elimination order.
        for k in (0..big).rev() {
            let (fac, inv) = (&self.factors[k], &self.inverses[k]);
            let j = Self::j_in(&self.arena, self.j_base, k);
            let r1: SVector<f64, NX> = self.bz[k + 1].fixed_rows::<NX>(0).into_owned();
            let (x, lambda) = Self::apply_pair(fac, &inv.ft, &r1, &self.bl[k]);
            let upd =
                mv_rows_t(&fac.yt, &x, &self.y_live) + jt_mul(j, inv.j_minus_identity, &lambda);
            self.bz[k] -= upd;
            let mut t: SVector<f64, NU> = self.bz[k].fixed_rows::<NU>(NX).into_owned();
            ldlt_solve_vec(&fac.quu_l, &fac.quu_d, &mut t);
            let ux = mtv(&fac.q_ux, &t);
            let mut head = self.bz[k].fixed_rows_mut::<NX>(0);
            head -= ux;
            if k > 0 {
                let ur = mv(&fac.r, &t);
                self.bz[k - 1] -= ur;
            }
        }
        // Initial block.
        for i in 0..NX {
            self.init_rhs[(i, 0)] = self.bz[0][i];
            self.init_rhs[(NX + i, 0)] = self.bl[big][i];
        }
        let perm = faer::perm::PermRef::new_checked(&self.init_perm, &self.init_perm_inv, 2 * NX);
        lblt::solve::solve_in_place_with_conj(
            self.init.as_ref(),
            self.init_diag.as_ref(),
            self.init_sub.as_ref(),
            Conj::No,
            perm,
            self.init_rhs.as_mut(),
            Par::Seq,
            MemStack::new(&mut self.mem),
        );
        for i in 0..NX {
            self.bz[0][i] = self.init_rhs[(i, 0)];
            self.bl[big][i] = self.init_rhs[(NX + i, 0)];
        }
        // Backward substitution.
        for k in 0..big {
            let (fac, inv) = (&self.factors[k], &self.inverses[k]);
            let j = Self::j_in(&self.arena, self.j_base, k);
            let x: SVector<f64, NX> = self.bz[k].fixed_rows::<NX>(0).into_owned();
            let mut t: SVector<f64, NU> = self.bz[k].fixed_rows::<NU>(NX) - mv(&fac.q_ux, &x);
            if k > 0 {
                t -= mtv(&fac.r, &self.bz[k - 1]);
            }
            ldlt_solve_vec(&fac.quu_l, &fac.quu_d, &mut t);
            self.bz[k].fixed_rows_mut::<NU>(NX).copy_from(&t);
            let z = self.bz[k];
            let r1: SVector<f64, NX> = self.bz[k + 1].fixed_rows::<NX>(0) - mtv_t(&fac.yt, &z);
            let r2 = self.bl[k] - j_mul(j, inv.j_minus_identity, &z);
            let (xn, lambda) = Self::apply_pair(fac, &inv.ft, &r1, &r2);
            self.bz[k + 1].fixed_rows_mut::<NX>(0).copy_from(&xn);
            self.bl[k] = lambda;
        }
        // Scatter; path-row multipliers from dy_r = (r_c,r - J_r dx) / D_c.
        for (chunk, b) in rhs_x.chunks_mut(NZ).zip(&self.bz) {
            chunk.copy_from_slice(&b.as_slice()[..chunk.len()]);
        }
        for (r, out) in rhs_y.iter_mut().enumerate() {
            *out = match self.rows[r] {
                Row::Dynamics(k, i) => self.bl[k as usize][i as usize],
                Row::Initial(i) => self.bl[big][i as usize],
                Row::Path(p) => {
                    let pr = self.path_rows[p as usize];
                    let mut jdx = 0.0;
                    for (e, &jv) in self.path_entries[pr.start..pr.end]
                        .iter()
                        .zip(&self.path_vals[pr.start..pr.end])
                    {
                        jdx += jv * self.bz[e.stage as usize][e.local as usize];
                    }
                    -(*out - jdx) * self.path_w[p as usize]
                }
            };
        }
    }

    /// The factorization in the AVX2 or the baseline copy (see [`Self::set_simd`]);
    /// `stop_on_excess` as in [`check_excess`].
    fn factorize_dispatch(
        &mut self,
        v: &KktValues<'_>,
        stop_on_excess: bool,
    ) -> Result<Inertia, KktError> {
        #[cfg(target_arch = "x86_64")]
        if self.simd {
            // SAFETY: `simd` is only true when the CPU reports AVX2 (`avx2_available`).
            return unsafe { self.factorize_avx2(v, stop_on_excess) };
        }
        self.factorize_body(v, stop_on_excess)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    unsafe fn factorize_avx2(
        &mut self,
        v: &KktValues<'_>,
        stop_on_excess: bool,
    ) -> Result<Inertia, KktError> {
        self.factorize_body(v, stop_on_excess)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    unsafe fn solve_avx2(&mut self, rhs_x: &mut [f64], rhs_y: &mut [f64]) {
        self.solve_body(rhs_x, rhs_y)
    }
}

impl<const NX: usize, const NU: usize, const NZ: usize> KktSolver for RiccatiKkt<NX, NU, NZ> {
    fn factorize(&mut self, v: &KktValues<'_>) -> Result<Inertia, KktError> {
        self.factorize_dispatch(v, false)
    }

    fn factorize_expecting(
        &mut self,
        v: &KktValues<'_>,
        expected: Inertia,
    ) -> Result<Inertia, KktError> {
        let correct =
            expected.positive == self.n && expected.negative == self.m && expected.zero == 0;
        self.factorize_dispatch(v, correct)
    }

    fn solve(&mut self, rhs_x: &mut [f64], rhs_y: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if self.simd {
            // SAFETY: as in `factorize`.
            return unsafe { self.solve_avx2(rhs_x, rhs_y) };
        }
        self.solve_body(rhs_x, rhs_y)
    }

    fn wants_dual_regularization(&self) -> bool {
        false
    }
}

/// Sets its flag when dropped during a panic (the pipelined factorization's helper job).
struct PanicFlag<'a>(&'a AtomicBool);

impl Drop for PanicFlag<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.store(true, Ordering::Release);
        }
    }
}

/// What writes the units: the op lists, read-only, and raw pointers to the arena and the
/// stage inverses. With a helper, each chunk of units is written by the one thread that
/// claimed or took it, and the sweep reads a helper's chunk only after it is published
/// ([`Claims`]: disjoint memory, release/acquire per chunk). Never a reference to the
/// whole arena while both threads run.
struct Assembly<'a, const NX: usize, const NZ: usize> {
    units: &'a [Unit],
    zero: &'a [(u32, u32)],
    jac: &'a [(u32, u32)],
    hess: &'a [(u32, u32)],
    diag: &'a [(u32, u32)],
    pairs: &'a [UnitPair],
    path_wv: &'a [f64],
    path_vals: &'a [f64],
    jac_assign: bool,
    hess_assign: bool,
    stages: usize,
    x_base: usize,
    e_base: usize,
    j_base: usize,
    arena: *mut f64,
    inverses: *mut StageInverse<NX>,
    /// Write the units in the AVX2-compiled copy ([`Self::unit_for_cpu`]).
    simd: bool,
}

// SAFETY: shared between the sweep and the helper only under the protocol described on the
// type (each unit's memory is written by one thread before the other reads it).
unsafe impl<const NX: usize, const NZ: usize> Sync for Assembly<'_, NX, NZ> {}

impl<const NX: usize, const NZ: usize> Assembly<'_, NX, NZ> {
    /// Writes unit `k` (see [`Unit`]): zeroes, Jacobian and Hessian values, the primal
    /// diagonal, then W += J_r^T J_r / |D_c| over the path rows (X for pairs across two
    /// stages); for a stage unit also E_k^-1 (reused while E_k keeps its bits).
    ///
    /// # Safety
    /// No other thread accesses unit `k`'s arena entries or inverse meanwhile.
    #[inline(always)]
    unsafe fn unit(&self, k: usize, v: &KktValues<'_>) {
        let u = self.units[k];
        let a = self.arena;
        let span = |r: (u32, u32)| r.0 as usize..r.1 as usize;
        for &(t, len) in &self.zero[span(u.zero)] {
            if len == 1 {
                *a.add(t as usize) = 0.0;
            } else {
                // All-zero bits are +0.0.
                std::ptr::write_bytes(a.add(t as usize), 0, len as usize);
            }
        }
        let jac = &self.jac[span(u.jac)];
        if self.jac_assign {
            for &(q, t) in jac {
                *a.add(t as usize) = v.jac[q as usize];
            }
        } else {
            for &(q, t) in jac {
                *a.add(t as usize) += v.jac[q as usize];
            }
        }
        let hess = &self.hess[span(u.hess)];
        if self.hess_assign {
            // 0 + h, not h: the bits of the summed version, signed zeros too.
            for &(q, t) in hess {
                *a.add(t as usize) = 0.0 + v.hess[q as usize];
            }
        } else {
            for &(q, t) in hess {
                *a.add(t as usize) += v.hess[q as usize];
            }
        }
        for &(i, t) in &self.diag[span(u.diag)] {
            *a.add(t as usize) += v.primal_diag[i as usize];
        }
        // SAFETY (indices): `a` and `b` index path entries, built with `path_wv` and
        // `path_vals` of the same length at setup.
        for pp in &self.pairs[span(u.pairs)] {
            *a.add(pp.target as usize) += *self.path_wv.get_unchecked(pp.a as usize)
                * *self.path_vals.get_unchecked(pp.b as usize);
        }
        // W_k's upper triangle from its lower one (the sweep reads whole blocks).
        let w = a.add(k * NZ * NZ);
        for c in 0..NZ {
            for r in c + 1..NZ {
                *w.add(r * NZ + c) = *w.add(c * NZ + r);
            }
        }
        if k < self.stages {
            let e = std::slice::from_raw_parts(a.add(self.e_base + k * NX * NX), NX * NX);
            let inv = &mut *self.inverses.add(k);
            inv.j_minus_identity = minus_identity_head(self.j_block(k));
            if same_bits(inv.e_in.as_slice(), e) {
                inv.ok = true;
            } else {
                let e = SMatrix::<f64, NX, NX>::from_column_slice(e);
                if let Some(ft) = invert_unit_tail_t(&e) {
                    inv.ft = ft;
                    inv.e_in = e;
                    inv.ok = true;
                } else {
                    inv.ok = false;
                }
            }
        }
    }

    /// [`Self::unit`] in the copy compiled for this CPU. The sweep's and the helper's
    /// callbacks are closures, and a closure does not take the target features of the AVX2
    /// entry point it is inlined into: called directly from them, the assembly (E_k^-1
    /// included) ran as baseline code. Same bits either way.
    ///
    /// # Safety
    /// As [`Self::unit`].
    #[inline(always)]
    unsafe fn unit_for_cpu(&self, k: usize, v: &KktValues<'_>) {
        #[cfg(target_arch = "x86_64")]
        if self.simd {
            // SAFETY: `simd` is only true when the CPU reports AVX2; the caller upholds
            // `unit`'s contract.
            return self.unit_avx2(k, v);
        }
        self.unit(k, v)
    }

    /// # Safety
    /// The CPU has AVX2; as [`Self::unit`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    unsafe fn unit_avx2(&self, k: usize, v: &KktValues<'_>) {
        self.unit(k, v)
    }

    /// `len` arena entries from `o`.
    ///
    /// # Safety
    /// Their unit is written and no thread writes it meanwhile.
    #[inline(always)]
    unsafe fn slice(&self, o: usize, len: usize) -> &[f64] {
        std::slice::from_raw_parts(self.arena.add(o), len)
    }

    /// W_k (both triangles, see [`Self::unit`]), in place. Safety: as [`Self::slice`].
    #[inline(always)]
    unsafe fn w_block(&self, k: usize) -> &SMatrix<f64, NZ, NZ> {
        block_ref(self.slice(k * NZ * NZ, NZ * NZ))
    }

    /// X_k, in place. Safety: as [`Self::slice`].
    #[inline(always)]
    unsafe fn x_block(&self, k: usize) -> &SMatrix<f64, NZ, NZ> {
        block_ref(self.slice(self.x_base + k * NZ * NZ, NZ * NZ))
    }

    /// E_k, in place. Safety: as [`Self::slice`].
    #[inline(always)]
    unsafe fn e_block(&self, k: usize) -> &SMatrix<f64, NX, NX> {
        block_ref(self.slice(self.e_base + k * NX * NX, NX * NX))
    }

    /// J_k, in place. Safety: as [`Self::slice`].
    #[inline(always)]
    unsafe fn j_block(&self, k: usize) -> &SMatrix<f64, NX, NZ> {
        block_ref(self.slice(self.j_base + k * NX * NZ, NX * NZ))
    }

    /// F^T = E_k^-T and whether J_k = [-I, G], or `Unsupported` when E_k is singular. Safety: as
    /// [`Self::slice`].
    #[inline(always)]
    unsafe fn inverse(&self, k: usize) -> Result<&StageInverse<NX>, KktError> {
        let inv = &*self.inverses.add(k);
        if inv.ok {
            Ok(inv)
        } else {
            Err(KktError::Unsupported)
        }
    }
}

/// Sets the pipelined factorization's cancel flag when dropped.
struct CancelOnDrop<'a>(&'a AtomicBool);

impl Drop for CancelOnDrop<'_> {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Relaxed);
    }
}

/// The backward sweep's own state (step 2).
struct Sweep<'a, const NX: usize, const NU: usize, const NZ: usize> {
    factors: &'a mut [StageFactor<NX, NU, NZ>],
    delta: &'a [SVector<f64, NX>],
    y_live: [bool; NZ],
    negative_path: usize,
    stop_on_excess: bool,
}

impl<const NX: usize, const NU: usize, const NZ: usize> Sweep<'_, NX, NU, NZ> {
    /// [`Self::run`] in the copy compiled for this CPU when `simd`: the pipelined
    /// factorization runs the sweep inside a closure, which does not take the target
    /// features of the AVX2 entry point it sits in. Same bits either way.
    #[inline(always)]
    fn run_for_cpu(
        self,
        asm: &Assembly<'_, NX, NZ>,
        ready: impl FnMut(usize),
        simd: bool,
    ) -> Result<(SMatrix<f64, NX, NX>, Inertia), KktError> {
        #[cfg(target_arch = "x86_64")]
        if simd {
            // SAFETY: `simd` is only true when the CPU reports AVX2.
            return unsafe { self.run_avx2(asm, ready) };
        }
        let _ = simd;
        self.run(asm, ready)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    unsafe fn run_avx2(
        self,
        asm: &Assembly<'_, NX, NZ>,
        ready: impl FnMut(usize),
    ) -> Result<(SMatrix<f64, NX, NX>, Inertia), KktError> {
        self.run(asm, ready)
    }

    /// Sweeps k = N-1 .. 0, calling `ready(k)` before it reads unit k (and `ready(N)`
    /// first); returns P_0 and the inertia so far.
    #[inline(always)]
    fn run(
        self,
        asm: &Assembly<'_, NX, NZ>,
        mut ready: impl FnMut(usize),
    ) -> Result<(SMatrix<f64, NX, NX>, Inertia), KktError> {
        let big = asm.stages;
        let (negative_path, stop_on_excess, y_live) =
            (self.negative_path, self.stop_on_excess, self.y_live);
        let mut inertia = Inertia {
            positive: 0,
            negative: negative_path,
            zero: 0,
        };
        ready(big);
        // SAFETY (every block read below): `ready(k)` returned, so unit k is written and
        // no thread writes it any more in this factorization.
        let mut p: SMatrix<f64, NX, NX> = unsafe { asm.w_block(big) }
            .fixed_view::<NX, NX>(0, 0)
            .into_owned();
        // Y^T: the coupling of z_k to x_{k+1}, stored transposed (NX x NZ, contiguous rows
        // of the X block).
        let mut yt: SMatrix<f64, NX, NZ> = unsafe { asm.x_block(big - 1) }
            .fixed_view::<NX, NZ>(0, 0)
            .into_owned();
        let mut pending: SMatrix<f64, NZ, NZ> = SMatrix::zeros();
        for k in (0..big).rev() {
            ready(k);
            let inv = unsafe { asm.inverse(k) }?;
            let mut q = unsafe { asm.w_block(k) } - pending;
            let e = unsafe { asm.e_block(k) };
            let j = unsafe { asm.j_block(k) };
            let prev = if k > 0 {
                Some(unsafe { asm.x_block(k - 1) })
            } else {
                None
            };
            let fac = &mut self.factors[k];
            let zero_delta = all_zero(self.delta[k].as_slice());
            let fast = zero_delta && inv.j_minus_identity;
            if fast {
                fast_stage(
                    fac,
                    &mut p,
                    &mut yt,
                    &mut pending,
                    inv,
                    j,
                    &mut q,
                    prev,
                    &y_live,
                    &mut inertia,
                )?;
                check_excess::<NX>(stop_on_excess, &inertia, negative_path, big - k)?;
                continue;
            }
            fac.yt = yt;
            RiccatiKkt::<NX, NU, NZ>::eliminate_pair(
                fac,
                &p,
                e,
                inv,
                j,
                &self.delta[k],
                &mut q,
                &mut inertia,
            )?;
            // u_k.
            let quu: SMatrix<f64, NU, NU> = q.fixed_view::<NU, NU>(NX, NX).into_owned();
            let (l, d, neg) = ldlt_factor(&quu)?;
            inertia.positive += NU - neg;
            inertia.negative += neg;
            fac.quu_l = l;
            fac.quu_d = d;
            fac.q_ux = q.fixed_view::<NU, NX>(NX, 0).into_owned();
            // g = Q_uu^-1 Q_ux.
            let mut g = fac.q_ux;
            ldlt_solve_cols(&l, &d, &mut g);
            p = q.fixed_view::<NX, NX>(0, 0) - fac.q_ux.tr_mul(&g);
            symmetrize(&mut p);
            if let Some(xc) = prev {
                // Y = X_{k-1}[x rows]^T - R g and W_{k-1} -= R Q_uu^-1 R^T.
                fac.r = xc.fixed_view::<NU, NZ>(NX, 0).transpose();
                yt = xc.fixed_view::<NX, NZ>(0, 0) - g.tr_mul(&fac.r.transpose());
                let mut rt = fac.r.transpose();
                ldlt_solve_cols(&l, &d, &mut rt);
                pending = fac.r * rt;
                symmetrize(&mut pending);
            } else {
                fac.r = SMatrix::zeros();
            }
            check_excess::<NX>(stop_on_excess, &inertia, negative_path, big - k)?;
        }
        Ok((p, inertia))
    }
}

/// With `stop_on_excess` (the caller expects the correct inertia (n, m)):
/// [`KktError::WrongInertia`] once the path rows and `done` stages hold more negative pivots
/// than their share (one per path row, NX per pair step, none in Q_uu). Every block's
/// negative count is at least its share (the pair and the initial block have a nonsingular
/// off-diagonal E), and the shares add up to m, so an excess anywhere means the total
/// inertia is not (n, m).
#[inline(always)]
fn check_excess<const NX: usize>(
    stop_on_excess: bool,
    inertia: &Inertia,
    negative_path: usize,
    done: usize,
) -> Result<(), KktError> {
    if stop_on_excess && inertia.negative > negative_path + done * NX {
        Err(KktError::WrongInertia)
    } else {
        Ok(())
    }
}

/// J_k = [-I, G] (the implicit-Euler dynamics Jacobian with respect to z_k).
#[inline(always)]
fn minus_identity_head<const NX: usize, const NZ: usize>(j: &SMatrix<f64, NX, NZ>) -> bool {
    let cols = &j.data.0;
    let mut ok = true;
    for (c, col) in cols.iter().take(NX).enumerate() {
        for (r, &v) in col.iter().enumerate() {
            ok &= v == if r == c { -1.0 } else { 0.0 };
        }
    }
    ok
}

/// One stage of the backward sweep in its common case, Delta_k = 0 and J_k = [-I, G]
/// (implicit Euler): the pair step of [`RiccatiKkt::eliminate_pair`] and the u_k step,
/// written over column arrays so that every product is a run of contiguous column updates
/// and only the lower triangles of symmetric results are formed. On entry `q` holds
/// W_k - pending, `p` and `yt` the state from stage k + 1; on exit they hold P_k, Y_{k-1}^T
/// and the pending update of W_{k-1}.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn fast_stage<const NX: usize, const NU: usize, const NZ: usize>(
    fac: &mut StageFactor<NX, NU, NZ>,
    p: &mut SMatrix<f64, NX, NX>,
    yt: &mut SMatrix<f64, NX, NZ>,
    pending: &mut SMatrix<f64, NZ, NZ>,
    inv: &StageInverse<NX>,
    j: &SMatrix<f64, NX, NZ>,
    q: &mut SMatrix<f64, NZ, NZ>,
    prev: Option<&SMatrix<f64, NZ, NZ>>,
    y_live: &[bool; NZ],
    inertia: &mut Inertia,
) -> Result<(), KktError> {
    let ft = &inv.ft.data.0;
    // P^ = F^T (P F): its pair has inertia (NX, NX).
    let mut pf = [[0.0; NX]; NX];
    mm_acc_bt(&mut pf, &p.data.0, ft);
    let mut phat = [[0.0; NX]; NX];
    mm_acc(&mut phat, ft, &pf, 1.0);
    sym_lower(&mut phat);
    inertia.positive += NX;
    inertia.negative += NX;
    // C^^T = F^T Y^T, in the columns where Y^T can be nonzero.
    let mut ct = [[0.0; NX]; NZ];
    for ((oc, yc), _) in ct
        .iter_mut()
        .zip(&yt.data.0)
        .zip(y_live)
        .filter(|(_, &l)| l)
    {
        let mut acc = [0.0; NX];
        for (fk, &y) in ft.iter().zip(yc) {
            for (o, &x) in acc.iter_mut().zip(fk) {
                *o += x * y;
            }
        }
        *oc = acc;
    }
    let y_states_zero = !y_live[..NX].contains(&true);
    let jc = &j.data.0;
    let g: [[f64; NX]; NU] = std::array::from_fn(|c| jc[NX + c]);
    // Q = W~ + [C^, -C^ G] + [C^, -C^ G]^T + [-I, G]^T P^ [-I, G], blockwise; S = P^ + C^_x.
    let mut pg = [[0.0; NX]; NU];
    mm_acc(&mut pg, &phat, &g, 1.0);
    let sg = if y_states_zero {
        pg
    } else {
        let mut s = phat;
        for (c, col) in s.iter_mut().enumerate() {
            for (r, v) in col.iter_mut().enumerate() {
                *v += ct[r][c];
            }
        }
        let mut sg = [[0.0; NX]; NU];
        mm_acc(&mut sg, &s, &g, 1.0);
        sg
    };
    let qc = &mut q.data.0;
    for c in 0..NX {
        for r in c..NX {
            qc[c][r] += phat[c][r] + (ct[c][r] + ct[r][c]);
        }
    }
    for c in 0..NU {
        for r in 0..NX {
            qc[NX + c][r] += ct[NX + c][r] - sg[c][r];
        }
        for r in c..NU {
            let gpg = dot(&g[r], &pg[c]);
            let cg = dot(&ct[NX + r], &g[c]) + dot(&ct[NX + c], &g[r]);
            qc[NX + c][NX + r] += gpg - cg;
        }
    }
    // u_k: Q_uu = L D L^T, g = Q_uu^-1 Q_ux, P_k = Q_xx - Q_xu g.
    let quu = SMatrix::<f64, NU, NU>::from_fn(|r, c| qc[NX + c.min(r)][NX + c.max(r)]);
    let (l, d, neg) = ldlt_factor(&quu)?;
    inertia.positive += NU - neg;
    inertia.negative += neg;
    let qxu: [[f64; NX]; NU] = std::array::from_fn(|k| std::array::from_fn(|r| qc[NX + k][r]));
    let mut gm = [[0.0; NU]; NX];
    for (c, gc) in gm.iter_mut().enumerate() {
        let mut v = SVector::<f64, NU>::from_fn(|k, _| qxu[k][c]);
        ldlt_solve_vec(&l, &d, &mut v);
        *gc = v.data.0[0];
    }
    // Written in place (no temporaries to copy: these blocks are the sweep's hot memory).
    let pc = &mut p.data.0;
    for (pcol, qcol) in pc.iter_mut().zip(qc.iter()) {
        pcol.copy_from_slice(&qcol[..NX]);
    }
    mm_acc(pc, &qxu, &gm, -1.0);
    sym_lower(pc);
    fac.zero_delta = true;
    fac.lambda_first = false;
    fac.a22.data.0 = phat.map(|col| col.map(|v| -v));
    fac.yt = *yt;
    fac.quu_l = l;
    fac.quu_d = d;
    fac.q_ux = SMatrix::from_fn(|k, c| qxu[k][c]);
    let Some(xc) = prev else {
        fac.r = SMatrix::zeros();
        return Ok(());
    };
    // R = X_{k-1}[u rows]^T, Y_{k-1}^T = X_{k-1}[x rows] - g^T R^T and
    // W_{k-1} -= R Q_uu^-1 R^T.
    let xcc = &xc.data.0;
    for (k, rcol) in fac.r.data.0.iter_mut().enumerate() {
        for (o, xcol) in rcol.iter_mut().zip(xcc.iter()) {
            *o = xcol[NX + k];
        }
    }
    let rc = &fac.r.data.0;
    // R^T as columns (row i of R per column), for g^T R^T and Q_uu^-1 R^T.
    let rtc: [[f64; NU]; NZ] = std::array::from_fn(|i| std::array::from_fn(|k| rc[k][i]));
    let gt: [[f64; NX]; NU] = std::array::from_fn(|k| std::array::from_fn(|j| gm[j][k]));
    let ytn = &mut yt.data.0;
    for (ycol, xcol) in ytn.iter_mut().zip(xcc.iter()) {
        ycol.copy_from_slice(&xcol[..NX]);
    }
    // Only the live columns of X_{k-1} (hence of R^T) can be nonzero: the products below
    // run over them alone. Elsewhere they would add exact zeros (+0 on a +0 start, so the
    // bits, signed zeros included, are those of the full products).
    let pd = &mut pending.data.0;
    for col in pd.iter_mut() {
        *col = [0.0; NZ];
    }
    for (i, _) in y_live.iter().enumerate().filter(|(_, &l)| l) {
        let mut acc = ytn[i];
        for (gk, &r) in gt.iter().zip(&rtc[i]) {
            let s = -r;
            for (o, &x) in acc.iter_mut().zip(gk) {
                *o += x * s;
            }
        }
        ytn[i] = acc;
        let mut v = SVector::<f64, NU>::from(rtc[i]);
        ldlt_solve_vec(&l, &d, &mut v);
        let rt = v.data.0[0];
        let mut col = [0.0; NZ];
        for (rk, &t) in rc.iter().zip(&rt) {
            for (o, &x) in col.iter_mut().zip(rk) {
                *o += x * t;
            }
        }
        pd[i] = col;
    }
    sym_lower(pd);
    Ok(())
}

/// An R x C column-major block of the arena, viewed in place as a matrix (no copy).
#[inline(always)]
fn block_ref<const R: usize, const C: usize>(s: &[f64]) -> &SMatrix<f64, R, C> {
    assert_eq!(s.len(), R * C);
    // SAFETY: `SMatrix<f64, R, C>` is `#[repr(C)]` over `ArrayStorage`, itself
    // `#[repr(transparent)]` over `[[f64; R]; C]` (plus zero-sized markers): R * C
    // contiguous f64 in column order with f64 alignment, which `s` provides.
    unsafe { &*(s.as_ptr() as *const SMatrix<f64, R, C>) }
}

/// a x for a small column-major matrix (C >= 1): column axpys in column order, inlined
/// into the caller's (baseline or AVX2) copy; nalgebra's generic gemv stayed out of line
/// and ran in the baseline instruction set.
#[inline(always)]
fn mv<const R: usize, const C: usize>(
    a: &SMatrix<f64, R, C>,
    x: &SVector<f64, C>,
) -> SVector<f64, R> {
    // The first column initializes (as nalgebra's gemv does: same bits, signed zeros too).
    let cols = &a.data.0;
    let mut out: [f64; R] = std::array::from_fn(|r| cols[0][r] * x[0]);
    for (col, &xc) in cols.iter().zip(x.as_slice()).skip(1) {
        for (o, &v) in out.iter_mut().zip(col) {
            *o += v * xc;
        }
    }
    SVector::from(out)
}

/// A x given A^T (`at`, C x R), for an A whose rows outside `live` are zero: those entries
/// of the result are +0 (the full product gives +-0 there), the others have [`mv`]'s bits
/// (each a serial sum in column order, read from a contiguous column of A^T).
#[inline(always)]
fn mv_rows_t<const R: usize, const C: usize>(
    at: &SMatrix<f64, C, R>,
    x: &SVector<f64, C>,
    live: &[bool; R],
) -> SVector<f64, R> {
    let cols = &at.data.0;
    let mut out = [0.0; R];
    for (r, o) in out.iter_mut().enumerate().filter(|(r, _)| live[*r]) {
        let row = &cols[r];
        let mut acc = row[0] * x[0];
        for (&a, &xc) in row.iter().zip(x.as_slice()).skip(1) {
            acc += a * xc;
        }
        *o = acc;
    }
    SVector::from(out)
}

/// A^T x given A^T (`at`, C x R) with [`mtv`]'s bits: each entry is [`nadot`] of a column
/// of A, gathered from a row of A^T.
#[inline(always)]
fn mtv_t<const R: usize, const C: usize>(
    at: &SMatrix<f64, C, R>,
    x: &SVector<f64, R>,
) -> SVector<f64, C> {
    let cols = &at.data.0;
    let mut out = [0.0; C];
    for (c, o) in out.iter_mut().enumerate() {
        let col: [f64; R] = std::array::from_fn(|i| cols[i][c]);
        *o = nadot(&col, &x.data.0[0]);
    }
    SVector::from(out)
}

/// J_k z for the stage's dynamics Jacobian; with J = [-I, G] it is -x + G u, which has the
/// bits of the full product [`mv`] (its zero terms only add +-0) up to the sign of a zero.
#[inline(always)]
fn j_mul<const NX: usize, const NZ: usize>(
    j: &SMatrix<f64, NX, NZ>,
    minus_identity: bool,
    z: &SVector<f64, NZ>,
) -> SVector<f64, NX> {
    if !minus_identity {
        return mv(j, z);
    }
    let cols = &j.data.0;
    let mut out: [f64; NX] = std::array::from_fn(|r| -z[r]);
    for (col, &u) in cols[NX..].iter().zip(&z.as_slice()[NX..]) {
        for (o, &g) in out.iter_mut().zip(col) {
            *o += g * u;
        }
    }
    SVector::from(out)
}

/// J_k^T lambda; with J = [-I, G] it is (-lambda, G^T lambda), the bits of [`mtv`] up to
/// the sign of a zero.
#[inline(always)]
fn jt_mul<const NX: usize, const NZ: usize>(
    j: &SMatrix<f64, NX, NZ>,
    minus_identity: bool,
    lambda: &SVector<f64, NX>,
) -> SVector<f64, NZ> {
    if !minus_identity {
        return mtv(j, lambda);
    }
    let cols = &j.data.0;
    let mut out = [0.0; NZ];
    for (o, &l) in out.iter_mut().zip(lambda.as_slice()) {
        *o = -l;
    }
    for (o, col) in out[NX..].iter_mut().zip(&cols[NX..]) {
        *o = nadot(col, &lambda.data.0[0]);
    }
    SVector::from(out)
}

/// a^T x for a small column-major matrix: one dot product per column ([`nadot`]).
#[inline(always)]
fn mtv<const R: usize, const C: usize>(
    a: &SMatrix<f64, R, C>,
    x: &SVector<f64, R>,
) -> SVector<f64, C> {
    let mut out = [0.0; C];
    for (o, col) in out.iter_mut().zip(&a.data.0) {
        *o = nadot(col, &x.data.0[0]);
    }
    SVector::from(out)
}

/// The dot product in nalgebra's summation order (0.35, `dotx`: closed forms for 2, 3 and 4
/// entries; otherwise eight lanes per block of eight, combined pairwise, then a serial tail),
/// so the inlined solves keep the bits of the nalgebra products they replace: the
/// iterates, and hence the iteration counts, are sensitive to the last bit.
#[inline(always)]
fn nadot<const D: usize>(a: &[f64; D], b: &[f64; D]) -> f64 {
    match D {
        2 => return a[0] * b[0] + a[1] * b[1],
        3 => return a[0] * b[0] + a[1] * b[1] + a[2] * b[2],
        4 => {
            let (x, y) = (a[0] * b[0] + a[2] * b[2], a[1] * b[1] + a[3] * b[3]);
            return x + y;
        }
        _ => {}
    }
    let mut res = 0.0;
    let mut i = 0;
    let mut acc = [0.0; 8];
    while D - i >= 8 {
        for (l, v) in acc.iter_mut().enumerate() {
            *v += a[i + l] * b[i + l];
        }
        i += 8;
    }
    res += acc[0] + acc[4];
    res += acc[1] + acc[5];
    res += acc[2] + acc[6];
    res += acc[3] + acc[7];
    for k in i..D {
        res += a[k] * b[k];
    }
    res
}

/// out += sign a b for column arrays (out R x C, a R x K, b K x C): each term is an axpy of a
/// contiguous column of a, accumulated in registers. `sign` is +-1, so exact.
#[inline(always)]
fn mm_acc<const R: usize, const K: usize, const C: usize>(
    out: &mut [[f64; R]; C],
    a: &[[f64; R]; K],
    b: &[[f64; K]; C],
    sign: f64,
) {
    for (oc, bc) in out.iter_mut().zip(b) {
        let mut acc = *oc;
        for (ak, &bkc) in a.iter().zip(bc) {
            let s = sign * bkc;
            for (o, &x) in acc.iter_mut().zip(ak) {
                *o += x * s;
            }
        }
        *oc = acc;
    }
}

/// out += a b given b^T (`bt`): [`mm_acc`] with sign 1 and its bits, b's entries read
/// (broadcast) from b^T's columns.
#[inline(always)]
fn mm_acc_bt<const R: usize, const K: usize, const C: usize>(
    out: &mut [[f64; R]; C],
    a: &[[f64; R]; K],
    bt: &[[f64; C]; K],
) {
    for (c, oc) in out.iter_mut().enumerate() {
        let mut acc = *oc;
        for (ak, btk) in a.iter().zip(bt) {
            let s = 1.0 * btk[c];
            for (o, &x) in acc.iter_mut().zip(ak) {
                *o += x * s;
            }
        }
        *oc = acc;
    }
}

/// Whether two slices of equal length hold the same bits (NaN never matches a number).
#[inline(always)]
fn same_bits(a: &[f64], b: &[f64]) -> bool {
    let mut diff = 0u64;
    for (x, y) in a.iter().zip(b) {
        diff |= x.to_bits() ^ y.to_bits();
    }
    diff == 0 && a.len() == b.len()
}

/// Largest magnitude; NaN when an entry is NaN or infinite (so such a block is rejected
/// by the callers' finiteness test). Four independent lanes, so the max chain does not
/// serialize on the latency of one register (it was 5 % of a factorization).
#[inline(always)]
fn amax(a: &[f64]) -> f64 {
    const L: usize = 4;
    let mut m = [0.0f64; L];
    // x * 0 is NaN exactly for NaN and +-inf.
    let mut bad = [0.0f64; L];
    let mut chunks = a.chunks_exact(L);
    for ch in &mut chunks {
        for l in 0..L {
            let x = ch[l].abs();
            m[l] = if x > m[l] { x } else { m[l] };
            bad[l] += ch[l] * 0.0;
        }
    }
    for &v in chunks.remainder() {
        let x = v.abs();
        m[0] = if x > m[0] { x } else { m[0] };
        bad[0] += v * 0.0;
    }
    let mx = m
        .iter()
        .fold(0.0f64, |acc, &x| if x > acc { x } else { acc });
    if bad.iter().sum::<f64>() == 0.0 {
        mx
    } else {
        f64::NAN
    }
}

/// Every entry is exactly zero.
#[inline(always)]
fn all_zero(a: &[f64]) -> bool {
    let mut z = true;
    for &v in a {
        z &= v == 0.0;
    }
    z
}

/// Copies the lower triangle of a column array into its upper one.
#[inline(always)]
fn sym_lower<const D: usize>(a: &mut [[f64; D]; D]) {
    for c in 0..D {
        for r in c + 1..D {
            a[r][c] = a[c][r];
        }
    }
}

#[inline(always)]
fn dot<const D: usize>(a: &[f64; D], b: &[f64; D]) -> f64 {
    let mut acc = 0.0;
    for (&x, &y) in a.iter().zip(b) {
        acc += x * y;
    }
    acc
}

/// Inverse of a small matrix ([`gauss_jordan`]); `None` when a pivot is below 1e-13 of the
/// largest entry (numerically singular) or the matrix is not finite.
#[inline(always)]
fn invert<const D: usize>(a: &SMatrix<f64, D, D>) -> Option<SMatrix<f64, D, D>> {
    let scale = amax(a.as_slice());
    if !scale.is_finite() {
        return None;
    }
    let mut rows: [[f64; D]; D] = std::array::from_fn(|r| std::array::from_fn(|c| a[(r, c)]));
    let mut inv: [[f64; D]; D] =
        std::array::from_fn(|r| std::array::from_fn(|c| f64::from(u8::from(r == c))));
    gauss_jordan(&mut rows, &mut inv, 1e-13 * scale)?;
    Some(SMatrix::from_fn(|r, c| inv[r][c]))
}

/// Inverse of E = [[A, 0], [B, I]] whose trailing columns are unit vectors, as
/// [[A^-1, 0], [-B A^-1, I]]: the implicit-Euler dynamics Jacobian E = I - ds df/dx has
/// them for s and t (no state depends on either), so only the leading k x k block is
/// inverted: embedded as diag(A, I) in a fixed 8 x 8 [`gauss_jordan`] (the identity rows
/// never pivot into A's, so A^-1 comes out with the same bits as from a k x k elimination).
/// Without unit columns, or with a leading block larger than 8, it is [`invert`]. Returns
/// the transpose F^T (see [`StageInverse::ft`]), written straight from the elimination's
/// rows.
#[inline(always)]
fn invert_unit_tail_t<const D: usize>(e: &SMatrix<f64, D, D>) -> Option<SMatrix<f64, D, D>> {
    const W: usize = 8;
    let mut k = D;
    while k > 1 && (0..D).all(|r| e[(r, k - 1)] == if r == k - 1 { 1.0 } else { 0.0 }) {
        k -= 1;
    }
    if k == D || k > W {
        return invert(e).map(|f| f.transpose());
    }
    let scale = amax(e.as_slice());
    if !scale.is_finite() {
        return None;
    }
    // The implicit-Euler case (k = 7: s and t are unit) eliminates its 7 rows alone; the
    // identity row of the 8 x 8 embedding only ever subtracted +0 from them (same bits).
    let tiny = 1e-13 * scale;
    Some(if k == 7 {
        unit_tail_inverse_t(e, &leading_inverse::<D, 7, W>(e, k, tiny)?)
    } else {
        unit_tail_inverse_t(e, &leading_inverse::<D, W, W>(e, k, tiny)?[..k])
    })
}

/// The transpose of [[A^-1, 0], [-B A^-1, I]] from the k rows of A^-1 (`ai`, padded rows)
/// and E's B: column r is row r of the inverse, each row of -B A^-1 a serial sum over j
/// (whole padded rows at a time; the padding columns are dropped).
#[inline(always)]
fn unit_tail_inverse_t<const D: usize, const W: usize>(
    e: &SMatrix<f64, D, D>,
    ai: &[[f64; W]],
) -> SMatrix<f64, D, D> {
    let k = ai.len();
    let mut out = SMatrix::<f64, D, D>::zeros();
    let cols = &mut out.data.0;
    for (col, row) in cols.iter_mut().zip(ai) {
        col[..k].copy_from_slice(&row[..k]);
    }
    for (r, col) in cols.iter_mut().enumerate().skip(k) {
        let mut acc = [0.0; W];
        for (j, row) in ai.iter().enumerate() {
            let s = e[(r, j)];
            for (a, &x) in acc.iter_mut().zip(row) {
                *a += s * x;
            }
        }
        for (o, &a) in col[..k].iter_mut().zip(&acc) {
            *o = -a;
        }
        col[r] = 1.0;
    }
    out
}

/// The first K (>= k) rows of diag(A, I)^-1 for E's leading k x k block A, each padded to
/// W entries (whole 4-wide vectors per row operation); `None` as [`gauss_jordan`].
#[inline(always)]
fn leading_inverse<const D: usize, const K: usize, const W: usize>(
    e: &SMatrix<f64, D, D>,
    k: usize,
    tiny: f64,
) -> Option<[[f64; W]; K]> {
    let mut a = [[0.0; W]; K];
    let mut ai = [[0.0; W]; K];
    for (r, (row, irow)) in a.iter_mut().zip(ai.iter_mut()).enumerate() {
        if r < k {
            for (c, v) in row.iter_mut().take(k).enumerate() {
                *v = e[(r, c)];
            }
        } else {
            row[r] = 1.0;
        }
        irow[r] = 1.0;
    }
    gauss_jordan(&mut a, &mut ai, tiny)?;
    Some(ai)
}

/// Gauss-Jordan elimination with partial pivoting on the K augmented rows [A | B]: the
/// leading K columns of `a` are the matrix (rows may be padded to WA entries, and B to WB,
/// so that row operations are whole 4-wide vectors); on success `b` holds A^-1 B. `None`
/// when a pivot is NaN or at most `tiny` in magnitude.
#[inline(always)]
fn gauss_jordan<const K: usize, const WA: usize, const WB: usize>(
    a: &mut [[f64; WA]; K],
    b: &mut [[f64; WB]; K],
    tiny: f64,
) -> Option<()> {
    for c in 0..K {
        let mut p = c;
        let mut best = a[c][c].abs();
        for (r, row) in a.iter().enumerate().skip(c + 1) {
            if row[c].abs() > best {
                best = row[c].abs();
                p = r;
            }
        }
        if best.is_nan() || best <= tiny {
            return None;
        }
        a.swap(p, c);
        b.swap(p, c);
        let piv = 1.0 / a[c][c];
        let (ac, bc) = (a[c].map(|v| v * piv), b[c].map(|v| v * piv));
        a[c] = ac;
        b[c] = bc;
        for (r, (ra, rb)) in a.iter_mut().zip(b.iter_mut()).enumerate() {
            if r != c {
                let f = ra[c];
                for (v, &x) in ra.iter_mut().zip(&ac) {
                    *v -= f * x;
                }
                for (v, &x) in rb.iter_mut().zip(&bc) {
                    *v -= f * x;
                }
            }
        }
    }
    Some(())
}

/// a b for small column-major matrices, as axpys over contiguous columns (zeros of b
/// skipped).
#[inline(always)]
fn mul_nn<const R: usize, const K: usize, const C: usize>(
    a: &SMatrix<f64, R, K>,
    b: &SMatrix<f64, K, C>,
) -> SMatrix<f64, R, C> {
    let mut out = SMatrix::<f64, R, C>::zeros();
    for c in 0..C {
        for k in 0..K {
            let bkc = b[(k, c)];
            if bkc != 0.0 {
                for r in 0..R {
                    out[(r, c)] += a[(r, k)] * bkc;
                }
            }
        }
    }
    out
}

/// a^T b for small column-major matrices, as dots of contiguous columns.
#[inline(always)]
fn mul_tn<const R: usize, const K: usize, const C: usize>(
    a: &SMatrix<f64, K, R>,
    b: &SMatrix<f64, K, C>,
) -> SMatrix<f64, R, C> {
    let mut out = SMatrix::<f64, R, C>::zeros();
    for c in 0..C {
        for r in 0..R {
            let mut acc = 0.0;
            for k in 0..K {
                acc += a[(k, r)] * b[(k, c)];
            }
            out[(r, c)] = acc;
        }
    }
    out
}

/// Copies the lower triangle's average into both triangles.
#[inline(always)]
fn symmetrize<const D: usize>(a: &mut SMatrix<f64, D, D>) {
    for c in 0..D {
        for r in c + 1..D {
            let v = 0.5 * (a[(r, c)] + a[(c, r)]);
            a[(r, c)] = v;
            a[(c, r)] = v;
        }
    }
}

/// LDL^T of a symmetric matrix without pivoting: returns (unit lower L, D, number of
/// negative pivots). A zero or non-finite pivot is a singular matrix.
#[inline(always)]
fn ldlt_factor<const D: usize>(
    a: &SMatrix<f64, D, D>,
) -> Result<(SMatrix<f64, D, D>, SVector<f64, D>, usize), KktError> {
    let mut l = SMatrix::<f64, D, D>::identity();
    let mut d = SVector::<f64, D>::zeros();
    let mut neg = 0;
    for j in 0..D {
        let mut dj = a[(j, j)];
        for k in 0..j {
            dj -= l[(j, k)] * l[(j, k)] * d[k];
        }
        if !dj.is_finite() || dj == 0.0 {
            return Err(KktError::Singular);
        }
        if dj < 0.0 {
            neg += 1;
        }
        d[j] = dj;
        for i in j + 1..D {
            let mut v = a[(i, j)];
            for k in 0..j {
                v -= l[(i, k)] * l[(j, k)] * d[k];
            }
            l[(i, j)] = v / dj;
        }
    }
    Ok((l, d, neg))
}

/// Solves (L D L^T) x = b in place for a vector.
#[inline(always)]
fn ldlt_solve_vec<const D: usize>(
    l: &SMatrix<f64, D, D>,
    d: &SVector<f64, D>,
    b: &mut SVector<f64, D>,
) {
    for i in 0..D {
        for k in 0..i {
            b[i] -= l[(i, k)] * b[k];
        }
    }
    for i in 0..D {
        b[i] /= d[i];
    }
    for i in (0..D).rev() {
        for k in i + 1..D {
            b[i] -= l[(k, i)] * b[k];
        }
    }
}

/// Solves (L D L^T) X = B in place, column by column.
#[inline(always)]
fn ldlt_solve_cols<const D: usize, const C: usize>(
    l: &SMatrix<f64, D, D>,
    d: &SVector<f64, D>,
    b: &mut SMatrix<f64, D, C>,
) {
    for c in 0..C {
        let mut col: SVector<f64, D> = b.column(c).into_owned();
        ldlt_solve_vec(l, d, &mut col);
        b.set_column(c, &col);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic E = [[A, 0], [B, I]] (9 x 9, unit s and t columns) whose A needs
    /// row pivoting (zero leading diagonal entry) and is far from diagonal dominance.
    fn unit_tail_e() -> SMatrix<f64, 9, 9> {
        let mut e = SMatrix::<f64, 9, 9>::zeros();
        for c in 0..7 {
            for r in 0..9 {
                let v = ((r * 7 + c * 3) % 11) as f64 - 5.0;
                e[(r, c)] = v * 0.3 + if r == c { 2.0 } else { 0.0 };
            }
        }
        e[(0, 0)] = 0.0;
        e[(7, 7)] = 1.0;
        e[(8, 8)] = 1.0;
        e
    }

    /// Pseudo-random matrix with entries of mixed sign and magnitude (and some zeros).
    fn scrambled<const R: usize, const C: usize>(seed: u64) -> SMatrix<f64, R, C> {
        let mut state = seed;
        SMatrix::from_fn(|_, _| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = (state >> 11) as f64 / (1u64 << 53) as f64;
            if u < 0.1 {
                0.0
            } else {
                (u - 0.55) * 10f64.powi((state % 7) as i32 - 3)
            }
        })
    }

    fn same<const R: usize, const C: usize>(
        a: &SMatrix<f64, R, C>,
        b: &SMatrix<f64, R, C>,
    ) -> bool {
        a.iter()
            .zip(b.iter())
            .all(|(x, y)| x.to_bits() == y.to_bits())
    }

    /// The inlined products keep nalgebra's bits for every block shape the solves use.
    #[test]
    fn inlined_products_have_nalgebras_bits() {
        fn check<const R: usize, const C: usize>(seed: u64) {
            let a: SMatrix<f64, R, C> = scrambled(seed);
            let x: SVector<f64, C> = scrambled(seed + 1);
            let xt: SVector<f64, R> = scrambled(seed + 2);
            assert!(same(&mv(&a, &x), &(a * x)), "a x, {R} x {C}");
            assert!(same(&mtv(&a, &xt), &a.tr_mul(&xt)), "a^T x, {R} x {C}");
        }
        for seed in [1, 7, 42] {
            check::<9, 9>(seed);
            check::<12, 9>(seed);
            check::<9, 12>(seed);
            check::<3, 9>(seed);
            check::<12, 3>(seed);
            check::<2, 5>(seed);
            check::<4, 4>(seed);
            check::<17, 1>(seed);
        }
    }

    /// The structured products of the solves (J = [-I, G], rows of Y known to be zero)
    /// give the full products' bits, up to the sign of a zero.
    #[test]
    fn structured_products_have_the_full_products_bits() {
        fn same_value<const R: usize, const C: usize>(
            a: &SMatrix<f64, R, C>,
            b: &SMatrix<f64, R, C>,
        ) -> bool {
            a.iter()
                .zip(b.iter())
                .all(|(x, y)| x.to_bits() == y.to_bits() || (*x == 0.0 && *y == 0.0))
        }
        for seed in [3, 11, 99] {
            let mut j: SMatrix<f64, 9, 12> = scrambled(seed);
            for c in 0..9 {
                for r in 0..9 {
                    j[(r, c)] = if r == c { -1.0 } else { 0.0 };
                }
            }
            let mut minus_identity = minus_identity_head(&j);
            assert!(minus_identity);
            let z: SVector<f64, 12> = scrambled(seed + 1);
            let lambda: SVector<f64, 9> = scrambled(seed + 2);
            assert!(same_value(&j_mul(&j, minus_identity, &z), &(j * z)));
            assert!(same_value(
                &jt_mul(&j, minus_identity, &lambda),
                &j.tr_mul(&lambda)
            ));
            // Anything else goes through the general products.
            j[(4, 4)] = -0.5;
            minus_identity = minus_identity_head(&j);
            assert!(!minus_identity);
            assert!(same(&j_mul(&j, minus_identity, &z), &(j * z)));
            assert!(same(
                &jt_mul(&j, minus_identity, &lambda),
                &j.tr_mul(&lambda)
            ));

            let live = [
                false, true, false, false, false, false, false, true, false, true, true, true,
            ];
            let mut y: SMatrix<f64, 12, 9> = scrambled(seed + 3);
            for (r, &l) in live.iter().enumerate() {
                if !l {
                    y.row_mut(r).fill(0.0);
                }
            }
            let x: SVector<f64, 9> = scrambled(seed + 4);
            let w: SVector<f64, 12> = scrambled(seed + 5);
            let yt = y.transpose();
            assert!(same_value(&mv_rows_t(&yt, &x, &live), &(y * x)));
            assert!(same(&mtv_t(&yt, &w), &y.tr_mul(&w)));
        }
    }

    /// Eliminating only A's 7 rows gives the bits of the 8 x 8 diag(A, I) elimination.
    #[test]
    fn seven_row_elimination_has_the_embeddings_bits() {
        let mut cases = vec![unit_tail_e()];
        for seed in [5, 17, 23] {
            let mut e: SMatrix<f64, 9, 9> = scrambled(seed);
            for c in 7..9 {
                for r in 0..9 {
                    e[(r, c)] = if r == c { 1.0 } else { 0.0 };
                }
            }
            cases.push(e);
        }
        for e in cases {
            let seven = leading_inverse::<9, 7, 8>(&e, 7, 0.0).expect("nonsingular");
            let eight = leading_inverse::<9, 8, 8>(&e, 7, 0.0).expect("nonsingular");
            for (a, b) in seven.iter().zip(&eight[..7]) {
                assert!(same_bits(a, b), "{a:?} vs {b:?}");
            }
        }
    }

    /// F from [`invert_unit_tail_t`].
    fn invert_unit_tail<const D: usize>(e: &SMatrix<f64, D, D>) -> Option<SMatrix<f64, D, D>> {
        invert_unit_tail_t(e).map(|ft| ft.transpose())
    }

    #[test]
    fn unit_tail_inverse_matches_general_inverse() {
        let e = unit_tail_e();
        let f = invert_unit_tail(&e).expect("nonsingular");
        let g = invert(&e).expect("nonsingular");
        let id = e * f;
        for r in 0..9 {
            for c in 0..9 {
                let want = if r == c { 1.0 } else { 0.0 };
                assert!(
                    (id[(r, c)] - want).abs() < 1e-12,
                    "E F at ({r}, {c}): {}",
                    id[(r, c)]
                );
                assert!((f[(r, c)] - g[(r, c)]).abs() < 1e-12 * g.amax());
            }
        }
    }

    #[test]
    fn unit_tail_inverse_rejects_singular_and_non_finite() {
        let mut e = unit_tail_e();
        // Row 1 of A := row 2 of A (columns 0..7): singular leading block.
        for c in 0..7 {
            e[(1, c)] = e[(2, c)];
        }
        assert!(invert_unit_tail(&e).is_none());
        let mut e = unit_tail_e();
        e[(3, 4)] = f64::NAN;
        assert!(invert_unit_tail(&e).is_none());
    }

    #[test]
    fn without_unit_tail_the_general_inverse_is_used() {
        let mut e = unit_tail_e();
        e[(2, 8)] = 0.5;
        let f = invert_unit_tail(&e).expect("nonsingular");
        let id = e * f;
        for r in 0..9 {
            for c in 0..9 {
                let want = if r == c { 1.0 } else { 0.0 };
                assert!((id[(r, c)] - want).abs() < 1e-12);
            }
        }
    }
}
