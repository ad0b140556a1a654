//! The constraint rows and Jacobian entries of every interval (stage), in the baseline or
//! the AVX2-compiled copy ([`crate::cpu`]), serially or with the second half of the stages
//! on the helper thread ([`Transcription::set_worker`]). Stages write disjoint entries, so
//! every path gives the same bits.

use super::rows::Stage;
use super::{DefectScheme, Transcription};
use crate::ocp::path_constraints::{
    friction_eval, friction_jac, rate_eval, rate_jac, SaturationRows, SATURATION_NNZ,
    SATURATION_ROWS,
};
use crate::ocp::scaling::saturation_scale;
use crate::worker;

/// Which per-stage values [`Transcription::stage_eval`] writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum StageEval {
    /// Constraint rows.
    Rows,
    /// Jacobian entries.
    Jacobian,
}

impl<S: DefectScheme, const N: usize> Transcription<S, N> {
    /// Jacobian values, inlined into both the baseline and the AVX2 entry point.
    #[inline(always)]
    pub(super) fn eval_jac_body(&mut self, x: &[f64], vals: &mut [f64]) {
        let this = &*self;
        vals[..this.n_init].fill(1.0);
        this.for_stages(
            vals,
            |st| st.jac_defect,
            |k, out, off| this.stage_for_cpu(StageEval::Jacobian, x, k, out, off),
        );
    }

    /// The tire saturation rows, scaled for this problem's initial state.
    fn saturation_rows(&self) -> SaturationRows<'_> {
        SaturationRows {
            p: &self.spec.vehicle,
            lay: &self.layout,
            scale: saturation_scale(&self.spec.initial),
        }
    }

    /// Stage k's constraint rows or Jacobian entries into `out`, which starts at row or
    /// entry `off` (the body of [`Self::for_stages`]' callbacks).
    #[inline(always)]
    fn stage_eval(&self, what: StageEval, x: &[f64], k: usize, out: &mut [f64], off: usize) {
        let cx = self.context();
        let lay = &self.layout;
        let p = &self.spec.vehicle;
        let st = &self.stages[k];
        match what {
            StageEval::Rows => {
                let d = st.row_defect - off;
                self.scheme.eval(&cx, k, x, &mut out[d..d + S::ROWS]);
                friction_eval(p, lay, k, x, &mut out[st.row_friction - off..]);
                for j in 0..st.sat_points {
                    let r = st.row_sat + j * SATURATION_ROWS - off;
                    self.saturation_rows().eval(k + j, x, &mut out[r..]);
                }
                if k >= 1 {
                    rate_eval(p, lay, k, x, &mut out[st.row_rate - off..]);
                }
            }
            StageEval::Jacobian => {
                let (d, len) = (st.jac_defect - off, self.jac_defect_len[k]);
                self.scheme.jac(&cx, k, x, &mut out[d..d + len]);
                friction_jac(p, &mut out[st.jac_friction - off..]);
                for j in 0..st.sat_points {
                    let e = st.jac_sat + j * SATURATION_NNZ - off;
                    let (rows, out) = (self.saturation_rows(), &mut out[e..]);
                    if cx.oracle {
                        rows.jac(k + j, x, out);
                    } else {
                        rows.jac_fast(k + j, x, out);
                    }
                }
                if k >= 1 {
                    rate_jac(p, &mut out[st.jac_rate - off..]);
                }
            }
        }
    }

    /// [`Self::stage_eval`] in the copy compiled for this CPU. [`Self::for_stages`] takes
    /// closures, and a closure does not take the target features of the AVX2 entry point
    /// it is inlined into: calling the stage body directly from one ran it as baseline
    /// code. Same bits either way.
    #[inline(always)]
    pub(super) fn stage_for_cpu(
        &self,
        what: StageEval,
        x: &[f64],
        k: usize,
        out: &mut [f64],
        off: usize,
    ) {
        #[cfg(target_arch = "x86_64")]
        if self.simd {
            // SAFETY: `simd` is only true when the CPU reports AVX2.
            return unsafe { self.stage_eval_avx2(what, x, k, out, off) };
        }
        self.stage_eval(what, x, k, out, off)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    unsafe fn stage_eval_avx2(
        &self,
        what: StageEval,
        x: &[f64],
        k: usize,
        out: &mut [f64],
        off: usize,
    ) {
        self.stage_eval(what, x, k, out, off)
    }

    /// Runs `stage(k, out, off)` for k = 0..N over `out`, whose entries are grouped by stage
    /// in stage order (`start(stage)` is a stage's first entry, Jacobian entries or rows).
    /// With a worker, the stages from `stage_split` on run on the helper thread over the tail
    /// of `out` (offset `off`). Disjoint writes, so the same bits.
    #[inline(always)]
    pub(super) fn for_stages(
        &self,
        out: &mut [f64],
        start: impl Fn(&Stage) -> usize,
        stage: impl Fn(usize, &mut [f64], usize) + Sync,
    ) {
        let Some(shared) = self.worker.as_ref().filter(|_| self.stage_split > 0) else {
            for k in 0..N {
                stage(k, out, 0);
            }
            return;
        };
        let split = self.stage_split;
        let off = start(&self.stages[split]);
        let (head, tail) = out.split_at_mut(off);
        let stage = &stage;
        let mut job = || {
            for k in split..N {
                stage(k, tail, off);
            }
        };
        worker::lock(shared).join(&mut job, || {
            for k in 0..split {
                stage(k, head, 0);
            }
        });
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    pub(super) unsafe fn eval_jac_avx2(&mut self, x: &[f64], vals: &mut [f64]) {
        self.eval_jac_body(x, vals)
    }
}
