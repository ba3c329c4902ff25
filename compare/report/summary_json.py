"""``summary.json``: every figure of a comparison, JSON-ready (:func:`summary`); its keys are
documented in docs/compare.md."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from ..analysis.diff import QUANTITIES
from ..analysis.events import engine_events, parting
from ..analysis.outcomes import CONFIDENCE, INTERVAL_METHOD, summarize
from ..analysis.parts import rank_parts
from ..analysis.verdict import Verdict
from ..pipeline import Comparison, Pair
from ..run.events import EngineEvents
from ..run.resync import Resync
from ..scenario import Scenario, format_timestep
from .departures import applicable
from .events import event_words
from .verdict import marginal_words

__all__ = ["summary", "verdict_dict"]


def summary(c: Comparison) -> dict[str, Any]:
    """``summary.json``: every figure of ``c``, JSON-ready (SI units: m, rad, s). Per engine:
    ``own``, ``sweep``'s ``engines``, ``ensemble``, ``events``, ``departures``, ``outcomes``,
    ``manifest``; per pair of engines, ``pairs``; the keys of one pair (``headline``, ``cross``,
    ``verdict``, ``parting``, ``parts``, ``resync``) are the first pair's (docs/compare.md)."""
    q = c.headline_quantity
    dt = c.timestep
    cross = c.cross[dt]
    sweep = []
    for t in c.timesteps:
        row: dict[str, Any] = {
            "timestep": t,
            "gap_final": c.cross[t].final[q],
            "gap_max": c.cross[t].maximum[q],
            "engines": {},
        }
        for slot, label in enumerate(c.labels):
            tr = c.runs[(slot, t)]
            row["engines"][label] = {
                "wall_per_sim_second": tr.wall_per_sim_second(),
                "wall_time": tr.wall_time,
                "own_error_final": c.own[(slot, t)].final[q],
                "own_error_max": c.own[(slot, t)].maximum[q],
            }
        sweep.append(row)
    manifests = {label: c.runs[(slot, dt)].manifest for slot, label in enumerate(c.labels)}
    events = engine_events(c)
    pairs = [_pair_summary(c, p, events) for p in _pairs_of(c)]
    first = pairs[0]
    return {
        "scenario": c.scenario.name,
        "description": c.scenario.description,
        "scenario_file": str(c.scenario.source) if c.scenario.source else None,
        "subject": c.scenario.subject,
        "backends": list(c.backends),
        "labels": list(c.labels),
        "profiles": list(c.profiles),
        "timestep": dt,
        "timestep_text": format_timestep(dt),
        "duration": float(cross.time[-1]),
        "headline_quantity": q,
        "headline": first["headline"],
        "cross": first["cross"],
        "own": {label: c.own[(slot, dt)].to_dict() for slot, label in enumerate(c.labels)},
        "sweep": sweep,
        "verdict": first["verdict"],
        "ensemble": _ensemble_summary(c),
        "resync": None if c.resync is None else _resync(c.resync),
        "outcomes": _outcomes_summary(c),
        "events": {e.label: e.to_dict() for e in events},
        "parting": first["parting"],
        "parts": first["parts"],
        "departures": applicable(c, events),
        "pairs": pairs,
        "wall_time": c.wall_time,
        "manifest": {
            "simbridge_version": _version(),
            "command_line": c.command_line,
            "engines": manifests,
        },
    }


def _pairs_of(c: Comparison) -> list[Pair]:
    """Every pair of ``c`` (a Comparison made by hand without ``pairs``: its ``cross`` and
    ``verdict``, engines 0 and 1)."""
    return c.pairs or [Pair(0, 1, c.cross, c.verdict)]


def _pair_summary(c: Comparison, p: Pair, events: list[EngineEvents]) -> dict[str, Any]:
    """``pairs[k]``: engines ``p.a`` and ``p.b``, their headline, cross diff, verdict, where the
    gap is born and which part parts first."""
    q = c.headline_quantity
    dt = c.timestep
    cross = p.cross[dt]
    gap = cross.final[q]
    first = cross.first_to_diverge()
    floor = p.verdict.floor if p.verdict is not None else 0.0
    own = {}
    for slot in (p.a, p.b):
        d = c.own[(slot, dt)]
        err = d.final[q]
        own[c.labels[slot]] = {
            "timestep": dt,
            "half_timestep": dt / 2,
            "final": err,
            "max": d.maximum[q],
            "gap_ratio": _ratio(gap, max(err, floor)),
            "gap_exceeds": bool(gap > max(err, floor)),
        }
    thr = QUANTITIES[q].thresholds[0]
    tr = c.runs[(p.a, dt)]
    phases = [(name, float(tr.time[a]), float(tr.time[b])) for name, a, b in tr.phases]
    return {
        "labels": [c.labels[p.a], c.labels[p.b]],
        "headline": {
            "quantity": q,
            "title": QUANTITIES[q].title,
            "unit": QUANTITIES[q].unit,
            "final": gap,
            "max": cross.maximum[q],
            "crossings": [
                {"threshold": t, "time": cross.first_crossing(q, t)}
                for t in QUANTITIES[q].thresholds
            ],
            "first_to_diverge": (
                None
                if first is None
                else {"quantity": first[0], "threshold": first[1], "time": first[2]}
            ),
            "own_error": own,
            "gap_exceeds_all_own_errors": all(v["gap_exceeds"] for v in own.values()),
        },
        "cross": cross.to_dict(),
        "verdict": None if p.verdict is None else verdict_dict(p.verdict),
        "parting": parting(
            cross.first_crossing(q, thr),
            thr,
            q,
            phases,
            [events[p.a], events[p.b]],
            c.timestep,
        ).to_dict(),
        "parts": [part.to_dict() for part in rank_parts(cross)],
    }


def _outcomes_summary(c: Comparison) -> dict[str, Any] | None:
    """The scenario's outcomes over each engine's runs (the ensemble's, else the nominal
    run alone): :func:`outcomes_summary`."""
    if c.ensembles:
        runs = [e.outcomes for e in c.ensembles]
    else:
        runs = [[c.runs[(slot, c.timestep)].outcomes] for slot in range(len(c.labels))]
    half = [c.runs.get((slot, c.timestep / 2)) for slot in range(len(c.labels))]
    return outcomes_summary(
        c.scenario,
        c.labels,
        runs,
        None if None in half else [tr.outcomes for tr in half if tr is not None],
    )


def _ensemble_summary(c: Comparison) -> dict[str, Any] | None:
    if not c.ensembles:
        return None
    s = c.ensemble_settings
    judged = {}  # slot -> its figures in the first pair that holds it
    for p in reversed(_pairs_of(c)):
        if p.verdict is not None:
            judged[p.a], judged[p.b] = p.verdict.per_engine
    engines = {}
    for slot, e in enumerate(c.ensembles):
        fig = judged.get(slot)
        engines[e.label] = {
            "backend": e.backend,
            "profile": e.profile,
            "spread_end": fig.spread_end.to_dict() if fig else float(e.spread[-1]),
            "spread_max": float(e.spread.max()),
            "horizons": [{"threshold": t, "time": h} for t, h in e.horizons()],
            "end_points": e.end_points.tolist(),
            "wall_time": e.wall_time,
        }
    return {
        "size": s["size"],
        "perturbation": {"position": s["perturb"][0], "orientation": s["perturb"][1]},
        "seed": s["seed"],
        "workers": s["workers"],
        "quantity": c.ensembles[0].quantity,
        "instants": len(c.ensembles[0].time),
        "wall_time": s.get("wall_time", 0.0),
        "engines": engines,
    }


def _ratio(gap: float, err: float) -> float | None:
    """gap / err; None when the engine's own error is zero (JSON has no infinity)."""
    return gap / err if err > 0 else None


def _version() -> str:
    from simbridge import __version__

    return __version__


def verdict_dict(v: Verdict) -> dict[str, Any]:
    """``summary.json``'s ``verdict``: :meth:`Verdict.to_dict`, the marginal reasons in words."""
    out = v.to_dict()
    out["marginal_reasons"] = [marginal_words(m) for m in v.marginal_reasons]
    return out


def _resync(r: Resync) -> dict[str, Any]:
    out = r.to_dict()
    for d in out["directions"]:
        for w in d["worst"]:
            w["events"] = [{**e, "words": event_words(e, d["source"])} for e in w["events"]]
    return out


def outcomes_summary(
    scenario: Scenario,
    labels: Sequence[str],
    per_engine: Sequence[Sequence[Mapping[str, Any]]],
    half_timestep: Sequence[Mapping[str, Any]] | None = None,
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
            o.name: summarize(o, [r[o.name] for r in runs if o.name in r]).to_dict()
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
                label: {k: dict(v) for k, v in runs.items()}
                for label, runs in zip(labels, half_timestep, strict=True)
            }
        ),
    }
