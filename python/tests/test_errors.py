"""Every input the planner refuses raises trajopt.TrajoptError with the library's message,
which names the file, the field or the option."""

import pytest

import trajopt
from conftest import CONFIG


def test_a_missing_scenario_file_is_an_error_naming_the_path(tmp_path):
    missing = tmp_path / "no_such_scenario.toml"
    with pytest.raises(trajopt.TrajoptError) as e:
        trajopt.load_scenario(missing)
    assert str(missing) in str(e.value)
    assert "cannot read file" in str(e.value)


def test_a_bad_field_names_the_file_and_the_field(tmp_path):
    text = (CONFIG / "scenarios" / "oval.toml").read_text()
    bad = tmp_path / "scenarios" / "oval.toml"
    bad.parent.mkdir()
    bad.write_text(text.replace("n_intervals = 100", "n_intervals = 50"))
    with pytest.raises(trajopt.TrajoptError, match=r"horizon\.n_intervals = 50") as e:
        trajopt.load_scenario(bad)
    assert str(bad) in str(e.value)


def test_an_unknown_segment_lists_the_available_ones():
    with pytest.raises(trajopt.TrajoptError, match="S01, S02"):
        trajopt.load_scenario(CONFIG / "scenarios" / "segments.toml", segment="S99")


def test_a_missing_vehicle_file_is_an_error_naming_it(tmp_path):
    with pytest.raises(trajopt.TrajoptError, match="nowhere.toml"):
        trajopt.load_scenario(CONFIG / "scenarios" / "oval.toml", vehicle=tmp_path / "nowhere.toml")


@pytest.mark.parametrize(
    "options, message",
    [
        ({"guess": "warm"}, "guess: `warm` is not one of"),
        ({"budget_ms": 0.0}, "budget_ms: `0` is not a budget in"),
        ({"steering_slew_weight": -1.0}, "steering_slew_weight: `-1` is not a weight in"),
        ({"barrier": "newton"}, "barrier: `newton` is not one of"),
        ({"kkt": "dense"}, "kkt: `dense` is not one of"),
        ({"threads": 3}, "threads: `3` is not 1 or 2"),
        ({"max_iter": 0}, "max_iter: `0` is not an iteration count"),
    ],
)
def test_a_bad_solve_option_is_refused_with_its_name(oval, options, message):
    with pytest.raises(trajopt.TrajoptError, match=message.replace("`", ".")):
        oval.solve(**options)


def test_a_missing_solver_file_is_an_error_naming_it(oval, tmp_path):
    with pytest.raises(trajopt.TrajoptError, match="solver_x.toml"):
        oval.solve(solver=tmp_path / "solver_x.toml")


def test_the_error_class_is_an_exception():
    assert issubclass(trajopt.TrajoptError, Exception)
