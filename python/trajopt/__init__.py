"""The reference-free minimum-time trajectory planner from Python.

Load a scenario file (``load_scenario``) or name a stretch of an indexed track
(``track_stretch``), solve it with the options of ``trajopt solve``
(``Problem.solve``) and read the trajectory as numpy arrays with named columns
(``Solution.states``, ``Solution.controls``, ``Solution["V"]``). Every input the
planner refuses raises ``TrajoptError`` with the library's message.
"""

from ._trajopt import (
    CONTROL_NAMES,
    HORIZON,
    STATE_NAMES,
    Equilibrium,
    Problem,
    Solution,
    TrajoptError,
    __version__,
    equilibrium_guess,
    load_scenario,
    selections,
    track_stretch,
)

__all__ = [
    "CONTROL_NAMES",
    "HORIZON",
    "STATE_NAMES",
    "Equilibrium",
    "Problem",
    "Solution",
    "TrajoptError",
    "__version__",
    "equilibrium_guess",
    "load_scenario",
    "selections",
    "track_stretch",
]
