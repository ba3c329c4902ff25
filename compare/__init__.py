"""simbridge.compare: run one scenario on two or more engines and report where and when they part.

A pipeline of stages, each importing only those before it (tests/test_import_graph.py):
:mod:`.scenario` (reading and writing scenarios, controllers, declared outcomes), :mod:`.run`
(one scenario on one engine, ensembles, the one-step resync), :mod:`.analysis` (diff, verdict,
events, parts, outcome statistics: figures, no words), :mod:`.pipeline` (:func:`compare`, the
whole comparison) and :mod:`.report` (``summary.json``, ``report.md``, figures, the terminal).

::

    from simbridge import compare

    a = compare.run("r2d2", "pybullet")            # Trajectory: every step recorded
    b = compare.run("r2d2", "mujoco")
    d = compare.diff(a, b)                         # Divergence: quantities over time
    print(d.final["base_distance"], d.first_crossing("base_distance", 0.01))

    c = compare.compare("r2d2", ["pybullet", "mujoco"], timesteps=["1/240", "1/480"])
    c.verdict.verdict, c.verdict.engines           # "chaotic", ["pybullet"]
    compare.summary(c)["headline"]["final"]        # summary.json's figures
    c.ensembles[0].spread, c.ensembles[0].horizons()   # 16 runs per engine, judged
    compare.run("r2d2-goto", "mujoco").outcomes    # closed loop: goals reached, and when
    compare.run("r2d2-gentle", "pybullet", controller="my_ctrl.py:Drive")   # your controller
    compare.report(c, "reports/r2d2")              # report.md, summary.json, figures

Only the :class:`simbridge.Sim` interface is used: no engine is imported here.
"""

from __future__ import annotations

from .analysis.diff import Divergence, PhaseRow, diff
from .analysis.verdict import Verdict, judge
from .pipeline import Comparison, compare, installed_backends
from .report import headline, report, summary
from .run.ensemble import Ensemble, run_ensembles
from .run.quantities import QUANTITIES, Quantity
from .run.trajectory import BodyTrajectory, Trajectory, run
from .scenario import (
    Command,
    Phase,
    RobotSpec,
    Scenario,
    dumps_scenario,
    list_scenarios,
    load_scenario,
    loads_scenario,
    save_scenario,
)
from .scenario.controllers import ControllerError, ControllerSpec
from .scenario.outcomes import Outcome

__all__ = [
    "run",
    "diff",
    "compare",
    "report",
    "headline",
    "summary",
    "Trajectory",
    "BodyTrajectory",
    "Divergence",
    "PhaseRow",
    "Quantity",
    "QUANTITIES",
    "Comparison",
    "Ensemble",
    "run_ensembles",
    "installed_backends",
    "Verdict",
    "judge",
    "Scenario",
    "RobotSpec",
    "Phase",
    "Command",
    "ControllerSpec",
    "ControllerError",
    "Outcome",
    "load_scenario",
    "loads_scenario",
    "dumps_scenario",
    "save_scenario",
    "list_scenarios",
]
