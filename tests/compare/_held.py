"""A comparison whose runs hold at a known point, for the tests that signal `simbridge compare`
while its workers run: the shipped pendulum with a controller that, at its first step, writes a
file named by its process id and then waits (:data:`HOLD_S`). Once two such files name workers
of the command, those workers are past their imports and inside a run that cannot end before
the test acts, on a fast machine as on a slow or loaded one (waiting for the workers to pass
some CPU time was a race with the ensemble's end: on a fast machine it often ended first)."""

from __future__ import annotations

import json
import subprocess
import time
from pathlib import Path

from _procs import children

HOLD_S = 600.0
"""How long a held run waits before it fails: far longer than any test lets it live (the
command is signalled, and its workers end with it, as soon as they are seen holding)."""

_CONTROLLER = '''\
"""Says where it is, then holds the run (tests/compare/_held.py)."""

import os
import time
from pathlib import Path


class Hold:
    def __init__(self, folder, hold_s):
        self.folder, self.hold_s = Path(folder), hold_s

    def step(self, sim, now):
        (self.folder / str(os.getpid())).touch()  # this worker is stepping a run
        time.sleep(self.hold_s)
        raise RuntimeError(f"held for {self.hold_s} s: nobody stopped this run")
'''


_SCENARIO = """\
# the shipped pendulum (compare/scenarios/pendulum.toml), its swing driven by the holding controller
name = "held-pendulum"
description = "the pendulum, each run held at its first step"
profile = "pybullet"
timestep = "1/240"
gravity = [0.0, 0.0, -9.8]
subject = "pendulum"

[[robots]]
name = "pendulum"
urdf = "pendulum.urdf"
fixed_base = true
position = [0.0, 0.0, 1.0]
joint_positions = {{ hinge = 0.5 }}

[[phases]]
name = "swing"
steps = 480
[phases.controller]
class = "hold.py:Hold"
every = 1
[phases.controller.params]
folder = {folder}
hold_s = {hold_s}
"""


def held_scenario(folder: Path) -> tuple[Path, Path]:
    """The scenario whose runs hold, written into ``folder`` with its controller; and the folder
    where its runs say they hold (empty until one does)."""
    ready = folder / "holding"
    ready.mkdir(parents=True)
    (folder / "hold.py").write_text(_CONTROLLER, "utf-8")
    path = folder / "held-pendulum.toml"
    path.write_text(_SCENARIO.format(folder=json.dumps(str(ready)), hold_s=HOLD_S), "utf-8")
    return path, ready


def wait_for_holding(
    proc: subprocess.Popen, ready: Path, n: int = 2, timeout: float = 120
) -> list[int]:
    """The pids of ``n`` workers of ``proc`` that hold a run (``timeout`` s at most: it only
    bounds a hang; the workers start in a few seconds)."""
    deadline = time.monotonic() + timeout
    while True:
        assert proc.poll() is None, proc.communicate()  # a held run cannot end: nothing can
        holding = {int(p.name) for p in ready.iterdir()} & set(children(proc.pid))
        if len(holding) >= n:
            return sorted(holding)
        assert time.monotonic() < deadline, f"no {n} workers held a run in {timeout} s"
        time.sleep(0.05)
