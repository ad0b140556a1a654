"""Solving from Python gives what `trajopt solve` gives: the golden statuses and iteration
counts, the trajectory as arrays of the horizon's shape with named columns."""

import numpy as np
import pytest

import trajopt
from conftest import CONFIG, golden


def test_the_oval_solves_with_the_golden_status_and_iteration_count(oval_solution):
    status, iterations = golden("oval", "planner")
    assert oval_solution.status == status == "optimal"
    assert oval_solution.success
    assert oval_solution.iterations == iterations


def test_the_pure_minimum_time_takes_its_own_solver_file_as_the_command_line_does(oval):
    sol = oval.solve(steering_slew_weight=0.0)
    assert (sol.status, sol.iterations) == golden("oval", "min_time")
    assert sol.steering_slew_weight == 0.0
    assert sol.solver_file.name == "solver_min_time.toml"


def test_the_zero_guess_reproduces_the_golden_zero_guess_solve(oval):
    sol = oval.solve(guess="zero")
    assert sol.guess == "zero"
    assert (sol.status, sol.iterations) == golden("oval_zero_guess", "planner")


def test_states_and_controls_have_the_horizon_shape_and_named_columns(oval_solution):
    n = trajopt.HORIZON
    sol = oval_solution
    assert sol.states.shape == (n + 1, 9)
    assert sol.controls.shape == (n, 3)
    assert sol.states.dtype == np.float64
    assert sol.state_names == ["r", "V", "beta", "V_wr", "dFz", "e", "dpsi", "s", "t"]
    assert sol.control_names == ["delta", "T_comb", "T_bf"]
    assert sol.state_names == trajopt.STATE_NAMES
    for j, name in enumerate(sol.state_names):
        np.testing.assert_array_equal(sol[name], sol.states[:, j])
    for j, name in enumerate(sol.control_names):
        np.testing.assert_array_equal(sol[name], sol.controls[:, j])
    with pytest.raises(KeyError, match="neither a state"):
        sol["speed"]


def test_the_trajectory_is_consistent_with_its_grid_and_bounds(oval, oval_solution):
    sol = oval_solution
    s = sol.s
    assert s.shape == (trajopt.HORIZON + 1,)
    assert s[0] == 0.0 and s[-1] == pytest.approx(oval.length_m)
    # The arc-length state runs on the node grid and time only grows along it.
    np.testing.assert_allclose(sol["s"], s, atol=1e-6)
    assert np.all(np.diff(sol["t"]) > 0)
    assert sol.t_final == sol["t"][-1]
    # Speed and lateral position stay inside their bounds (with the solver's tolerance).
    v_min, v_max = oval.speed_bounds
    assert np.all(sol["V"] >= v_min - 1e-6) and np.all(sol["V"] <= v_max + 1e-6)
    assert np.all(sol["e"] >= sol.e_min - 1e-6) and np.all(sol["e"] <= sol.e_max + 1e-6)
    assert sol.max_violation < 1e-6


def test_columns_are_the_command_lines_csv_table(oval_solution):
    cols = oval_solution.columns()
    assert list(cols) == [
        "k", "s_grid", "kappa", "r", "V", "beta", "V_wr", "dFz", "e", "dpsi", "s", "t",
        "delta", "T_comb", "T_bf", "e_min", "e_max", "s_track", "x", "y", "heading",
    ]
    assert all(len(v) == trajopt.HORIZON + 1 for v in cols.values())
    # Node N repeats the last control, as the CSV does.
    assert cols["delta"][-1] == cols["delta"][-2] == oval_solution["delta"][-1]


def test_times_are_reported_per_phase_in_seconds(oval_solution):
    t = oval_solution.times
    assert list(t) == ["evaluation", "factorization", "solve", "line_search", "total"]
    assert t["total"] == oval_solution.solve_time_s > 0
    assert t["evaluation"] + t["factorization"] + t["solve"] + t["line_search"] <= t["total"]


def test_an_iteration_cap_ends_the_solve_at_the_cap(oval):
    sol = oval.solve(max_iter=3)
    assert sol.status == "iteration_limit"
    assert sol.iterations == 3
    assert sol.best_iterate


def test_a_budget_too_small_for_one_iteration_ends_time_limit(oval):
    sol = oval.solve(budget_ms=1e-3)
    assert sol.status == "time_limit"
    assert not sol.success


def test_the_solver_options_of_the_command_line_are_applied(oval):
    sol = oval.solve(kkt="sparse", barrier="monotone", threads=1, tire_saturation=False)
    assert (sol.kkt, sol.barrier, sol.threads) == ("sparse", "monotone", 1)
    assert sol.tire_saturation is False
    assert sol.status == "optimal"


def test_segments_of_a_multi_entry_file_are_listed_and_loaded_by_name():
    path = CONFIG / "scenarios" / "segments.toml"
    names = trajopt.selections(path)
    assert names[:2] == ["S01", "S02"] and len(names) == 10
    sol = trajopt.load_scenario(path, segment="S03").solve()
    assert (sol.status, sol.iterations) == golden("S03", "planner")
