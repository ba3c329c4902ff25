"""``summary.json``'s records, one converter each: a verdict, a diff, a parting, a part, the
outcomes' statistics, an event, an engine's events and a resync as JSON-ready dicts
(:func:`verdict_dict`, :func:`divergence_dict`, ...); :mod:`.summary_json` assembles them into
the document."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..analysis.diff import Divergence
from ..analysis.events import Parting
from ..analysis.outcomes import (
    CONFIDENCE,
    INTERVAL_METHOD,
    Distribution,
    OutcomeStats,
    SuccessRate,
    summarize,
)
from ..analysis.parts import Part
from ..analysis.verdict import (
    ALPHA,
    MARGINAL,
    EngineJudgement,
    Interval,
    TwoSampleTest,
    Verdict,
)
from ..analysis.verdict import CONFIDENCE as VERDICT_CONFIDENCE
from ..run.ensemble import SPREAD_PERCENTILE
from ..run.events import EngineEvents, Event
from ..run.outcomes import OutcomeRecord
from ..run.quantities import FEATURE_SOURCES
from ..run.resync import BORN_FACTOR, PARTS, Direction, Peak, PhaseErrors, Resync
from ..scenario import Scenario
from .events import event_words
from .verdict import marginal_words

__all__ = [
    "verdict_dict",
    "interval_dict",
    "divergence_dict",
    "parting_dict",
    "part_dict",
    "outcome_stats_dict",
    "outcomes_summary",
    "event_dict",
    "engine_events_dict",
    "resync_dict",
]


def verdict_dict(v: Verdict) -> dict[str, Any]:
    """``summary.json``'s ``verdict`` (and ``pairs[k].verdict``), the marginal reasons in
    words."""
    return {
        "verdict": v.verdict,
        "engines": list(v.engines),
        "reason": v.reason,
        "marginal": v.marginal,
        "marginal_reasons": [marginal_words(m) for m in v.marginal_reasons],
        "quantity": v.quantity,
        "unit": v.unit,
        "tolerance": v.tolerance,
        "floor": v.floor,
        "labels": list(v.labels),
        "judged_at": {"time": v.judged_time, "why": v.judged_at},
        "gap": interval_dict(v.gap),
        "gap_end": interval_dict(v.gap_end),
        "nominal_gap": v.nominal_gap,
        "max_gap": {"value": v.max_gap[0], "time": v.max_gap[1]},
        "test": None if v.test is None else _test(v.test),
        "engine_figures": {e.label: _judgement(e) for e in v.per_engine},
        "instants": {"total": len(v.classes), **v.counts(), "within": v.within()},
        "timeline": [
            {"class": s.verdict, "start": s.start, "end": s.end, "instants": s.instants}
            for s in v.timeline()
        ],
        "confidence": VERDICT_CONFIDENCE,
        "marginal_range": list(MARGINAL),
        "spread_percentile": SPREAD_PERCENTILE,
    }


def interval_dict(x: Interval) -> dict[str, Any]:
    return {"value": x.value, "low": x.low, "high": x.high}


def _judgement(e: EngineJudgement) -> dict[str, Any]:
    return {
        "label": e.label,
        "size": e.size,
        "spread": interval_dict(e.spread),
        "spread_end": interval_dict(e.spread_end),
        "spread_max": e.spread_max,
        "largest_pair": e.largest_pair,
        "other_to_nearest": e.other_to_nearest,
        "own_error": e.own_error,
        "gap_over_spread": e.gap_over_spread,
        "gap_over_own_error": e.gap_over_own_error,
        "horizons": [{"threshold": t, "time": h} for t, h in e.horizons],
    }


def _test(t: TwoSampleTest) -> dict[str, Any]:
    return {
        "name": t.name,
        "statistic": t.statistic,
        "p_value": t.p_value,
        "alpha": ALPHA,
        "resamples": t.resamples,
        "exact": t.exact,
        "sizes": list(t.sizes),
    }


def divergence_dict(d: Divergence) -> dict[str, Any]:
    """``summary.json``'s ``cross`` and ``own.<engine>``: every headline figure of a diff."""
    first = d.first_to_diverge()
    return {
        "a": d.a,
        "b": d.b,
        "subject": d.subject,
        "duration": float(d.time[-1] - d.time[0]),
        "samples": len(d.time),
        "final": d.final,
        "max": d.maximum,
        "crossings": {
            k: [{"threshold": thr, "time": t} for thr, t in v.items()]
            for k, v in d.crossings.items()
        },
        "first_to_diverge": (
            None
            if first is None
            else {"quantity": first[0], "threshold": first[1], "time": first[2]}
        ),
        "phases": [
            {"name": p.name, "start": p.start, "end": p.end, "at_end": p.at_end, "max": p.max}
            for p in d.phases
        ],
        "final_pose": {k: dict(vars(p)) for k, p in d.final_pose.items()},
    }


def parting_dict(p: Parting) -> dict[str, Any]:
    """``summary.json``'s ``parting``."""
    return {
        "quantity": p.quantity,
        "threshold": p.threshold,
        "time": p.time,
        "step": p.step,
        "body": p.body,
        "phase": p.phase,
        "event": None if p.event is None else {"label": p.event_label, **event_dict(p.event)},
        "relation": p.relation,
        "since": p.since,
        "ongoing": [{"label": label, **event_dict(e)} for label, e in p.ongoing],
        "initial_contacts": dict(p.initial_contacts),
    }


def part_dict(p: Part) -> dict[str, Any]:
    """One of ``summary.json``'s ``parts``."""
    return {
        "kind": p.kind,
        "name": p.name,
        "unit": p.unit,
        "threshold": p.threshold,
        "first": p.first,
        "largest": p.largest,
        "largest_at": p.largest_at,
        "at_end": p.at_end,
    }


def outcome_stats_dict(s: OutcomeStats) -> dict[str, Any]:
    """``summary.json``'s ``outcomes.engines.<engine>.<outcome>``."""
    return {
        "name": s.name,
        "kind": s.kind,
        "unit": s.unit,
        "success": None if s.success is None else _success(s.success),
        "value": None if s.value is None else _distribution(s.value),
        "nominal": None if s.nominal is None else s.nominal.to_dict(),
        "runs": [r.to_dict() for r in s.records],
    }


def _success(r: SuccessRate) -> dict[str, Any]:
    return {
        "successes": r.successes,
        "runs": r.runs,
        "rate": r.rate,
        "low": r.low,
        "high": r.high,
        "confidence": CONFIDENCE,
        "method": INTERVAL_METHOD,
    }


def _distribution(d: Distribution) -> dict[str, Any]:
    return {
        "runs": d.runs,
        "mean": d.mean,
        "std": d.std,
        "min": d.min,
        "median": d.median,
        "max": d.max,
    }


def event_dict(e: Event) -> dict[str, Any]:
    """One event as ``summary.json`` holds it (``events.<engine>.events``, ``parting``)."""
    return {
        "kind": e.kind,
        "time": e.time,
        "end": e.end,
        "phase": e.phase,
        "body": e.body,
        "part": e.part,
        "others": list(e.others),
        "side": e.side,
        "figures": dict(e.figures),
    }


def engine_events_dict(e: EngineEvents, limit: int = 500) -> dict[str, Any]:
    """``summary.json``'s ``events.<engine>``: at most ``limit`` events listed (the first
    ones), ``total`` counts all."""
    return {
        "body": e.body,
        "up": [float(v) for v in e.up],
        "spawn_orientation": [float(v) for v in e.spawn],
        "contacts_recorded": e.has_contacts,
        "initial_contacts": list(e.initial_contacts),
        "initial_limits": [
            {"joint": x.joint, "side": x.side, "end": x.end} for x in e.initial_limits
        ],
        "start_depth": None
        if e.start_depth is None
        else {
            "link": e.start_depth.link,
            "depth": e.start_depth.depth,
            "others": list(e.start_depth.others),
        },
        "counts": e.counts(),
        "total": len(e.events),
        "events": [event_dict(x) for x in e.events[:limit]],
    }


def resync_dict(r: Resync) -> dict[str, Any]:
    """``summary.json``'s ``resync`` (docs/compare.md describes every field)."""
    dirs = [_direction(d, r.quantity) for d in r.directions]
    floors = {d["source"]: d["floor_max"]["value"] for d in dirs}
    largest = max(dirs, key=lambda d: -1.0 if d["max"]["value"] is None else d["max"]["value"])
    born = r.born()
    return {
        "every": r.every,
        "quantity": r.quantity,
        "unit": r.unit,
        "precision_floor": r.precision_floor,
        "significant": r.significant,
        "born_factor": BORN_FACTOR,
        "largest": {
            "value": largest["max"]["value"],
            "source": largest["source"],
            "target": largest["target"],
            "time": largest["max"]["time"],
            "phase": largest["max"]["phase"],
        },
        "floors": floors,
        "born": None if born is None else dict(vars(born)),
        "directions": dirs,
        "wall_time": r.wall_time,
    }


def _direction(d: Direction, quantity: str = "") -> dict[str, Any]:
    def med(v: Any) -> float | None:
        return float(np.nanmedian(v)) if np.isfinite(v).any() else None

    rounding = None
    if d.rounding is not None:  # a target keeping a narrower type: the state set, rounded
        head = d.rounding.get(FEATURE_SOURCES[quantity]) if quantity else None
        rounding = {
            "state_dtype": d.target_dtype,
            "max": None if head is None else d.peak(head).value,
            "median": None if head is None else med(head),
            "parts": {k: d.peak(d.rounding[k]).value for k in PARTS},
        }

    return {
        "source": d.source,
        "target": d.target,
        "points": len(d.rows),
        "failed": d.failed,
        "max": _peak(d.peak(d.error)),
        "median": med(d.error),
        "floor_max": _peak(d.peak(d.floor)),
        "floor_median": med(d.floor),
        "parts": {
            k: {
                "unit": PARTS[k][1],
                "max": d.peak(d.parts[k]).value,
                "floor_max": d.peak(d.floor_parts[k]).value,
            }
            for k in PARTS
        },
        "phases": [_phase_errors(p) for p in d.by_phase()],
        **({"rounding": rounding} if rounding is not None else {}),  # a float32 target's
        "worst": [
            {
                "time": w.time,
                "row": w.row,
                "phase": w.phase,
                "error": w.error,
                "floor": w.floor,
                "parts": dict(w.parts),
                "events": [
                    {**e, "words": event_words(e, d.source)} for e in map(event_dict, w.events)
                ],
            }
            for w in d.worst
        ],
    }


def _peak(p: Peak) -> dict[str, Any]:
    return {"value": p.value, "time": p.time, "phase": p.phase}


def _phase_errors(p: PhaseErrors) -> dict[str, Any]:
    return {
        "phase": p.phase,
        "points": p.points,
        "median": p.median,
        "max": p.max,
        "floor_median": p.floor_median,
        "floor_max": p.floor_max,
    }


def outcomes_summary(
    scenario: Scenario,
    labels: Sequence[str],
    per_engine: Sequence[Sequence[Mapping[str, OutcomeRecord]]],
    half_timestep: Sequence[Mapping[str, OutcomeRecord]] | None = None,
) -> dict[str, Any] | None:
    """``summary.json``'s ``outcomes``: ``declared`` (each outcome's declaration) and
    ``engines`` (per engine label, per outcome name, :func:`summarize`); ``per_engine[slot]``
    is the list of every run's ``{name: record}``, nominal first; ``half_timestep[slot]`` the
    records of the engine's nominal run at half the time step (its own-error run). None when the
    scenario declares no outcome."""
    if not scenario.outcomes:
        return None
    engines: dict[str, Any] = {}
    for label, runs in zip(labels, per_engine, strict=True):
        engines[label] = {
            o.name: outcome_stats_dict(summarize(o, [r[o.name] for r in runs if o.name in r]))
            for o in scenario.outcomes
        }
    return {
        "declared": [o.to_dict() for o in scenario.outcomes],
        "closed_loop": any(p.controller is not None for p in scenario.phases),
        "confidence": CONFIDENCE,
        "method": INTERVAL_METHOD,
        "engines": engines,
        "half_timestep": (
            None
            if half_timestep is None
            else {
                label: {k: v.to_dict() for k, v in runs.items()}
                for label, runs in zip(labels, half_timestep, strict=True)
            }
        ),
    }
