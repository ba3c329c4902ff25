"""Where the gap is born: what happens to the followed robot in each engine's run, found in its
recorded contacts, pose, joints and motors (:func:`find_events`), and which event the gap
between the engines first crossed its threshold after (:func:`parting`).

Kinds of :class:`Event` (:data:`KINDS`), each at the first recorded instant it holds:

===================== ===================================================================
``contact_made``      a link starts touching something (another body, or another of its
                      own links), after the first step
``contact_lost``      a link stops touching anything
``contact_chatter``   a link that keeps touching loses and regains its contact at least
                      :data:`CHATTER_LOSSES` (3) times, each loss shorter than the bridge
``airborne``          no link of the robot touches anything (a mobile base that touched
                      something at some time of the run)
``peak_height``       the highest point of the base during an airborne stretch
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
from typing import Any

import numpy as np

from .diff import DEG, tilt_from, up_of
from .fmt import fmt_distance, fmt_time
from .run import BodyTrajectory, Trajectory

__all__ = [
    "KINDS",
    "BRIDGE",
    "TIP_ANGLE",
    "LIMIT_TOLERANCE",
    "SATURATION_TOLERANCE",
    "Event",
    "EngineEvents",
    "find_events",
    "parting",
    "phase_at",
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

_INTERVAL_KINDS = ("airborne", "tipped_over", "contact_chatter", "joint_limit", "motor_saturated")


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
    ``duration`` (s); ``peak_height``: ``height`` (m, of the base link frame along the world's
    up) and ``rise`` (m, above where it left the ground); ``tipped_over``: ``tilt`` (rad, the
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

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "time": self.time,
            "end": self.end,
            "phase": self.phase,
            "body": self.body,
            "part": self.part,
            "others": list(self.others),
            "side": self.side,
            "figures": dict(self.figures),
        }

    def words(self, label: str) -> str:
        """The event in words, e.g. ``pybullet's r2d2 lost contact with plane at
        right_back_wheel``."""
        return event_words(self.to_dict(), label)


def event_words(e: dict[str, Any], label: str) -> str:
    """An event's dict (:meth:`Event.to_dict`, as ``summary.json`` holds it) in words."""
    who = f"{label}'s {e['body']}"
    others = " and ".join(e["others"]) if e["others"] else "another of its own links"
    f = e["figures"]
    kind = e["kind"]
    if kind == "contact_made":
        return f"{who} touched {others} with {e['part']}"
    if kind == "contact_lost":
        return f"{who} lost contact with {others} at {e['part']}"
    if kind == "contact_chatter":
        return (
            f"{who}'s {e['part']} chattered on {others} (lost and regained contact "
            f"{f['losses']:.0f} times in {f['duration']:.3g} s)"
        )
    if kind == "airborne":
        return f"{who} left the ground (airborne for {f['duration']:.3g} s)"
    if kind == "peak_height":
        return (
            f"{who} peaked at a height of {fmt_distance(f['height'])} "
            f"({fmt_distance(f['rise'])} above where it left the ground)"
        )
    if kind == "tipped_over":
        return (
            f"{who} tipped over (more than {TIP_ANGLE / DEG:g}° from its spawn orientation, "
            f"up to {f['tilt'] / DEG:.0f}°)"
        )
    if kind == "joint_limit":
        return f"{who} reached the {e['side']} limit of {e['part']} ({f['limit']:.4g})"
    if kind == "motor_saturated":
        return f"{who}'s {e['part']} motor saturated at its max_force {f['max_force']:g}"
    return f"{who}: {kind}"


@dataclass
class EngineEvents:
    """The events of one engine's run (one body, ``body``), in time order (ties in
    :data:`KINDS` order). ``up`` is the world's up (against gravity, unit), ``spawn`` the
    base orientation the tilt is measured from (x, y, z, w), ``initial_contacts`` the links
    touching something at the first step, ``initial_limits`` the joints at a limit from the
    start (``{joint, side, end}``, ``end`` as an event's)."""

    label: str
    body: str
    events: list[Event]
    up: np.ndarray
    spawn: np.ndarray
    initial_contacts: list[str]
    has_contacts: bool
    """Whether contacts were recorded at all (False for a trajectory recorded without them)."""
    initial_limits: list[dict[str, Any]] = field(default_factory=list)

    def counts(self) -> dict[str, int]:
        return {k: sum(e.kind == k for e in self.events) for k in KINDS}

    def to_dict(self, limit: int = 500) -> dict[str, Any]:
        """JSON-ready; at most ``limit`` events listed (the first ones), ``total`` counts all."""
        return {
            "body": self.body,
            "up": [float(v) for v in self.up],
            "spawn_orientation": [float(v) for v in self.spawn],
            "contacts_recorded": self.has_contacts,
            "initial_contacts": list(self.initial_contacts),
            "initial_limits": list(self.initial_limits),
            "counts": self.counts(),
            "total": len(self.events),
            "events": [e.to_dict() for e in self.events[:limit]],
        }


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
    )


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
    height = b.base_position @ up
    for first, last in gaps:
        if last - first + 1 < bridge:  # a start or an end shorter than the bridge
            continue
        a, z = first + 1, last + 1  # rows
        duration = float(time[min(z + 1, rows - 1)] - time[a])
        out.append(ev("airborne", a, end=end_of(z), figures={"duration": duration}))
        top = a + int(np.argmax(height[a : z + 1]))
        out.append(
            ev(
                "peak_height",
                top,
                figures={
                    "height": float(height[top]),
                    "rise": float(height[top] - height[a - 1]),
                },
            )
        )


def _limit_events(
    b: BodyTrajectory, bridge: int, ev: Any, end_of: Any, out: list[Event]
) -> list[dict[str, Any]]:
    initial: list[dict[str, Any]] = []
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
                    initial.append({"joint": joint, "side": side, "end": end_of(last)})
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


# ---------------------------------------------------------------- where the gap is born


def parting(
    time: float | None,
    threshold: float,
    quantity: str,
    phases: list[tuple[str, float, float]],
    engines: list[EngineEvents],
    step: float = 0.0,
) -> dict[str, Any]:
    """Where the gap is born: the phase and the event during which it first reached
    ``threshold`` (at ``time``, None: never).

    ``phases`` are ``(name, start, end)`` in s; the phase is the one whose steps led to
    ``time``. The event, of either engine (``peak_height`` aside), is the first found of:

    1. ``after``: the latest event that began within :data:`PARTING_WINDOW` (0.1 s) before
       ``time`` (up to ``time`` + ``step``: a contact lost in the very step that parts them
       counts);
    2. ``during``: the interval event (``airborne``, ``tipped_over``, ``contact_chatter``,
       ``joint_limit``, ``motor_saturated``) going on at ``time`` that began last;
    3. ``after``: the latest event that began before ``time``, however long before.

    Ties go in :data:`KINDS` order, then engine order. With no event before ``time``, the
    robot's contacts from its first step (``initial_contacts``) are what it parts during, when
    it has some.

    Returns ``{quantity, threshold, time, step, body, phase, event, relation, since, ongoing,
    initial_contacts}`` (``step``: the recorded step, s; ``body``: the followed robot):
    ``event`` is the event's dict with ``label`` (the engine) added, or None (no event before
    ``time``); ``relation`` ``after`` or ``during`` (None: no event);
    ``since`` (s) how long before ``time`` it began (negative: in the same step, just after);
    ``ongoing`` every interval event going on at ``time``; ``initial_contacts`` per engine
    label, the links touching from the first step (only when no event came before).
    """
    out: dict[str, Any] = {
        "quantity": quantity,
        "threshold": threshold,
        "time": time,
        "step": step,
        "body": engines[0].body if engines else None,
        "phase": None,
        "event": None,
        "relation": None,
        "since": None,
        "ongoing": [],
        "initial_contacts": {},
    }
    if time is None:
        return out
    for name, start, end in phases:
        if start - 1e-12 <= time <= end + 1e-12:
            out["phase"] = name
            if time > start + 1e-12:  # at a boundary: the phase that led to it
                break
    order = {k: i for i, k in enumerate(KINDS)}
    began: list[tuple[tuple[float, int, int], Event, str]] = []
    going: list[tuple[tuple[float, int, int], Event, str]] = []
    for slot, e in enumerate(engines):
        for event in e.events:
            if event.kind == "peak_height" or event.time > time + step + 1e-12:
                continue
            key = (event.time, -order[event.kind], -slot)
            began.append((key, event, e.label))
            if event.kind in _INTERVAL_KINDS and (event.end is None or event.end >= time - 1e-12):
                going.append((key, event, e.label))
                out["ongoing"].append({"label": e.label, **event.to_dict()})
    recent = [x for x in began if x[1].time >= time - PARTING_WINDOW - 1e-12]
    for pool, relation in ((recent, "after"), (going, "during"), (began, "after")):
        if pool:
            _, event, label = max(pool, key=lambda x: x[0])
            out["event"] = {"label": label, **event.to_dict()}
            out["relation"] = relation
            out["since"] = time - event.time
            break
    else:
        out["initial_contacts"] = {
            e.label: e.initial_contacts for e in engines if e.initial_contacts
        }
    return out


def with_start(words: str, time: float) -> str:
    """``words`` with ``from t = ...`` in its closing parenthesis (or a new one)."""
    start = f"from t = {fmt_time(time)}"
    return words[:-1] + f", {start})" if words.endswith(")") else f"{words} ({start})"


def parting_words(p: dict[str, Any]) -> str:
    """``during 'turn', 0.021 s after pybullet's r2d2 lost contact with plane at
    right_back_wheel`` (empty when they never part)."""
    if p.get("time") is None:
        return ""
    words = f"during '{p['phase']}'" if p.get("phase") else ""
    e = p.get("event")
    sep = ", " if words else ""
    if e is None:
        touching = p.get("initial_contacts") or {}
        if not touching:
            return words + sep + "before any event of either engine"
        links = sorted({k for v in touching.values() for k in v})
        shown = ", ".join(links[:4]) + (f" and {len(links) - 4} more" if len(links) > 4 else "")
        first = p["time"] <= p.get("step", 0.0) + 1e-12
        return (
            words
            + sep
            + ("in the first step" if first else "before any event")
            + f", with {p.get('body') or 'the robot'} touching something from its first step at "
            + f"{shown} ({' and '.join(touching)})"
        )
    what = event_words(e, e["label"])
    if p["relation"] == "during":
        return words + sep + f"while {with_start(what, e['time'])}"
    since = p["since"]
    when = "in the same step as" if since <= 0 else f"{fmt_time(since)} after"
    return words + sep + f"{when} {what}"
