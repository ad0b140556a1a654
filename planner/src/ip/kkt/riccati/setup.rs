//! Setup: checks that an NLP's sparsity fits the stage elimination and builds the maps from
//! its value arrays to the blocks.
//!
//! With z_k = (x_k, u_k), a Hessian entry may couple z_k to itself (block W_k) or to
//! z_{k-1} (block X_{k-1}); a dynamics row of interval k touches z_k (J_k) and x_{k+1}
//! (E_k); an initial row touches x_0 only (E_N); a path row may touch two neighbouring
//! stages. Anything else is a [`StructureError`]. Everything here allocates, once; the
//! factorizations and solves then only follow the maps.

use super::stage::{StageFactor, StageInverse};
use super::{RiccatiKkt, StructureError, NONE, SKIP_ENTRY};
use crate::ip::kkt::claims::Claims;
use crate::ip::kkt::structure::{RowRole, StageStructure};
use faer::diag::Diag;
use faer::dyn_stack::MemBuffer;
use faer::linalg::cholesky::lblt;
use faer::{Mat, Par};
use nalgebra::SVector;

/// What a constraint row is to this backend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Row {
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
pub(super) struct PathRow {
    pub(super) start: usize,
    pub(super) end: usize,
    pub(super) pairs_start: usize,
    pub(super) pairs_end: usize,
}

/// One term of J_r^T J_r: entries `a` and `b` of the row (local indices) add their
/// product to arena index `target` (lower triangle of W, or X).
#[derive(Debug, Clone, Copy)]
pub(super) struct PathPair {
    pub(super) a: u16,
    pub(super) b: u16,
    pub(super) target: u32,
}

/// One Jacobian entry of a path row: value index, stage, position in the stage.
#[derive(Debug, Clone, Copy)]
pub(super) struct PathEntry {
    pub(super) jac: usize,
    pub(super) stage: u32,
    pub(super) local: u16,
}

/// One assembly unit: the arena blocks the sweep reads at one of its stages, so the sweep can
/// run as soon as its unit is written (unit k < N: W_k, E_k, J_k and X_{k-1}; unit N: W_N and
/// X_{N-1}; E_N, the initial rows, rides with unit 0, read last). Ranges into the `u_*` op
/// lists, whose ops are in the order of an assembly of the whole arena at once: every entry
/// sums its terms in the same order, so the bits do not depend on how the units are
/// scheduled.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Unit {
    pub(super) zero: (u32, u32),
    pub(super) jac: (u32, u32),
    pub(super) hess: (u32, u32),
    pub(super) diag: (u32, u32),
    pub(super) pairs: (u32, u32),
}

/// One term of a path row's J_r^T J_r / |D_c| by path-entry indices: adds
/// `path_wv[a] * path_vals[b]`, i.e. (w_r J_ra) J_rb, to arena entry `target`.
#[derive(Debug, Clone, Copy)]
pub(super) struct UnitPair {
    pub(super) a: u32,
    pub(super) b: u32,
    pub(super) target: u32,
}

/// Where the blocks sit in the arena (each column-major): W_k (k = 0..=N; W_N uses the
/// NX x NX corner), X_k (k < N; rows z_{k+1}, columns z_k), E_k (k = 0..=N; index N: the
/// initial rows), J_k (k < N).
#[derive(Debug, Clone, Copy)]
struct Layout<const NX: usize, const NZ: usize> {
    /// Number of intervals N.
    big: usize,
    x_base: usize,
    e_base: usize,
    j_base: usize,
    /// Arena length.
    len: usize,
}

impl<const NX: usize, const NZ: usize> Layout<NX, NZ> {
    fn new(big: usize) -> Self {
        let x_base = (big + 1) * NZ * NZ;
        let e_base = x_base + big * NZ * NZ;
        let j_base = e_base + (big + 1) * NX * NX;
        let len = j_base + big * NX * NZ;
        Self {
            big,
            x_base,
            e_base,
            j_base,
            len,
        }
    }

    /// Entry (r, c) of W_s.
    fn w_at(&self, s: usize, r: usize, c: usize) -> u32 {
        (s * NZ * NZ + c * NZ + r) as u32
    }

    /// Entry (r, c) of X_s.
    fn x_at(&self, s: usize, r: usize, c: usize) -> u32 {
        (self.x_base + s * NZ * NZ + c * NZ + r) as u32
    }

    /// Entry (r, c) of E_s.
    fn e_at(&self, s: usize, r: usize, c: usize) -> u32 {
        (self.e_base + s * NX * NX + c * NX + r) as u32
    }

    /// Entry (r, c) of J_s.
    fn j_at(&self, s: usize, r: usize, c: usize) -> u32 {
        (self.j_base + s * NX * NZ + c * NX + r) as u32
    }

    /// The unit that writes arena entry `t` (see [`Unit`]).
    fn unit_of(&self, t: u32) -> usize {
        let t = t as usize;
        if t < self.x_base {
            t / (NZ * NZ)
        } else if t < self.e_base {
            (t - self.x_base) / (NZ * NZ) + 1
        } else if t < self.j_base {
            let s = (t - self.e_base) / (NX * NX);
            if s < self.big {
                s
            } else {
                0
            }
        } else {
            (t - self.j_base) / (NX * NZ)
        }
    }

    /// For an entry of an X block, its column: the entry of z_{k-1} it couples.
    fn x_col(&self, t: u32) -> Option<usize> {
        let t = t as usize;
        (self.x_base..self.e_base)
            .contains(&t)
            .then(|| ((t - self.x_base) % (NZ * NZ)) / NZ)
    }
}

/// The path rows' entries and the terms of their outer products J_r^T J_r.
struct PathTerms {
    rows: Vec<PathRow>,
    entries: Vec<PathEntry>,
    pairs: Vec<PathPair>,
}

/// The assembly's op lists by unit (see [`Unit`]).
struct UnitOps {
    units: Vec<Unit>,
    zero: Vec<(u32, u32)>,
    jac: Vec<(u32, u32)>,
    hess: Vec<(u32, u32)>,
    diag: Vec<(u32, u32)>,
    pairs: Vec<UnitPair>,
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
        check_sizes::<NX, NU, NZ>(st, n)?;
        let big = st.n_stages;
        let lay = Layout::<NX, NZ>::new(big);
        if big == 0 || lay.len >= NONE as usize {
            return Err(StructureError::Size(format!("{big} stages")));
        }
        let m = st.rows.len();
        let (rows, n_path) = classify_rows::<NX>(st)?;
        let (jac_map, per_path) = map_jacobian(st, &rows, n, n_path, jac_rows, jac_cols, &lay)?;
        let jac_assign = distinct_targets(&jac_map);
        let paths = path_terms(&per_path, &lay)?;
        let (gather_targets, gather_terms) = gather_order(&paths);
        let hess_map = map_hessian(st, n, hess_rows, hess_cols, &lay)?;
        // Entries the Hessian does not write but the diagonal or the path rows add to.
        let mut hess_targets = hess_map.clone();
        hess_targets.sort_unstable();
        hess_targets.dedup();
        let hess_assign = jac_assign && hess_targets.len() == hess_map.len();
        let zero_targets = unwritten_targets(n, &hess_targets, &paths.pairs, &lay);
        let y_live = live_columns::<NX, NZ>(&hess_map, &paths.pairs, &lay);
        let ops = unit_ops(
            n,
            &lay,
            jac_assign,
            hess_assign,
            &zero_targets,
            &jac_map,
            &hess_map,
            &paths,
        );
        let dim = 2 * NX;
        let params = Default::default();
        let mem = MemBuffer::new(
            lblt::factor::cholesky_in_place_scratch::<usize, f64>(dim, Par::Seq, params).or(
                lblt::solve::solve_in_place_scratch::<usize, f64>(dim, 1, Par::Seq),
            ),
        );
        let PathTerms {
            rows: path_rows,
            entries: path_entries,
            ..
        } = paths;
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
            units: ops.units,
            u_zero: ops.zero,
            u_jac: ops.jac,
            u_hess: ops.hess,
            u_diag: ops.diag,
            u_pairs: ops.pairs,
            inverses: vec![StageInverse::default(); big],
            worker: None,
            claims: Claims::new(big + 1),
            helper_idle: false,
            arena: vec![0.0; lay.len],
            x_base: lay.x_base,
            e_base: lay.e_base,
            j_base: lay.j_base,
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
}

/// The compiled-in block sizes against the stage structure and the NLP's size.
fn check_sizes<const NX: usize, const NU: usize, const NZ: usize>(
    st: &StageStructure,
    n: usize,
) -> Result<(), StructureError> {
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
    Ok(())
}

/// Each row's role with its index among its kind; checks one initial row per state and
/// one dynamics row per state and interval. Returns the rows and the number of path rows.
fn classify_rows<const NX: usize>(st: &StageStructure) -> Result<(Vec<Row>, u32), StructureError> {
    let big = st.n_stages;
    let mut rows = Vec::with_capacity(st.rows.len());
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
    Ok((rows, n_path))
}

/// The arena target of every Jacobian entry ([`NONE`] for path rows and skipped entries),
/// and each path row's entries.
#[allow(clippy::type_complexity)]
fn map_jacobian<const NX: usize, const NZ: usize>(
    st: &StageStructure,
    rows: &[Row],
    n: usize,
    n_path: u32,
    jac_rows: &[usize],
    jac_cols: &[usize],
    lay: &Layout<NX, NZ>,
) -> Result<(Vec<u32>, Vec<Vec<PathEntry>>), StructureError> {
    let m = rows.len();
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
                    lay.j_at(k, i, l)
                } else if s == k + 1 && l < NX {
                    lay.e_at(k, i, l)
                } else {
                    return Err(bad);
                }
            }
            Row::Initial(i) => {
                if s != 0 || l >= NX {
                    return Err(bad);
                }
                lay.e_at(lay.big, i as usize, l)
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
    Ok((jac_map, per_path))
}

/// Whether the Jacobian entries (other than [`NONE`]) have distinct targets: then they are
/// assigned, not summed, and the E, J regions need no zeroing.
fn distinct_targets(jac_map: &[u32]) -> bool {
    let mut targets: Vec<u32> = jac_map.iter().copied().filter(|&t| t != NONE).collect();
    let n_targets = targets.len();
    targets.sort_unstable();
    targets.dedup();
    targets.len() == n_targets
}

/// The path rows' entries, in row order, and the terms of their outer products; checks
/// that each row touches at most two neighbouring stages.
fn path_terms<const NX: usize, const NZ: usize>(
    per_path: &[Vec<PathEntry>],
    lay: &Layout<NX, NZ>,
) -> Result<PathTerms, StructureError> {
    let mut path_rows = Vec::with_capacity(per_path.len());
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
        push_row_pairs(ents, lay, &mut path_pairs);
        path_rows.push(PathRow {
            start,
            end: path_entries.len(),
            pairs_start,
            pairs_end: path_pairs.len(),
        });
    }
    Ok(PathTerms {
        rows: path_rows,
        entries: path_entries,
        pairs: path_pairs,
    })
}

/// The terms of one path row's J_r^T J_r that land in a lower triangle of W or in X.
fn push_row_pairs<const NX: usize, const NZ: usize>(
    ents: &[PathEntry],
    lay: &Layout<NX, NZ>,
    path_pairs: &mut Vec<PathPair>,
) {
    for (ia, a) in ents.iter().enumerate() {
        for (ib, b) in ents.iter().enumerate() {
            let (sa, la, sb, lb) = (
                a.stage as usize,
                a.local as usize,
                b.stage as usize,
                b.local as usize,
            );
            let target = if sa == sb && la >= lb {
                lay.w_at(sa, la, lb)
            } else if sb == sa + 1 {
                lay.x_at(sa, lb, la)
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
}

/// The solves' gather by target (path rows in row order, entries in row order): per target
/// entry of the right-hand side (stage, position, end of its terms), and its terms (path
/// entry, path row).
#[allow(clippy::type_complexity)]
fn gather_order(paths: &PathTerms) -> (Vec<(u32, u16, u32)>, Vec<(u32, u32)>) {
    let mut terms: Vec<(u32, u16, u32, u32)> = Vec::with_capacity(paths.entries.len());
    for (p, pr) in paths.rows.iter().enumerate() {
        for (e, ent) in paths.entries.iter().enumerate().take(pr.end).skip(pr.start) {
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
}

/// The arena target of every Hessian entry (lower triangle, row >= col).
fn map_hessian<const NX: usize, const NZ: usize>(
    st: &StageStructure,
    n: usize,
    hess_rows: &[usize],
    hess_cols: &[usize],
    lay: &Layout<NX, NZ>,
) -> Result<Vec<u32>, StructureError> {
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
            lay.w_at(sa, la.max(lb), la.min(lb))
        } else if sa == sb + 1 {
            lay.x_at(sb, la, lb)
        } else {
            return Err(StructureError::Coupling {
                what: "Hessian",
                row: r,
                col: c,
            });
        });
    }
    Ok(hess_map)
}

/// The W, X entries that no Hessian value writes (`hess_targets`, sorted) but the primal
/// diagonal or a path row adds to, sorted: what an assigning assembly zeroes.
fn unwritten_targets<const NX: usize, const NZ: usize>(
    n: usize,
    hess_targets: &[u32],
    path_pairs: &[PathPair],
    lay: &Layout<NX, NZ>,
) -> Vec<u32> {
    let mut zero_targets: Vec<u32> = (0..n)
        .map(|i| lay.w_at(i / NZ, i % NZ, i % NZ))
        .chain(path_pairs.iter().map(|pp| pp.target))
        .filter(|t| hess_targets.binary_search(t).is_err())
        .collect();
    zero_targets.sort_unstable();
    zero_targets.dedup();
    zero_targets
}

/// The columns of the X blocks (entries of z_{k-1}) that some Hessian or path-row entry
/// couples to z_k.
fn live_columns<const NX: usize, const NZ: usize>(
    hess_map: &[u32],
    path_pairs: &[PathPair],
    lay: &Layout<NX, NZ>,
) -> [bool; NZ] {
    let mut y_live = [false; NZ];
    for &t in hess_map
        .iter()
        .chain(path_pairs.iter().map(|pp| &pp.target))
    {
        if let Some(c) = lay.x_col(t) {
            y_live[c] = true;
        }
    }
    y_live
}

/// The zeroing ops per unit: the entries in `zero_targets` when the Hessian is assigned,
/// else whole W and X blocks (and E, J when the Jacobian is summed too).
fn zero_ops<const NX: usize, const NZ: usize>(
    lay: &Layout<NX, NZ>,
    jac_assign: bool,
    hess_assign: bool,
    zero_targets: &[u32],
) -> Vec<Vec<(u32, u32)>> {
    let big = lay.big;
    let mut zero_u: Vec<Vec<(u32, u32)>> = vec![Vec::new(); big + 1];
    if hess_assign {
        for &t in zero_targets {
            zero_u[lay.unit_of(t)].push((t, 1));
        }
    } else {
        let mut blocks: Vec<(usize, usize)> = (0..=big).map(|s| (s * NZ * NZ, NZ * NZ)).collect();
        blocks.extend((0..big).map(|s| (lay.x_base + s * NZ * NZ, NZ * NZ)));
        if !jac_assign {
            blocks.extend((0..=big).map(|s| (lay.e_base + s * NX * NX, NX * NX)));
            blocks.extend((0..big).map(|s| (lay.j_base + s * NX * NZ, NX * NZ)));
        }
        for (start, len) in blocks {
            zero_u[lay.unit_of(start as u32)].push((start as u32, len as u32));
        }
    }
    zero_u
}

/// The assembly's ops grouped by unit, each unit's ops contiguous and in the order of the
/// whole-arena assembly (zeroes, Jacobian, Hessian, primal diagonal, path pairs).
#[allow(clippy::too_many_arguments)]
fn unit_ops<const NX: usize, const NZ: usize>(
    n: usize,
    lay: &Layout<NX, NZ>,
    jac_assign: bool,
    hess_assign: bool,
    zero_targets: &[u32],
    jac_map: &[u32],
    hess_map: &[u32],
    paths: &PathTerms,
) -> UnitOps {
    let big = lay.big;
    let zero_u = zero_ops(lay, jac_assign, hess_assign, zero_targets);
    let mut jac_u: Vec<Vec<(u32, u32)>> = vec![Vec::new(); big + 1];
    for (q, &t) in jac_map.iter().enumerate() {
        if t != NONE {
            jac_u[lay.unit_of(t)].push((q as u32, t));
        }
    }
    let mut hess_u: Vec<Vec<(u32, u32)>> = vec![Vec::new(); big + 1];
    for (q, &t) in hess_map.iter().enumerate() {
        hess_u[lay.unit_of(t)].push((q as u32, t));
    }
    let mut diag_u: Vec<Vec<(u32, u32)>> = vec![Vec::new(); big + 1];
    for i in 0..n {
        let t = lay.w_at(i / NZ, i % NZ, i % NZ);
        diag_u[lay.unit_of(t)].push((i as u32, t));
    }
    let mut pairs_u: Vec<Vec<UnitPair>> = vec![Vec::new(); big + 1];
    for pr in &paths.rows {
        for pp in &paths.pairs[pr.pairs_start..pr.pairs_end] {
            pairs_u[lay.unit_of(pp.target)].push(UnitPair {
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
    let (mut zero, mut jac, mut hess, mut diag, mut pairs) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let units = (0..=big)
        .map(|k| Unit {
            zero: flatten(&zero_u, &mut zero, k),
            jac: flatten(&jac_u, &mut jac, k),
            hess: flatten(&hess_u, &mut hess, k),
            diag: flatten(&diag_u, &mut diag, k),
            pairs: flatten(&pairs_u, &mut pairs, k),
        })
        .collect();
    UnitOps {
        units,
        zero,
        jac,
        hess,
        diag,
        pairs,
    }
}
