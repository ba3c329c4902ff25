"""Outcomes over an ensemble (:func:`summarize`: success rate with a 95% interval, the
distribution of each value; :func:`outcomes_summary`). The outcome kinds are the scenario's
(:mod:`simbridge.compare.scenario.outcomes`), their evaluation on one run the run's
(:mod:`simbridge.compare.run.outcomes`), their words the report's
(:mod:`simbridge.compare.report.outcomes`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..scenario import Scenario
from ..scenario.outcomes import Outcome

__all__ = ["CONFIDENCE", "INTERVAL_METHOD", "success_interval", "summarize", "outcomes_summary"]

CONFIDENCE = 0.95
INTERVAL_METHOD = "wilson"
"""``scipy.stats.binomtest(...).proportion_ci(method=...)``: Wilson's score interval, which
stays inside [0, 1] and is not degenerate at 0/n or n/n."""


# ---------------------------------------------------------------- over an ensemble


def success_interval(successes: int, runs: int, confidence: float = CONFIDENCE):
    """``(low, high)``: the ``confidence`` interval of a success rate from ``successes`` of
    ``runs`` (Wilson's score interval, ``scipy.stats.binomtest(...).proportion_ci``)."""
    from scipy.stats import binomtest

    ci = binomtest(int(successes), int(runs)).proportion_ci(
        confidence_level=confidence, method=INTERVAL_METHOD
    )
    return float(ci.low), float(ci.high)


def _distribution(values: Sequence[float]) -> dict[str, Any] | None:
    if not values:
        return None
    v = np.asarray(values, dtype=np.float64)
    return {
        "runs": int(v.size),
        "mean": float(v.mean()),
        "std": float(v.std(ddof=1)) if v.size > 1 else 0.0,
        "min": float(v.min()),
        "median": float(np.median(v)),
        "max": float(v.max()),
    }


def summarize(outcome: Outcome, records: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """One engine's runs of one outcome (``records``: :func:`evaluate`'s dicts, the nominal
    run first): ``success`` (``{successes, runs, rate, low, high, confidence, method}``, or
    None when no run has a success), ``value`` (the distribution over the runs with a value:
    ``{runs, mean, std, min, median, max}``, std with ddof 1; None without one), ``nominal``
    (run 0's record) and ``runs`` (every record, run 0 first)."""
    judged = [r["success"] for r in records if r.get("success") is not None]
    success = None
    if judged:
        k, n = sum(bool(s) for s in judged), len(judged)
        low, high = success_interval(k, n)
        success = {
            "successes": k,
            "runs": n,
            "rate": k / n,
            "low": low,
            "high": high,
            "confidence": CONFIDENCE,
            "method": INTERVAL_METHOD,
        }
    values = [float(r["value"]) for r in records if r.get("value") is not None]
    return {
        "name": outcome.name,
        "kind": outcome.kind,
        "unit": outcome.unit,
        "success": success,
        "value": _distribution(values),
        "nominal": dict(records[0]) if records else None,
        "runs": [dict(r) for r in records],
    }


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
            o.name: summarize(o, [r[o.name] for r in runs if o.name in r])
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
