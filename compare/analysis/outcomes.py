"""Outcomes over an ensemble (:func:`summarize`: success rate with a 95% interval, the
distribution of each value: :class:`OutcomeStats`). The outcome kinds are the scenario's
(:mod:`simbridge.compare.scenario.outcomes`), their evaluation on one run the run's
(:mod:`simbridge.compare.run.outcomes`), their words the report's
(:mod:`simbridge.compare.report.outcomes`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..run.outcomes import OutcomeRecord
from ..scenario.outcomes import Outcome

__all__ = [
    "CONFIDENCE",
    "INTERVAL_METHOD",
    "SuccessRate",
    "Distribution",
    "OutcomeStats",
    "success_interval",
    "summarize",
]

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


@dataclass(frozen=True)
class SuccessRate:
    """How many of the runs that judge success succeeded, with Wilson's interval at
    :data:`CONFIDENCE`."""

    successes: int
    runs: int
    low: float
    high: float

    @property
    def rate(self) -> float:
        return self.successes / self.runs


@dataclass(frozen=True)
class Distribution:
    """An outcome's value over the runs that have one (``std`` with ddof 1; 0 for one run)."""

    runs: int
    mean: float
    std: float
    min: float
    median: float
    max: float


@dataclass(frozen=True)
class OutcomeStats:
    """One outcome over one engine's runs (:func:`summarize`): ``success`` (None when no run
    judges it), ``value`` (None when no run has one), ``records`` every run's record
    (:func:`simbridge.compare.run.outcomes.evaluate`), the nominal run first."""

    name: str
    kind: str
    unit: str
    success: SuccessRate | None
    value: Distribution | None
    records: tuple[OutcomeRecord, ...] = ()

    @property
    def nominal(self) -> OutcomeRecord | None:
        return self.records[0] if self.records else None


def _distribution(values: Sequence[float]) -> Distribution | None:
    if not values:
        return None
    v = np.asarray(values, dtype=np.float64)
    return Distribution(
        runs=int(v.size),
        mean=float(v.mean()),
        std=float(v.std(ddof=1)) if v.size > 1 else 0.0,
        min=float(v.min()),
        median=float(np.median(v)),
        max=float(v.max()),
    )


def summarize(outcome: Outcome, records: Sequence[OutcomeRecord]) -> OutcomeStats:
    """One engine's runs of one outcome (``records``: :func:`evaluate`'s, the nominal run
    first): the success rate over the runs that judge it, the distribution of the value over
    the runs that have one, and every record."""
    judged = [r.success for r in records if r.success is not None]
    success = None
    if judged:
        k, n = sum(bool(s) for s in judged), len(judged)
        low, high = success_interval(k, n)
        success = SuccessRate(k, n, low, high)
    values = [r.value for r in records if r.value is not None]
    return OutcomeStats(
        name=outcome.name,
        kind=outcome.kind,
        unit=outcome.unit,
        success=success,
        value=_distribution(values),
        records=tuple(records),
    )
