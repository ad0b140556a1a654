//! Steps 1 and 2 together: the assembly units and the backward sweep, on one thread or
//! pipelined over a helper thread.
//!
//! The sweep reads unit k only at stage k, so the units can be written while it runs:
//! with a helper, the two take the units in chunks, in sweep order (N, N-1, .., 0), from
//! one counter ([`Claims`]). The helper writes the chunks it claims while this thread
//! sweeps, and the sweep writes the ones the helper has not claimed when it reaches them.
//! Without a helper each unit is written just before its stage. Which thread writes a unit
//! does not change its bits.

use super::assemble::Assembly;
use super::sweep::Sweep;
use super::RiccatiKkt;
use crate::ip::kkt::claims::{Acquired, Claims, CHUNK};
use crate::ip::kkt::{Inertia, KktError, KktValues};
use crate::worker::{self, SharedWorker};
use nalgebra::SMatrix;
use std::sync::atomic::{AtomicBool, Ordering};

impl<const NX: usize, const NU: usize, const NZ: usize> RiccatiKkt<NX, NU, NZ> {
    /// Steps 1 and 2, then step 3 ([`Self::factorize_initial`]): returns the inertia of
    /// the whole system. `negative_path` is the number of path rows, `stop_on_excess` as in
    /// [`super::sweep::check_excess`].
    #[inline(always)]
    pub(super) fn factorize_blocks(
        &mut self,
        v: &KktValues<'_>,
        negative_path: usize,
        stop_on_excess: bool,
    ) -> Result<Inertia, KktError> {
        let big = self.stages;
        if self.worker.is_some() {
            self.claims.reset();
        }
        let claims = &self.claims;
        let asm = Assembly::<NX, NZ> {
            units: &self.units,
            zero: &self.u_zero,
            jac: &self.u_jac,
            hess: &self.u_hess,
            diag: &self.u_diag,
            pairs: &self.u_pairs,
            path_wv: &self.path_wv,
            path_vals: &self.path_vals,
            jac_assign: self.jac_assign,
            hess_assign: self.hess_assign,
            stages: big,
            x_base: self.x_base,
            e_base: self.e_base,
            j_base: self.j_base,
            arena: self.arena.as_mut_ptr(),
            inverses: self.inverses.as_mut_ptr(),
            simd: self.simd,
        };
        let sweep = Sweep {
            factors: &mut self.factors,
            delta: &self.delta,
            y_live: self.y_live,
            negative_path,
            stop_on_excess,
        };
        let (p, mut inertia) = match self.worker.as_mut() {
            None => sweep.run(&asm, |k| {
                // SAFETY: one thread; every unit is written once, before its stage reads it.
                unsafe { asm.unit_for_cpu(k, v) }
            })?,
            Some(shared) => {
                sweep_pipelined(shared, claims, &asm, sweep, v, self.helper_idle, self.simd)?
            }
        };
        self.factorize_initial(&p, &mut inertia)?;
        Ok(inertia)
    }
}

/// The sweep on this thread with the helper of `shared` writing units ahead of it: units
/// in sweep order, in chunks claimed by the helper or taken by the sweep ([`Claims`]). The
/// sweep stops the helper when it stops early; with `helper_idle` the helper claims
/// nothing (see [`RiccatiKkt::set_helper_idle`]).
#[inline(always)]
fn sweep_pipelined<const NX: usize, const NU: usize, const NZ: usize>(
    shared: &SharedWorker,
    claims: &Claims,
    asm: &Assembly<'_, NX, NZ>,
    sweep: Sweep<'_, NX, NU, NZ>,
    v: &KktValues<'_>,
    helper_idle: bool,
    simd: bool,
) -> Result<(SMatrix<f64, NX, NX>, Inertia), KktError> {
    let big = asm.stages;
    let cancel = AtomicBool::new(false);
    // Set if the helper's job panics, so the sweep stops waiting (and panics).
    let failed = AtomicBool::new(false);
    let chunk = |c: usize| {
        // SAFETY: the thread that claimed or took chunk c is the only one
        // writing its units, and the other reads them only after it is
        // published (release/acquire on its flag) or, for the sweep's own
        // chunks, after writing them itself.
        for i in c * CHUNK..((c + 1) * CHUNK).min(big + 1) {
            unsafe { asm.unit_for_cpu(big - i, v) };
        }
    };
    let mut job = || {
        let _flag = PanicFlag(&failed);
        if helper_idle {
            return;
        }
        while let Some(c) = claims.claim() {
            if cancel.load(Ordering::Relaxed) {
                break;
            }
            chunk(c);
            claims.publish(c);
        }
    };
    // The sweep can do every chunk itself, so a job the helper has not taken by
    // the end is withdrawn instead of waited for.
    worker::lock(shared).join_or_skip(&mut job, || {
        // Stops the helper however the sweep ends (result, early stop or panic).
        let _cancel = CancelOnDrop(&cancel);
        let mut have = 0;
        sweep.run_for_cpu(
            asm,
            |k| {
                let c = (big - k) / CHUNK;
                if c < have {
                    return;
                }
                match claims.acquire(c, || failed.load(Ordering::Acquire)) {
                    Acquired::Ready => {}
                    Acquired::Mine => chunk(c),
                    Acquired::Failed => {
                        panic!("the helper thread's assembly panicked")
                    }
                }
                have = c + 1;
            },
            simd,
        )
    })
}

/// Sets its flag when dropped during a panic (the pipelined factorization's helper job).
struct PanicFlag<'a>(&'a AtomicBool);

impl Drop for PanicFlag<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.store(true, Ordering::Release);
        }
    }
}

/// Sets the pipelined factorization's cancel flag when dropped.
struct CancelOnDrop<'a>(&'a AtomicBool);

impl Drop for CancelOnDrop<'_> {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Relaxed);
    }
}
