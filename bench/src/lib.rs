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

/// A planner for a shipped scenario (`config/` of this repository), with the shipped solver
/// settings. `select` picks a segment or collision-avoidance scenario.
pub fn planner_for(scenario: &str, select: Option<&str>) -> planner::plan::Planner<100> {
    planner_for_with(scenario, select, |_, _| {})
}

/// As [`planner_for`], with the scenario spec and solver settings adjusted by `edit` before
/// the planner is built.
pub fn planner_for_with(
    scenario: &str,
    select: Option<&str>,
    edit: impl FnOnce(&mut planner::ocp::OcpSpec, &mut planner::ip::Settings),
) -> planner::plan::Planner<100> {
    let root = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let vehicle = planner::config::load_vehicle(&root.join("vehicles/lc500.toml"))
        .expect("shipped vehicle file loads");
    let mut spec =
        planner::config::load_scenario(&root.join("scenarios").join(scenario), select, vehicle)
            .expect("shipped scenario loads");
    let mut settings =
        planner::config::load_solver(&root.join("solver.toml")).expect("shipped solver file loads");
    edit(&mut spec, &mut settings);
    planner::plan::Planner::<100>::new(spec, settings).expect("planner builds")
}
