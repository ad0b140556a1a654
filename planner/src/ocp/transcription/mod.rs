//! Direct multiple-shooting transcriptions of the minimum-time OCP (paper eq. 3) as an
//! [`Nlp`](crate::ip::Nlp).
//!
//! The decision vector z holds the scaled states x_0..x_N and controls u_0..u_{N-1} at the
//! N + 1 nodes s_k = k ds (plus, for collocation schemes, stage states per interval); the
//! objective is t_N (plus the optional steering-slew term); the constraints are the initial
//! conditions, the dynamics as defect rows per interval, and the path constraints.
//!
//! [`Transcription`] owns everything that does not depend on the integrator: the variable
//! [`Layout`], scaling, bounds, objective, initial-condition rows and the path constraints
//! of [`crate::ocp::path_constraints`]. A [`DefectScheme`] supplies only the dynamics defect
//! rows of each interval (plus, for collocation schemes, its stage variables), so other
//! integrators (RK2/4, BDF, Crank-Nicolson, Gauss-Legendre) plug in without touching the
//! model, the shared constraints or the solver. [`CrankNicolson`], [`ExplicitRk2`],
//! [`ExplicitRk4`] and [`GaussLegendre2`] / [`GaussLegendre3`] (stage states as NLP
//! variables) share the formulas of [`steps`]; the multistep schemes BDF4-6 and
//! Adams-Moulton ([`LinearMultistep`]) reference the earlier nodes x_{k-q+1}..x_k in their
//! defect on interval k. Every scheme whose defect is linear in the states and in f at
//! points of the interval (implicit Euler, Crank-Nicolson, multistep, Gauss-Legendre) takes
//! its exact derivatives from the hand-written jets of f at each point (`point_jets`,
//! `point_form`); explicit RK, which nests f inside f, from lean jets carried through its
//! stages (`rk_jets`). The num-dual oracle checks them all ([`Derivatives::Oracle`]).
//!
//! The rows are ordered stage by stage: first the initial-condition rows, then for each
//! interval k = 0..N-1: the scheme's defect rows, the two front friction rows (R9), the two
//! saturation rows (R5, when enforced) and, for k >= 1, the six control-rate rows.
//!
//! The terminal condition s_N = length of paper eq. (3) is deliberately NOT a row: it follows
//! from s_0 = 0 and the linear s defects (ds/ds = 1), so adding it would make the constraint
//! Jacobian rank deficient (a redundant equality the interior-point solver cannot handle).
//!
//! The pieces: `scheme` (the integrator interface), `rows` (row layout and Jacobian
//! pattern), `sparsity` (Hessian pattern), `bounds`, `packing` (physical trajectories in and
//! out of z), `nlp` (the solver interface), `stage_eval` (rows and Jacobian values),
//! `hessian` (Hessian values) and `error`.

mod bounds;
pub mod crank_nicolson;
mod dense;
mod error;
pub mod explicit_rk;
pub mod gauss_legendre;
mod hessian;
pub mod implicit_euler;
pub mod multistep;
mod nlp;
mod one_step;
mod packing;
mod point_form;
mod point_jets;
mod rk_jets;
mod rows;
mod scheme;
mod sparsity;
mod stage_eval;
pub mod steps;

pub use bounds::SATURATION_RAMP_NODES;
pub use crank_nicolson::CrankNicolson;
pub use error::TranscriptionError;
pub use explicit_rk::{ExplicitRk2, ExplicitRk4};
pub use gauss_legendre::{GaussLegendre2, GaussLegendre3};
pub use implicit_euler::ImplicitEuler;
pub use multistep::{LinearMultistep, MultistepFamily};
pub use rows::{RowInfo, RowKind};
pub use scheme::{DefectScheme, Derivatives, SchemeContext};

use super::layout::Layout;
use super::objective::Objective;
use super::path_constraints::INITIAL_ROWS;
use super::spec::OcpSpec;
use crate::worker::SharedWorker;
use error::check_node_vectors;
use rows::{RowLayout, Stage};
use sparsity::{HessBlocks, HessBuilder};

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

/// The implicit-Euler transcription used by the paper's best solver pairing.
pub type ImplicitEulerNlp<const N: usize> = Transcription<ImplicitEuler, N>;

impl<S: DefectScheme, const N: usize> Transcription<S, N> {
    /// Builds the transcription (all structures and buffers) for `spec` with `scheme`.
    pub fn with_scheme(spec: OcpSpec, scheme: S) -> Result<Self, TranscriptionError> {
        if spec.n_intervals != N {
            return Err(TranscriptionError::WrongN {
                expected: N,
                got: spec.n_intervals,
            });
        }
        check_node_vectors::<N, _>([
            ("kappa", spec.kappa.len()),
            ("e_min", spec.e_min.len()),
            ("e_max", spec.e_max.len()),
        ])?;
        let layout = Layout::new(N, S::STAGE_VARS);
        let sat = spec.enforce_tire_saturation;
        let sat_end = sat && spec.saturation_at_end;
        let n_init = INITIAL_ROWS.len();
        let RowLayout {
            rows,
            jac_rows,
            jac_cols,
            stages,
            jac_defect_len,
        } = RowLayout::build::<S, N>(&scheme, layout, sat, sat_end);
        let m = rows.len();

        // Hessian: union of the defect and saturation blocks, deduplicated.
        let mut hb = HessBuilder::new();
        let HessBlocks {
            defect_off: hess_defect_off,
            defect_slots: hess_defect_slots,
            sat_slots: hess_sat_slots,
            max_block,
        } = HessBlocks::build::<S, N>(&scheme, layout, sat, sat_end, &mut hb);

        // The objective's steering-slew and lane-band entries (none when off: the pattern
        // is unchanged).
        let objective = Objective::new(
            layout,
            N,
            (spec.steering_slew_weight, spec.soft_lane.weight),
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

    /// The read-only data the defect scheme evaluates with.
    fn context(&self) -> SchemeContext<'_> {
        SchemeContext {
            vehicle: &self.spec.vehicle,
            ds: self.spec.ds(),
            kappa: &self.spec.kappa,
            layout: self.layout,
            oracle: self.derivatives == Derivatives::Oracle,
        }
    }
}

impl<const N: usize> Transcription<ImplicitEuler, N> {
    /// Builds the implicit-Euler transcription of `spec`.
    pub fn new(spec: OcpSpec) -> Result<Self, TranscriptionError> {
        Self::with_scheme(spec, ImplicitEuler)
    }
}

impl<S: DefectScheme, const N: usize> Transcription<S, N> {
    /// Evaluates derivatives in the AVX2-compiled copy when `on` and the CPU has AVX2, else
    /// in the baseline one (default: AVX2 where available). Both give the same bits.
    pub fn set_simd(&mut self, on: bool) {
        self.simd = on && crate::cpu::avx2_available();
    }
}
