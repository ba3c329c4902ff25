"""What happens to the followed robot in one engine's run, found in its recorded contacts, pose,
joints and motors (:func:`find_events`). Which event the gap between two engines first crossed
its threshold after is the analysis's (:func:`simbridge.compare.analysis.events.parting`), the
events in words the report's (:mod:`simbridge.compare.report.events`).

Kinds of :class:`Event` (:data:`KINDS`), each at the first recorded instant it holds:

===================== ===================================================================
``contact_made``      a link starts touching something (another body, or another of its
                      own links), after the first step
``contact_lost``      a link stops touching anything
``contact_chatter``   a link that keeps touching loses and regains its contact at least
                      :data:`CHATTER_LOSSES` (3) times, each loss shorter than the bridge
``airborne``          no link of the robot touches anything (a mobile base that touched
                      something at some time of the run); one from the first step, before
                      any contact (a robot spawned in the air), has the figure
                      ``from_start`` (1.0): it falls, it did not leave the ground
``peak_height``       the highest point of the base during an airborne stretch (none in one
                      from the start unless the base rose above its spawn height)
``tipped_over``       the base turned more than :data:`TIP_ANGLE` (45°) from the way it stood
                      at spawn: the angle between the base axis that pointed up (against
                      gravity) at spawn and where that axis points now (a y-up URDF spawned
                      upright stands at 0°); a mobile base only
``joint_limit``       a joint within :data:`LIMIT_TOLERANCE` of its lower or upper limit, or
                      past it (one resting there from the start is in ``initial_limits``)
``motor_saturated``   a velocity or position motor's force at its ``max_force`` (within a
                      relative :data:`SATURATION_TOLERANCE`)
===================== ===================================================================

A condition that stops for less than :data:`BRIDGE` (0.05 s) and resumes counts as going on
(a wheel chattering on the ground every other step is one contact, not a hundred), so
``airborne`` lasts at least that long and contacts are made or lost at most that often per
link. Contacts are those of each step (the record at row r is the state after step r; row 0,
before any step, has none): a link touching at the first step is in ``initial_contacts``, not a
``contact_made`` event.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from .portable import dot
from .quantities import DEG, tilt_from, up_of
from .trajectory import BodyTrajectory, Trajectory

__all__ = [
    "LimitAtStart",
    "StartDepth",
    "KINDS",
    "BRIDGE",
    "TIP_ANGLE",
    "LIMIT_TOLERANCE",
    "SATURATION_TOLERANCE",
    "Event",
    "EngineEvents",
    "find_events",
    "phase_at",
    "PARTING_WINDOW",
    "INTERVAL_KINDS",
]

KINDS = (
    "tipped_over",
    "airborne",
    "contact_lost",
    "contact_made",
    "contact_chatter",
    "joint_limit",
    "motor_saturated",
    "peak_height",
)
"""Every kind, in the order that breaks ties between events at the same instant."""

BRIDGE = 0.05
"""s: a condition interrupted for less than this counts as going on."""
TIP_ANGLE = 45 * DEG
"""rad: the tilt from the spawn orientation past which the robot has tipped over."""
LIMIT_TOLERANCE = 1e-3
"""rad or m: how near its limit a joint counts as at it (at most 1% of the joint's range)."""
SATURATION_TOLERANCE = 1e-3
"""Relative: a motor whose |force| reaches (1 - this) x max_force is saturated."""
CHATTER_LOSSES = 3
"""Losses of contact, each shorter than :data:`BRIDGE`, that make a ``contact_chatter``."""
PARTING_WINDOW = 0.1
"""s: an event this shortly before the gap reaches its threshold is the one it parted after."""

INTERVAL_KINDS = ("airborne", "tipped_over", "contact_chatter", "joint_limit", "motor_saturated")


@dataclass(frozen=True)
class Event:
    """One thing that happened to ``body`` in one engine's run.

    ``time`` (s) is the first recorded instant of it, ``row`` its row in the trajectory, and
    ``phase`` the scenario phase that instant belongs to. Interval kinds (``airborne``,
    ``tipped_over``, ``joint_limit``, ``motor_saturated``) have ``end``: the last instant it
    held (None: it still held at the end of the run). ``part`` is the link (contacts) or joint
    (limits, motors); ``others`` the other bodies touching anything at that instant (contacts:
    the link's likely partners; empty: it touched another of its own links); ``side`` is
    ``lower`` or ``upper`` for a joint limit. ``figures`` holds the kind's numbers (SI):
    ``contact_made``: ``normal_force`` (N, the link's sum at that instant);
    ``contact_chatter``: ``losses`` (how many times the contact was lost and regained) and
    ``duration`` (s); ``airborne``:
    ``duration`` (s) and, from the first step before any contact, ``from_start`` (1.0);
    ``peak_height``: ``height`` (m, of the base link frame along the world's up) and ``rise``
    (m, above where it left the ground, or its spawn height); ``tipped_over``: ``tilt`` (rad, the
    largest while over); ``joint_limit``: ``limit`` (rad or m) and ``beyond`` (how far past it
    the joint went, rad or m; negative: it stayed short of it); ``motor_saturated``:
    ``max_force`` (N·m or N) and ``duration`` (s)."""

    kind: str
    time: float
    row: int
    phase: str
    body: str
    part: str | None = None
    end: float | None = None
    others: tuple[str, ...] = ()
    side: str | None = None
    figures: dict[str, float] = field(default_factory=dict)


class LimitAtStart(NamedTuple):
    """A joint at one of its limits from the first step (not an event:
    :attr:`EngineEvents.initial_limits`)."""

    joint: str
    side: str  # "lower" or "upper"
    end: float | None  # s, the last instant it held (None: to the end of the run)


class StartDepth(NamedTuple):
    """How far the robot starts inside something (not an event:
    :attr:`EngineEvents.start_depth`): the deepest point of its first step's contacts, found at
    the spawn pose."""

    link: str  # the link that went deepest
    depth: float  # m, > 0
    others: tuple[str, ...]  # the other bodies touching then (empty: its own links)


@dataclass
class EngineEvents:
    """The events of one engine's run (one body, ``body``), in time order (ties in
    :data:`KINDS` order). ``up`` is the world's up (against gravity, unit), ``spawn`` the
    base orientation the tilt is measured from (x, y, z, w), ``initial_contacts`` the links
    touching something at the first step, ``initial_limits`` the joints at a limit from the
    start (``{joint, side, end}``, ``end`` as an event's), ``start_depth`` how far it starts
    inside something (None: apart or resting on a surface, or no depth recorded)."""

    label: str
    body: str
    events: list[Event]
    up: np.ndarray
    spawn: np.ndarray
    initial_contacts: list[str]
    has_contacts: bool
    """Whether contacts were recorded at all (False for a trajectory recorded without them)."""
    initial_limits: list[LimitAtStart] = field(default_factory=list)
    start_depth: StartDepth | None = None

    def counts(self) -> dict[str, int]:
        return {k: sum(e.kind == k for e in self.events) for k in KINDS}


# ---------------------------------------------------------------- helpers


def phase_at(phases: list[tuple[str, int, int]], row: int) -> str:
    """The phase of the state recorded at ``row``: the one whose steps produced it (row 0, the
    initial state, belongs to the first phase)."""
    for name, first, last in phases:
        if first < row <= last:
            return name
    return phases[0][0] if phases else ""


def _runs(mask: np.ndarray, bridge: int) -> list[tuple[int, int]]:
    """``(first, last)`` index pairs (inclusive) of the runs of True in ``mask``, a gap of
    fewer than ``bridge`` False entries between two runs filled."""
    idx = np.flatnonzero(mask)
    if idx.size == 0:
        return []
    breaks = np.flatnonzero(np.diff(idx) > bridge)  # a gap of >= bridge False entries
    starts = np.concatenate([[idx[0]], idx[breaks + 1]])
    ends = np.concatenate([idx[breaks], [idx[-1]]])
    return [(int(a), int(b)) for a, b in zip(starts, ends, strict=True)]


def _bridge_rows(dt: float) -> int:
    """Gaps of fewer rows than this are bridged: ``ceil(BRIDGE / dt)`` (12 at 1/240 s)."""
    return max(1, math.ceil(BRIDGE / dt - 1e-9))


# ---------------------------------------------------------------- events of one run


def find_events(
    tr: Trajectory, *, body: str | None = None, label: str | None = None
) -> EngineEvents:
    """Every event of ``body`` (default the subject) in run ``tr``.

    Uses the recorded contacts (``contact_counts``, ``contact_normal_forces``; no contact
    event when the trajectory has none), the base pose, the joint positions against
    ``joint_limits`` and the joint forces against ``joint_max_forces`` (none when missing).
    """
    name = tr.subject if body is None else body
    b = tr.bodies[name]
    time = tr.time
    rows = len(time)
    dt = float(tr.timestep)
    bridge = _bridge_rows(dt)
    up = up_of(tr)
    phases = tr.phases
    out: list[Event] = []

    def ev(kind: str, row: int, **kw: Any) -> Event:
        return Event(kind, float(time[row]), row, phase_at(phases, row), name, **kw)

    def end_of(last: int) -> float | None:
        return None if last >= rows - 1 else float(time[last])

    initial: list[str] = []
    has_contacts = b.contact_counts is not None
    if has_contacts and rows > 1:
        initial = _contact_events(tr, name, b, bridge, ev, out)
        if not b.fixed_base:
            _airborne_events(b, bridge, up, time, ev, end_of, out)
    if not b.fixed_base:
        tilt = tilt_from(b.base_orientation, b.base_orientation[0], up)
        for first, last in _runs(tilt > TIP_ANGLE, bridge):
            seg = tilt[first : last + 1]
            out.append(
                ev("tipped_over", first, end=end_of(last), figures={"tilt": float(seg.max())})
            )
    initial_limits = _limit_events(b, bridge, ev, end_of, out)
    _saturation_events(b, bridge, time, ev, end_of, out)
    order = {k: i for i, k in enumerate(KINDS)}
    out.sort(key=lambda e: (e.row, order[e.kind], e.part or ""))
    return EngineEvents(
        label=label or tr.label,
        body=name,
        events=out,
        up=up,
        spawn=np.asarray(b.base_orientation[0], dtype=np.float64),
        initial_contacts=initial,
        has_contacts=has_contacts,
        initial_limits=initial_limits,
        start_depth=_start_depth(tr, name, b),
    )


def _start_depth(tr: Trajectory, name: str, b: BodyTrajectory) -> StartDepth | None:
    """The deepest contact of the first step (row 1: the contacts found at the spawn pose)."""
    d = b.contact_depths
    if d is None or len(d) < 2 or not (d[1] > 0).any():
        return None
    k = int(np.argmax(d[1]))
    return StartDepth(b.link_names[k], float(d[1, k]), _touching_others(tr, name, 1))


def _touching_others(tr: Trajectory, name: str, row: int) -> tuple[str, ...]:
    """The bodies other than ``name`` touching anything at ``row``."""
    return tuple(
        other
        for other, ob in tr.bodies.items()
        if other != name and ob.contact_counts is not None and ob.contact_counts[row].any()
    )


def _contact_events(
    tr: Trajectory, name: str, b: BodyTrajectory, bridge: int, ev: Any, out: list[Event]
) -> list[str]:
    assert b.contact_counts is not None
    rows = len(tr.time)
    touching = b.contact_counts[1:] > 0  # row 0: no step yet
    forces = b.contact_normal_forces
    initial = []
    for k, link in enumerate(b.link_names):
        for first, last in _runs(touching[:, k], bridge):
            a, z = first + 1, last + 1  # rows
            losses = _runs(~touching[first : last + 1, k], 1)  # each one < bridge
            stretch = [(x + first, y + first) for x, y in losses]
            for c0, c1 in _chatter(stretch, bridge):
                n = c1 - c0 + 1
                out.append(
                    ev(
                        "contact_chatter",
                        stretch[c0][0] + 1,
                        part=link,
                        end=float(tr.time[stretch[c1][1] + 1]),
                        others=_touching_others(tr, name, a),
                        figures={
                            "losses": float(n),
                            "duration": float(
                                tr.time[stretch[c1][1] + 2] - tr.time[stretch[c0][0] + 1]
                            ),
                        },
                    )
                )
            if a == 1:
                initial.append(link)
            else:
                force = float(forces[a, k]) if forces is not None else float("nan")
                out.append(
                    ev(
                        "contact_made",
                        a,
                        part=link,
                        others=_touching_others(tr, name, a),
                        figures={"normal_force": force},
                    )
                )
            if z < rows - 1:
                out.append(
                    ev("contact_lost", z + 1, part=link, others=_touching_others(tr, name, z))
                )
    return initial


def _chatter(losses: list[tuple[int, int]], bridge: int) -> list[tuple[int, int]]:
    """Index ranges ``(i, j)`` into ``losses`` (gaps in one contact, in order) of the groups of
    at least :data:`CHATTER_LOSSES` consecutive losses less than ``bridge`` rows apart."""
    groups = []
    i = 0
    for j in range(1, len(losses) + 1):
        if j == len(losses) or losses[j][0] - losses[j - 1][1] > bridge:
            if j - i >= CHATTER_LOSSES:
                groups.append((i, j - 1))
            i = j
    return groups


def _airborne_events(
    b: BodyTrajectory,
    bridge: int,
    up: np.ndarray,
    time: np.ndarray,
    ev: Any,
    end_of: Any,
    out: list[Event],
) -> None:
    assert b.contact_counts is not None
    rows = len(time)
    any_contact: np.ndarray = np.asarray((b.contact_counts[1:] > 0).any(axis=1))
    runs = _runs(any_contact, bridge)
    if not runs:
        return  # never touched anything: nothing to leave
    gaps = []
    if runs[0][0] > 0:
        gaps.append((0, runs[0][0] - 1))
    gaps += [(z + 1, a - 1) for (_, z), (a, _) in zip(runs[:-1], runs[1:], strict=True)]
    if runs[-1][1] < len(any_contact) - 1:
        gaps.append((runs[-1][1] + 1, len(any_contact) - 1))
    height = dot(b.base_position, up)
    for first, last in gaps:
        if last - first + 1 < bridge:  # a start or an end shorter than the bridge
            continue
        a, z = first + 1, last + 1  # rows
        duration = float(time[min(z + 1, rows - 1)] - time[a])
        figures = {"duration": duration}
        from_start = first == 0  # spawned in the air: it never left the ground
        if from_start:
            figures["from_start"] = 1.0
        out.append(ev("airborne", a, end=end_of(z), figures=figures))
        top = a + int(np.argmax(height[a : z + 1]))
        if from_start and height[top] <= height[a - 1]:
            continue  # no higher than its spawn: falling from the start is not a peak
        out.append(
            ev(
                "peak_height",
                top,
                figures={
                    "height": float(height[top]),
                    "rise": float(height[top] - height[a - 1]),
                    **({"from_start": 1.0} if from_start else {}),
                },
            )
        )


def _limit_events(
    b: BodyTrajectory, bridge: int, ev: Any, end_of: Any, out: list[Event]
) -> list[LimitAtStart]:
    initial: list[LimitAtStart] = []
    if b.joint_limits is None:
        return initial
    q = b.joint_positions
    for j, joint in enumerate(b.joint_names):
        lo, hi = (float(x) for x in b.joint_limits[j])
        if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
            continue
        tol = min(LIMIT_TOLERANCE, 0.01 * (hi - lo))
        for side, limit, past in (("lower", lo, lo - q[:, j]), ("upper", hi, q[:, j] - hi)):
            for first, last in _runs(past >= -tol, bridge):
                if first == 0:
                    initial.append(LimitAtStart(joint, side, end_of(last)))
                    continue
                out.append(
                    ev(
                        "joint_limit",
                        first,
                        part=joint,
                        side=side,
                        end=end_of(last),
                        figures={"limit": limit, "beyond": float(past[first : last + 1].max())},
                    )
                )
    return initial


def _saturation_events(
    b: BodyTrajectory, bridge: int, time: np.ndarray, ev: Any, end_of: Any, out: list[Event]
) -> None:
    if b.joint_max_forces is None or len(time) < 2:
        return
    mf = b.joint_max_forces[1:]
    f = np.abs(b.joint_forces[1:])
    with np.errstate(invalid="ignore"):
        sat = np.isfinite(mf) & (mf > 0) & (f >= mf * (1.0 - SATURATION_TOLERANCE))
    rows = len(time)
    for j, joint in enumerate(b.joint_names):
        for first, last in _runs(sat[:, j], bridge):
            a, z = first + 1, last + 1
            out.append(
                ev(
                    "motor_saturated",
                    a,
                    part=joint,
                    end=end_of(z),
                    figures={
                        "max_force": float(mf[first, j]),
                        "duration": float(time[min(z + 1, rows - 1)] - time[a]),
                    },
                )
            )
