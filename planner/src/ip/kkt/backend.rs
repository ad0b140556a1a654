//! Backend selection: the Riccati backend where the NLP's stage structure allows it, with
//! the general sparse LDL^T as fallback for other structures and for the rare values the
//! Riccati sweep cannot take (a singular dynamics Jacobian).

use super::chain::{ChainSplit, Reduced};
use super::riccati::{RiccatiKkt, StructureError};
use super::sparse_ldlt::{SparseLdlt, SymbolicError};
use super::structure::StageStructure;
use super::{Inertia, KktError, KktSolver, KktValues};
use serde::{Deserialize, Serialize};

/// Which KKT backend the solver uses (`kkt` in `config/solver.toml`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum KktBackendKind {
    /// Riccati when the NLP publishes a stage structure it fits, else sparse.
    Auto,
    /// Always the general sparse LDL^T (faer) (default).
    #[default]
    Sparse,
    /// The Riccati backend; setup fails if the structure does not fit.
    Riccati,
}

impl KktBackendKind {
    /// Name used in configs and reports.
    pub fn name(self) -> &'static str {
        match self {
            KktBackendKind::Auto => "auto",
            KktBackendKind::Sparse => "sparse",
            KktBackendKind::Riccati => "riccati",
        }
    }

    /// Parses `auto`, `sparse` or `riccati`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "auto" => Some(KktBackendKind::Auto),
            "sparse" => Some(KktBackendKind::Sparse),
            "riccati" => Some(KktBackendKind::Riccati),
            _ => None,
        }
    }
}

/// The Riccati backend for the vehicle OCP's block sizes (9 states, 3 controls).
pub type VehicleRiccati = RiccatiKkt<9, 3, 12>;

/// The vehicle OCP's Riccati backend with its arc-length state split off
/// ([`super::chain`]): 8-state blocks.
pub type VehicleSplitRiccati = ChainSplit<RiccatiKkt<8, 3, 11>>;

/// The vehicle OCP's Riccati backend with its arc-length state split off, when the pattern
/// has exactly one chain state; `None` otherwise.
pub fn split_riccati(
    st: &StageStructure,
    n: usize,
    hess_rows: &[usize],
    hess_cols: &[usize],
    jac_rows: &[usize],
    jac_cols: &[usize],
) -> Option<VehicleSplitRiccati> {
    let red = Reduced::detect(st, n, hess_rows, hess_cols, jac_rows, jac_cols)
        .filter(|r| r.structure.nx == 8 && r.structure.nu == 3)?;
    let inner = RiccatiKkt::<8, 3, 11>::new(
        &red.structure,
        red.n,
        &red.hess_rows,
        &red.hess_cols,
        &red.jac_rows,
        &red.jac_cols,
    )
    .ok()?;
    Some(ChainSplit::new(red, inner))
}

/// The structured backend in use: on the whole system, or with the chain states split off.
#[derive(Debug)]
enum Structured {
    Full(Box<VehicleRiccati>),
    Split(Box<VehicleSplitRiccati>),
}

impl Structured {
    /// The split backend when `st` has exactly one chain state, else the full one.
    fn new(st: &StageStructure, pat: &Pattern<'_>) -> Result<Self, StructureError> {
        let (hr, hc, jr, jc) = (pat.hess_rows, pat.hess_cols, pat.jac_rows, pat.jac_cols);
        if let Some(split) = split_riccati(st, pat.n, hr, hc, jr, jc) {
            return Ok(Self::Split(Box::new(split)));
        }
        VehicleRiccati::new(st, pat.n, hr, hc, jr, jc).map(|r| Self::Full(Box::new(r)))
    }

    fn set_pipelined(&mut self, on: bool) -> std::io::Result<()> {
        match self {
            Self::Full(r) => r.set_pipelined(on),
            Self::Split(r) => r.inner_mut().set_pipelined(on),
        }
    }

    fn worker(&self) -> Option<&crate::worker::SharedWorker> {
        match self {
            Self::Full(r) => r.worker(),
            Self::Split(r) => r.inner().worker(),
        }
    }

    fn solver(&mut self) -> &mut dyn KktSolver {
        match self {
            Self::Full(r) => r.as_mut(),
            Self::Split(r) => r.as_mut(),
        }
    }
}

/// Why no backend could be built.
#[derive(Debug, thiserror::Error)]
pub enum BackendError {
    /// The sparse symbolic analysis failed.
    #[error(transparent)]
    Sparse(#[from] SymbolicError),
    /// `riccati` was requested but the structure does not fit.
    #[error("riccati KKT backend: {0}")]
    Structure(#[from] StructureError),
    /// `riccati` was requested but the NLP publishes no stage structure.
    #[error("riccati KKT backend: the problem has no stage structure")]
    NoStructure,
    /// The helper thread of the pipelined factorization could not be started.
    #[error("riccati KKT backend: cannot start the helper thread: {0}")]
    Worker(#[from] std::io::Error),
}

/// A KKT backend chosen at setup.
#[derive(Debug)]
pub struct KktBackend {
    riccati: Option<Structured>,
    sparse: Option<SparseLdlt>,
    /// The last factorization was done by the sparse backend.
    on_sparse: bool,
    /// Factorizations the Riccati backend handed to the sparse one.
    fallbacks: usize,
}

/// Sparsity of an NLP as the backends need it.
#[derive(Debug, Clone, Copy)]
pub struct Pattern<'a> {
    /// Variables.
    pub n: usize,
    /// Constraint rows.
    pub m: usize,
    /// Hessian coordinates (lower triangle).
    pub hess_rows: &'a [usize],
    /// Hessian columns.
    pub hess_cols: &'a [usize],
    /// Jacobian rows.
    pub jac_rows: &'a [usize],
    /// Jacobian columns.
    pub jac_cols: &'a [usize],
}

impl KktBackend {
    /// Builds the backend `kind` for this pattern and (optional) stage structure, with one
    /// thread.
    pub fn new(
        kind: KktBackendKind,
        pat: Pattern<'_>,
        structure: Option<&StageStructure>,
    ) -> Result<Self, BackendError> {
        Self::with_threads(kind, pat, structure, 1)
    }

    /// As [`Self::new`]; with `threads` = 2 the Riccati backend pipelines its factorization
    /// over a helper thread (same bits; the sparse backend always runs on one).
    pub fn with_threads(
        kind: KktBackendKind,
        pat: Pattern<'_>,
        structure: Option<&StageStructure>,
        threads: usize,
    ) -> Result<Self, BackendError> {
        let sparse = || {
            SparseLdlt::new(
                pat.n,
                pat.m,
                pat.hess_rows,
                pat.hess_cols,
                pat.jac_rows,
                pat.jac_cols,
            )
        };
        let riccati = |st: &StageStructure| Structured::new(st, &pat);
        let (riccati, sparse) = match kind {
            KktBackendKind::Sparse => (None, Some(sparse()?)),
            KktBackendKind::Riccati => {
                let st = structure.ok_or(BackendError::NoStructure)?;
                (Some(riccati(st)?), Some(sparse()?))
            }
            KktBackendKind::Auto => match structure.map(riccati) {
                Some(Ok(r)) => (Some(r), Some(sparse()?)),
                _ => (None, Some(sparse()?)),
            },
        };
        let mut riccati = riccati;
        if let Some(r) = riccati.as_mut() {
            r.set_pipelined(threads > 1)?;
        }
        Ok(Self {
            riccati,
            sparse,
            on_sparse: false,
            fallbacks: 0,
        })
    }

    /// Name of the backend in use: `riccati` or `sparse`.
    pub fn name(&self) -> &'static str {
        if self.riccati.is_some() {
            "riccati"
        } else {
            "sparse"
        }
    }

    /// The helper thread of the pipelined Riccati factorization (`threads = 2`), to share
    /// with the NLP's stage-parallel evaluation.
    pub fn worker(&self) -> Option<crate::worker::SharedWorker> {
        self.riccati.as_ref().and_then(|r| r.worker().cloned())
    }

    /// States the Riccati backend split off as decoupled chains ([`super::chain`]): 1 for
    /// the vehicle OCP (the arc length s), 0 when it runs on the whole system.
    pub fn chain_states(&self) -> usize {
        match &self.riccati {
            Some(Structured::Split(r)) => r.chain_states(),
            _ => 0,
        }
    }

    /// Factorizations the Riccati backend handed to the sparse one since setup.
    pub fn fallbacks(&self) -> usize {
        self.fallbacks
    }

    /// Riccati where it can, else sparse; `expected` as in
    /// [`KktSolver::factorize_expecting`].
    fn factorize_with(
        &mut self,
        values: &KktValues<'_>,
        expected: Option<Inertia>,
    ) -> Result<Inertia, KktError> {
        self.on_sparse = false;
        if let Some(r) = self.riccati.as_mut().map(Structured::solver) {
            let res = match expected {
                Some(e) => r.factorize_expecting(values, e),
                None => r.factorize(values),
            };
            match res {
                Err(KktError::Unsupported) => self.fallbacks += 1,
                res => return res,
            }
        }
        self.on_sparse = true;
        match (self.sparse.as_mut(), expected) {
            (Some(s), Some(e)) => s.factorize_expecting(values, e),
            (Some(s), None) => s.factorize(values),
            (None, _) => Err(KktError::Unsupported),
        }
    }
}

impl KktSolver for KktBackend {
    fn factorize(&mut self, values: &KktValues<'_>) -> Result<Inertia, KktError> {
        self.factorize_with(values, None)
    }

    fn factorize_expecting(
        &mut self,
        values: &KktValues<'_>,
        expected: Inertia,
    ) -> Result<Inertia, KktError> {
        self.factorize_with(values, Some(expected))
    }

    /// The Riccati backend factorizes the exact system; with only the sparse one the base
    /// regularization stays.
    fn wants_dual_regularization(&self) -> bool {
        self.riccati.is_none()
    }

    fn solve(&mut self, rhs_x: &mut [f64], rhs_y: &mut [f64]) {
        match (self.on_sparse, self.riccati.as_mut(), self.sparse.as_mut()) {
            (false, Some(r), _) => r.solver().solve(rhs_x, rhs_y),
            (_, _, Some(s)) => s.solve(rhs_x, rhs_y),
            _ => {}
        }
    }
}
