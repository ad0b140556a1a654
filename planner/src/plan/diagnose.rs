//! Where a solve stands against its constraints: the rows violated most at a point, and
//! the point a solve starts from. For reports (`trajopt solve`, `replay run --log-plan`),
//! not the hot path: these allocate.

use super::Planner;
use crate::ip::Nlp;

impl<const N: usize> Planner<N> {
    /// The `count` constraint rows violated most at the NLP point `x` (variables in the
    /// transcription's order, e.g. [`crate::ip::Solver::x`]), named (e.g.
    /// `defect[V]@7`) with their violation, largest first; rows within their bounds are
    /// left out.
    pub fn worst_rows(&mut self, x: &[f64], count: usize) -> Vec<(String, f64)> {
        let nlp = &mut self.nlp;
        let d = nlp.dims();
        if x.len() != d.n {
            return Vec::new();
        }
        let (mut xl, mut xu) = (vec![0.0; d.n], vec![0.0; d.n]);
        let (mut gl, mut gu, mut g) = (vec![0.0; d.m], vec![0.0; d.m], vec![0.0; d.m]);
        nlp.bounds(&mut xl, &mut xu, &mut gl, &mut gu);
        nlp.eval_g(x, &mut g);
        let mut rows: Vec<(usize, f64)> = (0..d.m)
            .map(|i| (i, (gl[i] - g[i]).max(g[i] - gu[i]).max(0.0)))
            .filter(|(_, v)| *v > 0.0)
            .collect();
        rows.sort_by(|a, b| b.1.total_cmp(&a.1));
        rows.truncate(count);
        rows.into_iter()
            .map(|(i, v)| (nlp.row_name(i), v))
            .collect()
    }

    /// The NLP point of the guess last written ([`Self::set_guess`], or the primal guess
    /// of a warm start), before the solver pushes it into the bounds.
    pub fn guess_point(&self) -> Vec<f64> {
        let mut x = vec![0.0; self.nlp.dims().n];
        self.nlp.initial_point(&mut x);
        x
    }
}
