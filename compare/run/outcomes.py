"""Outcomes measured on one run (:func:`evaluate`, :func:`evaluate_all`): the declarations
(:class:`~simbridge.compare.scenario.outcomes.Outcome`) are the scenario's, the statistics over
an ensemble the analysis's (:mod:`simbridge.compare.analysis.outcomes`).

Every evaluation is an :class:`OutcomeRecord` (frozen): ``name``, ``kind``, ``unit``,
``value``, ``success`` (True, False, or None where the outcome declares no bound), the kind's own
figures (:class:`ReachFigures`, :class:`UprightFigures`, :class:`TrackFigures`; see
:func:`evaluate`) and a ``note``. :meth:`OutcomeRecord.to_dict` and
:meth:`OutcomeRecord.from_dict` are its JSON form: in a saved trajectory, in ``summary.json``,
and on the way back from an ensemble's worker process.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ScenarioError, TrajectoryFileError
from ..scenario.outcomes import KINDS, JointRef, Outcome
from .portable import acos, dot, length, norm
from .quantities import rotate

if TYPE_CHECKING:
    from ..scenario import Scenario

# .trajectory's Trajectory and BodyTrajectory by name only: its run() imports this module, and
# no module here imports one that imports it (tests/test_import_graph.py), not even for types;
# .quantities, which this module imports, does not import .trajectory either
Trajectory = Any
BodyTrajectory = Any

__all__ = [
    "OutcomeRecord",
    "ReachFigures",
    "UprightFigures",
    "TrackFigures",
    "evaluate",
    "evaluate_all",
    "tilt",
]


# ---------------------------------------------------------------- one run's record


@dataclass(frozen=True)
class ReachFigures:
    """A ``reach`` outcome's own figures."""

    closest: float
    """m: the smallest distance over the window."""
    final_distance: float
    """m: the distance at the window's last instant."""


@dataclass(frozen=True)
class UprightFigures:
    """An ``upright`` outcome's own figures."""

    exceeded_at: float | None
    """s from the window's start: the first instant at or over ``max_tilt``; None: never."""
    final_tilt: float
    """rad: the tilt at the window's last instant."""


@dataclass(frozen=True)
class TrackFigures:
    """A ``track`` outcome's own figures."""

    samples: int
    """Values counted (instants times joints, or instants for a link)."""
    max_error: float | None
    """The largest of them; None when there is none."""


Figures = ReachFigures | UprightFigures | TrackFigures

_FIGURES: dict[str, type[ReachFigures] | type[UprightFigures] | type[TrackFigures]] = {
    "reach": ReachFigures,
    "upright": UprightFigures,
    "track": TrackFigures,
}
"""Each kind's figures (the other kinds have none)."""

_BASE_KEYS = ("name", "kind", "unit", "value", "success")


@dataclass(frozen=True)
class OutcomeRecord:
    """One outcome measured on one run (:func:`evaluate`).

    ``figures`` is the kind's own (:data:`_FIGURES`): None for the kinds that have none and
    for a window the run did not reach; ``note`` says why an outcome could not be measured as
    declared (None: it was)."""

    name: str
    kind: str
    unit: str
    value: float | None
    success: bool | None
    figures: Figures | None = None
    note: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: ``name``, ``kind``, ``unit``, ``value``, ``success``, then the figures'
        keys (``closest``, ``final_distance``...) and ``note`` when there are any;
        :meth:`from_dict` reads it back."""
        out: dict[str, Any] = {key: getattr(self, key) for key in _BASE_KEYS}
        if self.figures is not None:
            out.update(dataclasses.asdict(self.figures))
        if self.note is not None:
            out["note"] = self.note
        return out

    @classmethod
    def from_dict(
        cls, data: Mapping[str, Any], *, file: str = "<record>", key: str = "outcomes"
    ) -> OutcomeRecord:
        """The record :meth:`to_dict` wrote.

        Raises:
            TrajectoryFileError: not a table, a key missing, unknown (naming the valid ones)
                or of the wrong type; ``file`` and ``key`` (the record's place, e.g.
                ``outcomes.goal``) name where.
        """
        if not isinstance(data, Mapping):
            raise TrajectoryFileError(file, key, f"expected a table, got {data!r}")
        for k in _BASE_KEYS:
            if k not in data:
                raise TrajectoryFileError(file, f"{key}.{k}", "missing")

        def bad(k: str, expected: str) -> TrajectoryFileError:
            return TrajectoryFileError(file, f"{key}.{k}", f"expected {expected}, got {data[k]!r}")

        def text(k: str) -> str:
            if not isinstance(data[k], str):
                raise bad(k, "a string")
            return str(data[k])

        def real(k: str) -> float:
            v = data[k]
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise bad(k, "a number")
            return float(v)

        def number(k: str) -> float | None:
            return None if data[k] is None else real(k)

        kind = text("kind")
        if kind not in KINDS:
            raise TrajectoryFileError(
                file, f"{key}.kind", f"unknown kind {kind!r}; kinds: {', '.join(KINDS)}"
            )
        success = data["success"]
        if success is not None and not isinstance(success, bool):
            raise bad("success", "true, false or null")
        shape = _FIGURES.get(kind)
        figure_keys = [f.name for f in dataclasses.fields(shape)] if shape else []
        valid = [*_BASE_KEYS, *figure_keys, "note"]
        for k in data:
            if k not in valid:
                raise TrajectoryFileError(
                    file, f"{key}.{k}", f"unknown key; a {kind} record's keys: {', '.join(valid)}"
                )
        figures: Figures | None = None
        present = [k for k in figure_keys if k in data]
        if present:
            missing = [k for k in figure_keys if k not in data]
            if missing:
                raise TrajectoryFileError(file, f"{key}.{missing[0]}", "missing")
            if kind == "reach":
                figures = ReachFigures(
                    closest=real("closest"),
                    final_distance=real("final_distance"),
                )
            elif kind == "upright":
                figures = UprightFigures(
                    exceeded_at=number("exceeded_at"),
                    final_tilt=real("final_tilt"),
                )
            else:
                samples = data["samples"]
                if isinstance(samples, bool) or not isinstance(samples, int):
                    raise bad("samples", "an integer")
                figures = TrackFigures(samples=samples, max_error=number("max_error"))
        note = data.get("note")
        if note is not None and not isinstance(note, str):
            raise bad("note", "a string or null")
        return cls(
            name=text("name"),
            kind=kind,
            unit=text("unit"),
            value=number("value"),
            success=success,
            figures=figures,
            note=note,
        )


# ---------------------------------------------------------------- evaluation


def _fail(outcome: Outcome, index: int | None, key: str, detail: str, file: str) -> ScenarioError:
    where = f"outcomes[{index}].{key}" if index is not None else f"outcome {outcome.name!r}.{key}"
    return ScenarioError(file, where, detail)


def _window(outcome: Outcome, tr: Trajectory) -> tuple[int, int] | None:
    if not outcome.phase:
        return 0, len(tr.time) - 1
    for name, a, b in tr.phases:
        if name == outcome.phase:
            return a, b
    return None


def _link_column(body: BodyTrajectory, link: JointRef) -> int | None:
    """Column of ``body.link_positions`` for ``link`` (None: the base frame)."""
    if link == "base" or link == -1:
        return None
    if isinstance(link, int):
        if 0 <= link < len(body.link_names) - 1:
            return link + 1
        raise KeyError(link)
    if link in body.link_names[1:]:
        return body.link_names.index(link, 1)
    raise KeyError(link)


def _joint_columns(body: BodyTrajectory, joints: Sequence[JointRef]) -> list[int]:
    cols = []
    indices = [int(j) for j in body.joint_indices]
    for j in joints:
        if isinstance(j, str):
            if j not in body.joint_names:
                raise KeyError(j)
            cols.append(body.joint_names.index(j))
        else:
            if j not in indices:
                raise KeyError(j)
            cols.append(indices.index(j))
    return cols


def _positions(body: BodyTrajectory, link: JointRef) -> np.ndarray:
    col = _link_column(body, link)
    return body.base_position if col is None else body.link_positions[:, col, :]


def tilt(orientation: np.ndarray) -> np.ndarray:
    """(T,) rad: the angle between the world z axis and the body axis that pointed along it at
    the first instant (orientations (T, 4), x, y, z, w)."""
    q0 = orientation[0]
    conj = np.array([-q0[0], -q0[1], -q0[2], q0[3]])
    up_body = rotate(conj, np.array([0.0, 0.0, 1.0]))
    up = rotate(orientation, up_body)
    up /= norm(up, keepdims=True)
    return acos(np.clip(up[:, 2], -1.0, 1.0))


def _record(
    outcome: Outcome,
    value: float | None,
    success: bool | None,
    figures: Figures | None = None,
    note: str | None = None,
) -> OutcomeRecord:
    return OutcomeRecord(
        outcome.name, outcome.kind, outcome.unit, value, success, figures=figures, note=note
    )


def evaluate(
    outcome: Outcome,
    tr: Trajectory,
    *,
    base: Path | None = None,
    file: str = "<scenario>",
    index: int | None = None,
    cut_at: float | None = None,
) -> OutcomeRecord:
    """Measure ``outcome`` on the recorded run ``tr``.

    Returns an :class:`OutcomeRecord`: ``name``, ``kind``, ``unit``, ``value`` (float or None),
    ``success`` (bool, or None where no bound is declared or the window was not run), and per
    kind its ``figures``: ``reach``: :class:`ReachFigures` (``closest``, m, the smallest
    distance; ``final_distance``, m); ``upright``: :class:`UprightFigures` (``exceeded_at``, s,
    the first instant over the bound, None: never; ``final_tilt``, rad); ``track``:
    :class:`TrackFigures` (``samples``, values counted; ``max_error``); the other kinds none. A
    phase the run did not reach (a shortened run) gives value and success None, no figures and
    a ``note``. ``cut_at``: the seconds the scenario was cut to (``Scenario.cut_at``), said in
    those notes; on such a run a ``function`` that raises or returns a number that is not
    finite (it needed what was not run) gives value and success None and a ``note`` saying so,
    where a whole run raises. Any other outcome of a cut run is measured on what ran.

    Raises:
        ScenarioError: an unknown robot, link or joint (naming the outcome and the valid
            names), or a function that fails.
    """
    if outcome.kind == "function":
        return _evaluate_function(outcome, tr, base, file, index, cut_at)
    robot = outcome.robot or tr.subject
    if robot not in tr.bodies:
        raise _fail(
            outcome, index, "robot", f"no robot {robot!r}; robots: {sorted(tr.bodies)}", file
        )
    body = tr.bodies[robot]
    window = _window(outcome, tr)
    if window is None:
        note = f"phase {outcome.phase!r} was not run"
        if cut_at is not None:
            note += f" (the run was cut at {cut_at:g} s)"
        return _record(outcome, None, None, note=note)
    a, b = window
    t = tr.time[a : b + 1] - tr.time[a]
    measure = _MEASURES.get(outcome.kind)
    if measure is None:
        raise _fail(outcome, index, "kind", f"unknown kind {outcome.kind!r}; kinds: {KINDS}", file)
    try:
        return measure(outcome, body, a, b, t, tr.timestep)
    except KeyError as exc:
        (missing,) = exc.args
        raise _unknown_name(outcome, index, file, robot, body, missing) from None


def _unknown_name(
    outcome: Outcome, index: int | None, file: str, robot: str, body: BodyTrajectory, missing: Any
) -> ScenarioError:
    """The error for a joint or link ``missing`` from ``robot`` (``body``), naming the valid
    ones."""
    if outcome.kind in ("track", "final_pose", "effort") and outcome.joints:
        valid = ", ".join(body.joint_names)
        if missing in outcome.joints:
            return _fail(
                outcome,
                index,
                "joints",
                f"robot {robot!r} has no movable joint {missing!r}; movable joints: {valid}",
                file,
            )
    valid = ", ".join(["base", *body.link_names[1:]])
    return _fail(
        outcome, index, "link", f"robot {robot!r} has no link {missing!r}; links: {valid}", file
    )


def _upright(
    outcome: Outcome, body: BodyTrajectory, a: int, b: int, t: np.ndarray, dt: float
) -> OutcomeRecord:
    """``upright``: the largest tilt of the base (rad) over rows ``a`` to ``b``, and when it
    first reached the bound (``t``: s from row ``a``)."""
    angles = tilt(body.base_orientation[a : b + 1])
    assert outcome.max_tilt is not None
    over = np.flatnonzero(angles >= outcome.max_tilt)
    worst = float(angles.max())
    return _record(
        outcome,
        worst,
        bool(over.size == 0),
        UprightFigures(
            exceeded_at=float(t[over[0]]) if over.size else None,
            final_tilt=float(angles[-1]),
        ),
    )


def _final_pose(
    outcome: Outcome, body: BodyTrajectory, a: int, b: int, t: np.ndarray, dt: float
) -> OutcomeRecord:
    """``final_pose``: at row ``b``, the distance to the point (m), the angle to the
    orientation (rad) or the joints' RMS error to their targets."""
    if outcome.point is not None:
        n = len(outcome.point)
        pos = _positions(body, outcome.link)[b, :n]
        err = length(pos - np.asarray(outcome.point))
    elif outcome.orientation is not None:
        q = body.base_orientation[b]
        target = np.asarray(outcome.orientation)
        cos = abs(float(dot(q, target))) / (length(q) * length(target))
        err = 2.0 * math.acos(min(1.0, cos))
    else:
        cols = _joint_columns(body, outcome.joints)
        q = body.joint_positions[b, cols]
        err = float(np.sqrt(np.mean((q - np.asarray(outcome.targets)) ** 2)))
    ok = None if outcome.within is None else bool(err <= outcome.within)
    return _record(outcome, err, ok)


def _effort(
    outcome: Outcome, body: BodyTrajectory, a: int, b: int, t: np.ndarray, dt: float
) -> OutcomeRecord:
    """``effort``: the work of the joints (every movable one by default) over the steps after
    row ``a`` to row ``b``, |force x velocity| summed times ``dt`` (s)."""
    cols = (
        _joint_columns(body, outcome.joints)
        if outcome.joints
        else list(range(len(body.joint_names)))
    )
    power = np.abs(
        body.joint_forces[a + 1 : b + 1, cols] * body.joint_velocities[a + 1 : b + 1, cols]
    )
    work = float(power.sum() * dt)
    ok = None if outcome.max is None else bool(work <= outcome.max)
    return _record(outcome, work, ok)


def _reach(
    outcome: Outcome, body: BodyTrajectory, a: int, b: int, t: np.ndarray, dt: float
) -> OutcomeRecord:
    assert outcome.point is not None and outcome.within is not None
    n = len(outcome.point)
    pos = _positions(body, outcome.link)[a : b + 1, :n]
    d = norm(pos - np.asarray(outcome.point))
    inside = d <= outcome.within
    if outcome.hold:
        outside = np.flatnonzero(~inside)
        first = 0 if outside.size == 0 else int(outside[-1]) + 1
        row = first if first < len(d) else None
    else:
        hits = np.flatnonzero(inside)
        row = int(hits[0]) if hits.size else None
    when = None if row is None else float(t[row])
    ok = when is not None and (outcome.by is None or when <= outcome.by)
    return _record(
        outcome, when, bool(ok), ReachFigures(closest=float(d.min()), final_distance=float(d[-1]))
    )


def _track(
    outcome: Outcome, body: BodyTrajectory, a: int, b: int, t: np.ndarray, dt: float
) -> OutcomeRecord:
    if outcome.points:
        pos = _positions(body, outcome.link)[a : b + 1]
        pts = np.asarray(outcome.points, dtype=np.float64)
        n = pts.shape[1] - 1
        k = np.searchsorted(pts[:, 0], t, side="right") - 1  # the last point at or before t
        use = k >= 0
        if not use.any():
            return _record(outcome, None, None, TrackFigures(samples=0, max_error=None))
        err = norm(pos[use, :n] - pts[k[use], 1:])
    else:
        cols = (
            _joint_columns(body, outcome.joints)
            if outcome.joints
            else list(range(len(body.joint_names)))
        )
        source = body.joint_velocities if outcome.quantity == "velocity" else body.joint_positions
        actual = source[a : b + 1, cols]
        if outcome.targets:
            target = np.broadcast_to(np.asarray(outcome.targets), actual.shape)
            mask = np.ones(actual.shape, dtype=bool)
        else:
            code = 1 if outcome.quantity == "velocity" else 2
            target = body.joint_targets[a : b + 1, cols]
            mask = (body.joint_modes[a : b + 1, cols] == code) & np.isfinite(target)
            if not outcome.joints:  # all joints: those commanded in this mode at some instant
                keep = mask.any(axis=0)
                actual, target, mask = actual[:, keep], target[:, keep], mask[:, keep]
        if not mask.any():
            return _record(outcome, None, None, TrackFigures(samples=0, max_error=None))
        err = np.abs(actual - target)[mask]
    rms = float(np.sqrt(np.mean(err**2)))
    ok = None if outcome.max is None else bool(rms <= outcome.max)
    return _record(
        outcome, rms, ok, TrackFigures(samples=int(err.size), max_error=float(err.max()))
    )


_MEASURES: dict[
    str, Callable[[Outcome, BodyTrajectory, int, int, np.ndarray, float], OutcomeRecord]
] = {
    "reach": _reach,
    "upright": _upright,
    "track": _track,
    "final_pose": _final_pose,
    "effort": _effort,
}
"""Each kind measured on a body's rows ``a`` to ``b`` (the outcome's window), ``t`` their times
from row ``a`` (s), ``dt`` the time step (s); ``function`` is :func:`_evaluate_function`."""


def _evaluate_function(
    outcome: Outcome,
    tr: Trajectory,
    base: Path | None,
    file: str,
    index: int | None,
    cut_at: float | None = None,
) -> OutcomeRecord:
    from ..scenario.controllers import RefError, load_object

    def not_evaluable(what: str) -> OutcomeRecord:
        note = f"not evaluable on the run cut at {cut_at:g} s: {outcome.function}(trajectory) "
        return _record(outcome, None, None, note=note + what)

    try:
        fn = load_object(outcome.function, base)
    except RefError as exc:
        raise _fail(outcome, index, "function", str(exc), file) from None
    try:
        out = fn(tr, **outcome.params)
    except Exception as exc:
        if cut_at is not None:
            return not_evaluable(f"raised {type(exc).__name__}: {exc}")
        raise _fail(
            outcome,
            index,
            "function",
            f"{outcome.function}(trajectory) raised {type(exc).__name__}: {exc}",
            file,
        ) from exc
    if out is None:
        return _record(outcome, None, None)
    if isinstance(out, (bool, np.bool_)):
        return _record(outcome, float(bool(out)), bool(out))
    if isinstance(out, (int, float, np.integer, np.floating)) and math.isfinite(float(out)):
        v = float(out)
        ok: bool | None = None
        if outcome.max is not None or outcome.min is not None:
            ok = (outcome.max is None or v <= outcome.max) and (
                outcome.min is None or v >= outcome.min
            )
        return _record(outcome, v, ok)
    if isinstance(out, (int, float, np.integer, np.floating)) and cut_at is not None:
        return not_evaluable(f"returned {out!r}")
    raise _fail(
        outcome,
        index,
        "function",
        f"{outcome.function}(trajectory) returned {out!r}; expected a finite number, a bool or "
        "None",
        file,
    )


def evaluate_all(scenario: Scenario, tr: Trajectory) -> dict[str, OutcomeRecord]:
    """Every outcome the scenario declares, measured on ``tr``: ``{name: record}``."""
    base = scenario.source.parent if scenario.source is not None else None
    file = str(scenario.source) if scenario.source is not None else f"<scenario {scenario.name}>"
    return {
        o.name: evaluate(o, tr, base=base, file=file, index=i, cut_at=scenario.cut_at)
        for i, o in enumerate(scenario.outcomes)
    }
