"""``--resolve``: where the headline verdict is "unresolved" because the gap lies within an
engine's own time-step error, halve the time step until it resolves: :func:`resolve`.

An engine's own time-step error is the distance between its nominal runs at dt and at dt/2
(:mod:`~simbridge.compare.analysis.verdict`); a gap within twice it cannot be told from the
time step. Halving dt shrinks that error (about in proportion for a first-order scheme) while a
real engine difference stays: the verdict then comes out ``differ`` (or ``agree``, or
``chaotic``). The study stops at the first verdict that is not unresolved for that reason, or
after ``limit`` halvings; every step's verdict is kept (:class:`Resolution`).
"""

from __future__ import annotations

import time as _time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from simbridge.exceptions import InvalidArgumentError

from ..analysis.verdict import OWN_ERROR_REASONS, Verdict
from ..pipeline import Comparison, compare
from ..scenario import load_scenario
from .points import PairFigures, all_pairs

__all__ = ["DEFAULT_LIMIT", "ResolveStep", "Resolution", "resolve", "needs_halving", "Resolver"]

DEFAULT_LIMIT = 4
"""Halvings at most (``--resolve-limit``): dt / 16 at the end, 31x the nominal steps in all."""


def needs_halving(v: Verdict | PairFigures | None) -> bool:
    """The verdict is unresolved because the gap lies within an engine's own time-step error."""
    return v is not None and v.verdict == "unresolved" and v.reason in OWN_ERROR_REASONS


@dataclass
class ResolveStep:
    """One time step of a resolve study: every pair's figures there."""

    timestep: float
    pairs: list[PairFigures]
    wall_time: float

    @property
    def headline(self) -> PairFigures:
        return self.pairs[0]


@dataclass
class Resolution:
    """The verdict at each time step, coarsest first; ``final`` is the last comparison (the one
    the report is written from). ``outcome``: ``resolved`` (the last verdict is not unresolved
    by the time step), ``limit`` (still unresolved after ``limit`` halvings) or ``not needed``
    (the first verdict was not unresolved by the time step)."""

    steps: list[ResolveStep]
    limit: int
    final: Comparison
    outcome: str

    @property
    def halvings(self) -> int:
        return len(self.steps) - 1

    def as_dict(self) -> dict[str, Any]:
        return {
            "limit": self.limit,
            "halvings": self.halvings,
            "outcome": self.outcome,
            "steps": [
                {
                    "timestep": s.timestep,
                    "wall_time": s.wall_time,
                    "pairs": [p.as_dict() for p in s.pairs],
                }
                for s in self.steps
            ],
        }


def _check_limit(limit: Any) -> int:
    if isinstance(limit, bool) or not isinstance(limit, int) or limit < 0:
        raise InvalidArgumentError(
            "resolve_limit", f"expected a whole number of halvings >= 0, got {limit!r}"
        )
    return limit


def resolve(
    scenario: Any,
    backends: Sequence[str] | None = None,
    *,
    limit: int = DEFAULT_LIMIT,
    timesteps: Sequence[float | str] | None = None,
    **compare_args: Any,
) -> Resolution:
    """Run :func:`~simbridge.compare.compare` and, while its headline verdict is unresolved
    because the gap lies within an engine's own time-step error, again at half the headline
    time step, at most ``limit`` times.

    Args:
        scenario: as :func:`~simbridge.compare.compare`'s.
        backends: as :func:`~simbridge.compare.compare`'s.
        timesteps: as :func:`~simbridge.compare.compare`'s; the first time step is the one
            halved (the others, a time-step sweep, are kept as given).
        limit: halvings at most (0: none, the comparison alone).
        compare_args: passed to every :func:`~simbridge.compare.compare` call.

    Raises:
        InvalidArgumentError: a bad ``limit``; what :func:`~simbridge.compare.compare` raises.
    """
    limit = _check_limit(limit)
    sc = load_scenario(scenario)
    if "controller" in compare_args and compare_args["controller"] is not None:
        sc = sc.with_controller(compare_args.pop("controller"))
    given = list(timesteps) if timesteps else [sc.timestep]
    from ..scenario import parse_timestep

    first, rest = parse_timestep(given[0]), list(given[1:])
    steps: list[ResolveStep] = []
    dt = first
    while True:
        start = _time.perf_counter()
        c = compare(sc, backends, timesteps=[dt, *rest], **compare_args)
        pairs = all_pairs(c)
        steps.append(ResolveStep(dt, pairs, _time.perf_counter() - start))
        head = pairs[0] if pairs else None
        if not needs_halving(head):
            outcome = "not needed" if len(steps) == 1 else "resolved"
            break
        if len(steps) > limit:
            outcome = "limit"
            break
        dt = dt / 2
    return Resolution(steps=steps, limit=limit, final=c, outcome=outcome)


class Resolver:
    """:func:`resolve` with :func:`~simbridge.compare.compare`'s call: calling it returns the
    last comparison and keeps the study in :attr:`resolution` (what the CLI's ``--resolve``
    runs in place of compare)."""

    def __init__(self, limit: int = DEFAULT_LIMIT) -> None:
        self.limit = _check_limit(limit)
        self.resolution: Resolution | None = None

    def __call__(self, scenario: Any, backends: Any = None, **compare_args: Any) -> Comparison:
        self.resolution = resolve(scenario, backends, limit=self.limit, **compare_args)
        return self.resolution.final
