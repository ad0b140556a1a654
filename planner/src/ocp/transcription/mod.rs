//! Direct multiple-shooting transcriptions of the minimum-time OCP (paper eq. 3) as an
//! [`Nlp`].
//!
//! [`Transcription`] owns everything that does not depend on the integrator: the variable
//! [`Layout`], scaling, bounds, objective, initial-condition rows and the path constraints
//! of [`crate::ocp::path_constraints`]. A [`DefectScheme`] supplies only the dynamics defect
//! rows of each interval (plus, for collocation schemes, its stage variables), so other
//! integrators (RK2/4, BDF, Crank-Nicolson, Gauss-Legendre) plug in without touching the
//! model, the shared constraints or the solver. [`ImplicitEuler`] (hand-written fast
//! derivatives) was the first scheme; [`CrankNicolson`], [`ExplicitRk2`], [`ExplicitRk4`]
//! and [`GaussLegendre2`] / [`GaussLegendre3`] (stage states as NLP variables) share the
//! formulas of [`steps`] and take exact derivatives from the num-dual oracle; the
//! multistep schemes BDF4-6 and Adams-Moulton ([`LinearMultistep`]) reference the earlier
//! nodes x_{k-q+1}..x_k in their defect on interval k.
//!
//! Rows are ordered stage by stage: first the initial-condition rows, then for each
//! interval k = 0..N-1: the scheme's defect rows, the two front friction rows (R9), the two
//! saturation rows (R5, when enforced) and, for k >= 1, the six control-rate rows.
//!
//! The terminal condition s_N = length of paper eq. (3) is deliberately NOT a row: it follows
//! from s_0 = 0 and the linear s defects (ds/ds = 1), so adding it would make the constraint
//! Jacobian rank deficient (a redundant equality the interior-point solver cannot handle).

pub mod crank_nicolson;
mod dense;
pub mod explicit_rk;
pub mod gauss_legendre;
pub mod implicit_euler;
pub mod multistep;
mod one_step;
pub mod steps;

pub use crank_nicolson::CrankNicolson;
pub use explicit_rk::{ExplicitRk2, ExplicitRk4};
pub use gauss_legendre::{GaussLegendre2, GaussLegendre3};
pub use implicit_euler::ImplicitEuler;
pub use multistep::{LinearMultistep, MultistepFamily};

use super::layout::Layout;
use super::objective::Objective;
use super::path_constraints::*;
use super::scaling::saturation_scale;
use super::scaling::{scale_control, scale_state, unscale_control, unscale_state};
use super::spec::{InitialState, OcpSpec};
use crate::ip::kkt::{RowRole, StageStructure};
use crate::ip::{Nlp, NlpDims};
use crate::model::{VehicleParams, CONTROL_NAMES, NU, NX, STATE_NAMES};
use std::collections::HashMap;

use crate::worker::{self, SharedWorker};

/// Read-only problem data a [`DefectScheme`] evaluates with.
#[derive(Debug, Clone, Copy)]
pub struct SchemeContext<'a> {
    /// Vehicle parameters.
    pub vehicle: &'a VehicleParams,
    /// Node spacing ds [m].
    pub ds: f64,
    /// k_ref at every node (R8).
    pub kappa: &'a [f64],
    /// Decision-vector layout.
    pub layout: Layout,
    /// Evaluate derivatives with the num-dual oracle instead of the fast path.
    pub oracle: bool,
}

/// Which implementation evaluates the exact Jacobian and Hessian.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Derivatives {
    /// Structured hand-written jets of [`crate::ocp::fast`] (default).
    #[default]
    Fast,
    /// num-dual duals through the generic model (the reference implementation).
    Oracle,
}

/// The integrator-specific part of a transcription: the defect rows of one interval.
///
/// All values are in scaled units; Jacobian values are written in `jac_pattern` order and
/// Hessian values (of `lambda^T defect_k`, lower triangle, global indices) in `hess_pattern`
/// order. Patterns are queried once at construction; evaluations must not allocate.
pub trait DefectScheme: Sync {
    /// Extra variables per interval (collocation stage states); 0 for single-step schemes.
    const STAGE_VARS: usize;
    /// Defect rows per interval.
    const ROWS: usize;
    /// Short name of the scheme.
    fn name(&self) -> &'static str;
    /// Name of defect row `row` (for diagnostics).
    fn row_name(&self, row: usize) -> &'static str;
    /// Jacobian pattern of interval k as (local row, global column) pairs.
    fn jac_pattern(&self, lay: &Layout, k: usize, push: &mut dyn FnMut(usize, usize));
    /// Defect values of interval k.
    fn eval(&self, cx: &SchemeContext, k: usize, z: &[f64], out: &mut [f64]);
    /// Jacobian values of interval k in `jac_pattern` order.
    fn jac(&self, cx: &SchemeContext, k: usize, z: &[f64], vals: &mut [f64]);
    /// Hessian pattern of interval k as global (row >= col) pairs.
    fn hess_pattern(&self, lay: &Layout, k: usize, push: &mut dyn FnMut(usize, usize));
    /// Hessian of `lambda^T defect_k` in `hess_pattern` order (overwrites `vals`).
    fn hess(&self, cx: &SchemeContext, k: usize, z: &[f64], lambda: &[f64], vals: &mut [f64]);
    /// Fills the stage variables of interval k of a starting point (default: nothing).
    fn guess_stage_vars(&self, _cx: &SchemeContext, _k: usize, _z: &mut [f64]) {}
}

/// Errors building a transcription.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum TranscriptionError {
    /// The spec's interval count differs from the compiled-in N.
    #[error("spec has {got} intervals, this transcription is built for N = {expected}")]
    WrongN {
        /// Compiled-in N.
        expected: usize,
        /// spec.n_intervals.
        got: usize,
    },
    /// A per-node vector has the wrong length.
    #[error("spec field {field} has {got} entries, expected N + 1 = {expected}")]
    BadLength {
        /// Field name.
        field: &'static str,
        /// N + 1.
        expected: usize,
        /// Actual length.
        got: usize,
    },
}

/// What a constraint row is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowKind {
    /// Initial-condition equality x_0[state] = target.
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
    /// Tire saturation (R5), front or rear axle.
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
struct Stage {
    row_defect: usize,
    row_friction: usize,
    row_sat: usize,
    row_rate: usize,
    jac_defect: usize,
    jac_friction: usize,
    jac_sat: usize,
    jac_rate: usize,
}

/// Transcription of the minimum-time OCP with N intervals and defect scheme `S`.
#[derive(Debug, Clone)]
pub struct Transcription<S: DefectScheme, const N: usize> {
    spec: OcpSpec,
    scheme: S,
    derivatives: Derivatives,
    layout: Layout,
    n_init: usize,
    m: usize,
    stages: Vec<Stage>,
    jac_rows: Vec<usize>,
    jac_cols: Vec<usize>,
    jac_defect_len: Vec<usize>,
    hess_rows: Vec<usize>,
    hess_cols: Vec<usize>,
    hess_defect_off: Vec<usize>,
    hess_defect_slots: Vec<usize>,
    hess_sat_slots: Vec<usize>,
    /// t_N and the steering-slew term, with the latter's Hessian slots.
    objective: Objective,
    scratch: Vec<f64>,
    /// The stage-parallel evaluation ([`Self::set_worker`]): the helper thread, its scratch,
    /// the first stage it takes (0: serial), and per position of that stage's Hessian slots
    /// (defect, then saturation) whether an earlier stage writes the slot too; such values
    /// wait in `hess_side` and are added after the earlier stages', in the serial order.
    worker: Option<SharedWorker>,
    stage_split: usize,
    hess_deferred: Vec<bool>,
    hess_side: Vec<f64>,
    scratch2: Vec<f64>,
    /// Evaluate derivatives in the AVX2-compiled copy ([`crate::cpu`]; same bits).
    simd: bool,
    g_buf: Vec<f64>,
    x_l: Vec<f64>,
    x_u: Vec<f64>,
    g_l: Vec<f64>,
    g_u: Vec<f64>,
    z0: Vec<f64>,
    rows: Vec<RowInfo>,
}

/// Which per-stage values [`Transcription::stage_eval`] writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum StageEval {
    /// Constraint rows.
    Rows,
    /// Jacobian entries.
    Jacobian,
}

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
    /// each loop's inlined code is then small enough to stay in the instruction cache
    /// (measured: the Hessian 5 % faster).
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
        let base = self.defect_off[k + 1] - self.defect_off[k];
        let slots = &self.sat_slots[k * SATURATION_HESS_NNZ..(k + 1) * SATURATION_HESS_NNZ];
        let lam = &lambda[st.row_sat..st.row_sat + SATURATION_ROWS];
        let out = &mut scratch[..SATURATION_HESS_NNZ];
        if self.cx.oracle {
            self.sat_rows.hess(k, x, lam, out);
        } else {
            self.sat_rows.hess_fast(k, x, lam, out);
        }
        emit_block(slots, scratch, base, emit);
    }

    /// The (position, slot) pairs of stage k, positions as [`Self::stages`] emits them.
    fn stage_slots(&self, k: usize, mut f: impl FnMut(usize, usize)) {
        let slots = &self.defect_slots[self.defect_off[k]..self.defect_off[k + 1]];
        for (pos, &s) in slots.iter().enumerate() {
            f(pos, s);
        }
        if self.saturation {
            let sat = &self.sat_slots[k * SATURATION_HESS_NNZ..(k + 1) * SATURATION_HESS_NNZ];
            for (pos, &s) in sat.iter().enumerate() {
                f(slots.len() + pos, s);
            }
        }
    }
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

/// Upper bound of the rear saturation row at node 0 with a fixed initial state (scaled;
/// sigma - sigma_sl <= 100, never active).
const SATURATION_FIXED_X0_BOUND: f64 = 1e3;

/// The implicit-Euler transcription used by the paper's best solver pairing.
pub type ImplicitEulerNlp<const N: usize> = Transcription<ImplicitEuler, N>;

/// Pattern sink: (local row, column).
type Push<'a> = &'a mut dyn FnMut(usize, usize);

/// Deduplicating builder of the lower-triangle Hessian structure.
struct HessBuilder {
    rows: Vec<usize>,
    cols: Vec<usize>,
    map: HashMap<(usize, usize), usize>,
}

impl HessBuilder {
    fn slot(&mut self, r: usize, c: usize) -> usize {
        debug_assert!(r >= c);
        let next = self.rows.len();
        *self.map.entry((r, c)).or_insert_with(|| {
            self.rows.push(r);
            self.cols.push(c);
            next
        })
    }
}

impl<S: DefectScheme, const N: usize> Transcription<S, N> {
    /// Builds the transcription (all structures and buffers) for `spec` with `scheme`.
    pub fn with_scheme(spec: OcpSpec, scheme: S) -> Result<Self, TranscriptionError> {
        if spec.n_intervals != N {
            return Err(TranscriptionError::WrongN {
                expected: N,
                got: spec.n_intervals,
            });
        }
        for (field, len) in [
            ("kappa", spec.kappa.len()),
            ("e_min", spec.e_min.len()),
            ("e_max", spec.e_max.len()),
        ] {
            if len != N + 1 {
                return Err(TranscriptionError::BadLength {
                    field,
                    expected: N + 1,
                    got: len,
                });
            }
        }
        let layout = Layout::new(N, S::STAGE_VARS);
        let sat = spec.enforce_tire_saturation;
        let n_init = INITIAL_ROWS.len();

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
            if sat {
                for rear in [false, true] {
                    rows.push(RowInfo {
                        kind: RowKind::Saturation { rear },
                        node: k,
                    });
                }
                push_group(st.row_sat, &mut jac_rows, &mut jac_cols, &mut |p| {
                    saturation_pattern(&layout, k, &mut |r, c| p(r, c))
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
        let m = rows.len();

        // Hessian: union of the defect and saturation blocks, deduplicated.
        let mut hb = HessBuilder {
            rows: Vec::new(),
            cols: Vec::new(),
            map: HashMap::new(),
        };
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
            if sat {
                saturation_hess_pattern(&layout, k, &mut |r, c| {
                    let s = hb.slot(r, c);
                    hess_sat_slots.push(s);
                });
            }
        }

        // The objective's steering-slew entries (none at weight 0: the pattern is unchanged).
        let objective = Objective::new(
            layout,
            N,
            spec.steering_slew_weight,
            &spec.vehicle,
            |r, c| hb.slot(r, c),
        );

        let n = layout.n();
        let mut me = Self {
            objective,
            scheme,
            derivatives: Derivatives::Fast,
            layout,
            n_init,
            m,
            stages,
            jac_rows,
            jac_cols,
            jac_defect_len,
            hess_rows: hb.rows,
            hess_cols: hb.cols,
            hess_defect_off,
            hess_defect_slots,
            hess_sat_slots,
            scratch: vec![0.0; max_block],
            worker: None,
            stage_split: 0,
            hess_deferred: Vec::new(),
            hess_side: Vec::new(),
            scratch2: vec![0.0; max_block],
            simd: crate::cpu::avx2_available(),
            g_buf: vec![0.0; m],
            x_l: vec![0.0; n],
            x_u: vec![0.0; n],
            g_l: vec![0.0; m],
            g_u: vec![0.0; m],
            z0: vec![0.0; n],
            rows,
            spec,
        };
        me.refresh_bounds();
        me.default_guess();
        Ok(me)
    }

    /// The problem data.
    pub fn spec(&self) -> &OcpSpec {
        &self.spec
    }

    /// The decision-vector layout.
    pub fn layout(&self) -> Layout {
        self.layout
    }

    /// The defect scheme.
    pub fn scheme(&self) -> &S {
        &self.scheme
    }

    /// Which implementation evaluates derivatives.
    pub fn derivatives(&self) -> Derivatives {
        self.derivatives
    }

    /// Selects the derivative implementation (fast path or num-dual oracle).
    pub fn set_derivatives(&mut self, d: Derivatives) {
        self.derivatives = d;
    }

    fn context(&self) -> SchemeContext<'_> {
        SchemeContext {
            vehicle: &self.spec.vehicle,
            ds: self.spec.ds(),
            kappa: &self.spec.kappa,
            layout: self.layout,
            oracle: self.derivatives == Derivatives::Oracle,
        }
    }

    /// Default starting point: straight-line driving at 15 m/s (r = beta = dFz = e = dpsi = 0,
    /// V_wr = V, zero controls), s_k = k ds, t_k = s_k / 15 m/s; stage variables from the
    /// scheme.
    fn default_guess(&mut self) {
        let ds = self.spec.ds();
        let xs: Vec<[f64; NX]> = (0..=N)
            .map(|k| {
                let s = k as f64 * ds;
                [0.0, 15.0, 0.0, 15.0, 0.0, 0.0, 0.0, s, s / 15.0]
            })
            .collect();
        let us = vec![[0.0; NU]; N];
        self.set_initial_guess(&xs, &us);
    }

    /// Sets the starting point returned by [`Nlp::initial_point`] from physical states
    /// (N + 1 rows) and controls (N rows). Panics on wrong lengths.
    pub fn set_initial_guess(&mut self, xs: &[[f64; NX]], us: &[[f64; NU]]) {
        assert_eq!(xs.len(), N + 1, "need N + 1 states");
        assert_eq!(us.len(), N, "need N controls");
        let lay = self.layout;
        let mut z0 = std::mem::take(&mut self.z0);
        for (k, x) in xs.iter().enumerate() {
            z0[lay.x(k, 0)..lay.x(k, 0) + NX].copy_from_slice(&scale_state(x));
        }
        for (k, u) in us.iter().enumerate() {
            z0[lay.u(k, 0)..lay.u(k, 0) + NU].copy_from_slice(&scale_control(u));
        }
        {
            let cx = self.context();
            for k in 0..N {
                self.scheme.guess_stage_vars(&cx, k, &mut z0);
            }
        }
        self.z0 = z0;
    }

    /// Packs physical states (N + 1) and controls (N) into a scaled decision vector `z`.
    pub fn pack(&self, xs: &[[f64; NX]], us: &[[f64; NU]], z: &mut [f64]) {
        let lay = self.layout;
        for (k, x) in xs.iter().enumerate().take(N + 1) {
            z[lay.x(k, 0)..lay.x(k, 0) + NX].copy_from_slice(&scale_state(x));
        }
        for (k, u) in us.iter().enumerate().take(N) {
            z[lay.u(k, 0)..lay.u(k, 0) + NU].copy_from_slice(&scale_control(u));
        }
    }

    /// Physical states (N + 1) and controls (N) of a scaled decision vector, written into
    /// caller buffers (allocation-free).
    pub fn trajectory_into(&self, z: &[f64], xs: &mut [[f64; NX]], us: &mut [[f64; NU]]) {
        let lay = self.layout;
        for (k, x) in xs.iter_mut().enumerate().take(N + 1) {
            *x = unscale_state(&z[lay.x(k, 0)..lay.x(k, 0) + NX]);
        }
        for (k, u) in us.iter_mut().enumerate().take(N) {
            *u = unscale_control(&z[lay.u(k, 0)..lay.u(k, 0) + NU]);
        }
    }

    /// Physical states (N + 1) and controls (N) of a scaled decision vector.
    pub fn trajectory_from(&self, z: &[f64]) -> (Vec<[f64; NX]>, Vec<[f64; NU]>) {
        let mut xs = vec![[0.0; NX]; N + 1];
        let mut us = vec![[0.0; NU]; N];
        self.trajectory_into(z, &mut xs, &mut us);
        (xs, us)
    }

    /// Largest constraint violation at `z` in the scaled NLP's units: max over equality
    /// residuals, inequality excesses and variable-bound excesses (allocation-free).
    pub fn max_violation(&mut self, z: &[f64]) -> f64 {
        let mut g = std::mem::take(&mut self.g_buf);
        self.eval_g(z, &mut g);
        let mut v: f64 = 0.0;
        for ((gi, lo), hi) in g.iter().zip(&self.g_l).zip(&self.g_u) {
            v = v.max(lo - gi).max(gi - hi);
        }
        for (i, zi) in z.iter().enumerate() {
            v = v.max(self.x_l[i] - zi).max(zi - self.x_u[i]);
        }
        self.g_buf = g;
        v
    }

    /// Largest absolute scaled defect residual (dynamics only) at `z`.
    pub fn max_defect(&mut self, z: &[f64]) -> f64 {
        let mut g = std::mem::take(&mut self.g_buf);
        self.eval_g(z, &mut g);
        let mut v: f64 = 0.0;
        for st in &self.stages {
            for gi in &g[st.row_defect..st.row_defect + S::ROWS] {
                v = v.max(gi.abs());
            }
        }
        self.g_buf = g;
        v
    }

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

    /// Recomputes the variable and row bounds from the spec in place (allocation-free).
    fn refresh_bounds(&mut self) {
        let mut x_l = std::mem::take(&mut self.x_l);
        let mut x_u = std::mem::take(&mut self.x_u);
        let mut g_l = std::mem::take(&mut self.g_l);
        let mut g_u = std::mem::take(&mut self.g_u);
        self.compute_bounds(&mut x_l, &mut x_u, &mut g_l, &mut g_u);
        self.x_l = x_l;
        self.x_u = x_u;
        self.g_l = g_l;
        self.g_u = g_u;
    }

    /// Re-uses this instance for a new road of the same size: replaces k_ref, e_min and e_max
    /// at the N + 1 nodes in the spec and updates the bounds. Allocation-free; the
    /// constraint structure is unchanged (the solver reads bounds at the start of each
    /// solve). On a length mismatch nothing is changed.
    pub fn update_road(
        &mut self,
        kappa: &[f64],
        e_min: &[f64],
        e_max: &[f64],
    ) -> Result<(), TranscriptionError> {
        for (field, len) in [
            ("kappa", kappa.len()),
            ("e_min", e_min.len()),
            ("e_max", e_max.len()),
        ] {
            if len != N + 1 {
                return Err(TranscriptionError::BadLength {
                    field,
                    expected: N + 1,
                    got: len,
                });
            }
        }
        self.spec.kappa.copy_from_slice(kappa);
        self.spec.e_min.copy_from_slice(e_min);
        self.spec.e_max.copy_from_slice(e_max);
        self.refresh_bounds();
        Ok(())
    }

    /// Switches the initial-state treatment (Free or Fixed(x0)) without changing the
    /// constraint structure: all nine initial-condition rows always exist and only their
    /// bounds change (see [`initial_row_bounds`]). Allocation-free.
    pub fn set_initial(&mut self, initial: InitialState) {
        self.spec.initial = initial;
        self.refresh_bounds();
    }

    fn compute_bounds(&self, x_l: &mut [f64], x_u: &mut [f64], g_l: &mut [f64], g_u: &mut [f64]) {
        let p = &self.spec.vehicle;
        variable_bounds(&self.layout, &self.spec, x_l, x_u);
        for (r, &i) in INITIAL_ROWS.iter().enumerate() {
            (g_l[r], g_u[r]) = initial_row_bounds(&self.spec, i);
        }
        for (k, st) in self.stages.iter().enumerate() {
            g_l[st.row_defect..st.row_defect + S::ROWS].fill(0.0);
            g_u[st.row_defect..st.row_defect + S::ROWS].fill(0.0);
            g_l[st.row_friction..st.row_friction + FRICTION_ROWS].fill(0.0);
            g_u[st.row_friction..st.row_friction + FRICTION_ROWS].fill(f64::INFINITY);
            if self.spec.enforce_tire_saturation {
                g_l[st.row_sat..st.row_sat + SATURATION_ROWS].fill(f64::NEG_INFINITY);
                g_u[st.row_sat..st.row_sat + SATURATION_ROWS]
                    .fill(p.eps_sat / saturation_scale(&self.spec.initial));
                // With a fixed (measured) x_0 the rear slip at node 0 depends on x_0 alone: a
                // car that is already sliding would make the problem infeasible whatever the
                // controls. That row gets a bound it never reaches (the front row stays: the
                // steering controls its slip).
                if k == 0 && matches!(self.spec.initial, InitialState::Fixed(_)) {
                    g_u[st.row_sat + 1] = SATURATION_FIXED_X0_BOUND;
                }
            }
            if k >= 1 {
                rate_row_bounds(
                    &mut g_l[st.row_rate..st.row_rate + RATE_ROWS],
                    &mut g_u[st.row_rate..st.row_rate + RATE_ROWS],
                );
            }
        }
    }
}

impl<const N: usize> Transcription<ImplicitEuler, N> {
    /// Builds the implicit-Euler transcription of `spec`.
    pub fn new(spec: OcpSpec) -> Result<Self, TranscriptionError> {
        Self::with_scheme(spec, ImplicitEuler)
    }
}

impl<S: DefectScheme, const N: usize> Nlp for Transcription<S, N> {
    fn dims(&self) -> NlpDims {
        NlpDims {
            n: self.layout.n(),
            m: self.m,
            nnz_jac: self.jac_rows.len(),
            nnz_hess: self.hess_rows.len(),
        }
    }

    fn bounds(&self, x_l: &mut [f64], x_u: &mut [f64], g_l: &mut [f64], g_u: &mut [f64]) {
        x_l.copy_from_slice(&self.x_l);
        x_u.copy_from_slice(&self.x_u);
        g_l.copy_from_slice(&self.g_l);
        g_u.copy_from_slice(&self.g_u);
    }

    fn initial_point(&self, x: &mut [f64]) {
        x.copy_from_slice(&self.z0);
    }

    fn jac_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        rows.copy_from_slice(&self.jac_rows);
        cols.copy_from_slice(&self.jac_cols);
    }

    fn hess_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        rows.copy_from_slice(&self.hess_rows);
        cols.copy_from_slice(&self.hess_cols);
    }

    /// Objective t_N / OBJECTIVE_SCALE (= 10 t_N), plus the steering-slew term ([`Objective`]).
    fn eval_f(&mut self, x: &[f64]) -> f64 {
        self.objective.value(x)
    }

    fn eval_grad_f(&mut self, x: &[f64], grad: &mut [f64]) {
        self.objective.gradient(x, grad);
    }

    fn eval_g(&mut self, x: &[f64], g: &mut [f64]) {
        let this = &*self;
        let lay = &this.layout;
        for (r, &i) in INITIAL_ROWS.iter().enumerate() {
            g[r] = x[lay.x(0, i)];
        }
        this.for_stages(
            g,
            |st| st.row_defect,
            |k, out, off| this.stage_for_cpu(StageEval::Rows, x, k, out, off),
        );
    }

    fn eval_jac_g(&mut self, x: &[f64], vals: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if self.simd {
            // SAFETY: `simd` is only true when the CPU reports AVX2.
            return unsafe { self.eval_jac_avx2(x, vals) };
        }
        self.eval_jac_body(x, vals)
    }

    /// Stages z_k = (x_k, u_k) for single-step schemes (no stage variables); the Riccati
    /// backend checks at setup that the defects couple only x_k, u_k and x_{k+1}.
    fn stage_structure(&self) -> Option<StageStructure> {
        if S::STAGE_VARS != 0 || S::ROWS != NX {
            return None;
        }
        let rows = self
            .rows
            .iter()
            .map(|r| match r.kind {
                RowKind::Initial { .. } => RowRole::Initial,
                RowKind::Defect { row } => RowRole::Dynamics {
                    stage: r.node,
                    index: row,
                },
                _ => RowRole::Path,
            })
            .collect();
        Some(StageStructure {
            n_stages: N,
            nx: NX,
            nu: NU,
            rows,
        })
    }

    /// Hessian of `obj_factor f + lambda^T g`: the defect and saturation rows (all other
    /// rows are linear) and the objective's constant steering-slew term.
    fn eval_hess(&mut self, x: &[f64], obj_factor: f64, lambda: &[f64], vals: &mut [f64]) {
        self.eval_hess_for_cpu(x, lambda, vals);
        // The objective's only curvature: the steering-slew term, constant.
        self.objective.add_hessian(obj_factor, vals);
    }
}

impl<S: DefectScheme, const N: usize> Transcription<S, N> {
    /// The constraints' Hessian terms (overwrites `vals`) in the copy compiled for this CPU.
    fn eval_hess_for_cpu(&mut self, x: &[f64], lambda: &[f64], vals: &mut [f64]) {
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
        let sat = |k: usize| {
            self.hess_sat_slots
                .get(k * SATURATION_HESS_NNZ..(k + 1) * SATURATION_HESS_NNZ)
                .unwrap_or(&[])
        };
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

    /// Jacobian values, inlined into both the baseline and the AVX2 entry point.
    #[inline(always)]
    fn eval_jac_body(&mut self, x: &[f64], vals: &mut [f64]) {
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
                if self.spec.enforce_tire_saturation {
                    self.saturation_rows()
                        .eval(k, x, &mut out[st.row_sat - off..]);
                }
                if k >= 1 {
                    rate_eval(p, lay, k, x, &mut out[st.row_rate - off..]);
                }
            }
            StageEval::Jacobian => {
                let (d, len) = (st.jac_defect - off, self.jac_defect_len[k]);
                self.scheme.jac(&cx, k, x, &mut out[d..d + len]);
                friction_jac(p, &mut out[st.jac_friction - off..]);
                if self.spec.enforce_tire_saturation {
                    let (rows, out) = (self.saturation_rows(), &mut out[st.jac_sat - off..]);
                    if cx.oracle {
                        rows.jac(k, x, out);
                    } else {
                        rows.jac_fast(k, x, out);
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
    fn stage_for_cpu(&self, what: StageEval, x: &[f64], k: usize, out: &mut [f64], off: usize) {
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
    fn for_stages(
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
    unsafe fn eval_jac_avx2(&mut self, x: &[f64], vals: &mut [f64]) {
        self.eval_jac_body(x, vals)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    unsafe fn eval_hess_avx2(&mut self, x: &[f64], lambda: &[f64], vals: &mut [f64]) {
        self.eval_hess_body(x, lambda, vals)
    }

    /// Evaluates derivatives in the AVX2-compiled copy when `on` and the CPU has AVX2, else
    /// in the baseline one (default: AVX2 where available). Both give the same bits.
    pub fn set_simd(&mut self, on: bool) {
        self.simd = on && crate::cpu::avx2_available();
    }
}
