//! A full NLP evaluation (f, grad, g, jac, hess) and max_violation allocate nothing after
//! construction (N = 100).

use planner::ip::Nlp;
use planner::ocp::fixtures::oval_spec;
use planner::ocp::ImplicitEulerNlp;

#[test]
fn evaluation_does_not_allocate() {
    let mut nlp = ImplicitEulerNlp::<100>::new(oval_spec()).unwrap();
    let d = nlp.dims();
    let mut z = vec![0.0; d.n];
    nlp.initial_point(&mut z);
    let mut grad = vec![0.0; d.n];
    let mut g = vec![0.0; d.m];
    let mut jac = vec![0.0; d.nnz_jac];
    let mut hess = vec![0.0; d.nnz_hess];
    let lambda: Vec<f64> = (0..d.m).map(|i| ((i % 7) as f64 - 3.0) * 0.1).collect();
    let mut run = |nlp: &mut ImplicitEulerNlp<100>| {
        let f = nlp.eval_f(&z);
        nlp.eval_grad_f(&z, &mut grad);
        nlp.eval_g(&z, &mut g);
        nlp.eval_jac_g(&z, &mut jac);
        nlp.eval_hess(&z, 1.0, &lambda, &mut hess);
        f + nlp.max_violation(&z)
    };
    run(&mut nlp); // warm-up
    let info = allocation_counter::measure(|| {
        std::hint::black_box(run(&mut nlp));
    });
    assert_eq!(info.count_total, 0, "{info:?}");
    // The measurement itself works: an allocation would be seen.
    let info = allocation_counter::measure(|| {
        std::hint::black_box(nlp.trajectory_from(&z));
    });
    assert!(info.count_total > 0);
    assert!(hess.iter().any(|v| *v != 0.0) && jac.iter().any(|v| *v != 0.0));
}
