//! The Hessian of the constraints, sum_k lambda_k^T g_k: only the defect rows and the tire
//! saturation rows (R5) are nonlinear. Each interval's two blocks add into the slots of
//! `sparsity`; serially, or with the second half of the stages on the helper
//! thread ([`Transcription::set_worker`]), where slots that two halves share are added in
//! the serial order, so both give the same bits.

use super::rows::Stage;
use super::{DefectScheme, Derivatives, SchemeContext, Transcription};
use crate::ocp::path_constraints::{SaturationRows, SATURATION_HESS_NNZ, SATURATION_ROWS};
use crate::ocp::scaling::saturation_scale;
use crate::worker::{self, SharedWorker};

/// What one stage's Hessian terms need, shared by the serial and the stage-parallel
/// evaluation.
struct HessParts<'a, S> {
    scheme: &'a S,
    cx: &'a SchemeContext<'a>,
    stages: &'a [Stage],
    defect_off: &'a [usize],
    defect_slots: &'a [usize],
    sat_slots: &'a [usize],
    saturation: bool,
    /// The saturation rows, scaled for the problem's initial state.
    sat_rows: SaturationRows<'a>,
}

impl<S: DefectScheme> HessParts<'_, S> {
    /// [`Self::stage`] for the stages `ks`, `emit(k, position, slot, value)`, in the copy
    /// compiled for this CPU when `simd`: the stage-parallel evaluation runs it from
    /// closures, which do not take the AVX2 entry point's target features. Same bits.
    #[inline(always)]
    fn stages_for_cpu(
        &self,
        simd: bool,
        ks: std::ops::Range<usize>,
        x: &[f64],
        lambda: &[f64],
        scratch: &mut [f64],
        emit: &mut impl FnMut(usize, usize, usize, f64),
    ) {
        #[cfg(target_arch = "x86_64")]
        if simd {
            // SAFETY: `simd` is only true when the CPU reports AVX2.
            return unsafe { self.stages_avx2(ks, x, lambda, scratch, emit) };
        }
        let _ = simd;
        self.stages(ks, x, lambda, scratch, emit)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    unsafe fn stages_avx2(
        &self,
        ks: std::ops::Range<usize>,
        x: &[f64],
        lambda: &[f64],
        scratch: &mut [f64],
        emit: &mut impl FnMut(usize, usize, usize, f64),
    ) {
        self.stages(ks, x, lambda, scratch, emit)
    }

    /// The Hessian terms of the stages `ks` in the serial order, `emit(k, position, slot,
    /// value)`: every stage's defect block, then every stage's saturation block (a stage's
    /// positions count on across its two blocks). Two passes rather than one per stage:
    /// each loop's inlined code is then small enough to stay in the instruction cache.
    #[inline(always)]
    fn stages(
        &self,
        ks: std::ops::Range<usize>,
        x: &[f64],
        lambda: &[f64],
        scratch: &mut [f64],
        emit: &mut impl FnMut(usize, usize, usize, f64),
    ) {
        for k in ks.clone() {
            self.defect_stage(k, x, lambda, scratch, &mut |pos, s, v| emit(k, pos, s, v));
        }
        if self.saturation {
            for k in ks {
                self.sat_stage(k, x, lambda, scratch, &mut |pos, s, v| emit(k, pos, s, v));
            }
        }
    }

    /// Stage k's defect Hessian terms (positions from 0).
    #[inline(always)]
    fn defect_stage(
        &self,
        k: usize,
        x: &[f64],
        lambda: &[f64],
        scratch: &mut [f64],
        emit: &mut impl FnMut(usize, usize, f64),
    ) {
        let st = &self.stages[k];
        let slots = &self.defect_slots[self.defect_off[k]..self.defect_off[k + 1]];
        self.scheme.hess(
            self.cx,
            k,
            x,
            &lambda[st.row_defect..st.row_defect + S::ROWS],
            &mut scratch[..slots.len()],
        );
        emit_block(slots, scratch, 0, emit);
    }

    /// Stage k's saturation Hessian terms (positions after its defect terms).
    #[inline(always)]
    fn sat_stage(
        &self,
        k: usize,
        x: &[f64],
        lambda: &[f64],
        scratch: &mut [f64],
        emit: &mut impl FnMut(usize, usize, f64),
    ) {
        let st = &self.stages[k];
        let mut base = self.defect_off[k + 1] - self.defect_off[k];
        for j in 0..st.sat_points {
            let point = k + j;
            let slots = sat_block(self.sat_slots, point);
            let row = st.row_sat + j * SATURATION_ROWS;
            let lam = &lambda[row..row + SATURATION_ROWS];
            let out = &mut scratch[..SATURATION_HESS_NNZ];
            if self.cx.oracle {
                self.sat_rows.hess(point, x, lam, out);
            } else {
                self.sat_rows.hess_fast(point, x, lam, out);
            }
            emit_block(slots, scratch, base, emit);
            base += SATURATION_HESS_NNZ;
        }
    }

    /// The (position, slot) pairs of stage k, positions as [`Self::stages`] emits them.
    fn stage_slots(&self, k: usize, mut f: impl FnMut(usize, usize)) {
        let slots = &self.defect_slots[self.defect_off[k]..self.defect_off[k + 1]];
        for (pos, &s) in slots.iter().enumerate() {
            f(pos, s);
        }
        let sat = stage_sat_slots(self.sat_slots, &self.stages[k], k);
        for (pos, &s) in sat.iter().enumerate() {
            f(slots.len() + pos, s);
        }
    }
}

/// The Hessian slots of interval k's saturation blocks (its [`Stage::sat_points`] points
/// from k on; empty without saturation rows).
fn stage_sat_slots<'a>(sat_slots: &'a [usize], st: &Stage, k: usize) -> &'a [usize] {
    sat_slots
        .get(k * SATURATION_HESS_NNZ..(k + st.sat_points) * SATURATION_HESS_NNZ)
        .unwrap_or(&[])
}

/// The Hessian slots of saturation point `p`'s block.
#[inline(always)]
fn sat_block(sat_slots: &[usize], p: usize) -> &[usize] {
    &sat_slots[p * SATURATION_HESS_NNZ..(p + 1) * SATURATION_HESS_NNZ]
}

/// Emits a block's values (`vals`, in `slots` order) at positions from `base`.
#[inline(always)]
fn emit_block(
    slots: &[usize],
    vals: &[f64],
    base: usize,
    emit: &mut impl FnMut(usize, usize, f64),
) {
    for (pos, (&s, &v)) in slots.iter().zip(vals).enumerate() {
        emit(base + pos, s, v);
    }
}

/// A raw output pointer handed to the helper thread (disjoint slots, see
/// `Transcription::eval_hess_body`).
struct SendPtr(*mut f64);
// SAFETY: the two threads write disjoint entries through it and the caller joins first.
unsafe impl Send for SendPtr {}
// SAFETY: as above.
unsafe impl Sync for SendPtr {}

impl<S: DefectScheme, const N: usize> Transcription<S, N> {
    /// The constraints' Hessian terms (overwrites `vals`) in the copy compiled for this CPU.
    pub(super) fn eval_hess_for_cpu(&mut self, x: &[f64], lambda: &[f64], vals: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if self.simd {
            // SAFETY: `simd` is only true when the CPU reports AVX2.
            return unsafe { self.eval_hess_avx2(x, lambda, vals) };
        }
        self.eval_hess_body(x, lambda, vals)
    }

    /// Hessian values, inlined into both the baseline and the AVX2 entry point. With a
    /// worker the stages after `stage_split` run on the helper thread; same bits.
    #[inline(always)]
    fn eval_hess_body(&mut self, x: &[f64], lambda: &[f64], vals: &mut [f64]) {
        // The stage-parallel path writes through a raw pointer: every slot must be in `vals`.
        assert_eq!(
            vals.len(),
            self.hess_rows.len(),
            "Hessian values buffer length"
        );
        vals.fill(0.0);
        let cx = SchemeContext {
            vehicle: &self.spec.vehicle,
            ds: self.spec.ds(),
            kappa: &self.spec.kappa,
            layout: self.layout,
            oracle: self.derivatives == Derivatives::Oracle,
        };
        let parts = HessParts {
            scheme: &self.scheme,
            cx: &cx,
            stages: &self.stages,
            defect_off: &self.hess_defect_off,
            defect_slots: &self.hess_defect_slots,
            sat_slots: &self.hess_sat_slots,
            saturation: self.spec.enforce_tire_saturation,
            sat_rows: SaturationRows {
                p: &self.spec.vehicle,
                lay: &self.layout,
                scale: saturation_scale(&self.spec.initial),
            },
        };
        let Some(shared) = self.worker.as_ref().filter(|_| self.stage_split > 0) else {
            parts.stages(0..N, x, lambda, &mut self.scratch, &mut |_, _, s, v| {
                vals[s] += v
            });
            return;
        };
        let split = self.stage_split;
        let out = SendPtr(vals.as_mut_ptr());
        let (deferred, side, scratch2) =
            (&self.hess_deferred, &mut self.hess_side, &mut self.scratch2);
        let simd = self.simd;
        let mut job = || {
            let out = &out;
            parts.stages_for_cpu(simd, split..N, x, lambda, scratch2, &mut |k, pos, s, v| {
                if k == split && deferred[pos] {
                    side[pos] = v;
                } else {
                    // SAFETY: slots of stages >= split that no earlier stage writes:
                    // this thread's alone until the join.
                    unsafe { *out.0.add(s) += v };
                }
            });
        };
        let scratch = &mut self.scratch;
        worker::lock(shared).join(&mut job, || {
            // SAFETY: slots of stages < split (the helper defers those it shares).
            parts.stages_for_cpu(
                simd,
                0..split,
                x,
                lambda,
                scratch,
                &mut |_, _, s, v| unsafe { *out.0.add(s) += v },
            );
        });
        parts.stage_slots(split, |pos, s| {
            if self.hess_deferred[pos] {
                vals[s] += self.hess_side[pos];
            }
        });
    }

    /// Lets the constraint, Jacobian and Hessian evaluations run their second half of the
    /// stages on `worker`'s helper thread (None: serial); same bits. Allocates; call at
    /// setup. Serial anyway unless the only Hessian slots the two halves share are the
    /// helper's first stage's with earlier stages (so on this OCP: it couples neighbours).
    pub fn set_worker(&mut self, worker: Option<SharedWorker>) {
        self.worker = worker;
        self.stage_split = 0;
        if self.worker.is_none() || N < 2 {
            return;
        }
        let split = N / 2;
        let defect = |k: usize| {
            &self.hess_defect_slots[self.hess_defect_off[k]..self.hess_defect_off[k + 1]]
        };
        let sat = |k: usize| stage_sat_slots(&self.hess_sat_slots, &self.stages[k], k);
        let slots = |k: usize| {
            defect(k)
                .iter()
                .chain(sat(k))
                .copied()
                .collect::<Vec<usize>>()
        };
        // The serial order adds every defect block before any saturation block: a slot of
        // the helper's first defect block that a saturation block of the first half also
        // writes would be added after it on two threads but before it on one. (Never on the
        // schemes whose defect k reads no earlier stage, implicit Euler among them.)
        let sat_before: std::collections::HashSet<usize> =
            (0..split).flat_map(|k| sat(k).iter().copied()).collect();
        if defect(split).iter().any(|s| sat_before.contains(s)) {
            return;
        }
        let before: std::collections::HashSet<usize> = (0..split).flat_map(slots).collect();
        let after: std::collections::HashSet<usize> = (split + 1..N).flat_map(slots).collect();
        let first = slots(split);
        self.hess_deferred = first.iter().map(|s| before.contains(s)).collect();
        // Only the helper's first stage may share slots with the first half, and those
        // slots no later stage: anything else would have both threads add to one entry.
        if first
            .iter()
            .zip(&self.hess_deferred)
            .any(|(s, &d)| d && after.contains(s))
            || after.iter().any(|s| before.contains(s))
        {
            return;
        }
        self.hess_side = vec![0.0; first.len()];
        self.stage_split = split;
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    unsafe fn eval_hess_avx2(&mut self, x: &[f64], lambda: &[f64], vals: &mut [f64]) {
        self.eval_hess_body(x, lambda, vals)
    }
}
