//! The constraint rows of a transcription and their Jacobian pattern, stage by stage.
//!
//! Rows are ordered stage by stage: first the initial-condition rows g = x_0[i], then for
//! each interval k = 0..N-1: the scheme's defect rows, the two front friction rows (R9),
//! the two saturation rows (R5, when enforced; the last interval also carries the two rows
//! of the last node (x_N, u_{N-1}) when [`crate::ocp::OcpSpec::saturation_at_end`]) and,
//! for k >= 1, the six control-rate rows. The Jacobian entries follow the same order, each
//! group in its pattern's order.

use super::{DefectScheme, Transcription};
use crate::model::{CONTROL_NAMES, NU, STATE_NAMES};
use crate::ocp::layout::Layout;
use crate::ocp::path_constraints::{
    friction_pattern, rate_pattern, saturation_pattern, INITIAL_ROWS, SATURATION_ROWS,
};

/// What a constraint row is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowKind {
    /// Initial-condition equality x_0\[state\] = target.
    Initial {
        /// State index.
        state: usize,
    },
    /// Defect row of the scheme (for implicit Euler: the state index).
    Defect {
        /// Local defect row.
        row: usize,
    },
    /// Front friction limit (R9) at (x_k, u_k) or, if `at_next`, at (x_{k+1}, u_k).
    Friction {
        /// Evaluated at x_{k+1}.
        at_next: bool,
    },
    /// Tire saturation (R5), front or rear axle, at (x_k, u_k) of the row's node k, or at
    /// (x_N, u_{N-1}) for node N.
    Saturation {
        /// Rear axle.
        rear: bool,
    },
    /// Upper control-rate row u_k - u_{k-1} <= rate (t_k - t_{k-1}).
    RateUpper {
        /// Control index.
        control: usize,
    },
    /// Lower control-rate row u_k - u_{k-1} >= -rate (t_k - t_{k-1}).
    RateLower {
        /// Control index.
        control: usize,
    },
}

/// Kind and node (interval k) of a constraint row.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RowInfo {
    /// What the row is.
    pub kind: RowKind,
    /// Node / interval index k.
    pub node: usize,
}

/// Offsets of one interval's rows and Jacobian entries.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Stage {
    pub(super) row_defect: usize,
    pub(super) row_friction: usize,
    pub(super) row_sat: usize,
    /// Saturation points of the interval: 0 (not enforced), 1 (node k) or 2 (the last
    /// interval's nodes N - 1 and N), each [`SATURATION_ROWS`] rows from `row_sat` on.
    pub(super) sat_points: usize,
    pub(super) row_rate: usize,
    pub(super) jac_defect: usize,
    pub(super) jac_friction: usize,
    pub(super) jac_sat: usize,
    pub(super) jac_rate: usize,
}

/// The saturation points (nodes) interval k of N carries: none without saturation rows,
/// node k, or, for the last interval with `sat_end`, nodes N - 1 and N. Points number the
/// saturation blocks: point p's rows and Hessian block are the p-th.
pub(super) fn sat_points(sat: bool, sat_end: bool, k: usize, n: usize) -> std::ops::Range<usize> {
    let count = usize::from(sat) * (1 + usize::from(sat_end && k + 1 == n));
    k..k + count
}

/// Pattern sink: (local row, column).
type Push<'a> = &'a mut dyn FnMut(usize, usize);

/// The rows of a transcription with their Jacobian pattern.
pub(super) struct RowLayout {
    /// Kind and node of every row.
    pub(super) rows: Vec<RowInfo>,
    /// Row of every Jacobian entry.
    pub(super) jac_rows: Vec<usize>,
    /// Column of every Jacobian entry.
    pub(super) jac_cols: Vec<usize>,
    /// Row and entry offsets of each interval.
    pub(super) stages: Vec<Stage>,
    /// Jacobian entries of each interval's defect rows.
    pub(super) jac_defect_len: Vec<usize>,
}

impl RowLayout {
    /// The rows of N intervals with `scheme`'s defects, with saturation rows when `sat`
    /// (and at the last node too when `sat_end`).
    pub(super) fn build<S: DefectScheme, const N: usize>(
        scheme: &S,
        layout: Layout,
        sat: bool,
        sat_end: bool,
    ) -> Self {
        let mut rows = Vec::new();
        let mut jac_rows = Vec::new();
        let mut jac_cols = Vec::new();
        for &i in &INITIAL_ROWS {
            rows.push(RowInfo {
                kind: RowKind::Initial { state: i },
                node: 0,
            });
            jac_rows.push(rows.len() - 1);
            jac_cols.push(layout.x(0, i));
        }

        let mut stages = Vec::with_capacity(N);
        let mut jac_defect_len = Vec::with_capacity(N);
        for k in 0..N {
            let mut st = Stage::default();
            let push_group =
                |base: usize, jr: &mut Vec<usize>, jc: &mut Vec<usize>, f: &mut dyn FnMut(Push)| {
                    f(&mut |r, c| {
                        jr.push(base + r);
                        jc.push(c);
                    });
                };
            // Defects.
            st.row_defect = rows.len();
            st.jac_defect = jac_rows.len();
            for r in 0..S::ROWS {
                rows.push(RowInfo {
                    kind: RowKind::Defect { row: r },
                    node: k,
                });
            }
            push_group(st.row_defect, &mut jac_rows, &mut jac_cols, &mut |p| {
                scheme.jac_pattern(&layout, k, p)
            });
            jac_defect_len.push(jac_rows.len() - st.jac_defect);
            // Front friction (R9).
            st.row_friction = rows.len();
            st.jac_friction = jac_rows.len();
            for at_next in [false, true] {
                rows.push(RowInfo {
                    kind: RowKind::Friction { at_next },
                    node: k,
                });
            }
            push_group(st.row_friction, &mut jac_rows, &mut jac_cols, &mut |p| {
                friction_pattern(&layout, k, &mut |r, c| p(r, c))
            });
            // Saturation (R5).
            st.row_sat = rows.len();
            st.jac_sat = jac_rows.len();
            let points = sat_points(sat, sat_end, k, N);
            st.sat_points = points.len();
            for (j, node) in points.enumerate() {
                for rear in [false, true] {
                    rows.push(RowInfo {
                        kind: RowKind::Saturation { rear },
                        node,
                    });
                }
                let base = st.row_sat + j * SATURATION_ROWS;
                push_group(base, &mut jac_rows, &mut jac_cols, &mut |p| {
                    saturation_pattern(&layout, node, &mut |r, c| p(r, c))
                });
            }
            // Control rates.
            st.row_rate = rows.len();
            st.jac_rate = jac_rows.len();
            if k >= 1 {
                for j in 0..NU {
                    rows.push(RowInfo {
                        kind: RowKind::RateUpper { control: j },
                        node: k,
                    });
                    rows.push(RowInfo {
                        kind: RowKind::RateLower { control: j },
                        node: k,
                    });
                }
                push_group(st.row_rate, &mut jac_rows, &mut jac_cols, &mut |p| {
                    rate_pattern(&layout, k, &mut |r, c| p(r, c))
                });
            }
            stages.push(st);
        }
        RowLayout {
            rows,
            jac_rows,
            jac_cols,
            stages,
            jac_defect_len,
        }
    }
}

impl<S: DefectScheme, const N: usize> Transcription<S, N> {
    /// Kind and node of constraint row `i`.
    pub fn describe_row(&self, i: usize) -> RowInfo {
        self.rows[i]
    }

    /// Human-readable name of constraint row `i`, e.g. `defect[V]@7`.
    pub fn row_name(&self, i: usize) -> String {
        let RowInfo { kind, node } = self.rows[i];
        match kind {
            RowKind::Initial { state } => format!("initial[{}]@{node}", STATE_NAMES[state]),
            RowKind::Defect { row } => format!("defect[{}]@{node}", self.scheme.row_name(row)),
            RowKind::Friction { at_next } => {
                format!("friction[{}]@{node}", if at_next { "x_k+1" } else { "x_k" })
            }
            RowKind::Saturation { rear } => {
                format!("saturation[{}]@{node}", if rear { "rear" } else { "front" })
            }
            RowKind::RateUpper { control } => {
                format!("rate_upper[{}]@{node}", CONTROL_NAMES[control])
            }
            RowKind::RateLower { control } => {
                format!("rate_lower[{}]@{node}", CONTROL_NAMES[control])
            }
        }
    }

    /// Names of all constraint rows (diagnostics; allocates).
    pub fn constraint_names(&self) -> Vec<String> {
        (0..self.m).map(|i| self.row_name(i)).collect()
    }
}
