"""Scenarios as data: robots, where they spawn, and a timeline of held joint commands.

A scenario is a TOML file (read with the standard library's ``tomllib``)::

    name = "r2d2"
    description = "The classic PyBullet tutorial drive"   # one line, shown by `simbridge scenarios`
    profile = "pybullet"          # simbridge profile name (default "pybullet")
    timestep = "1/240"            # seconds: a number, or a fraction written as a string
    gravity = [0, 0, -9.8]        # m/s^2 (default)
    subject = "r2d2"              # the robot the report follows (default: the last robot)
    headline = "base_distance"    # the report's headline quantity (default: base_distance for a
                                  # free base, link_distance for a fixed one)

    [[robots]]
    name = "r2d2"                 # label used by commands and in the report
    urdf = "r2d2.urdf"            # a shipped name, a path (relative to this file), or a name on
                                  # simbridge's search path
    position = [0, 0, 0.1]        # where the URDF link frame of the root goes (m, world)
    orientation = [0, 0, 0, 1]    # (x, y, z, w); or rpy = [roll, pitch, yaw] (rad)
    fixed_base = false
    joint_positions = { hinge = 0.5 }   # optional initial joint positions (by name or index)
    # or, for a robot from an MJCF file (Sim.load_mjcf; the file places it, so no position,
    # orientation or fixed_base): mjcf = "mjcf/ant.xml", and body = 0 (which of the bodies the
    # file makes is this robot; the others are loaded too)

    [[phases]]
    name = "turn"
    steps = 240                   # number of time steps the phase lasts
    [[phases.commands]]
    robot = "r2d2"                # default: the subject
    joints = [2, 3, 6, 7]         # indices or names (one or a list)
    mode = "velocity"             # "velocity" (rad/s, m/s), "position" (rad, m) or "torque"
    target = [-100, -100, 100, 100]   # one number for all the joints, or one per joint
    max_force = 50                # N·m or N; required for velocity and position, not for torque
    # kp = 0.1, kd = 1.0          # position mode only (PyBullet's gains)

    [phases.controller]           # optional: a closed-loop controller drives this phase
    class = "goto.py:GoTo"        # a file beside this scenario, or "package.module:GoTo"
    every = 4                     # control period, in steps (default 1: before every step)
    [phases.controller.params]    # keyword arguments: GoTo(goal = [0.0, 2.0])
    goal = [0.0, 2.0]
    # (or, with no params and every = 1: controller = "goto.py:GoTo")

    [[outcomes]]                  # optional: what success means (see outcomes.py)
    name = "reaches the goal"
    kind = "reach"                # reach, upright, track, final_pose, effort, function
    robot = "r2d2"                # default: the subject
    point = [0.0, 2.0]
    within = 0.05

Semantics, as in the tutorial: every command of a phase is re-issued before every step of that
phase. A phase without a command for a joint leaves whatever the engine holds (the profile's
default brake, or the last velocity/position command, which persist). A torque command first
releases the joint's velocity motor (``max_force=0``) at the start of its phase, as PyBullet
requires for torque control; torque lasts one step, so it is re-applied every step.

A phase's controller (:mod:`simbridge.compare.controllers`) is made when the phase starts, in
every run, and called after the phase's commands, before its first step and every ``every``
steps after; its velocity and position commands persist, its torques are held until its next
call.

A scenario rerun at another time step keeps each phase's duration and each controller's period
in seconds (see :meth:`Scenario.with_timestep`).
"""

from __future__ import annotations

import os
from pathlib import Path

from simbridge.exceptions import did_you_mean

from ..errors import ScenarioError
from .checks import find_key_line
from .controllers import ControllerSpec

# re-exported: callers import these from here
from .model import (  # noqa: F401
    HEADLINE_QUANTITIES,
    MAX_STEPS,
    MODES,
    Command,
    JointRef,
    Phase,
    RobotSpec,
    Scenario,
    format_timestep,
    parse_timestep,
)
from .outcomes import Outcome
from .reader import loads_scenario
from .writer import dumps_scenario, save_scenario

__all__ = [
    "Command",
    "ControllerSpec",
    "Outcome",
    "Phase",
    "RobotSpec",
    "Scenario",
    "SCENARIOS_DIR",
    "MODES",
    "HEADLINE_QUANTITIES",
    "list_scenarios",
    "load_scenario",
    "loads_scenario",
    "dumps_scenario",
    "save_scenario",
    "find_key_line",
]

SCENARIOS_DIR = Path(__file__).resolve().parent.parent / "scenarios"


def _shipped() -> dict[str, Path]:
    return {p.stem: p for p in sorted(SCENARIOS_DIR.glob("*.toml"), key=lambda p: p.stem)}


def load_scenario(scenario: str | Path | Scenario) -> Scenario:
    """A shipped scenario by name (``"r2d2"``), a path to a TOML file, or a Scenario (returned
    as is). Raises :class:`ScenarioError` when the name is unknown or the file is invalid."""
    if isinstance(scenario, Scenario):
        return scenario
    text_path = Path(scenario)
    shipped = _shipped()
    if isinstance(scenario, str) and scenario in shipped and not text_path.is_file():
        path = shipped[scenario]
    elif text_path.is_file():
        path = text_path
    elif "/" in str(scenario) or os.sep in str(scenario) or text_path.suffix in (".toml", ".tml"):
        # a path, not a name: say which file is missing (a typo of a file name is no name)
        raise ScenarioError(str(scenario), None, f"file not found: {text_path.resolve()}")
    else:
        raise ScenarioError(
            str(scenario),
            None,
            "no such scenario file, and not a shipped scenario"
            + did_you_mean(str(scenario), shipped)
            + "; shipped scenarios: "
            + ", ".join(shipped),
        )
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(str(path), None, f"cannot read the file: {exc}") from None
    return loads_scenario(text, file=str(path), source=path.resolve())


def list_scenarios() -> list[Scenario]:
    """The shipped scenarios, sorted by name."""
    return [load_scenario(p) for p in _shipped().values()]
