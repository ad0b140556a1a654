"""A stretch of an indexed track, named by track and start s, is the segment of
segments.toml that starts there."""

import numpy as np
import pytest

import trajopt
from conftest import CONFIG, golden


def test_the_stretch_where_s01_starts_solves_as_s01():
    p = trajopt.track_stretch("Austin", 480.0)
    assert p.name == "Austin_s480"
    assert p.length_m == 250.0 and p.n_intervals == trajopt.HORIZON
    sol = p.solve()
    assert (sol.status, sol.iterations) == golden("S01", "planner")
    s01 = trajopt.load_scenario(CONFIG / "scenarios" / "segments.toml", segment="S01")
    np.testing.assert_array_equal(p.kappa, s01.kappa)
    np.testing.assert_array_equal(p.e_min, s01.e_min)


def test_the_edge_margin_widens_the_lane_by_the_margin_given_up():
    base = trajopt.track_stretch("Spa", 1000.0, length_m=200.0)
    raw = trajopt.track_stretch("Spa", 1000.0, length_m=200.0, edge_margin_m=0.0)
    np.testing.assert_allclose(raw.e_max - base.e_max, 1.0, atol=1e-12)
    np.testing.assert_allclose(base.e_min - raw.e_min, 1.0, atol=1e-12)
    assert base.ds_m == pytest.approx(200.0 / trajopt.HORIZON)


def test_an_unknown_track_names_the_tracks_of_the_index():
    with pytest.raises(trajopt.TrajoptError, match="no such track") as e:
        trajopt.track_stretch("Monza", 0.0)
    assert "Austin" in str(e.value) and "tracks.toml" in str(e.value)


def test_a_start_that_is_not_a_number_is_refused_by_field():
    with pytest.raises(trajopt.TrajoptError, match="start_s"):
        trajopt.track_stretch("Austin", float("nan"))
