"""A scenario's robot files and joint references checked before any run starts:
:func:`check_robots`. The static reader (:mod:`.reader`) sees the scenario file alone; what its
robot files hold (that each exists, its joints' names and count) is read here without an engine,
with the core's URDF and MJCF readers, so that ``joints = "hinje"`` or a misspelt ``urdf`` is
told as ``FILE:LINE: key ...`` at once, not by the first run some seconds later."""

from __future__ import annotations

import logging
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from simbridge.exceptions import SimbridgeError, UnknownJointError

from ..errors import ScenarioError
from .checks import _keystr, find_key_line
from .model import JointRef, Scenario

__all__ = ["check_robots"]


@contextmanager
def _quiet() -> Iterator[None]:
    """The readers' notes (a lenient parse's warnings) are the run's to log, once: within the
    block, the ``simbridge`` loggers' records go nowhere."""
    log = logging.getLogger("simbridge")
    handlers, propagate = log.handlers[:], log.propagate
    log.handlers, log.propagate = [logging.NullHandler()], False
    try:
        yield
    finally:
        log.handlers, log.propagate = handlers, propagate


_READ: dict[tuple[object, ...], list[str]] = {}
"""Joint names by robot file as read (a sweep checks its scenario at every point; a large
robot's file takes about half a second to read)."""


def _joint_names(sc: Scenario, index: int) -> list[str]:
    """Joint names of robot ``index`` as its file makes them (PyBullet's order)."""
    from simbridge.model.mjcf import parse_mjcf
    from simbridge.model.scene import resolve_scene_source
    from simbridge.model.urdf import parse_urdf
    from simbridge.model.urdf_source import resolve_source

    robot = sc.robots[index]
    source = sc.resolve_urdf(robot)
    # searched where the run searches: the scenario's folder first (a missing file's message
    # lists it), then as Sim.load_urdf and load_mjcf search
    near = Path(sc.source).parent if sc.source is not None else None
    if robot.kind == "mjcf":
        src = resolve_scene_source(source, "mjcf", near=near)
    else:
        src = resolve_source(source, near=near)
    found = src.path
    try:
        stat = found.stat() if found is not None else None
    except OSError:
        stat = None
    key = (robot.kind, robot.body, str(found), source, stat and (stat.st_mtime_ns, stat.st_size))
    if stat is not None and key in _READ:
        return _READ[key]
    if robot.kind == "mjcf":
        bodies = parse_mjcf(src)
        names = (
            [] if not 0 <= robot.body < len(bodies) else [j.name for j in bodies[robot.body].joints]
        )
    else:
        names = [j.name for j in parse_urdf(src).joints]
    if stat is not None:
        _READ[key] = names
    return names


def _valid(ref: JointRef, names: Sequence[str]) -> bool:
    if isinstance(ref, str):
        return ref in names
    return isinstance(ref, int) and not isinstance(ref, bool) and 0 <= ref < len(names)


def check_robots(sc: Scenario) -> None:
    """Raise :class:`ScenarioError` naming the scenario file, the line and the key when a robot
    file cannot be found or read, or a joint named (a command's, a robot's
    ``joint_positions``, an outcome's) is not one of its robot's. A robot's fixed links merged
    by a profile can only take joints away: a name valid here may still be refused by the run,
    never the other way round."""
    file = sc._where()
    text = ""
    if sc.source is not None:
        try:
            text = Path(sc.source).read_text(encoding="utf-8")
        except OSError:
            text = ""

    def error(path: list[str | int], detail: str) -> ScenarioError:
        line = find_key_line(text, path) if text else None
        return ScenarioError(file, _keystr(path), detail, line)

    names: dict[str, tuple[int, list[str]]] = {}
    with _quiet():
        for i, robot in enumerate(sc.robots):
            try:
                names[robot.name] = (i, _joint_names(sc, i))
            except (SimbridgeError, OSError, ValueError) as exc:
                raise error(["robots", i, "urdf"], str(exc)) from None

    def check(robot: str, refs: Sequence[JointRef], path: list[str | int]) -> None:
        if robot not in names:
            return  # the reader checks robot names
        i, joints = names[robot]
        for ref in refs:
            if not _valid(ref, joints):
                r = sc.robots[i]
                why = UnknownJointError(r.name, ref, joints, body=None, source=r.urdf)
                raise error(path, f"{why} (in {r.urdf})")

    for i, robot in enumerate(sc.robots):
        for ref, _ in robot.joint_positions:
            check(robot.name, [ref], ["robots", i, "joint_positions", str(ref)])
    for p, phase in enumerate(sc.phases):
        for c, command in enumerate(phase.commands):
            check(command.robot, command.joints, ["phases", p, "commands", c, "joints"])
    for o, outcome in enumerate(sc.outcomes):
        if outcome.joints:
            check(outcome.robot or sc.subject, outcome.joints, ["outcomes", o, "joints"])
