"""The verdict over the whole run: do the engines ``agree``, ``differ``, or is one of them
``chaotic`` at the scale of the gap? :func:`judge` and :class:`Verdict`.

The statistics and the judgement built on them follow the fields of :class:`Verdict`; the
verdict in words is the report's (:mod:`simbridge.compare.report.verdict`).

Inputs, all at the same recorded instants ``time`` (T,): each engine's ensemble (the
headline quantity's :func:`~simbridge.compare.diff.features` of N runs started a tiny offset
apart, member 0 the nominal run) and each engine's own time-step error (the quantity between
its nominal run at dt and at dt/2).

At every instant:

- the **gap** is the median, over every pair (run of engine A, run of engine B), of the
  quantity between them (with one run each: the nominal runs' gap);
- an engine's **spread** is the 90th percentile of the quantity between its own runs, every
  pair once;
- spreads and own errors below the **floor** (float and recording precision: 1e-12 times the
  size of the recorded values, at least 1e-12) count as the floor, so that no ratio is absurd;
- a ratio gap / spread or gap / own error between 0.5 and 2 is "near 1" (:data:`MARGINAL`): a
  gap up to twice an engine's spread or own error is not clearly larger, so it is covered by
  it (the words say "within" only up to 1x, the ratio above);
- the instant is ``agree`` (gap below the tolerance, by default the quantity's first threshold:
  1 cm, 1°, 0.1 rad/s), else ``chaotic`` (the gap is at most twice an engine's spread), else
  ``unresolved`` (at most twice an engine's own time-step error), else ``differ``.

The verdict is ``agree`` when every instant is. Otherwise it is judged at one instant: the end
when the gap there reaches the tolerance, else the instant of the largest gap. There it is
``chaotic`` (naming the engines whose spread covers the gap), ``differ`` (the gap is more than
twice both engines' spreads and own errors, AND a permutation test on the energy distance
between the two ensembles gives p < alpha), or ``unresolved`` (what is left: an engine's own
time-step error covers the gap, the test does not separate the ensembles, or an ensemble has
one run). A deciding ratio between 0.5 and 2 makes the verdict ``marginal``
(``agree``: the largest gap is at least half the tolerance). The gap and the spreads carry
bootstrap intervals (``scipy.stats.bootstrap``, percentile method, over the runs).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..run.ensemble import SPREAD_PERCENTILE, horizons, pairwise_spread
from ..run.quantities import QUANTITIES, distance

__all__ = [
    "VERDICTS",
    "ALPHA",
    "CONFIDENCE",
    "MARGINAL",
    "OWN_ERROR_REASONS",
    "FLOOR_RELATIVE",
    "Interval",
    "EngineJudgement",
    "TwoSampleTest",
    "Verdict",
    "Segment",
    "judge",
    "precision_floor",
    "energy_test",
    "Marginal",
]

VERDICTS = ("agree", "differ", "chaotic", "unresolved")
ALPHA = 0.05
"""The permutation test separates the ensembles when p < ALPHA."""
CONFIDENCE = 0.95
"""Confidence level of the bootstrap intervals."""
BOOTSTRAP_RESAMPLES = 1999
TEST_RESAMPLES = 9999
"""Random permutations of the test; it is exact (every split) when there are fewer."""
MARGINAL = (0.5, 2.0)
"""A deciding ratio within this range is "near 1": the verdict is called marginal. A gap up to
``MARGINAL[1]`` times a spread or own error is not clearly larger: it lies within it."""
OWN_ERROR_REASONS = ("within own time-step error", "near own time-step error")
"""An ``unresolved`` verdict's reason where an engine's own time-step error covers the gap:
``within`` where the gap is at most 1x the smallest covering own error, ``near`` where it is
larger but at most ``MARGINAL[1]`` times it (not clearly larger). A ``chaotic`` verdict's
reason is likewise ``within spread`` or ``near spread``."""
FLOOR_RELATIVE = 1e-12
"""The precision floor is this times the largest recorded magnitude (at least 1)."""

_CODES = {"agree": 0, "chaotic": 1, "unresolved": 2, "differ": 3}


@dataclass(frozen=True)
class Marginal:
    """Why a verdict is marginal: its deciding ratio near 1 (:data:`MARGINAL`). ``what`` is
    ``tolerance`` (``agree``: the largest gap over the tolerance), ``spread`` (``chaotic``: the
    gap over engine ``label``'s spread) or ``own_error`` (``unresolved``: over its own time-step
    error)."""

    what: str
    ratio: float
    label: str | None = None


@dataclass(frozen=True)
class Segment:
    """A stretch of the run over which the per-instant class stays the same
    (:meth:`Verdict.timeline`)."""

    verdict: str  # the class of its instants, one of VERDICTS
    start: float  # s, its first instant
    end: float  # s, its last instant
    instants: int  # how many


@dataclass
class Interval:
    """A figure and its bootstrap interval (``low``, ``high``: None when there is none, as
    with a single run)."""

    value: float
    low: float | None = None
    high: float | None = None


@dataclass
class EngineJudgement:
    """One engine's figures at the judged instant (and at the end)."""

    label: str
    size: int  # runs in its ensemble
    spread: Interval  # at the judged instant, the quantity's unit
    spread_end: Interval  # at the last instant
    spread_max: float  # the largest spread over the run
    largest_pair: float  # the two runs farthest apart at the judged instant
    other_to_nearest: float
    """Median, over the other engine's runs, of the distance to this engine's nearest run."""
    own_error: float  # dt against dt/2 at the judged instant (not floored)
    gap_over_spread: float  # gap / max(spread, floor)
    gap_over_own_error: float  # gap / max(own error, floor)
    horizons: list[tuple[float, float | None]]  # (threshold, first time the spread reaches it)


@dataclass
class TwoSampleTest:
    """Permutation test of "both ensembles come from one distribution", statistic the energy
    distance with the quantity as the metric, alternative: larger than under permutation."""

    statistic: float
    p_value: float
    resamples: int  # permutations drawn; ``exact`` when every split was counted
    exact: bool
    sizes: tuple[int, int]
    name: str = "energy-distance permutation test"


@dataclass
class Verdict:
    """The judgement of a comparison (``summary.json``'s ``verdict``:
    :func:`simbridge.compare.report.summary_json.verdict_dict`)."""

    verdict: str  # one of VERDICTS
    engines: list[str]  # chaotic: whose spread covers the gap; unresolved: whose own error does
    reason: str  # a short machine-readable cause (see docs/compare.md)
    marginal: bool
    marginal_reasons: list[Marginal]
    quantity: str
    unit: str
    tolerance: float
    floor: float
    labels: tuple[str, str]
    judged_index: int
    judged_at: str  # "end" | "largest gap"
    gap: Interval  # at the judged instant
    gap_end: Interval
    nominal_gap: float  # the nominal runs' gap at the judged instant
    max_gap: tuple[float, float]  # (value, time)
    test: TwoSampleTest | None
    per_engine: list[EngineJudgement]
    time: np.ndarray = field(repr=False)  # (T,) s
    gap_series: np.ndarray = field(repr=False)  # (T,)
    spreads: np.ndarray = field(repr=False)  # (2, T), not floored
    own_errors: np.ndarray = field(repr=False)  # (2, T), not floored
    classes: np.ndarray = field(repr=False)  # (T,) int: 0 agree 1 chaotic 2 unresolved 3 differ

    @property
    def judged_time(self) -> float:
        return float(self.time[self.judged_index])

    def counts(self) -> dict[str, int]:
        """How many instants fall in each class (:data:`VERDICTS`)."""
        return {k: int(np.sum(self.classes == v)) for k, v in _CODES.items()}

    def within(self) -> dict[str, dict[str, int]]:
        """Per engine label, at how many instants the gap (at least the tolerance) lies within
        its spread (``spread``) and within its own time-step error (``own_error``), each counted
        alone: an instant can count for both, and for both engines (the classes of
        :meth:`counts` give each instant one)."""
        apart = self.gap_series >= self.tolerance
        reach = MARGINAL[1] * np.maximum(
            np.stack([self.spreads, self.own_errors]), self.floor
        )  # (2 kinds, 2 engines, T)
        inside = apart & (self.gap_series <= reach)
        return {
            label: {"spread": int(inside[0, k].sum()), "own_error": int(inside[1, k].sum())}
            for k, label in enumerate(self.labels)
        }

    def timeline(self) -> list[Segment]:
        """The run cut where the per-instant class changes."""
        names = {v: k for k, v in _CODES.items()}
        out: list[Segment] = []
        start = 0
        for i in range(1, len(self.classes) + 1):
            if i == len(self.classes) or self.classes[i] != self.classes[start]:
                out.append(
                    Segment(
                        verdict=names[int(self.classes[start])],
                        start=float(self.time[start]),
                        end=float(self.time[i - 1]),
                        instants=i - start,
                    )
                )
                start = i
        return out


# ---------------------------------------------------------------- statistics


def precision_floor(members: Sequence[np.ndarray]) -> float:
    """FLOOR_RELATIVE times the largest magnitude recorded in ``members`` (at least 1): below
    it a difference is float and recording noise."""
    scale = 1.0
    for m in members:
        if m.size:
            scale = max(scale, float(np.max(np.abs(m))))
    return FLOOR_RELATIVE * scale


def _last_axis(x: np.ndarray, axis: int) -> tuple[np.ndarray, tuple[int, ...]]:
    x = np.moveaxis(np.asarray(x), axis, -1)
    return x.reshape(-1, x.shape[-1]).astype(np.intp), x.shape[:-1]


def _spread_statistic(d: np.ndarray, percentile: float = SPREAD_PERCENTILE):
    """Statistic over resampled run indices: the percentile of d between every pair of the
    resample (positions i < j)."""

    def stat(idx: np.ndarray, axis: int = -1) -> np.ndarray:
        flat, shape = _last_axis(idx, axis)
        n = flat.shape[1]
        iu, ju = np.triu_indices(n, 1)
        pairs = d[flat[:, iu], flat[:, ju]]
        return np.percentile(pairs, percentile, axis=-1).reshape(shape)

    return stat


def _median_cross_statistic(d: np.ndarray):
    def stat(ia: np.ndarray, ib: np.ndarray, axis: int = -1) -> np.ndarray:
        fa, shape = _last_axis(ia, axis)
        fb, _ = _last_axis(ib, axis)
        sub = d[fa[:, :, None], fb[:, None, :]].reshape(fa.shape[0], -1)
        return np.median(sub, axis=-1).reshape(shape)

    return stat


def _bootstrap(data: tuple[np.ndarray, ...], stat: Any, value: float, seed: int) -> Interval:
    if any(len(x) < 2 for x in data):
        return Interval(value)
    from scipy import stats

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = stats.bootstrap(
            data,
            stat,
            vectorized=True,
            n_resamples=BOOTSTRAP_RESAMPLES,
            batch=250,
            confidence_level=CONFIDENCE,
            method="percentile",
            rng=np.random.default_rng(seed),
        )
    lo, hi = float(res.confidence_interval.low), float(res.confidence_interval.high)
    if not (math.isfinite(lo) and math.isfinite(hi)):  # every resample equal
        return Interval(value, value, value)
    return Interval(value, lo, hi)


def energy_test(d: np.ndarray, na: int, seed: int = 0) -> TwoSampleTest:
    """Permutation test on the energy distance ``2 E|A-B| - E|A-A'| - E|B-B'|`` between the
    first ``na`` and the other runs of the distance matrix ``d`` (n, n): exact when there are
    at most :data:`TEST_RESAMPLES` splits, else that many random ones."""
    from scipy import stats

    n = d.shape[0]
    nb = n - na

    def stat(x: np.ndarray, y: np.ndarray, axis: int = -1) -> np.ndarray:
        fx, shape = _last_axis(x, axis)
        fy, _ = _last_axis(y, axis)
        dxy = d[fx[:, :, None], fy[:, None, :]].mean(axis=(1, 2))
        dxx = d[fx[:, :, None], fx[:, None, :]].mean(axis=(1, 2))
        dyy = d[fy[:, :, None], fy[:, None, :]].mean(axis=(1, 2))
        return (2 * dxy - dxx - dyy).reshape(shape)

    splits = math.comb(n, na)
    res = stats.permutation_test(
        (np.arange(na), np.arange(na, n)),
        stat,
        permutation_type="independent",
        vectorized=True,
        n_resamples=TEST_RESAMPLES,
        batch=500,
        alternative="greater",
        rng=np.random.default_rng(seed),
    )
    exact = splits <= TEST_RESAMPLES
    return TwoSampleTest(
        statistic=float(res.statistic),
        p_value=float(res.pvalue),
        resamples=splits if exact else TEST_RESAMPLES,
        exact=exact,
        sizes=(na, nb),
    )


def _matrix(quantity: str, fa: np.ndarray, fb: np.ndarray) -> np.ndarray:
    """(len(fa), len(fb)) the quantity between every run of fa and every run of fb (one
    instant's features, (N, ...))."""
    return distance(quantity, fa[:, None], fb[None, :])


# ---------------------------------------------------------------- judgement


def judge(
    time: np.ndarray,
    quantity: str,
    labels: Sequence[str],
    members: Sequence[np.ndarray],
    own_errors: Sequence[np.ndarray],
    *,
    tolerance: float | None = None,
    floor: float | None = None,
    seed: int = 0,
) -> Verdict:
    """Judge two engines' ensembles over the whole run.

    Args:
        time: (T,) s, the instants.
        quantity: a key of :data:`~simbridge.compare.diff.QUANTITIES`.
        labels: the two engines' names.
        members: per engine, (N, T, ...) features of its runs (member 0: the nominal run).
        own_errors: per engine, (T,) its own time-step error (dt against dt/2).
        tolerance: below it at every instant the engines agree (default: the quantity's first
            threshold).
        floor: the precision floor (default :func:`precision_floor` of the features).
        seed: seeds the bootstrap and the permutations.
    """
    q = QUANTITIES[quantity]
    tol = float(q.thresholds[0] if tolerance is None else tolerance)
    fa, fb = (np.asarray(m, dtype=np.float64) for m in members)
    na, nb = fa.shape[0], fb.shape[0]
    flo = float(precision_floor([fa, fb]) if floor is None else floor)
    time = np.asarray(time, dtype=np.float64)
    own = np.stack([np.asarray(o, dtype=np.float64) for o in own_errors])
    spreads = np.stack([pairwise_spread(quantity, fa), pairwise_spread(quantity, fb)])
    cross = np.stack([distance(quantity, fa[i], fb[j]) for i in range(na) for j in range(nb)])
    gap = np.median(cross, axis=0)
    spread_f = np.maximum(spreads, flo)
    own_f = np.maximum(own, flo)
    classes = _classes(gap, tol, own_f, spread_f)
    end = len(time) - 1
    if gap[end] >= tol:
        j, why = end, "end"
    else:
        j, why = int(np.argmax(gap)), "largest gap"
    g = float(gap[j])

    # bootstrap intervals: the gap, each engine's spread (at the judged instant and the end)
    gap_j = _gap_interval(quantity, fa, fb, gap, j, seed)
    gap_end = gap_j if j == end else _gap_interval(quantity, fa, fb, gap, end, seed)
    per_engine = _engine_judgements(
        quantity, labels, (fa, fb), j, end, g, spreads, (spread_f, own_f), own, time, seed
    )
    test = None
    if not np.all(gap < tol) and na >= 2 and nb >= 2:
        both = np.concatenate([fa[:, j], fb[:, j]])
        test = energy_test(_matrix(quantity, both, both), na, seed)
    verdict, engines, reason, marginal = _decide(gap, tol, per_engine, test)
    imax = int(np.argmax(gap))
    return Verdict(
        verdict=verdict,
        engines=engines,
        reason=reason,
        marginal=bool(marginal),
        marginal_reasons=marginal,
        quantity=quantity,
        unit=q.unit,
        tolerance=tol,
        floor=flo,
        labels=(labels[0], labels[1]),
        judged_index=j,
        judged_at=why,
        gap=gap_j,
        gap_end=gap_end,
        nominal_gap=float(distance(quantity, fa[0, j], fb[0, j])),
        max_gap=(float(gap[imax]), float(time[imax])),
        test=test,
        per_engine=per_engine,
        time=time,
        gap_series=gap,
        spreads=spreads,
        own_errors=own,
        classes=classes,
    )


def _classes(gap: np.ndarray, tol: float, own_f: np.ndarray, spread_f: np.ndarray) -> np.ndarray:
    """(T,) int8 code of each instant (:data:`_CODES`): the gap below ``tol``, within the
    spreads, within the own errors (each floored, (2, T)), else apart."""
    classes = np.full(len(gap), _CODES["differ"], dtype=np.int8)
    within = MARGINAL[1]
    classes[np.any(gap <= within * own_f, axis=0)] = _CODES["unresolved"]
    classes[np.any(gap <= within * spread_f, axis=0)] = _CODES["chaotic"]
    classes[gap < tol] = _CODES["agree"]
    return classes


def _gap_interval(
    quantity: str, fa: np.ndarray, fb: np.ndarray, gap: np.ndarray, k: int, seed: int
) -> Interval:
    """The bootstrap interval of the gap (the median cross distance) at instant ``k``."""
    d = _matrix(quantity, fa[:, k], fb[:, k])
    return _bootstrap(
        (np.arange(len(fa)), np.arange(len(fb))), _median_cross_statistic(d), float(gap[k]), seed
    )


def _spread_interval(
    quantity: str, f: np.ndarray, spread: np.ndarray, k: int, seed: int
) -> Interval:
    """The bootstrap interval of one engine's spread (``spread``, (T,)) at instant ``k``."""
    d = _matrix(quantity, f[:, k], f[:, k])
    return _bootstrap((np.arange(len(f)),), _spread_statistic(d), float(spread[k]), seed)


def _decide(
    gap: np.ndarray,
    tol: float,
    per_engine: list[EngineJudgement],
    test: TwoSampleTest | None,
) -> tuple[str, list[str], str, list[Marginal]]:
    """The verdict from the gap series, each engine's judgement and the energy test.

    Returns:
        The verdict, the engines it names, its reason, and what put it near a line.
    """
    marginal: list[Marginal] = []
    lo_m, within = MARGINAL
    if np.all(gap < tol):
        ratio = float(np.max(gap)) / tol
        if ratio >= lo_m:
            marginal.append(Marginal("tolerance", ratio))
        return "agree", [], "below tolerance", marginal
    covering = [e for e in per_engine if e.gap_over_spread <= within]
    if covering:
        covering.sort(key=lambda e: -e.spread.value)
        inside = min(e.gap_over_spread for e in covering) <= 1.0
        for e in covering:
            if e.gap_over_spread >= lo_m:
                marginal.append(Marginal("spread", e.gap_over_spread, e.label))
        reason = "within spread" if inside else "near spread"
        return "chaotic", [e.label for e in covering], reason, marginal
    own_cover = [e for e in per_engine if e.gap_over_own_error <= within]
    if own_cover:
        inside = min(e.gap_over_own_error for e in own_cover) <= 1.0
        for e in own_cover:
            if e.gap_over_own_error >= lo_m:
                marginal.append(Marginal("own_error", e.gap_over_own_error, e.label))
        reason = OWN_ERROR_REASONS[0 if inside else 1]
        return "unresolved", [e.label for e in own_cover], reason, marginal
    if test is None:
        return "unresolved", [], "single run", marginal
    if test.p_value >= ALPHA:
        return "unresolved", [], "not separated", marginal
    return "differ", [], "separated", marginal


def _engine_judgements(
    quantity: str,
    labels: Sequence[str],
    members: tuple[np.ndarray, np.ndarray],
    j: int,
    end: int,
    g: float,
    spreads: np.ndarray,
    floored: tuple[np.ndarray, np.ndarray],
    own: np.ndarray,
    time: np.ndarray,
    seed: int,
) -> list[EngineJudgement]:
    """Each engine's judgement at the judged instant ``j`` (and the last, ``end``), where the
    gap is ``g``.

    Args:
        members: per engine, (N, T, ...) features of its runs.
        spreads, own: (2, T) each engine's spread and own time-step error; ``floored`` the
            two floored at the precision floor.
        time: (T,) s.
    """
    q = QUANTITIES[quantity]
    fa, fb = members
    spread_f, own_f = floored
    dab = _matrix(quantity, fa[:, j], fb[:, j])  # (na, nb)
    nearest = (float(np.median(dab.min(axis=0))), float(np.median(dab.min(axis=1))))
    per_engine = []
    for slot, f in enumerate((fa, fb)):
        sj = _spread_interval(quantity, f, spreads[slot], j, seed)
        send = sj if j == end else _spread_interval(quantity, f, spreads[slot], end, seed)
        largest = float(np.max(_matrix(quantity, f[:, j], f[:, j]))) if len(f) > 1 else 0.0
        per_engine.append(
            EngineJudgement(
                label=labels[slot],
                size=len(f),
                spread=sj,
                spread_end=send,
                spread_max=float(np.max(spreads[slot])),
                largest_pair=largest,
                other_to_nearest=nearest[slot],
                own_error=float(own[slot, j]),
                gap_over_spread=g / float(spread_f[slot, j]),
                gap_over_own_error=g / float(own_f[slot, j]),
                horizons=horizons(time, spreads[slot], q.thresholds),
            )
        )
    return per_engine
