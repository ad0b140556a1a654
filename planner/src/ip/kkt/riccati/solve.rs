//! Solves with the stage factors: the path rows gathered into the right-hand side, a
//! forward substitution in elimination order (k = N-1 .. 0), the initial block, a backward
//! substitution (k = 0 .. N-1), and the path rows' multipliers from
//! dy_r = (r_c,r - J_r dx) / D_c,r.
//!
//! Per stage the pair's M^-1 is applied as in its factorization ([`apply_pair`]); every
//! product keeps the summation order of the nalgebra product it stands for (see
//! [`super::kernels`]), so the solve has the same bits in the baseline and the AVX2 copy.

use super::kernels::{block_ref, j_mul, jt_mul, ldlt_solve_vec, mtv, mtv_t, mv, mv_rows_t};
use super::setup::Row;
use super::stage::StageFactor;
use super::RiccatiKkt;
use faer::dyn_stack::MemStack;
use faer::linalg::cholesky::lblt;
use faer::{Conj, Par};
use nalgebra::{SMatrix, SVector};

impl<const NX: usize, const NU: usize, const NZ: usize> RiccatiKkt<NX, NU, NZ> {
    /// The solve, inlined into both entry points ([`super::RiccatiKkt`]'s `solve`).
    #[inline(always)]
    pub(super) fn solve_body(&mut self, rhs_x: &mut [f64], rhs_y: &mut [f64]) {
        if !self.factorized {
            return;
        }
        // Every path row's right-hand side is read into `path_t` below.
        debug_assert_eq!((rhs_x.len(), rhs_y.len()), (self.n, self.m), "rhs lengths");
        self.gather(rhs_x, rhs_y);
        self.forward_substitution();
        self.solve_initial();
        self.backward_substitution();
        self.scatter(rhs_x, rhs_y);
    }

    /// J_k in the arena, in place (the solves read it there: it keeps its values until the
    /// next assembly).
    #[inline(always)]
    fn j_in(arena: &[f64], j_base: usize, k: usize) -> &SMatrix<f64, NX, NZ> {
        let o = j_base + k * NX * NZ;
        block_ref(&arena[o..o + NX * NZ])
    }

    /// Reads the right-hand side into the stage vectors, the path rows eliminated:
    /// r_x += J_r^T r_c,r / |D_c|.
    #[inline(always)]
    fn gather(&mut self, rhs_x: &[f64], rhs_y: &[f64]) {
        let big = self.stages;
        for (b, chunk) in self.bz.iter_mut().zip(rhs_x.chunks(NZ)) {
            b.as_mut_slice()[..chunk.len()].copy_from_slice(chunk);
        }
        for (r, &v) in rhs_y.iter().enumerate() {
            match self.rows[r] {
                Row::Dynamics(k, i) => self.bl[k as usize][i as usize] = v,
                Row::Initial(i) => self.bl[big][i as usize] = v,
                Row::Path(p) => self.path_t[p as usize] = v * self.path_w[p as usize],
            }
        }
        let mut start = 0;
        for &(stage, local, end) in &self.gather_targets {
            let b = &mut self.bz[stage as usize][local as usize];
            let mut acc = *b;
            for &(e, p) in &self.gather_terms[start..end as usize] {
                acc += self.path_t[p as usize] * self.path_vals[e as usize];
            }
            *b = acc;
            start = end as usize;
        }
    }

    /// Forward substitution in elimination order.
    #[inline(always)]
    fn forward_substitution(&mut self) {
        let big = self.stages;
        for k in (0..big).rev() {
            let (fac, inv) = (&self.factors[k], &self.inverses[k]);
            let j = Self::j_in(&self.arena, self.j_base, k);
            let r1: SVector<f64, NX> = self.bz[k + 1].fixed_rows::<NX>(0).into_owned();
            let (x, lambda) = apply_pair(fac, &inv.ft, &r1, &self.bl[k]);
            let upd =
                mv_rows_t(&fac.yt, &x, &self.y_live) + jt_mul(j, inv.j_minus_identity, &lambda);
            self.bz[k] -= upd;
            let mut t: SVector<f64, NU> = self.bz[k].fixed_rows::<NU>(NX).into_owned();
            ldlt_solve_vec(&fac.quu_l, &fac.quu_d, &mut t);
            let ux = mtv(&fac.q_ux, &t);
            let mut head = self.bz[k].fixed_rows_mut::<NX>(0);
            head -= ux;
            if k > 0 {
                let ur = mv(&fac.r, &t);
                self.bz[k - 1] -= ur;
            }
        }
    }

    /// The initial block, with the LBL^T factors of [`Self::factorize_initial`].
    #[inline(always)]
    fn solve_initial(&mut self) {
        let big = self.stages;
        for i in 0..NX {
            self.init_rhs[(i, 0)] = self.bz[0][i];
            self.init_rhs[(NX + i, 0)] = self.bl[big][i];
        }
        let perm = faer::perm::PermRef::new_checked(&self.init_perm, &self.init_perm_inv, 2 * NX);
        lblt::solve::solve_in_place_with_conj(
            self.init.as_ref(),
            self.init_diag.as_ref(),
            self.init_sub.as_ref(),
            Conj::No,
            perm,
            self.init_rhs.as_mut(),
            Par::Seq,
            MemStack::new(&mut self.mem),
        );
        for i in 0..NX {
            self.bz[0][i] = self.init_rhs[(i, 0)];
            self.bl[big][i] = self.init_rhs[(NX + i, 0)];
        }
    }

    /// Backward substitution.
    #[inline(always)]
    fn backward_substitution(&mut self) {
        let big = self.stages;
        for k in 0..big {
            let (fac, inv) = (&self.factors[k], &self.inverses[k]);
            let j = Self::j_in(&self.arena, self.j_base, k);
            let x: SVector<f64, NX> = self.bz[k].fixed_rows::<NX>(0).into_owned();
            let mut t: SVector<f64, NU> = self.bz[k].fixed_rows::<NU>(NX) - mv(&fac.q_ux, &x);
            if k > 0 {
                t -= mtv(&fac.r, &self.bz[k - 1]);
            }
            ldlt_solve_vec(&fac.quu_l, &fac.quu_d, &mut t);
            self.bz[k].fixed_rows_mut::<NU>(NX).copy_from(&t);
            let z = self.bz[k];
            let r1: SVector<f64, NX> = self.bz[k + 1].fixed_rows::<NX>(0) - mtv_t(&fac.yt, &z);
            let r2 = self.bl[k] - j_mul(j, inv.j_minus_identity, &z);
            let (xn, lambda) = apply_pair(fac, &inv.ft, &r1, &r2);
            self.bz[k + 1].fixed_rows_mut::<NX>(0).copy_from(&xn);
            self.bl[k] = lambda;
        }
    }

    /// Writes the solution back; path-row multipliers from dy_r = (r_c,r - J_r dx) / D_c.
    #[inline(always)]
    fn scatter(&self, rhs_x: &mut [f64], rhs_y: &mut [f64]) {
        let big = self.stages;
        for (chunk, b) in rhs_x.chunks_mut(NZ).zip(&self.bz) {
            chunk.copy_from_slice(&b.as_slice()[..chunk.len()]);
        }
        for (r, out) in rhs_y.iter_mut().enumerate() {
            *out = match self.rows[r] {
                Row::Dynamics(k, i) => self.bl[k as usize][i as usize],
                Row::Initial(i) => self.bl[big][i as usize],
                Row::Path(p) => {
                    let pr = self.path_rows[p as usize];
                    let mut jdx = 0.0;
                    for (e, &jv) in self.path_entries[pr.start..pr.end]
                        .iter()
                        .zip(&self.path_vals[pr.start..pr.end])
                    {
                        jdx += jv * self.bz[e.stage as usize][e.local as usize];
                    }
                    -(*out - jdx) * self.path_w[p as usize]
                }
            };
        }
    }
}

/// Applies the pair's M^-1 to (r1, r2): returns (x_{k+1}, lambda_k). `ft` is F^T.
#[inline(always)]
fn apply_pair<const NX: usize, const NU: usize, const NZ: usize>(
    fac: &StageFactor<NX, NU, NZ>,
    ft: &SMatrix<f64, NX, NX>,
    r1: &SVector<f64, NX>,
    r2: &SVector<f64, NX>,
) -> (SVector<f64, NX>, SVector<f64, NX>) {
    if fac.lambda_first {
        // (P + E^T E / delta) x = r1 + E^T r2 / delta, lambda = (E x - r2) / delta.
        let mut x = r1 + mtv(&fac.e, r2) / fac.delta;
        ldlt_solve_vec(&fac.sx_l, &fac.sx_d, &mut x);
        let lambda = (mv(&fac.e, &x) - r2) / fac.delta;
        return (x, lambda);
    }
    // [[P^, I], [I, -Delta]]^-1 applied to (F^T r1, r2) gives (a, lambda), x = F a.
    let all = [true; NX];
    let q1 = mtv_t(ft, r1);
    if fac.zero_delta {
        (mv_rows_t(ft, r2, &all), q1 + mv(&fac.a22, r2))
    } else {
        let a = mv(&fac.a11, &q1) + mv(&fac.a12, r2);
        let b = mtv(&fac.a12, &q1) + mv(&fac.a22, r2);
        (mv_rows_t(ft, &a, &all), b)
    }
}
