"""Where the gap is born and which part carries it, for ``summary.json``: each engine's events
(:mod:`.events`), the event the gap first crossed its threshold after, the joints and links
ranked (:mod:`.parts`), and the profile departures that apply here (:mod:`.departures`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .departures import applicable
from .diff import QUANTITIES
from .events import EngineEvents, find_events, parting
from .parts import rank_parts

if TYPE_CHECKING:
    from .view import ComparisonView

__all__ = ["engine_events", "where_born"]


def engine_events(c: ComparisonView) -> list[EngineEvents]:
    """The followed robot's events in each engine's nominal run at the headline time step."""
    return [
        find_events(c.runs[(slot, c.timestep)], label=label) for slot, label in enumerate(c.labels)
    ]


def where_born(c: ComparisonView) -> dict[str, Any]:
    """``summary.json``'s ``events`` (per engine label), ``parting``, ``parts`` and
    ``departures``."""
    events = engine_events(c)
    cross = c.cross[c.timestep]
    q = c.headline_quantity
    thr = QUANTITIES[q].thresholds[0]
    tr = c.runs[(0, c.timestep)]
    phases = [(name, float(tr.time[a]), float(tr.time[b])) for name, a, b in tr.phases]
    return {
        "events": {e.label: e.to_dict() for e in events},
        "parting": parting(cross.first_crossing(q, thr), thr, q, phases, events, c.timestep),
        "parts": [p.to_dict() for p in rank_parts(cross)],
        "departures": applicable(c, events),
    }
