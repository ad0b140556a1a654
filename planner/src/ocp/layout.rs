//! Ordering of the decision vector, shared by all transcriptions.
//!
//! Stage by stage: z = [x_0, u_0, w_0, x_1, u_1, w_1, ..., x_{N-1}, u_{N-1}, w_{N-1}, x_N], where
//! w_k are `stage_vars` extra variables per interval (collocation stage states of e.g.
//! Gauss-Legendre; zero for implicit Euler). All entries are in scaled units
//! ([`crate::ocp::scaling`]).

use crate::model::{NU, NX};

/// Index map of the decision vector.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Number of intervals N.
    pub n_intervals: usize,
    /// Extra variables per interval (0 for single-step schemes).
    pub stage_vars: usize,
}

impl Layout {
    /// Layout with N intervals and `stage_vars` extra variables per interval.
    pub const fn new(n_intervals: usize, stage_vars: usize) -> Self {
        Self {
            n_intervals,
            stage_vars,
        }
    }
    /// Variables per interval block (x_k, u_k, w_k).
    pub const fn block(&self) -> usize {
        NX + NU + self.stage_vars
    }
    /// Total number of variables n.
    pub const fn n(&self) -> usize {
        self.n_intervals * self.block() + NX
    }
    /// Index of state `i` at node `k` (k = 0..=N).
    #[inline]
    pub const fn x(&self, k: usize, i: usize) -> usize {
        k * self.block() + i
    }
    /// Index of control `j` on interval `k` (k = 0..N).
    #[inline]
    pub const fn u(&self, k: usize, j: usize) -> usize {
        k * self.block() + NX + j
    }
    /// Index of extra variable `l` of interval `k`.
    #[inline]
    pub const fn w(&self, k: usize, l: usize) -> usize {
        k * self.block() + NX + NU + l
    }
    /// What variable index `idx` is: (node/interval, VarKind).
    pub fn describe(&self, idx: usize) -> (usize, VarKind) {
        let k = idx / self.block();
        let o = idx % self.block();
        if o < NX {
            (k, VarKind::State(o))
        } else if o < NX + NU {
            (k, VarKind::Control(o - NX))
        } else {
            (k, VarKind::Stage(o - NX - NU))
        }
    }
}

/// Kind of a decision variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VarKind {
    /// State index into x.
    State(usize),
    /// Control index into u.
    Control(usize),
    /// Scheme-specific stage variable.
    Stage(usize),
}
