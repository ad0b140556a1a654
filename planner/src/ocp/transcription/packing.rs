//! Physical trajectories in and out of the scaled decision vector z (z = x / nominal, see
//! [`crate::ocp::scaling`]), and the starting point the solver reads.

use super::{DefectScheme, Transcription};
use crate::model::{NU, NX};
use crate::ocp::scaling::{scale_control, scale_state, unscale_control, unscale_state};

impl<S: DefectScheme, const N: usize> Transcription<S, N> {
    /// Default starting point: straight-line driving at 15 m/s (r = beta = dFz = e = dpsi = 0,
    /// V_wr = V, zero controls), s_k = k ds, t_k = s_k / 15 m/s; stage variables from the
    /// scheme.
    pub(super) fn default_guess(&mut self) {
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

    /// Sets the starting point returned by
    /// [`Nlp::initial_point`](crate::ip::Nlp::initial_point) from physical states (N + 1
    /// rows) and controls (N rows). Panics on wrong lengths.
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
}
