//! Linear algebra of the Newton step: the condensed primal-dual (KKT) system behind one
//! trait, so a structure-exploiting backend can replace the general sparse one.
//!
//! The system solved every iteration is (paper eq. 6 after eliminating bound multipliers
//! and inequality slacks)
//!
//! ```text
//! [ H + D_x   J^T ] [dx]   [r_x]
//! [ J         D_c ] [dy] = [r_c]
//! ```
//!
//! with `H` the Hessian of the Lagrangian (lower triangle, coordinate form), `J` the
//! constraint Jacobian, `D_x` a positive primal diagonal (barrier terms + regularization)
//! and `D_c` a non-positive dual diagonal.

pub mod backend;
pub mod chain;
mod claims;
pub mod riccati;
pub mod sparse_ldlt;
pub mod structure;

pub use backend::{KktBackend, KktBackendKind};
pub use riccati::RiccatiKkt;
pub use sparse_ldlt::SparseLdlt;
pub use structure::{RowRole, StageStructure};

/// Numerical values of one KKT system; the sparsity structure was given at setup.
#[derive(Debug, Clone, Copy)]
pub struct KktValues<'a> {
    /// Hessian values in the NLP's `hess_structure` order.
    pub hess: &'a [f64],
    /// Jacobian values in the NLP's `jac_structure` order.
    pub jac: &'a [f64],
    /// Primal diagonal D_x (length n).
    pub primal_diag: &'a [f64],
    /// Dual diagonal D_c (length m), <= 0.
    pub dual_diag: &'a [f64],
}

/// Inertia of a factorized symmetric matrix: counts of positive, negative and zero pivots.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Inertia {
    /// Number of positive eigenvalues.
    pub positive: usize,
    /// Number of negative eigenvalues.
    pub negative: usize,
    /// Number of zero (or non-finite) pivots.
    pub zero: usize,
}

/// Why a KKT factorization failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum KktError {
    /// A pivot was exactly zero or not finite: the matrix is singular (to working precision).
    #[error("singular KKT matrix (zero pivot)")]
    Singular,
    /// The matrix contains a NaN or infinite value.
    #[error("non-finite value in the KKT matrix")]
    NonFinite,
    /// A structure-exploiting backend cannot factorize these values (e.g. a singular
    /// dynamics Jacobian E_k); a general backend can.
    #[error("values outside what the structured KKT backend handles")]
    Unsupported,
    /// [`KktSolver::factorize_expecting`] stopped early: the inertia is not the expected
    /// one, and no factorization is held.
    #[error("KKT inertia differs from the expected one (factorization stopped early)")]
    WrongInertia,
}

/// A factorization backend for the condensed KKT system.
pub trait KktSolver {
    /// Factorizes the system with these values and returns its inertia. Must not allocate.
    fn factorize(&mut self, values: &KktValues<'_>) -> Result<Inertia, KktError>;
    /// As [`KktSolver::factorize`], for a caller that only needs the factorization when
    /// its inertia is `expected` (inertia correction): a backend may stop as soon as the
    /// inertia is known to differ and return [`KktError::WrongInertia`], holding no
    /// factorization. Must not allocate.
    fn factorize_expecting(
        &mut self,
        values: &KktValues<'_>,
        expected: Inertia,
    ) -> Result<Inertia, KktError> {
        let _ = expected;
        self.factorize(values)
    }
    /// Solves with the last factorization: `rhs_x` (length n) and `rhs_y` (length m) are
    /// overwritten by `dx` and `dy`. Must not allocate.
    fn solve(&mut self, rhs_x: &mut [f64], rhs_y: &mut [f64]);
    /// Whether equality rows need the solver's base dual regularization `delta_c_min`
    /// (a general LDL^T without pivoting does; a backend that pivots on the dynamics
    /// Jacobian does not, and then factorizes the exact system).
    fn wants_dual_regularization(&self) -> bool {
        true
    }
}
