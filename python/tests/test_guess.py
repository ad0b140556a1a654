"""The equilibrium guess (paper eq. 8): a steady straight-line state with vanishing rates,
the one the planner starts from and spreads over the horizon."""

import numpy as np
import pytest

import trajopt


def test_the_problems_equilibrium_is_the_one_its_solve_started_from(oval, oval_solution):
    eq = oval.equilibrium_guess()
    assert eq.status == oval_solution.equilibrium.status
    np.testing.assert_array_equal(eq.x, oval_solution.equilibrium.x)
    np.testing.assert_array_equal(eq.u, oval_solution.equilibrium.u)
    assert eq.cost < 1e-12


def test_the_equilibrium_is_straight_and_steady(oval):
    eq = oval.equilibrium_guess()
    v = eq.values()
    assert list(v) == ["r", "V", "beta", "V_wr", "dFz", "delta", "T_comb", "T_bf"]
    # Straight line: no yaw rate; free rolling at the guess speed: V_wr = V.
    assert v["r"] == pytest.approx(0.0, abs=1e-9)
    assert v["V_wr"] == pytest.approx(v["V"], rel=1e-9)
    v_min, v_max = oval.speed_bounds
    assert v_min <= v["V"] <= v_max


def test_the_module_level_guess_matches_the_problems_for_the_same_speed_bounds(oval):
    v_min, v_max = oval.speed_bounds
    eq = trajopt.equilibrium_guess(v_min=v_min, v_max=v_max)
    np.testing.assert_array_equal(eq.x, oval.equilibrium_guess().x)


def test_bad_speed_bounds_are_refused_with_the_command_lines_message():
    with pytest.raises(trajopt.TrajoptError, match="need 0 < v_min < v_max"):
        trajopt.equilibrium_guess(v_min=10.0, v_max=5.0)


def test_the_initial_guess_spreads_the_equilibrium_over_the_grid(oval):
    xs, us = oval.initial_guess("equilibrium")
    eq = oval.equilibrium_guess()
    n = trajopt.HORIZON
    assert xs.shape == (n + 1, 9) and us.shape == (n, 3)
    np.testing.assert_array_equal(us, np.tile(eq.u, (n, 1)))
    np.testing.assert_allclose(xs[:, 7], oval.s)
    np.testing.assert_allclose(xs[:, 8], oval.s / eq.x[1])
    zx, zu = oval.initial_guess("zero")
    assert not zx.any() and not zu.any()
