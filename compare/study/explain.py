"""``simbridge explain SCENARIO``: which setting explains the gap between two engines here?
:func:`explain`.

For every pair of engines the study lists a short set of **candidates**, each a setting and the
value it is moved to, with the reason it could explain the gap in this scenario
(:func:`candidates`):

- a profile entry (or engine setting) on which the two engines' profiles differ: the first
  engine is given the second's value (the gap between two runs of one engine with a friction
  changed on purpose is then gone);
- each profile departure that applies to this scenario (:func:`~simbridge.compare.report.
  departures.applicable`) and that a setting can move: the speed clamp (the engines apply it
  differently: run without it), the <contact> restitution and rolling/spinning friction MuJoCo
  and PhysX do not reproduce (run without the file's <contact>), the motor rows and contacts an
  iterative solve leaves short (PyBullet's or PhysX's at 200 iterations where MuJoCo solves
  them exactly; both at 200 where both iterate), link damping PhysX applies by another law
  (both run without it), and the contact settings that move one engine's contact toward the
  other's (:func:`_engine_candidates`);
- the joint-limit rule (``physx.limit_rule``, ``mujoco.limit_rule``), where the engines part at
  a limit event (a joint reached its limit in either engine's run within
  :data:`~simbridge.compare.run.events.PARTING_WINDOW` before the gap first reached its
  threshold, or the gap was born while one was at it: :func:`limit_parting`) and their rules
  differ: each engine that has the setting given the other's rule (:func:`_limit_candidates`);
- a departure no setting moves (collision cylinders, joint axes, float32 state, the joint
  limits where the engines do not part at one) or that changes only what is reported is listed
  as not tested, and why.

Each candidate is one :func:`~simbridge.compare.compare` of the pair with the setting moved.
The **share of the gap removed** is ``1 - gap_after / gap_before``, both the median distance
between the two engines' runs at the instant the pair's verdict was judged, with a 95% bootstrap
interval over the four ensembles (the pair's runs before and after, resampled independently).
The candidates are ranked by it; one that removes at least :data:`EXPLAINS` of the gap with the
interval's low end at least :data:`PARTLY` explains it; where none removes :data:`PARTLY` with an
interval above 0 the report says that nothing tested explains the gap.
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from simbridge.exceptions import InvalidArgumentError, SimbridgeError

from ..analysis.diff import QUANTITIES
from ..analysis.events import EngineEvents, Parting, engine_events, parting
from ..analysis.verdict import BOOTSTRAP_RESAMPLES, CONFIDENCE, Interval
from ..pipeline import Comparison, Pair, compare
from ..report.departures import applicable
from ..run.quantities import distance
from ..scenario import Scenario, load_scenario
from .candidates import Candidate, candidates, limit_parting, not_checked
from .points import PairFigures, _with_change, pair_figures

__all__ = [
    "DEFAULT_ENSEMBLE",
    "EXPLAINS",
    "PARTLY",
    "Candidate",
    "CandidateResult",
    "PairExplanation",
    "Explanation",
    "candidates",
    "explain",
    "limit_parting",
    "not_checked",
    "share_removed",
]

DEFAULT_ENSEMBLE = 6
"""Runs per engine in explain's comparisons (compare's default is 16): 6 keeps an explain of
r2d2-gentle within minutes on 2 cores, and 6 against 6 runs lets the permutation test reach
p = 0.002."""
EXPLAINS = 0.5
"""A candidate that removes at least this share of the gap explains it..."""
PARTLY = 0.2
"""...with the low end of its interval at least this; one whose low end is above 0 and whose
share reaches this explains part of it."""


@dataclass
class CandidateResult:
    """A candidate's run: the pair's profiles, the gap after at the judged instant, the share
    of the gap it removed (bootstrap intervals), the pair's verdict after."""

    candidate: Candidate
    profiles: tuple[str, str]
    gap: Interval
    share: Interval
    after: PairFigures
    wall_time: float

    @property
    def explains(self) -> str:
        """``yes`` (most of the gap), ``partly`` or ``no``."""
        s = self.share
        low = s.low if s.low is not None else s.value
        if s.value >= EXPLAINS and low >= PARTLY:
            return "yes"
        if s.value >= PARTLY and low > 0:
            return "partly"
        return "no"


@dataclass
class PairExplanation:
    """One pair of engines: its gap before, the candidates ranked, those not tested."""

    a: int
    b: int
    labels: tuple[str, str]
    before: PairFigures
    instant: float  # s, where the gap is measured (the pair's judged instant)
    gap: Interval  # before, at that instant
    ranked: list[CandidateResult] = field(default_factory=list)
    not_tested: list[tuple[str, str]] = field(default_factory=list)  # (departure, why)
    not_checked: list[str] = field(default_factory=list)
    """Departures the engines list that are not checked against this scenario: not tested."""
    failed: list[tuple[Candidate, str]] = field(default_factory=list)
    """Candidates whose rerun stopped with an error (a diverged engine...), with it."""
    note: str = ""  # why nothing was run (no gap to explain)

    @property
    def conclusion(self) -> str:
        text = self._conclusion()
        if self.before.verdict == "chaotic" and not self.note:
            who = " and ".join(self.before.engines) or "an engine"
            text += (
                f" (The gap is {'within' if self.before.reason == 'within spread' else 'near'} "
                f"{who}'s own spread: part of it is chaos, which no setting removes.)"
            )
        return text

    def _conclusion(self) -> str:
        a, b = self.labels
        if self.note:
            return self.note
        if not self.ranked and self.failed:
            return (
                f"Every candidate's rerun for {a} - {b} failed ({len(self.failed)}): nothing "
                "tested explains the gap."
            )
        if not self.ranked:
            return f"No setting could be moved for {a} - {b}: nothing tested explains the gap."
        best = self.ranked[0]
        pct = _pct(best.share)
        if best.explains == "yes":
            return (
                f"{best.candidate.name} explains most of the gap between {a} and {b}: moving it "
                f"({best.candidate.describe(self.labels)}) removes {pct} of it."
            )
        if best.explains == "partly":
            return (
                f"{best.candidate.name} explains part of the gap between {a} and {b}: it removes "
                f"{pct}; no setting tested removes most of it."
            )
        return (
            f"Nothing tested explains the gap between {a} and {b}: of {len(self.ranked)} "
            f"setting(s) moved, the most any removes is {pct} ({best.candidate.name})."
        )


@dataclass
class Explanation:
    """An explain study: every pair's explanation, with how it was run."""

    scenario: str
    backends: tuple[str, ...]
    profiles: tuple[str, ...]
    labels: tuple[str, ...]
    timestep: float
    ensemble: int
    duration: float | None
    pairs: list[PairExplanation]
    wall_time: float

    def as_dict(self) -> dict[str, Any]:
        out = []
        for p in self.pairs:
            out.append(
                {
                    "labels": list(p.labels),
                    "before": p.before.as_dict(),
                    "instant": p.instant,
                    "gap": _idict(p.gap),
                    "conclusion": p.conclusion,
                    "ranking": [
                        {
                            **r.candidate.as_dict(p.labels),
                            "explains": r.explains,
                            "share_removed": _idict(r.share),
                            "gap_after": _idict(r.gap),
                            "verdict_after": r.after.verdict,
                            "profiles": list(r.profiles),
                            "wall_time": r.wall_time,
                        }
                        for r in p.ranked
                    ],
                    "not_tested": [{"departure": k, "why": w} for k, w in p.not_tested],
                    "not_checked": list(p.not_checked),
                    "failed": [{**c.as_dict(p.labels), "error": err} for c, err in p.failed],
                }
            )
        return {
            "scenario": self.scenario,
            "backends": list(self.backends),
            "profiles": list(self.profiles),
            "labels": list(self.labels),
            "timestep": self.timestep,
            "ensemble": self.ensemble,
            "duration": self.duration,
            "wall_time": self.wall_time,
            "explains_at": {"share": EXPLAINS, "interval_low": PARTLY},
            "pairs": out,
        }


def _idict(x: Interval) -> dict[str, float | None]:
    return {"value": x.value, "low": x.low, "high": x.high}


def _p(x: float) -> str:
    return f"{100 * x:.0f}%".replace("-0%", "0%")


def _pct(x: Interval) -> str:
    if x.low is None or x.high is None:
        return _p(x.value)
    return f"{_p(x.value)} (95% interval {_p(x.low)} to {_p(x.high)})"


# ---------------------------------------------------------------- measuring


def _matrix(quantity: str, fa: np.ndarray, fb: np.ndarray) -> np.ndarray:
    return distance(quantity, fa[:, None], fb[None, :])


def share_removed(
    quantity: str,
    before: tuple[np.ndarray, np.ndarray],
    after: tuple[np.ndarray, np.ndarray],
    *,
    seed: int = 0,
    resamples: int = BOOTSTRAP_RESAMPLES,
) -> tuple[Interval, Interval, Interval]:
    """(gap before, gap after, share removed) at one instant, each with its 95% percentile
    bootstrap interval: ``before``/``after`` are the two engines' runs' features there, (N, ...)
    each; a gap is the median distance over every pair (run of A, run of B)."""
    db = _matrix(quantity, *before)
    da = _matrix(quantity, *after)
    gb, ga = float(np.median(db)), float(np.median(da))
    share = 1.0 - ga / gb if gb > 0 else math.nan
    if min(*db.shape, *da.shape) < 2:
        return Interval(gb), Interval(ga), Interval(share)
    rng = np.random.default_rng(seed)
    bs, as_, ss = [], [], []
    for _ in range(resamples):
        ib = (rng.integers(0, db.shape[0], db.shape[0]), rng.integers(0, db.shape[1], db.shape[1]))
        ia = (rng.integers(0, da.shape[0], da.shape[0]), rng.integers(0, da.shape[1], da.shape[1]))
        x = float(np.median(db[np.ix_(*ib)]))
        y = float(np.median(da[np.ix_(*ia)]))
        bs.append(x)
        as_.append(y)
        ss.append(1.0 - y / x if x > 0 else math.nan)
    q = (100 * (1 - CONFIDENCE) / 2, 100 * (1 + CONFIDENCE) / 2)

    def iv(value: float, xs: list[float]) -> Interval:
        arr = np.asarray(xs)
        arr = arr[np.isfinite(arr)]
        if not arr.size:
            return Interval(value)
        lo, hi = np.percentile(arr, q)
        return Interval(value, float(lo), float(hi))

    return iv(gb, bs), iv(ga, as_), iv(share, ss)


def _at(time: np.ndarray, t: float) -> int:
    return int(np.argmin(np.abs(np.asarray(time) - t)))


# ---------------------------------------------------------------- the study


def explain(
    scenario: Any,
    backends: Sequence[str] | None = None,
    *,
    profile: str | Sequence[str] | None = None,
    timestep: float | str | None = None,
    ensemble: int = DEFAULT_ENSEMBLE,
    seed: int = 0,
    on_run: Callable[[str], None] | None = None,
    **compare_args: Any,
) -> Explanation:
    """For every pair of engines, move each candidate setting toward the other engine's
    behaviour and rank the settings by the share of the gap each removes.

    Args:
        scenario: as :func:`~simbridge.compare.compare`'s.
        backends: as :func:`~simbridge.compare.compare`'s.
        profile: as :func:`~simbridge.compare.compare`'s.
        timestep: the time step of every run (default the scenario's).
        ensemble: runs per engine in every comparison (:data:`DEFAULT_ENSEMBLE`); at least 2
            for intervals.
        seed: seeds the ensembles and the bootstrap.
        on_run: ``on_run(what)`` before each comparison runs.
        compare_args: passed to every :func:`~simbridge.compare.compare` call (``duration``,
            ``perturb``, ``workers``...; ``resync_every`` defaults to 0 here: not needed).

    Raises:
        InvalidArgumentError: a bad ensemble size; what compare raises (an
            ``engine_settings`` for an engine not run: EngineNotInStudyError, before any run).
    """
    if isinstance(ensemble, bool) or not isinstance(ensemble, int) or ensemble < 1:
        raise InvalidArgumentError("ensemble", f"expected an integer >= 1, got {ensemble!r}")
    start = _time.perf_counter()
    sc = load_scenario(scenario)
    if compare_args.get("controller") is not None:
        sc = sc.with_controller(compare_args.pop("controller"))
    compare_args.setdefault("resync_every", 0)
    from ..scenario import parse_timestep

    dt = parse_timestep(timestep) if timestep is not None else sc.timestep
    if on_run is not None:
        on_run("the comparison as given")
    base = compare(
        sc, backends, profile=profile, timesteps=[dt], ensemble=ensemble, seed=seed, **compare_args
    )
    events = engine_events(base)
    deps = applicable(base, events)
    rerun = _Rerun(sc, dt, ensemble, seed, on_run, compare_args)
    pairs = [_explain_pair(base, p, events, deps, rerun) for p in base.pairs]
    return Explanation(
        scenario=sc.name,
        backends=base.backends,
        profiles=base.profiles,
        labels=base.labels,
        timestep=dt,
        ensemble=ensemble,
        duration=compare_args.get("duration"),
        pairs=pairs,
        wall_time=_time.perf_counter() - start,
    )


@dataclass(frozen=True)
class _Rerun:
    """How every candidate's comparison is run: :func:`explain`'s scenario and arguments."""

    scenario: Scenario
    dt: float  # s, the time step of every run
    ensemble: int
    seed: int
    on_run: Callable[[str], None] | None
    compare_args: dict[str, Any]


def _explain_pair(
    base: Comparison,
    p: Pair,
    events: Sequence[EngineEvents],
    deps: Any,
    rerun: _Rerun,
) -> PairExplanation:
    """One pair of the comparison as given: its gap, its candidates (each run, ranked by the
    share of the gap removed), those not tested and why; a note alone where they agree.

    Args:
        base: the comparison as given.
        p: the pair, with its verdict.
        events: every engine's events in ``base``.
        deps: the profile departures that apply to ``base``.
        rerun: how each candidate is run.
    """
    assert p.verdict is not None
    a, b = p.a, p.b
    labels = (base.labels[a], base.labels[b])
    names = (base.backends[a], base.backends[b])
    profs = (base.profiles[a], base.profiles[b])
    before = pair_figures(p.verdict)
    j = p.verdict.judged_index
    t = float(p.verdict.time[j])
    fb = (base.ensembles[a].features[:, j], base.ensembles[b].features[:, j])
    gap = share_removed(p.verdict.quantity, fb, fb, seed=rerun.seed)[0]
    pe = PairExplanation(a, b, labels, before, t, gap)
    if before.verdict == "agree":
        pe.note = (
            f"{labels[0]} and {labels[1]} agree here (the gap stays below "
            f"{fmt_tol(before)}): there is no gap to explain."
        )
        return pe
    pair_events = (events[a], events[b])
    at = limit_parting(pair_parting(base, p, events), pair_events)
    cands, pe.not_tested = candidates(names, profs, labels, deps, rerun.dt, at, pair_events)
    pe.not_checked = not_checked(labels, deps)
    results = []
    for cand in cands:
        result = _run_candidate(cand, names, profs, labels, p.verdict.quantity, t, fb, rerun, pe)
        if result is not None:
            results.append(result)
    results.sort(key=lambda r: -(r.share.value if math.isfinite(r.share.value) else -1e300))
    pe.ranked = results
    return pe


def _run_candidate(
    cand: Candidate,
    names: tuple[str, str],
    profs: tuple[str, str],
    labels: tuple[str, str],
    quantity: str,
    t: float,
    before: tuple[np.ndarray, np.ndarray],
    rerun: _Rerun,
    pe: PairExplanation,
) -> CandidateResult | None:
    """Compare the pair with ``cand``'s settings moved and measure the gap it leaves at ``t``
    (s) against ``before`` (each engine's ensemble features there).

    Returns:
        Its result; None where the moved setting broke a run (said in ``pe.failed``).
    """
    moved = list(profs)
    for slot, key, value in cand.moves:
        moved[slot] = _with_change(moved[slot], key, value)
    if rerun.on_run is not None:
        rerun.on_run(f"{labels[0]} - {labels[1]}: {cand.describe(labels)}")
    t0 = _time.perf_counter()
    try:
        c = compare(
            rerun.scenario,
            list(names),
            profile=moved,
            timesteps=[rerun.dt],
            ensemble=rerun.ensemble,
            seed=rerun.seed,
            **rerun.compare_args,
        )
    except SimbridgeError as exc:  # the moved setting broke a run: say so, go on
        pe.failed.append((cand, str(exc)))
        return None
    v = c.pairs[0].verdict
    assert v is not None
    k = _at(c.ensembles[0].time, t)
    fa = (c.ensembles[0].features[:, k], c.ensembles[1].features[:, k])
    _, g_after, share = share_removed(quantity, before, fa, seed=rerun.seed)
    return CandidateResult(
        cand,
        (moved[0], moved[1]),
        g_after,
        share,
        pair_figures(v),
        _time.perf_counter() - t0,
    )


def fmt_tol(p: PairFigures) -> str:
    from ..report.fmt import fmt_threshold

    return fmt_threshold(p.tolerance, p.unit)


def pair_parting(c: Comparison, p: Pair, events: Sequence[EngineEvents]) -> Parting:
    """Where the gap between the engines of ``p`` is born, as the compare report says it
    (``summary.json``'s ``pairs[].parting``): the headline quantity first reaching its first
    threshold at the headline time step, the phases and the pair's events (``events``: every
    engine's, :func:`~simbridge.compare.analysis.events.engine_events`)."""
    q = c.headline_quantity
    dt = c.timestep
    thr = QUANTITIES[q].thresholds[0]
    tr = c.runs[(p.a, dt)]
    phases = [(name, float(tr.time[i]), float(tr.time[j])) for name, i, j in tr.phases]
    return parting(
        p.cross[dt].first_crossing(q, thr), thr, q, phases, [events[p.a], events[p.b]], dt
    )
