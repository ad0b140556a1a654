"""Shared fixtures: the repository's paths and the golden results of the Rust test suite."""

import csv
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
CONFIG = REPO / "config"


def golden(case, objective="planner"):
    """(status, iterations) of a case in planner/tests/golden/results.csv, the results
    `trajopt solve` and the Rust golden test reproduce."""
    with open(REPO / "planner" / "tests" / "golden" / "results.csv", newline="") as f:
        for row in csv.DictReader(f):
            if row["case"] == case and row["objective"] == objective:
                return row["status"], int(row["iterations"])
    raise KeyError(f"no golden row for {case}/{objective}")


@pytest.fixture(scope="session")
def oval():
    import trajopt

    return trajopt.load_scenario(CONFIG / "scenarios" / "oval.toml")


@pytest.fixture(scope="session")
def oval_solution(oval):
    return oval.solve()
