//! The Hessian sparsity of a transcription: the lower triangle of the union of every
//! interval's defect block (the scheme's `lambda^T defect_k`), its saturation block (R5)
//! and the objective's steering-slew entries, each (row, column) pair stored once. Every
//! block keeps the slots its values add into.

use super::rows::sat_points;
use super::DefectScheme;
use crate::ocp::layout::Layout;
use crate::ocp::path_constraints::{saturation_hess_pattern, SATURATION_HESS_NNZ};
use std::collections::HashMap;

/// Deduplicating builder of the lower-triangle Hessian structure.
pub(super) struct HessBuilder {
    /// Row of every slot.
    pub(super) rows: Vec<usize>,
    /// Column of every slot.
    pub(super) cols: Vec<usize>,
    map: HashMap<(usize, usize), usize>,
}

impl HessBuilder {
    /// An empty structure.
    pub(super) fn new() -> Self {
        HessBuilder {
            rows: Vec::new(),
            cols: Vec::new(),
            map: HashMap::new(),
        }
    }

    /// The slot of entry (r, c), r >= c, added to the structure if new.
    pub(super) fn slot(&mut self, r: usize, c: usize) -> usize {
        debug_assert!(r >= c);
        let next = self.rows.len();
        *self.map.entry((r, c)).or_insert_with(|| {
            self.rows.push(r);
            self.cols.push(c);
            next
        })
    }
}

/// The slots of every interval's defect and saturation Hessian blocks.
pub(super) struct HessBlocks {
    /// Start of interval k's defect slots in `defect_slots` (N + 1 entries).
    pub(super) defect_off: Vec<usize>,
    /// The defect blocks' slots, interval by interval, in `hess_pattern` order.
    pub(super) defect_slots: Vec<usize>,
    /// The saturation blocks' slots, [`SATURATION_HESS_NNZ`] per saturation point: one per
    /// interval, and the last node's after them (none when the saturation rows are not
    /// enforced).
    pub(super) sat_slots: Vec<usize>,
    /// Entries of the largest block (the size of a scratch buffer for one block's values).
    pub(super) max_block: usize,
}

impl HessBlocks {
    /// Adds the blocks of N intervals with `scheme`'s defects (and saturation rows when
    /// `sat`, with the last node's when `sat_end`) to `hb`, interval by interval.
    pub(super) fn build<S: DefectScheme, const N: usize>(
        scheme: &S,
        layout: Layout,
        sat: bool,
        sat_end: bool,
        hb: &mut HessBuilder,
    ) -> Self {
        let mut hess_defect_off = vec![0];
        let mut hess_defect_slots = Vec::new();
        let mut hess_sat_slots = Vec::new();
        let mut max_block = SATURATION_HESS_NNZ;
        for k in 0..N {
            scheme.hess_pattern(&layout, k, &mut |r, c| {
                let s = hb.slot(r, c);
                hess_defect_slots.push(s);
            });
            hess_defect_off.push(hess_defect_slots.len());
            max_block = max_block.max(hess_defect_off[k + 1] - hess_defect_off[k]);
            for node in sat_points(sat, sat_end, k, N) {
                saturation_hess_pattern(&layout, node, &mut |r, c| {
                    let s = hb.slot(r, c);
                    hess_sat_slots.push(s);
                });
            }
        }
        HessBlocks {
            defect_off: hess_defect_off,
            defect_slots: hess_defect_slots,
            sat_slots: hess_sat_slots,
            max_block,
        }
    }
}
