"""Outcomes: what a scenario calls success, measured on every run (:func:`evaluate`) and over
each engine's ensemble (:func:`summarize`: success rate with a 95% interval, the distribution of
each value).

Kinds (:data:`KINDS`), each on one robot (default the scenario's subject), over the whole run or
one phase (``phase``: rows from the phase's first to its last, times counted from its start):

- ``reach``: a body's base (``link = "base"``: the URDF root link frame) or a link (its centre
  of mass) comes within ``within`` m of ``point`` (2 coordinates: distance in the horizontal
  plane; 3: in space). Value: the time it took (s; None: never). With ``hold = true`` it must
  stay within until the window's end (the value is then the settling time); with ``by`` it must
  get there by that time (s) to succeed.
- ``upright``: the tilt stays below ``max_tilt`` (rad) throughout. The tilt is the angle
  between the world's z axis and the body axis that pointed along it at the window's first
  instant: against the robot's own initial orientation, whatever it is. Value: the largest tilt.
- ``track``: RMS error of joints against targets (``quantity`` ``position``, the default, or
  ``velocity``: the commanded targets recorded with the run, or constant ``targets``), or of a
  link against ``points`` (``[t, x, y, z]`` rows, each held from its time, t from the window's
  start). Value: the RMS (rad, m, or rad/s); success when ``max`` is given: value <= max.
- ``final_pose``: at the window's last instant, the distance of the base or link from
  ``point`` (m), the angle of the base's rotation from ``orientation`` (x, y, z, w; rad), or
  the RMS of joints' positions against ``targets`` (rad or m). Success when ``within`` is
  given.
- ``effort``: the sum over steps and joints of |joint force x joint speed| times the time
  step (J): the work the motors did, counting braking as work too. Success when ``max`` is
  given.
- ``function``: ``function = "file.py:name"`` (or ``"package.module:name"``) called as
  ``name(trajectory, **params)``; a number is the value (success by ``max``/``min`` when
  given), a bool the success itself, None no value.

Every evaluation is a plain dict (JSON-ready, picklable): ``name``, ``kind``, ``unit``,
``value``, ``success`` (True, False, or None where the outcome declares no bound) and the kind's
own figures (see :func:`evaluate`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

__all__ = ["KINDS", "Outcome", "JointRef"]

KINDS = ("reach", "upright", "track", "final_pose", "effort", "function")

_UNITS = {"reach": "s", "upright": "rad", "effort": "J"}

_TITLES = {
    "reach": "time to reach",
    "upright": "largest tilt",
    "track": "RMS error",
    "final_pose": "final error",
    "effort": "effort",
    "function": "value",
}
"""What each kind's value is, as the report names it (:attr:`Outcome.title`)."""


JointRef = int | str


@dataclass(frozen=True)
class Outcome:
    """One declared outcome (see the module's docstring for each kind's keys).

    Make one with the class methods (:meth:`reach`, :meth:`upright`, :meth:`track`,
    :meth:`final_pose`, :meth:`effort`, :meth:`function_of`) or read it from a scenario's
    ``[[outcomes]]`` tables."""

    name: str
    kind: str
    robot: str = ""
    """A robot's scenario name; "" = the subject."""
    phase: str = ""
    """A phase's name: its rows only; "" = the whole run."""
    link: JointRef = "base"
    """``"base"`` (the URDF root link frame), or a link's name or index (its centre of mass)."""
    point: tuple[float, ...] | None = None
    """m, world: 2 coordinates (x, y; horizontal distance) or 3."""
    within: float | None = None
    by: float | None = None
    hold: bool = False
    max_tilt: float | None = None
    quantity: str = "position"
    joints: tuple[JointRef, ...] = ()
    targets: tuple[float, ...] = ()
    points: tuple[tuple[float, ...], ...] = ()
    orientation: tuple[float, float, float, float] | None = None
    """final_pose: the base's target orientation (x, y, z, w)."""
    max: float | None = None
    min: float | None = None
    function: str = ""
    params: dict[str, Any] = field(default_factory=dict)
    function_unit: str = ""
    """The unit of a function's value (shown in the report)."""

    # ------------------------------------------------------------ constructors

    @classmethod
    def reach(
        cls,
        name: str,
        point: Sequence[float],
        within: float,
        *,
        robot: str = "",
        link: JointRef = "base",
        by: float | None = None,
        hold: bool = False,
        phase: str = "",
    ) -> Outcome:
        return cls(
            name,
            "reach",
            robot,
            phase,
            link,
            tuple(float(x) for x in point),
            float(within),
            by,
            hold,
        )

    @classmethod
    def upright(cls, name: str, max_tilt: float, *, robot: str = "", phase: str = "") -> Outcome:
        return cls(name, "upright", robot, phase, max_tilt=float(max_tilt))

    @classmethod
    def track(
        cls,
        name: str,
        *,
        robot: str = "",
        joints: Sequence[JointRef] = (),
        quantity: str = "position",
        targets: Sequence[float] = (),
        link: JointRef = "base",
        points: Sequence[Sequence[float]] = (),
        max: float | None = None,
        phase: str = "",
    ) -> Outcome:
        return cls(
            name,
            "track",
            robot,
            phase,
            link=link,
            quantity=quantity,
            joints=tuple(joints),
            targets=tuple(float(x) for x in targets),
            points=tuple(tuple(float(x) for x in p) for p in points),
            max=max,
        )

    @classmethod
    def final_pose(
        cls,
        name: str,
        *,
        robot: str = "",
        point: Sequence[float] | None = None,
        link: JointRef = "base",
        joints: Sequence[JointRef] = (),
        targets: Sequence[float] = (),
        orientation: Sequence[float] | None = None,
        within: float | None = None,
        phase: str = "",
    ) -> Outcome:
        quat = None
        if orientation is not None:
            x, y, z, w = (float(c) for c in orientation)
            quat = (x, y, z, w)
        return cls(
            name,
            "final_pose",
            robot,
            phase,
            link=link,
            point=None if point is None else tuple(float(x) for x in point),
            within=within,
            joints=tuple(joints),
            targets=tuple(float(x) for x in targets),
            orientation=quat,
        )

    @classmethod
    def effort(
        cls,
        name: str,
        *,
        robot: str = "",
        joints: Sequence[JointRef] = (),
        max: float | None = None,
        phase: str = "",
    ) -> Outcome:
        return cls(name, "effort", robot, phase, joints=tuple(joints), max=max)

    @classmethod
    def function_of(
        cls,
        name: str,
        function: Any,
        *,
        params: Mapping[str, Any] | None = None,
        max: float | None = None,
        min: float | None = None,
        unit: str = "",
    ) -> Outcome:
        """``function``: a top-level function, or a ``"file.py:name"`` /
        ``"package.module:name"`` reference (ensemble workers import it again)."""
        from .controllers import reference_of

        ref = function if isinstance(function, str) else reference_of(function)
        return cls(
            name,
            "function",
            function=ref,
            params=dict(params or {}),
            max=max,
            min=min,
            function_unit=unit,
        )

    @property
    def unit(self) -> str:
        """The value's unit: s, rad, m, rad/s, J, or a function's ``unit``."""
        if self.kind in _UNITS:
            return _UNITS[self.kind]
        if self.kind == "function":
            return self.function_unit
        if self.kind == "track" and self.points:
            return "m"
        if self.kind == "final_pose" and self.point is not None:
            return "m"
        unit = "rad"  # joints: rad (revolute); a prismatic joint's error is in m
        return unit + "/s" if self.quantity == "velocity" else unit

    @property
    def title(self) -> str:
        return _TITLES[self.kind]

    def has_bound(self) -> bool:
        """Whether success is defined (reach and upright always; others with a bound)."""
        if self.kind in ("reach", "upright"):
            return True
        if self.kind == "final_pose":
            return self.within is not None
        if self.kind == "function":
            return True  # a bool result is a success; a number needs max or min (else None)
        return self.max is not None

    def to_dict(self) -> dict[str, Any]:
        """The declaration, JSON-ready (only the keys this kind uses)."""
        out: dict[str, Any] = {"name": self.name, "kind": self.kind, "unit": self.unit}
        for key in (
            "robot",
            "phase",
            "link",
            "point",
            "within",
            "by",
            "hold",
            "max_tilt",
            "quantity",
            "joints",
            "targets",
            "points",
            "orientation",
            "max",
            "min",
            "function",
            "params",
        ):
            value = getattr(self, key)
            default = Outcome.__dataclass_fields__[key].default
            if key == "params":
                if not value:
                    continue
            elif value == default:
                continue
            out[key] = list(value) if isinstance(value, tuple) else value
        return out
