//! Shared fixtures for the criterion benchmarks.

use planner::ip::Nlp;
use planner::ocp::fixtures::{oval_reference_path, oval_spec, ReferenceCsv};
use planner::ocp::ImplicitEulerNlp;

/// The oval implicit-Euler NLP (N = 100) and an evaluation point: the peer reference optimum
/// if `config/reference/oval_ie_ipopt.csv` is readable, else the default starting point.
pub fn oval_nlp_at_reference() -> (ImplicitEulerNlp<100>, Vec<f64>) {
    let nlp = ImplicitEulerNlp::<100>::new(oval_spec()).expect("oval spec has N = 100");
    let mut z = vec![0.0; nlp.dims().n];
    match ReferenceCsv::load(&oval_reference_path()) {
        Ok(csv) => {
            let (xs, us) = csv.trajectory();
            nlp.pack(&xs, &us, &mut z);
        }
        Err(_) => nlp.initial_point(&mut z),
    }
    (nlp, z)
}
