"""``summary.json``: every figure of a comparison, JSON-ready (:func:`summary`); its keys are
documented in docs/compare.md. Each record's converter is :mod:`.summary_dicts`' (re-exported
here)."""

from __future__ import annotations

from typing import Any

from ..analysis.diff import QUANTITIES
from ..analysis.events import engine_events, parting
from ..analysis.parts import rank_parts
from ..pipeline import Comparison, Pair
from ..run.events import EngineEvents
from ..run.resync import Resync
from ..scenario import format_timestep
from .departures import applicable
from .engine_settings import settings_summary
from .summary_dicts import (
    divergence_dict,
    engine_events_dict,
    event_dict,
    interval_dict,
    outcome_stats_dict,
    outcomes_summary,
    part_dict,
    parting_dict,
    resync_dict,
    verdict_dict,
)

__all__ = [
    "summary",
    "verdict_dict",
    "divergence_dict",
    "parting_dict",
    "part_dict",
    "outcome_stats_dict",
    "outcomes_summary",
    "event_dict",
    "engine_events_dict",
    "resync_dict",
]


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
    chosen = settings_summary(c.scenario, c.backends, c.profiles, dt)
    if not chosen:  # every engine at its defaults: the manifests as they were before settings
        manifests = {k: _without_settings(m) for k, m in manifests.items()}
    out = {
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
        "own": {label: divergence_dict(c.own[(slot, dt)]) for slot, label in enumerate(c.labels)},
        "sweep": sweep,
        "verdict": first["verdict"],
        "ensemble": _ensemble_summary(c),
        "resync": _resync_or_none(c.resync),
        "outcomes": _outcomes_summary(c),
        "events": {e.label: engine_events_dict(e) for e in events},
        "parting": first["parting"],
        "parts": first["parts"],
        "departures": applicable(c, events),
        "pairs": pairs,
        "wall_time": c.wall_time,
        **({"left_out": dict(c.left_out)} if c.left_out else {}),
        "manifest": {
            "simbridge_version": _version(),
            "command_line": c.command_line,
            "engines": manifests,
        },
    }
    if chosen:  # the engine settings the study set (none: the key is left out)
        out["engine_settings"] = chosen
    return out


def _without_settings(manifest: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in manifest.items() if k != "engine_settings"}


def _pairs_of(c: Comparison) -> list[Pair]:
    """Every pair of ``c`` (a Comparison made by hand without ``pairs``: its ``cross`` and
    ``verdict``, engines 0 and 1)."""
    return c.pairs or [Pair(0, 1, c.cross, c.verdict, c.resync)]


def _pair_summary(c: Comparison, p: Pair, events: list[EngineEvents]) -> dict[str, Any]:
    """``pairs[k]``: engines ``p.a`` and ``p.b``, their headline, cross diff, verdict, where the
    gap is born, which part parts first and, with more than two engines, their resync."""
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
        "cross": divergence_dict(cross),
        "verdict": None if p.verdict is None else verdict_dict(p.verdict),
        "parting": parting_dict(
            parting(
                cross.first_crossing(q, thr),
                thr,
                q,
                phases,
                [events[p.a], events[p.b]],
                c.timestep,
            )
        ),
        "parts": [part_dict(part) for part in rank_parts(cross)],
        # more than two engines: each pair's one-step error (two: the top-level ``resync``)
        **({"resync": _resync_or_none(p.resync)} if len(c.labels) > 2 else {}),
    }


def _resync_or_none(r: Resync | None) -> dict[str, Any] | None:
    return None if r is None else resync_dict(r)


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
    s = c.ensemble_settings
    if not c.ensembles or s is None:
        return None
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
            "spread_end": interval_dict(fig.spread_end) if fig else float(e.spread[-1]),
            "spread_max": float(e.spread.max()),
            "horizons": [{"threshold": t, "time": h} for t, h in e.horizons()],
            "end_points": e.end_points.tolist(),
            "wall_time": e.wall_time,
        }
    if any(tuple(e.perturbation) != tuple(s.perturb) for e in c.ensembles):
        for e in c.ensembles:  # only where an engine's differs: two engines' summary unchanged
            engines[e.label]["perturbation"] = {
                "position": e.perturbation[0],
                "orientation": e.perturbation[1],
                "state_dtype": e.state_dtype,
            }
    failed = getattr(c, "failed_members", None) or {}
    for label, jobs in failed.items():  # only where members failed: the summary unchanged else
        engines[label]["failed"] = {
            "members": len(jobs),
            "judged_on": int(c.ensembles[c.labels.index(label)].size),
            "causes": sorted({f.cause for f in jobs}),
        }
    return {
        "size": s.size,
        "perturbation": {"position": s.perturb[0], "orientation": s.perturb[1]},
        "seed": s.seed,
        "workers": s.workers,
        "quantity": c.ensembles[0].quantity,
        "instants": len(c.ensembles[0].time),
        "wall_time": s.wall_time,
        "engines": engines,
    }


def _ratio(gap: float, err: float) -> float | None:
    """gap / err; None when the engine's own error is zero (JSON has no infinity)."""
    return gap / err if err > 0 else None


def _version() -> str:
    from simbridge import __version__

    return __version__


# ---------------------------------------------------------------- one result each
