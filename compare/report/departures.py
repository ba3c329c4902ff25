"""Which of a backend's profile departures (``manifest()["departures"]``) apply to this scenario,
and what this run measured of each (:func:`applicable`).

A backend lists, once for every scenario, where it cannot reproduce the profile exactly; some
of its sentences quote figures measured on one robot (r2d2's resting height...). The report
lists a departure only where it applies here, in its general words (the backend's text cut
before the figures of another robot, :data:`GENERAL_CUT`), with figures measured in this run
or none:

====================== ===============================================================
``contact``            some body touched something in either engine's run
``cylinder``           a link with a collision cylinder touched something
``restitution``        a link with a nonzero ``<contact><restitution>`` touched something
``rolling/spinning     a link with a nonzero ``<contact>`` rolling or spinning friction
friction``             touched something
``joint limits``       a joint reached its limit in either run (a ``joint_limit`` event)
``motors``             a velocity or position command drove a joint of the followed robot
``speed clamp``        a joint speed or the base's speed reached 99 % of the profile's
                       ``max_joint_velocity``
``joint axis``         a movable joint's ``<axis>`` is not of length 1 (by more than 1e-6)
``link damping``       a profile's ``linear_damping`` or ``angular_damping`` is not 0
``precision``          the engine keeps its state in a type other than float64 (float32):
                       every scenario, as the ensemble's perturbation is raised for it
====================== ===============================================================

A departure naming a body of this world (``body 1 mass bound``) applies as the backend wrote
it; any other is listed as the backend wrote it, marked as not checked against the scenario.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from simbridge.exceptions import SimbridgeError

from ..run.events import EngineEvents
from ..run.portable import dot, length, norm
from .fmt import fmt_distance

if TYPE_CHECKING:
    from ..analysis.view import ComparisonView

__all__ = ["GENERAL_CUT", "NOT_CHECKED", "applicable", "checked"]

NOT_CHECKED = "not checked against this scenario"
"""The ``why`` of a departure no rule here checks against the scenario (listed as the backend
wrote it, not said to apply)."""

GENERAL_CUT = {
    "contact": ": ",
    "joint limits": ": ",
    "motors": "; ",
    "joint axis": " (",
}
"""Where a known departure's text stops being general: what follows quotes another robot."""

SPEED_CLAMP_FRACTION = 0.99
LINK_DAMPING = ("linear_damping", "angular_damping")


def _general(key: str, text: str) -> str:
    cut = GENERAL_CUT.get(key)
    if cut and cut in text:
        return text.split(cut, 1)[0]
    return text


def _urdf_facts(c: ComparisonView) -> dict[str, Any]:
    """Per robot: links with collision cylinders, restitution, rolling/spinning friction,
    and joints with a non-unit axis, from the scenario's URDFs (read as ``Sim.load_urdf``
    reads them; the root link is named ``base`` as in the record)."""
    from simbridge.model.urdf import parse_urdf, resolve_source

    log = logging.getLogger("simbridge.model.urdf")
    facts: dict[str, Any] = {}
    for r in c.scenario.robots:
        was = log.disabled
        log.disabled = True  # the run already logged what was read leniently
        try:
            model = parse_urdf(resolve_source(c.scenario.resolve_urdf(r)))
        except SimbridgeError:
            continue
        finally:
            log.disabled = was

        def name(link: Any) -> str:
            return "base" if link.index == -1 else str(link.name)

        facts[r.name] = {
            "cylinder": [
                name(k) for k in model.links if any(g.kind == "cylinder" for g in k.collisions)
            ],
            "restitution": {
                name(k): k.contact.restitution for k in model.links if k.contact.restitution
            },
            "rolling/spinning friction": {
                name(k): (k.contact.rolling_friction or 0.0, k.contact.spinning_friction or 0.0)
                for k in model.links
                if k.contact.rolling_friction or k.contact.spinning_friction
            },
            "joint axis": {
                j.name: length(j.axis)
                for j in model.joints
                if j.type != "fixed" and abs(length(j.axis) - 1.0) > 1e-6
            },
        }
    return facts


def _touched(c: ComparisonView, slot: int) -> dict[str, list[str]]:
    """Per body of the run: the links that touched something at some recorded instant."""
    tr = c.runs[(slot, c.timestep)]
    out = {}
    for name, b in tr.bodies.items():
        if b.contact_counts is None:
            continue
        links = [b.link_names[k] for k in np.flatnonzero((b.contact_counts > 0).any(axis=0))]
        if links:
            out[name] = links
    return out


def applicable(c: ComparisonView, events: list[EngineEvents]) -> dict[str, dict[str, Any]]:
    """Per engine label: ``apply`` (a list of ``{key, text, why, measured}``: the departure's
    general words, why it applies here, and what this run measured of it, None when nothing)
    and ``left_out`` (the keys that do not apply to this scenario)."""
    facts = _urdf_facts(c)
    touched = [_touched(c, slot) for slot in range(len(c.labels))]
    labels = c.labels
    out: dict[str, dict[str, Any]] = {}
    for slot, label in enumerate(labels):
        tr = c.runs[(slot, c.timestep)]
        deps = tr.manifest.get("departures") or {}
        apply, left = [], []
        for key, text in deps.items():
            why, measured = _judge(key, c, facts, touched, events, slot)
            if why is None:
                left.append(key)
            else:
                apply.append(
                    {"key": key, "text": _general(key, str(text)), "why": why, "measured": measured}
                )
        out[label] = {"apply": apply, "left_out": left}
    return out


def checked(entry: dict[str, Any]) -> bool:
    """Whether one of :func:`applicable`'s ``apply`` entries was found to apply here (not merely
    listed as :data:`NOT_CHECKED`)."""
    return entry.get("why") != NOT_CHECKED


class _Case(NamedTuple):
    """What a rule of :func:`_judge` reads: one departure of one engine against this run."""

    key: str
    """The departure's key (``contact``, ``joint limits``...)."""
    c: ComparisonView
    """The comparison."""
    facts: dict[str, Any]
    """Each robot's model facts (collision cylinders, restitution, joint axes...)."""
    touched: list[dict[str, list[str]]]
    """Per shown engine, what each robot's links touched."""
    events: list[EngineEvents]
    """Per shown engine, its events."""
    slot: int
    """The slot of the engine whose departure it is."""
    shown: list[int]
    """The slots whose figures are shown: both of two engines, else the reference and
    ``slot``."""


def _judge(
    key: str,
    c: ComparisonView,
    facts: dict[str, Any],
    touched: list[dict[str, list[str]]],
    events: list[EngineEvents],
    slot: int = 0,
) -> tuple[str | None, str | None]:
    """Whether the departure ``key`` applies, for the engine in ``slot``: with two engines,
    both engines' figures; with more, its own beside the first engine's (the reference), never
    a third engine's.

    Args:
        key: the departure's key.
        c: the comparison.
        facts: each robot's model facts.
        touched: per engine (every slot), what each robot's links touched.
        events: per engine (every slot), its events.
        slot: the engine whose departure it is.

    Returns:
        (why it applies, measured), measured None where the rule measures nothing; (None,
        None) when it does not apply; (:data:`NOT_CHECKED`, None) where no rule checks it.
    """
    shown = list(range(len(c.labels))) if len(c.labels) <= 2 else sorted({0, slot})
    case = _Case(
        key, c, facts, [touched[k] for k in shown], [events[k] for k in shown], slot, shown
    )
    rule = _RULES.get(key)
    if rule is not None:
        return rule(case)
    if key.startswith("body "):
        return "it names a body of this world", None
    return NOT_CHECKED, None


def _contact(case: _Case) -> tuple[str | None, str | None]:
    """``contact``: some body touched something in a shown engine's run."""
    if not any(case.touched):
        return None, None
    bodies = sorted({b for t in case.touched for b in t})
    why = "contacts in this run (" + ", ".join(bodies) + ")"
    return why, _contact_figures(case.c, case.events, case.shown)


_TOUCHING_WHAT = {
    "cylinder": "collision cylinders",
    "restitution": "nonzero restitution",
    "rolling/spinning friction": "rolling or spinning friction",
}
"""The links each touching rule looks for, by departure key (a key of each robot's facts)."""


def _touching(case: _Case) -> tuple[str | None, str | None]:
    """``cylinder``, ``restitution``, ``rolling/spinning friction``: a link with it touched
    something in a shown engine's run."""
    hits = []
    for robot, f in case.facts.items():
        links = f[case.key] if isinstance(f[case.key], list) else list(f[case.key])
        for link in links:
            if any(link in t.get(robot, []) for t in case.touched):
                hits.append(f"{robot}'s {link}")
    if not hits:
        return None, None
    return f"links with {_TOUCHING_WHAT[case.key]} touched something: " + ", ".join(hits), None


def _joint_limits(case: _Case) -> tuple[str | None, str | None]:
    """``joint limits``: a joint sat at its limit from the start or reached it."""
    per = []
    for e in case.events:
        reached = [x for x in e.events if x.kind == "joint_limit"]
        words: list[str] = []
        if e.initial_limits:
            words.append(
                "from the start " + ", ".join(f"{x.joint} ({x.side})" for x in e.initial_limits)
            )
        if reached:
            first = reached[0]
            words.append(
                f"reached {len(reached)} time(s), first {first.part} ({first.side}) at "
                f"t = {first.time:.3f} s"
            )
        if words:
            per.append(f"{e.label}: " + "; ".join(words))
    if not per:
        return None, None
    return "joints at their limits in this run", "; ".join(per)


def _motors(case: _Case) -> tuple[str | None, str | None]:
    """``motors``: a velocity or position motor drove a joint of the followed robot; each
    engine's count of saturations."""
    c = case.c
    tr = c.runs[(0, c.timestep)]
    mf = tr.body.joint_max_forces
    driven = (
        np.any(tr.body.joint_modes[1:] != 0, axis=0)
        if mf is None
        else np.any(np.isfinite(mf), axis=0)
    )
    names = [tr.body.joint_names[j] for j in np.flatnonzero(driven)]
    if not names:
        return None, None
    sat = [f"{e.label} {sum(x.kind == 'motor_saturated' for x in e.events)}" for e in case.events]
    return (
        f"velocity or position motors drive {c.scenario.subject}'s " + ", ".join(names),
        "motor saturations (force at max_force): " + ", ".join(sat),
    )


def _speed_clamp(case: _Case) -> tuple[str | None, str | None]:
    """``speed clamp``: a joint speed or the base's speed reached
    :data:`SPEED_CLAMP_FRACTION` of the profile's ``max_joint_velocity``."""
    c = case.c
    rows = []
    hit = False
    for k in case.shown:
        label = c.labels[k]
        tr = c.runs[(k, c.timestep)]
        clamp = (tr.manifest.get("profile") or {}).get("max_joint_velocity")
        if not clamp:
            continue
        b = tr.body
        joint = float(np.abs(b.joint_velocities).max()) if b.joint_velocities.size else 0.0
        base = float(norm(b.base_linear_velocity).max())
        spin = float(norm(b.base_angular_velocity).max())
        top = max(joint, base, spin)
        hit |= top >= SPEED_CLAMP_FRACTION * clamp
        rows.append(
            f"{label}: largest joint speed {joint:.3g}, base {base:.3g} m/s and "
            f"{spin:.3g} rad/s against the clamp {clamp:g}"
        )
    if not hit:
        return None, None
    return "a speed reached the profile's max_joint_velocity", "; ".join(rows)


def _joint_axis(case: _Case) -> tuple[str | None, str | None]:
    """``joint axis``: a movable joint's axis is not of length 1."""
    hits = [
        f"{robot}'s {j} (|axis| {n:.6g})"
        for robot, f in case.facts.items()
        for j, n in f["joint axis"].items()
    ]
    if not hits:
        return None, None
    return "joints with an axis not of length 1: " + ", ".join(hits), None


def _precision(case: _Case) -> tuple[str | None, str | None]:
    """``precision``: the engine keeps its state in a type other than float64."""
    c = case.c
    dtype = _state_dtype(c.runs[(case.slot, c.timestep)].manifest)
    if dtype in (None, "float64"):
        return NOT_CHECKED, None
    return f"every scenario: {c.labels[case.slot]} keeps its state in {dtype}", None


def _link_damping(case: _Case) -> tuple[str | None, str | None]:
    """``link damping``: a shown engine's profile damps link velocities."""
    c = case.c
    damped = []
    for k in case.shown:  # its own figures and the reference's, never a third engine's
        label = c.labels[k]
        prof = c.runs[(k, c.timestep)].manifest.get("profile") or {}
        found = [f"{k} {prof[k]:g}" for k in LINK_DAMPING if prof.get(k)]
        if found:
            damped.append(f"{label}: " + ", ".join(found))
    if not damped:
        return None, None
    return "the profiles damp link velocities: " + "; ".join(damped), None


_RULES: dict[str, Callable[[_Case], tuple[str | None, str | None]]] = {
    "contact": _contact,
    "cylinder": _touching,
    "restitution": _touching,
    "rolling/spinning friction": _touching,
    "joint limits": _joint_limits,
    "motors": _motors,
    "speed clamp": _speed_clamp,
    "joint axis": _joint_axis,
    "precision": _precision,
    "link damping": _link_damping,
}
"""The rule that checks each departure key against this run."""


def _state_dtype(manifest: dict[str, Any]) -> str | None:
    """The floating-point type the engine of ``manifest`` keeps its state in: its native
    defaults' ``state``, else the registry's (None when neither says)."""
    native = manifest.get("native_defaults") or {}
    if isinstance(native, dict) and native.get("state"):
        return str(native["state"])
    from simbridge.registry import state_dtype

    try:
        return state_dtype(str(manifest.get("backend")))
    except SimbridgeError:
        return None


def _contact_figures(c: ComparisonView, events: list[EngineEvents], slots: list[int]) -> str:
    """This run's own contact figures of the engines in ``slots`` (``events`` theirs): the
    followed robot's base height at the end of the first phase, how often its links made or
    lost contact, its highest hop."""
    phase = c.runs[(0, c.timestep)].phases[0][0]
    heights, changes, hops = [], [], []
    for slot, e in zip(slots, events, strict=True):
        tr = c.runs[(slot, c.timestep)]
        row = tr.phases[0][2]
        h = float(dot(tr.body.base_position[row], e.up))
        heights.append(f"{fmt_distance(h)} ({e.label})")
        n = sum(x.kind in ("contact_made", "contact_lost") for x in e.events)
        changes.append(f"{n} ({e.label})")
        peaks = [x.figures["rise"] for x in e.events if x.kind == "peak_height"]
        hops.append(f"{fmt_distance(max(peaks)) if peaks else 'none'} ({e.label})")
    return (
        f"{c.scenario.subject}'s base at the end of '{phase}' at height "
        + " and ".join(heights)
        + "; contacts made or lost "
        + " and ".join(changes)
        + " times; highest rise while airborne "
        + " and ".join(hops)
    )
