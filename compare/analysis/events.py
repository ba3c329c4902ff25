"""Where the gap is born: each engine's events at the headline time step
(:func:`engine_events`, found by :func:`simbridge.compare.run.events.find_events`) and which
event the gap between two engines first crossed its threshold after (:func:`parting`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from ..run.events import (
    INTERVAL_KINDS,
    KINDS,
    PARTING_WINDOW,
    TIP_ANGLE,
    EngineEvents,
    Event,
    find_events,
    phase_at,
)

if TYPE_CHECKING:
    from .view import ComparisonView

__all__ = [
    "KINDS",
    "TIP_ANGLE",
    "Event",
    "EngineEvents",
    "find_events",
    "phase_at",
    "engine_events",
    "Parting",
    "parting",
]


def engine_events(c: ComparisonView) -> list[EngineEvents]:
    """The followed robot's events in each engine's nominal run at the headline time step."""
    return [
        find_events(c.runs[(slot, c.timestep)], label=label) for slot, label in enumerate(c.labels)
    ]


@dataclass
class Parting:
    """Where the gap between two engines is born (:func:`parting`): the phase and the event
    during or after which it first reached ``threshold`` (at ``time``, None: never).

    ``event`` is the event (of the engine labelled ``event_label``) or None (no event before
    ``time``); ``relation`` ``after`` or ``during`` (None: no event); ``since`` (s) how long
    before ``time`` it began (negative: in the same step, just after); ``ongoing`` every
    interval event going on at ``time``, with its engine's label; ``initial_contacts`` per
    engine label, the links touching from the first step (only when no event came before).
    :func:`simbridge.compare.report.summary_json.parting_dict` is ``summary.json``'s
    ``parting``."""

    quantity: str
    threshold: float
    time: float | None
    step: float
    body: str | None
    phase: str | None = None
    event: Event | None = None
    event_label: str | None = None
    relation: str | None = None
    since: float | None = None
    ongoing: list[tuple[str, Event]] = field(default_factory=list)
    initial_contacts: dict[str, list[str]] = field(default_factory=dict)


def parting(
    time: float | None,
    threshold: float,
    quantity: str,
    phases: list[tuple[str, float, float]],
    engines: list[EngineEvents],
    step: float = 0.0,
) -> Parting:
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

    Returns a :class:`Parting` (``step``: the recorded step, s; ``body``: the followed robot).
    """
    out = Parting(
        quantity=quantity,
        threshold=threshold,
        time=time,
        step=step,
        body=engines[0].body if engines else None,
    )
    if time is None:
        return out
    for name, start, end in phases:
        if start - 1e-12 <= time <= end + 1e-12:
            out.phase = name
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
            if event.kind in INTERVAL_KINDS and (event.end is None or event.end >= time - 1e-12):
                going.append((key, event, e.label))
                out.ongoing.append((e.label, event))
    recent = [x for x in began if x[1].time >= time - PARTING_WINDOW - 1e-12]
    for pool, relation in ((recent, "after"), (going, "during"), (began, "after")):
        if pool:
            _, event, label = max(pool, key=lambda x: x[0])
            out.event, out.event_label = event, label
            out.relation = relation
            out.since = time - event.time
            break
    else:
        out.initial_contacts = {e.label: e.initial_contacts for e in engines if e.initial_contacts}
    return out
