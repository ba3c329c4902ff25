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

import importlib
import sys
import types
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .analysis.diff import Divergence, PhaseRow, diff
    from .analysis.verdict import Verdict, judge
    from .pipeline import Comparison, compare, installed_backends
    from .report import headline, report, summary
    from .run.ensemble import Ensemble, run_ensembles
    from .run.quantities import QUANTITIES, Quantity
    from .run.recording import run
    from .run.trajectory import BodyTrajectory, Trajectory
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

# The names above are imported on first use (PEP 562): a module that needs one stage only (a
# pool worker running a job imports simbridge.compare.run.jobs, whose package this is) does not
# pay for the others (the pipeline, the analysis, the report: about 0.2 s).
_LAZY = {
    "diff": ".analysis.diff",
    "Divergence": ".analysis.diff",
    "PhaseRow": ".analysis.diff",
    "Verdict": ".analysis.verdict",
    "judge": ".analysis.verdict",
    "Comparison": ".pipeline",
    "compare": ".pipeline",
    "installed_backends": ".pipeline",
    "headline": ".report",
    "report": ".report",
    "summary": ".report",
    "Ensemble": ".run.ensemble",
    "run_ensembles": ".run.ensemble",
    "QUANTITIES": ".run.quantities",
    "Quantity": ".run.quantities",
    "BodyTrajectory": ".run.trajectory",
    "Trajectory": ".run.trajectory",
    "run": ".run.recording",
    "Command": ".scenario",
    "Phase": ".scenario",
    "RobotSpec": ".scenario",
    "Scenario": ".scenario",
    "dumps_scenario": ".scenario",
    "list_scenarios": ".scenario",
    "load_scenario": ".scenario",
    "loads_scenario": ".scenario",
    "save_scenario": ".scenario",
    "ControllerError": ".scenario.controllers",
    "ControllerSpec": ".scenario.controllers",
    "Outcome": ".scenario.outcomes",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


class _Package(types.ModuleType):
    """This package's class: ``run`` and ``report`` are functions here (:func:`run`,
    :func:`report`) and also the names of two of its subpackages. Importing a submodule sets
    its name on the package (``import simbridge.compare.run.jobs`` would make ``compare.run``
    the subpackage); here the function keeps the name, as when every stage was imported
    eagerly. The subpackages stay in ``sys.modules`` and import as before."""

    def __setattr__(self, name: str, value: Any) -> None:
        if name in ("run", "report") and isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
