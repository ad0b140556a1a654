//! Assembly of the stage blocks, with the path inequalities condensed into them (step 1).
//!
//! A path row r (an inequality with dual diagonal D_c,r < 0) is eliminated into the primal
//! blocks before the sweep: W += J_r^T J_r / |D_c,r| (X for the pairs of entries on two
//! neighbouring stages), which adds one negative eigenvalue per row. The blocks are written
//! into one arena, unit by unit ([`super::setup::Unit`]): unit k holds everything the sweep
//! reads at stage k, so the sweep can start on a unit as soon as it is written, and each
//! entry sums its terms in the same order whichever thread writes its unit.

use super::inverse::invert_unit_tail_t;
use super::kernels::{block_ref, minus_identity_head, same_bits};
use super::setup::{Row, Unit, UnitPair};
use super::stage::StageInverse;
use super::RiccatiKkt;
use crate::ip::kkt::{KktError, KktValues};
use nalgebra::SMatrix;

impl<const NX: usize, const NU: usize, const NZ: usize> RiccatiKkt<NX, NU, NZ> {
    /// The row terms of the KKT values (Delta of the dynamics and initial rows, the path
    /// rows' weights and Jacobian values); the blocks follow unit by unit
    /// ([`Assembly::unit`]). Returns the number of path rows (one negative eigenvalue
    /// each).
    #[inline(always)]
    pub(super) fn prepare(&mut self, v: &KktValues<'_>) -> Result<usize, KktError> {
        let big = self.stages;
        for (r, &d) in v.dual_diag.iter().enumerate() {
            match self.rows[r] {
                Row::Dynamics(k, i) => self.delta[k as usize][i as usize] = -d,
                Row::Initial(i) => self.delta[big][i as usize] = -d,
                Row::Path(p) => {
                    if d.is_nan() || d >= 0.0 {
                        return Err(KktError::Unsupported);
                    }
                    self.path_w[p as usize] = -1.0 / d;
                }
            }
        }
        for (val, e) in self.path_vals.iter_mut().zip(&self.path_entries) {
            *val = v.jac[e.jac];
        }
        for (pr, &w) in self.path_rows.iter().zip(&self.path_w) {
            for (wv, &val) in self.path_wv[pr.start..pr.end]
                .iter_mut()
                .zip(&self.path_vals[pr.start..pr.end])
            {
                *wv = w * val;
            }
        }
        Ok(self.path_rows.len())
    }
}

/// What writes the units: the op lists, read-only, and raw pointers to the arena and the
/// stage inverses. With a helper, each chunk of units is written by the one thread that
/// claimed or took it, and the sweep reads a helper's chunk only after it is published
/// ([`Claims`](crate::ip::kkt::claims::Claims): disjoint memory, release/acquire per
/// chunk). Never a reference to the
/// whole arena while both threads run.
pub(super) struct Assembly<'a, const NX: usize, const NZ: usize> {
    pub(super) units: &'a [Unit],
    pub(super) zero: &'a [(u32, u32)],
    pub(super) jac: &'a [(u32, u32)],
    pub(super) hess: &'a [(u32, u32)],
    pub(super) diag: &'a [(u32, u32)],
    pub(super) pairs: &'a [UnitPair],
    pub(super) path_wv: &'a [f64],
    pub(super) path_vals: &'a [f64],
    pub(super) jac_assign: bool,
    pub(super) hess_assign: bool,
    pub(super) stages: usize,
    pub(super) x_base: usize,
    pub(super) e_base: usize,
    pub(super) j_base: usize,
    pub(super) arena: *mut f64,
    pub(super) inverses: *mut StageInverse<NX>,
    /// Write the units in the AVX2-compiled copy ([`Self::unit_for_cpu`]).
    pub(super) simd: bool,
}

// SAFETY: shared between the sweep and the helper only under the protocol described on the
// type (each unit's memory is written by one thread before the other reads it).
unsafe impl<const NX: usize, const NZ: usize> Sync for Assembly<'_, NX, NZ> {}

impl<const NX: usize, const NZ: usize> Assembly<'_, NX, NZ> {
    /// Writes unit `k` (see [`Unit`]): zeroes, Jacobian and Hessian values, the primal
    /// diagonal, then W += J_r^T J_r / |D_c| over the path rows (X for pairs across two
    /// stages); for a stage unit also E_k^-1 (reused while E_k keeps its bits).
    ///
    /// # Safety
    /// No other thread accesses unit `k`'s arena entries or inverse meanwhile.
    #[inline(always)]
    unsafe fn unit(&self, k: usize, v: &KktValues<'_>) {
        let u = self.units[k];
        let a = self.arena;
        let span = |r: (u32, u32)| r.0 as usize..r.1 as usize;
        for &(t, len) in &self.zero[span(u.zero)] {
            if len == 1 {
                *a.add(t as usize) = 0.0;
            } else {
                // All-zero bits are +0.0.
                std::ptr::write_bytes(a.add(t as usize), 0, len as usize);
            }
        }
        let jac = &self.jac[span(u.jac)];
        if self.jac_assign {
            for &(q, t) in jac {
                *a.add(t as usize) = v.jac[q as usize];
            }
        } else {
            for &(q, t) in jac {
                *a.add(t as usize) += v.jac[q as usize];
            }
        }
        let hess = &self.hess[span(u.hess)];
        if self.hess_assign {
            // 0 + h, not h: the bits of the summed version, signed zeros too.
            for &(q, t) in hess {
                *a.add(t as usize) = 0.0 + v.hess[q as usize];
            }
        } else {
            for &(q, t) in hess {
                *a.add(t as usize) += v.hess[q as usize];
            }
        }
        for &(i, t) in &self.diag[span(u.diag)] {
            *a.add(t as usize) += v.primal_diag[i as usize];
        }
        // SAFETY (indices): `a` and `b` index path entries, built with `path_wv` and
        // `path_vals` of the same length at setup.
        for pp in &self.pairs[span(u.pairs)] {
            *a.add(pp.target as usize) += *self.path_wv.get_unchecked(pp.a as usize)
                * *self.path_vals.get_unchecked(pp.b as usize);
        }
        // W_k's upper triangle from its lower one (the sweep reads whole blocks).
        let w = a.add(k * NZ * NZ);
        for c in 0..NZ {
            for r in c + 1..NZ {
                *w.add(r * NZ + c) = *w.add(c * NZ + r);
            }
        }
        if k < self.stages {
            let e = std::slice::from_raw_parts(a.add(self.e_base + k * NX * NX), NX * NX);
            let inv = &mut *self.inverses.add(k);
            inv.j_minus_identity = minus_identity_head(self.j_block(k));
            if same_bits(inv.e_in.as_slice(), e) {
                inv.ok = true;
            } else {
                let e = SMatrix::<f64, NX, NX>::from_column_slice(e);
                if let Some(ft) = invert_unit_tail_t(&e) {
                    inv.ft = ft;
                    inv.e_in = e;
                    inv.ok = true;
                } else {
                    inv.ok = false;
                }
            }
        }
    }

    /// [`Self::unit`] in the copy compiled for this CPU. The sweep's and the helper's
    /// callbacks are closures, and a closure does not take the target features of the AVX2
    /// entry point it is inlined into: called directly from them, the assembly (E_k^-1
    /// included) would run as baseline code. Same bits either way.
    ///
    /// # Safety
    /// As [`Self::unit`].
    #[inline(always)]
    pub(super) unsafe fn unit_for_cpu(&self, k: usize, v: &KktValues<'_>) {
        #[cfg(target_arch = "x86_64")]
        if self.simd {
            // SAFETY: `simd` is only true when the CPU reports AVX2; the caller upholds
            // `unit`'s contract.
            return self.unit_avx2(k, v);
        }
        self.unit(k, v)
    }

    /// # Safety
    /// The CPU has AVX2; as [`Self::unit`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    unsafe fn unit_avx2(&self, k: usize, v: &KktValues<'_>) {
        self.unit(k, v)
    }

    /// `len` arena entries from `o`.
    ///
    /// # Safety
    /// Their unit is written and no thread writes it meanwhile.
    #[inline(always)]
    unsafe fn slice(&self, o: usize, len: usize) -> &[f64] {
        std::slice::from_raw_parts(self.arena.add(o), len)
    }

    /// W_k (both triangles, see [`Self::unit`]), in place. Safety: as [`Self::slice`].
    #[inline(always)]
    pub(super) unsafe fn w_block(&self, k: usize) -> &SMatrix<f64, NZ, NZ> {
        block_ref(self.slice(k * NZ * NZ, NZ * NZ))
    }

    /// X_k, in place. Safety: as [`Self::slice`].
    #[inline(always)]
    pub(super) unsafe fn x_block(&self, k: usize) -> &SMatrix<f64, NZ, NZ> {
        block_ref(self.slice(self.x_base + k * NZ * NZ, NZ * NZ))
    }

    /// E_k, in place. Safety: as [`Self::slice`].
    #[inline(always)]
    pub(super) unsafe fn e_block(&self, k: usize) -> &SMatrix<f64, NX, NX> {
        block_ref(self.slice(self.e_base + k * NX * NX, NX * NX))
    }

    /// J_k, in place. Safety: as [`Self::slice`].
    #[inline(always)]
    pub(super) unsafe fn j_block(&self, k: usize) -> &SMatrix<f64, NX, NZ> {
        block_ref(self.slice(self.j_base + k * NX * NZ, NX * NZ))
    }

    /// F^T = E_k^-T and whether J_k = [-I, G], or `Unsupported` when E_k is singular. Safety: as
    /// [`Self::slice`].
    #[inline(always)]
    pub(super) unsafe fn inverse(&self, k: usize) -> Result<&StageInverse<NX>, KktError> {
        let inv = &*self.inverses.add(k);
        if inv.ok {
            Ok(inv)
        } else {
            Err(KktError::Unsupported)
        }
    }
}
