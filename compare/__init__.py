"""simbridge.compare: run one scenario on two engines and report where and when they part.

::

    from simbridge import compare

    a = compare.run("r2d2", "pybullet")            # Trajectory: every step recorded
    b = compare.run("r2d2", "mujoco")
    d = compare.diff(a, b)                         # Divergence: quantities over time
    print(d.final["base_distance"], d.first_crossing("base_distance", 0.01))

    c = compare.compare("r2d2", ["pybullet", "mujoco"], timesteps=["1/240", "1/480"])
    c.verdict.verdict, c.verdict.engines           # "chaotic", ["pybullet"]
    c.ensembles[0].spread, c.ensembles[0].horizons()   # 16 runs per engine, judged
    compare.run("r2d2-goto", "mujoco").outcomes    # closed loop: goals reached, and when
    compare.run("r2d2-gentle", "pybullet", controller="my_ctrl.py:Drive")   # your controller
    compare.report(c, "reports/r2d2")              # report.md, summary.json, figures

Only the :class:`simbridge.Sim` interface is used: no engine is imported here.
"""

from __future__ import annotations

from .controllers import ControllerError, ControllerSpec
from .diff import QUANTITIES, Divergence, PhaseRow, Quantity, diff
from .ensemble import Ensemble, run_ensembles
from .outcomes import Outcome
from .pipeline import Comparison, compare
from .report import headline, report
from .run import BodyTrajectory, Trajectory, run
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
from .verdict import Verdict, judge

__all__ = [
    "run",
    "diff",
    "compare",
    "report",
    "headline",
    "Trajectory",
    "BodyTrajectory",
    "Divergence",
    "PhaseRow",
    "Quantity",
    "QUANTITIES",
    "Comparison",
    "Ensemble",
    "run_ensembles",
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
