//! Structure-exploiting KKT backend: a Riccati-type block elimination over the stages of an
//! optimal-control NLP, with fixed-size (nalgebra) blocks. Allocation-free after setup; the
//! inertia comes from the stage factorizations, so inertia correction stays cheap.
//!
//! # The stage-wise block elimination
//!
//! With z_k = (x_k, u_k) (NZ = NX + NU entries; z_N = x_N), multipliers lambda_k of the
//! dynamics rows `J_k z_k + E_k x_{k+1}` of interval k, and the initial rows on x_0, the
//! condensed KKT matrix is block-banded in stage order, and it is factorized by eliminating
//! its blocks from the last stage to the first:
//!
//! 1. **Path rows** (inequalities, dual diagonal D_c < 0) are eliminated into the primal
//!    block: W = H + D_x + sum_r J_r^T J_r / |D_c,r|. Each adds one negative eigenvalue.
//! 2. **Backward sweep** k = N-1 .. 0 over what remains:
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
//!
//! A solve runs the same elimination on a right-hand side: the path rows gathered in, a
//! forward substitution over the stages in elimination order, the initial block, and a
//! backward substitution.
//!
//! # Modules
//!
//! - `setup`: structure checks and the value maps into the block arena (allocates, once).
//! - `assemble`: the stage blocks with the path rows condensed in (step 1), unit by unit.
//! - `stage`, `fast_stage`: one stage of the sweep, in general form and in its common case
//!   (Delta = 0, J = [-I, G]) over column arrays.
//! - `sweep`: the backward sweep and the initial block, with the inertia (steps 2 and 3).
//! - `pipeline`: steps 1 and 2 on one thread, or with a helper thread writing the units
//!   ahead of the sweep ([`RiccatiKkt::set_pipelined`]).
//! - `solve`: the forward and backward substitutions.
//! - `kernels`, `inverse`: the small dense kernels and E_k^-1.
//!
//! Factorizations and solves run in one of two copies of the same code, the baseline one or
//! one compiled with AVX2 enabled ([`RiccatiKkt::set_simd`]); both give the same bits.

mod assemble;
mod fast_stage;
mod inverse;
mod kernels;
mod pipeline;
mod setup;
mod solve;
mod stage;
mod sweep;

use super::claims::Claims;
use super::{Inertia, KktError, KktSolver, KktValues};
use crate::worker::{self, SharedWorker};
use faer::diag::Diag;
use faer::dyn_stack::MemBuffer;
use faer::Mat;
use nalgebra::SVector;
use setup::{PathEntry, PathRow, Row, Unit, UnitPair};
use stage::{StageFactor, StageInverse};

/// No target in the block arena.
const NONE: u32 = u32::MAX;

/// Row and column of a Jacobian entry this backend ignores: the values array keeps its
/// slot (so a caller that split part of the system off passes its values unchanged).
pub const SKIP_ENTRY: usize = usize::MAX;

/// Why a [`StageStructure`](super::StageStructure) does not fit this backend.
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
    /// C^^T = F^T Y^T only there (`fast_stage`). On the vehicle OCP: t and the controls.
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
    /// The assembly by units (see `Unit`): index k < N for stage k, index N (swept first)
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
    /// Factorize and solve in code compiled for AVX2 (set from
    /// [`crate::cpu::avx2_available`]).
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

    /// The factorization in the AVX2 or the baseline copy (see [`Self::set_simd`]);
    /// `stop_on_excess` as in [`sweep::check_excess`].
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
