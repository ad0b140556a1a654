//! Stage structure of an optimal-control NLP, as a structure-exploiting KKT backend needs
//! it: which rows are dynamics, initial conditions or path constraints, and how variables
//! are grouped into stages.

/// Role of one constraint row.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowRole {
    /// Initial condition: a row on x_0 only (one per state).
    Initial,
    /// Dynamics (defect) row `index` of interval `stage`: couples x_k, u_k and x_{k+1}.
    Dynamics {
        /// Interval k.
        stage: usize,
        /// Row within the interval's defect block (0..nx).
        index: usize,
    },
    /// Any other row (path constraint). Must be an inequality and touch at most two
    /// neighbouring stages.
    Path,
}

/// Stage layout of an NLP: variables ordered z = [x_0, u_0, x_1, u_1, ..., x_N] with `nx`
/// states and `nu` controls per stage, and one [`RowRole`] per constraint row.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StageStructure {
    /// Number of intervals N.
    pub n_stages: usize,
    /// States per stage.
    pub nx: usize,
    /// Controls per stage.
    pub nu: usize,
    /// Role of every constraint row (length m).
    pub rows: Vec<RowRole>,
}

impl StageStructure {
    /// Number of variables this layout implies: N (nx + nu) + nx.
    pub fn n(&self) -> usize {
        self.n_stages * (self.nx + self.nu) + self.nx
    }

    /// Stage and position within the stage of variable `v`.
    #[inline]
    pub fn locate(&self, v: usize) -> (usize, usize) {
        let nz = self.nx + self.nu;
        (v / nz, v % nz)
    }
}
