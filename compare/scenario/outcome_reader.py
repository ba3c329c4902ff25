"""Reading one ``[[outcomes]]`` table of a scenario file: :func:`read_outcome`, one function per
outcome kind (:data:`READERS`), each checking the keys its kind takes in the file's order."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import ScenarioError
from .checks import TableReader
from .controllers import RefError, absolute_ref, load_object
from .model import JointRef, RobotSpec
from .outcomes import KINDS as OUTCOME_KINDS
from .outcomes import Outcome

__all__ = ["read_outcome", "READERS", "KEYS"]

_COMMON = ("name", "kind", "robot", "phase")
KEYS: dict[str, tuple[str, ...]] = {
    "reach": (*_COMMON, "link", "point", "within", "by", "hold"),
    "upright": (*_COMMON, "max_tilt"),
    "track": (*_COMMON, "joints", "quantity", "targets", "link", "points", "max"),
    "final_pose": (*_COMMON, "link", "point", "orientation", "joints", "targets", "within"),
    "effort": (*_COMMON, "joints", "max"),
    "function": ("name", "kind", "function", "params", "max", "min", "unit"),
}
"""The keys each outcome kind takes."""


@dataclass(frozen=True)
class OutcomeTable:
    """One ``[[outcomes]]`` table being read, with the keys every kind shares already checked.

    ``robot`` and ``phase`` are ``""`` when the table names none, ``link`` ``"base"``."""

    reader: TableReader
    t: dict[str, Any]
    path: list[str | int]
    name: str
    robot: str
    phase: str
    link: JointRef
    base: Path | None  # the scenario file's folder: function references are relative to it

    def error(self, key: str | int | None, detail: str) -> ScenarioError:
        """The error for ``key`` of this table (the table itself for None)."""
        return self.reader.error(self.path if key is None else [*self.path, key], detail)

    def positive(self, key: str) -> float | None:
        """The number at ``key``, > 0; None when the table has no ``key``."""
        if key not in self.t:
            return None
        v = self.reader.number(self.t[key], [*self.path, key])
        if v <= 0:
            raise self.error(key, f"must be > 0, got {self.t[key]!r}")
        return v

    def point(self, key: str) -> tuple[float, ...] | None:
        """The (x, y) or (x, y, z) point at ``key`` (m); None when the table has no ``key``."""
        if key not in self.t:
            return None
        v = self.t[key]
        if not isinstance(v, list) or len(v) not in (2, 3):
            raise self.error(key, f"expected 2 (x, y) or 3 (x, y, z) numbers, got {v!r}")
        return tuple(self.reader.number(x, [*self.path, key, i]) for i, x in enumerate(v))

    def joints(self) -> tuple[JointRef, ...]:
        """The joints at ``joints`` (one or a list); ``()`` when the table names none."""
        if "joints" not in self.t:
            return ()
        raw = self.t["joints"]
        refs = raw if isinstance(raw, list) else [raw]
        if not refs:
            raise self.error("joints", "expected at least one joint")
        return tuple(self.reader.joint_ref(j, [*self.path, "joints"]) for j in refs)

    def targets(self, n: int) -> tuple[float, ...]:
        """The ``targets``, one number for all ``n`` joints or one each."""
        return self.reader.per_joint(self.t["targets"], [*self.path, "targets"], n)


def read_outcome(
    reader: TableReader,
    t: Any,
    path: list[str | int],
    robots: dict[str, RobotSpec],
    phases: Sequence[str],
    base: Path | None,
) -> Outcome:
    """The outcome an ``[[outcomes]]`` table declares.

    Args:
        reader: the scenario file's checks.
        t: the table as parsed.
        path: its key path (``["outcomes", 2]``).
        robots: the scenario's robots by name.
        phases: the scenario's phase names, in order.
        base: the scenario file's folder (None for text not read from a file).

    Returns:
        The outcome.

    Raises:
        ScenarioError: anything wrong in the table, at its key and line.
    """
    if not isinstance(t, dict):
        raise reader.error(path, "expected a table ([[outcomes]])")
    kind = reader.require(t, path, "kind")
    if kind not in OUTCOME_KINDS:
        raise reader.error(
            [*path, "kind"], f"expected one of {', '.join(OUTCOME_KINDS)}, got {kind!r}"
        )
    reader.keys(t, path, KEYS[kind])
    name = reader.string(reader.require(t, path, "name"), [*path, "name"])
    robot = _robot(reader, t, path, robots)
    phase = _phase(reader, t, path, phases)
    link: JointRef = "base"
    if "link" in t:
        link = t["link"]
        if isinstance(link, bool) or not isinstance(link, (int, str)) or link == "":
            raise reader.error(
                [*path, "link"], f'expected "base", a link name or index, got {link!r}'
            )
    return READERS[kind](OutcomeTable(reader, t, path, name, robot, phase, link, base))


def _robot(
    reader: TableReader, t: dict[str, Any], path: list[str | int], robots: dict[str, RobotSpec]
) -> str:
    """The table's ``robot``, one of ``robots``; ``""`` when it names none."""
    if "robot" not in t:
        return ""
    robot = reader.string(t["robot"], [*path, "robot"])
    if robot not in robots:
        raise reader.error([*path, "robot"], f"no robot {robot!r}; robots: {sorted(robots)}")
    return robot


def _phase(
    reader: TableReader, t: dict[str, Any], path: list[str | int], phases: Sequence[str]
) -> str:
    """The table's ``phase``, one phase's name, and that of no other; ``""`` when it names none."""
    if "phase" not in t:
        return ""
    phase = reader.string(t["phase"], [*path, "phase"])
    if phase not in phases:
        raise reader.error([*path, "phase"], f"no phase {phase!r}; phases: {list(phases)}")
    if list(phases).count(phase) > 1:
        raise reader.error([*path, "phase"], f"two phases are named {phase!r}: name them apart")
    return phase


def _reach(o: OutcomeTable) -> Outcome:
    """``kind = "reach"``: a point (``point``) reached within ``within`` m, by ``by`` s."""
    pt = o.point("point")
    if pt is None:
        raise o.error("point", "missing (required by reach)")
    within = o.positive("within")
    if within is None:
        raise o.error("within", "missing (required by reach): metres")
    hold = o.t.get("hold", False)
    if not isinstance(hold, bool):
        raise o.error("hold", f"expected true or false, got {hold!r}")
    return Outcome.reach(
        o.name,
        pt,
        within,
        robot=o.robot,
        link=o.link,
        by=o.positive("by"),
        hold=hold,
        phase=o.phase,
    )


def _upright(o: OutcomeTable) -> Outcome:
    """``kind = "upright"``: the base tilted at most ``max_tilt`` rad."""
    bound = o.positive("max_tilt")
    if bound is None:
        raise o.error("max_tilt", "missing (required by upright): radians")
    return Outcome.upright(o.name, bound, robot=o.robot, phase=o.phase)


def _track_points(o: OutcomeTable) -> list[tuple[float, ...]]:
    """A tracked link's ``points``: ``[t, x, y]`` or ``[t, x, y, z]`` rows, times in order."""
    raw_pts = o.t["points"]
    if not isinstance(raw_pts, list) or not raw_pts:
        raise o.error("points", "expected a list of [t, x, y] or [t, x, y, z] rows")
    pts: list[tuple[float, ...]] = []
    width = None
    for i, row in enumerate(raw_pts):
        at: list[str | int] = [*o.path, "points", i]
        if not isinstance(row, list) or len(row) not in (3, 4):
            raise o.reader.error(at, f"expected [t, x, y] or [t, x, y, z], got {row!r}")
        if width is not None and len(row) != width:
            raise o.reader.error(at, "every row needs the same length")
        width = len(row)
        pts.append(tuple(o.reader.number(x, at) for x in row))
    times = [p[0] for p in pts]
    if times != sorted(times):
        raise o.error("points", "times must not decrease")
    return pts


def _track(o: OutcomeTable) -> Outcome:
    """``kind = "track"``: joints following ``targets``, or a link following ``points``."""
    quantity = o.t.get("quantity", "position")
    if quantity not in ("position", "velocity"):
        raise o.error("quantity", f"expected position or velocity, got {quantity!r}")
    js = o.joints()
    pts: list[tuple[float, ...]] = []
    if "points" in o.t:
        pts = _track_points(o)
        if js or "targets" in o.t:
            raise o.error("points", "track either a link (points) or joints, not both")
    elif "link" in o.t:
        raise o.error("link", "a tracked link needs points")
    targets: tuple[float, ...] = ()
    if "targets" in o.t:
        if not js:
            raise o.error("targets", "constant targets need joints")
        targets = o.targets(len(js))
    return Outcome.track(
        o.name,
        robot=o.robot,
        joints=js,
        quantity=quantity,
        targets=targets,
        link=o.link,
        points=pts,
        max=o.positive("max"),
        phase=o.phase,
    )


def _final_pose(o: OutcomeTable) -> Outcome:
    """``kind = "final_pose"``: at the end, one of a point, the base's orientation or joints."""
    pt = o.point("point")
    js = o.joints()
    quat = None
    if "orientation" in o.t:
        quat = o.reader.vector(o.t["orientation"], [*o.path, "orientation"], 4)
        if abs(math.sqrt(sum(c * c for c in quat)) - 1) > 1e-3:
            raise o.error("orientation", "expected a unit quaternion (x, y, z, w)")
    if [pt is not None, bool(js), quat is not None].count(True) != 1:
        raise o.error(
            None,
            "final_pose takes one of point (a base or link position), orientation (the "
            "base's, x, y, z, w) or joints",
        )
    targets: tuple[float, ...] = ()
    if js:
        if "targets" not in o.t:
            raise o.error("targets", "missing (joints need targets)")
        targets = o.targets(len(js))
    elif "targets" in o.t:
        raise o.error("targets", "targets go with joints")
    return Outcome.final_pose(
        o.name,
        robot=o.robot,
        point=pt,
        link=o.link,
        joints=js,
        targets=targets,
        orientation=quat,
        within=o.positive("within"),
        phase=o.phase,
    )


def _effort(o: OutcomeTable) -> Outcome:
    """``kind = "effort"``: the joints' effort, at most ``max``."""
    return Outcome.effort(
        o.name, robot=o.robot, joints=o.joints(), max=o.positive("max"), phase=o.phase
    )


def _function(o: OutcomeTable) -> Outcome:
    """``kind = "function"``: a function of the run (``"file.py:name"``) and its bounds."""
    ref = o.reader.string(o.reader.require(o.t, o.path, "function"), [*o.path, "function"])
    try:
        fn = load_object(ref, o.base)
    except RefError as exc:
        raise o.error("function", f"function {ref!r}: {exc}") from None
    if not callable(fn):
        raise o.error("function", f"{ref!r} is not a function")
    params = o.t.get("params", {})
    if not isinstance(params, dict):
        raise o.error("params", "expected a table of keyword arguments")
    bounds = {}
    for key in ("max", "min"):
        if key in o.t:
            bounds[key] = o.reader.number(o.t[key], [*o.path, key])
    unit = o.t.get("unit", "")
    if not isinstance(unit, str):
        raise o.error("unit", f"expected a string, got {unit!r}")
    return Outcome.function_of(
        o.name, absolute_ref(ref, o.base), params=params, unit=unit, **bounds
    )


READERS: dict[str, Callable[[OutcomeTable], Outcome]] = {
    "reach": _reach,
    "upright": _upright,
    "track": _track,
    "final_pose": _final_pose,
    "effort": _effort,
    "function": _function,
}
"""The reader of each outcome kind."""
