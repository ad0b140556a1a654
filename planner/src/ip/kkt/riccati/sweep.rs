//! The backward sweep (step 2) and the initial block (step 3), with the inertia they count.
//!
//! The sweep runs k = N-1 .. 0 over the assembled blocks, carrying P (the weight of the
//! eliminated future on x_{k+1}), Y^T (z_k's coupling to x_{k+1}) and the pending update
//! of W_k from u_{k+1}'s elimination; each stage is [`fast_stage`] or [`general_stage`].
//! The inertia adds up block by block: one negative eigenvalue per path row, the pair's
//! (NX - t, NX + t), Q_uu's pivot signs, and the initial block's Bunch-Kaufman pivots.

use super::assemble::Assembly;
use super::fast_stage::fast_stage;
use super::kernels::all_zero;
use super::stage::{general_stage, StageFactor};
use super::RiccatiKkt;
use crate::ip::kkt::{Inertia, KktError};
use faer::dyn_stack::MemStack;
use faer::linalg::cholesky::lblt;
use faer::Par;
use nalgebra::{SMatrix, SVector};

/// The backward sweep's own state (step 2).
pub(super) struct Sweep<'a, const NX: usize, const NU: usize, const NZ: usize> {
    pub(super) factors: &'a mut [StageFactor<NX, NU, NZ>],
    pub(super) delta: &'a [SVector<f64, NX>],
    pub(super) y_live: [bool; NZ],
    pub(super) negative_path: usize,
    pub(super) stop_on_excess: bool,
}

impl<const NX: usize, const NU: usize, const NZ: usize> Sweep<'_, NX, NU, NZ> {
    /// [`Self::run`] in the copy compiled for this CPU when `simd`: the pipelined
    /// factorization runs the sweep inside a closure, which does not take the target
    /// features of the AVX2 entry point it sits in. Same bits either way.
    #[inline(always)]
    pub(super) fn run_for_cpu(
        self,
        asm: &Assembly<'_, NX, NZ>,
        ready: impl FnMut(usize),
        simd: bool,
    ) -> Result<(SMatrix<f64, NX, NX>, Inertia), KktError> {
        #[cfg(target_arch = "x86_64")]
        if simd {
            // SAFETY: `simd` is only true when the CPU reports AVX2.
            return unsafe { self.run_avx2(asm, ready) };
        }
        let _ = simd;
        self.run(asm, ready)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    unsafe fn run_avx2(
        self,
        asm: &Assembly<'_, NX, NZ>,
        ready: impl FnMut(usize),
    ) -> Result<(SMatrix<f64, NX, NX>, Inertia), KktError> {
        self.run(asm, ready)
    }

    /// Sweeps k = N-1 .. 0, calling `ready(k)` before it reads unit k (and `ready(N)`
    /// first); returns P_0 and the inertia so far.
    #[inline(always)]
    pub(super) fn run(
        self,
        asm: &Assembly<'_, NX, NZ>,
        mut ready: impl FnMut(usize),
    ) -> Result<(SMatrix<f64, NX, NX>, Inertia), KktError> {
        let big = asm.stages;
        let (negative_path, stop_on_excess, y_live) =
            (self.negative_path, self.stop_on_excess, self.y_live);
        let mut inertia = Inertia {
            positive: 0,
            negative: negative_path,
            zero: 0,
        };
        ready(big);
        // SAFETY (every block read below): `ready(k)` returned, so unit k is written and
        // no thread writes it any more in this factorization.
        let mut p: SMatrix<f64, NX, NX> = unsafe { asm.w_block(big) }
            .fixed_view::<NX, NX>(0, 0)
            .into_owned();
        // Y^T: the coupling of z_k to x_{k+1}, stored transposed (NX x NZ, contiguous rows
        // of the X block).
        let mut yt: SMatrix<f64, NX, NZ> = unsafe { asm.x_block(big - 1) }
            .fixed_view::<NX, NZ>(0, 0)
            .into_owned();
        let mut pending: SMatrix<f64, NZ, NZ> = SMatrix::zeros();
        for k in (0..big).rev() {
            ready(k);
            let inv = unsafe { asm.inverse(k) }?;
            let mut q = unsafe { asm.w_block(k) } - pending;
            let e = unsafe { asm.e_block(k) };
            let j = unsafe { asm.j_block(k) };
            let prev = if k > 0 {
                Some(unsafe { asm.x_block(k - 1) })
            } else {
                None
            };
            let fac = &mut self.factors[k];
            let zero_delta = all_zero(self.delta[k].as_slice());
            let fast = zero_delta && inv.j_minus_identity;
            if fast {
                fast_stage(
                    fac,
                    &mut p,
                    &mut yt,
                    &mut pending,
                    inv,
                    j,
                    &mut q,
                    prev,
                    &y_live,
                    &mut inertia,
                )?;
            } else {
                general_stage(
                    fac,
                    &mut p,
                    &mut yt,
                    &mut pending,
                    inv,
                    e,
                    j,
                    &self.delta[k],
                    &mut q,
                    prev,
                    &mut inertia,
                )?;
            }
            check_excess::<NX>(stop_on_excess, &inertia, negative_path, big - k)?;
        }
        Ok((p, inertia))
    }
}

/// With `stop_on_excess` (the caller expects the correct inertia (n, m)):
/// [`KktError::WrongInertia`] once the path rows and `done` stages hold more negative pivots
/// than their share (one per path row, NX per pair step, none in Q_uu). Every block's
/// negative count is at least its share (the pair and the initial block have a nonsingular
/// off-diagonal E), and the shares add up to m, so an excess anywhere means the total
/// inertia is not (n, m).
#[inline(always)]
pub(super) fn check_excess<const NX: usize>(
    stop_on_excess: bool,
    inertia: &Inertia,
    negative_path: usize,
    done: usize,
) -> Result<(), KktError> {
    if stop_on_excess && inertia.negative > negative_path + done * NX {
        Err(KktError::WrongInertia)
    } else {
        Ok(())
    }
}

impl<const NX: usize, const NU: usize, const NZ: usize> RiccatiKkt<NX, NU, NZ> {
    /// E_k (the arena's copy).
    #[inline(always)]
    fn e_block(&self, k: usize) -> SMatrix<f64, NX, NX> {
        let o = self.e_base + k * NX * NX;
        SMatrix::from_column_slice(&self.arena[o..o + NX * NX])
    }

    /// The initial block [[P_0, E^T], [E, -Delta]] by Bunch-Kaufman (step 3).
    #[inline(always)]
    pub(super) fn factorize_initial(
        &mut self,
        p: &SMatrix<f64, NX, NX>,
        inertia: &mut Inertia,
    ) -> Result<(), KktError> {
        let big = self.stages;
        let e = self.e_block(big);
        let dl = self.delta[big];
        let a = &mut self.init;
        for c in 0..NX {
            for r in 0..NX {
                a[(r, c)] = p[(r, c)];
                a[(NX + r, c)] = e[(r, c)];
                a[(r, NX + c)] = e[(c, r)];
                a[(NX + r, NX + c)] = 0.0;
            }
            a[(NX + c, NX + c)] = -dl[c];
        }
        // faer leaves the subdiagonal entry of a pivot with a zero column untouched.
        self.init_sub.column_vector_mut().fill(0.0);
        lblt::factor::cholesky_in_place(
            self.init.as_mut(),
            self.init_sub.as_mut(),
            &mut self.init_perm,
            &mut self.init_perm_inv,
            Par::Seq,
            MemStack::new(&mut self.mem),
            Default::default(),
        );
        self.initial_inertia(inertia)?;
        let dim = 2 * NX;
        // faer's solve wants the unit lower factor.
        for c in 0..dim {
            self.init[(c, c)] = 1.0;
            for r in 0..c {
                self.init[(r, c)] = 0.0;
            }
        }
        Ok(())
    }

    /// Copies the pivots of the initial block's LBL^T into `init_diag` and adds their
    /// inertia (a 2 x 2 pivot by the sign of its determinant); a zero or non-finite pivot
    /// is a singular block.
    #[inline(always)]
    fn initial_inertia(&mut self, inertia: &mut Inertia) -> Result<(), KktError> {
        let dim = 2 * NX;
        let mut i = 0;
        while i < dim {
            let d = self.init[(i, i)];
            self.init_diag.column_vector_mut()[i] = d;
            let s = if i + 1 < dim {
                self.init_sub.column_vector()[i]
            } else {
                0.0
            };
            if s != 0.0 {
                let d2 = self.init[(i + 1, i + 1)];
                self.init_diag.column_vector_mut()[i + 1] = d2;
                let det = d * d2 - s * s;
                if !det.is_finite() || det == 0.0 {
                    return Err(KktError::Singular);
                } else if det < 0.0 {
                    inertia.positive += 1;
                    inertia.negative += 1;
                } else if d > 0.0 {
                    inertia.positive += 2;
                } else {
                    inertia.negative += 2;
                }
                i += 2;
            } else {
                if !d.is_finite() || d == 0.0 {
                    return Err(KktError::Singular);
                }
                if d > 0.0 {
                    inertia.positive += 1;
                } else {
                    inertia.negative += 1;
                }
                i += 1;
            }
        }
        Ok(())
    }
}
