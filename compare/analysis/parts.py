"""Which part of the robot parts first: every movable joint and every link of the followed robot
ranked by when the two engines' runs part there and how far (:func:`rank_parts`).

A joint's gap is |q_a - q_b| (rad, angles unwrapped, or m for a prismatic joint); a link's is
the distance between its centres of mass (m). Each has its threshold (:data:`THRESHOLDS`: 1° for
an angle, 1 cm for a distance); a part *parts* at the first recorded instant its gap reaches it.
Parts that part come first, earliest first (ties: the larger gap relative to the threshold
first); then the others, the largest gap relative to the threshold first.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .diff import DEG, Divergence

__all__ = ["THRESHOLDS", "Part", "rank_parts"]

THRESHOLDS = {"rad": 1 * DEG, "m": 0.01}
"""The gap at which a joint (rad or m) or a link (m) parts."""


@dataclass(frozen=True)
class Part:
    """One joint or link: ``kind`` (``joint`` or ``link``), its ``name``, the ``unit`` of its
    gap, the ``threshold``, ``first`` (s: when the gap first reaches it; None: never),
    ``largest`` (the largest gap) and ``largest_at`` (s), ``at_end`` (the gap at the end)."""

    kind: str
    name: str
    unit: str
    threshold: float
    first: float | None
    largest: float
    largest_at: float
    at_end: float

    @property
    def ratio(self) -> float:
        """The largest gap over the threshold."""
        return self.largest / self.threshold


def _part(kind: str, name: str, unit: str, time: np.ndarray, gap: np.ndarray) -> Part:
    thr = THRESHOLDS[unit]
    hit = np.flatnonzero(gap >= thr)
    top = int(np.argmax(gap))
    return Part(
        kind=kind,
        name=name,
        unit=unit,
        threshold=thr,
        first=float(time[hit[0]]) if hit.size else None,
        largest=float(gap[top]),
        largest_at=float(time[top]),
        at_end=float(gap[-1]),
    )


def rank_parts(d: Divergence) -> list[Part]:
    """Every movable joint and every link (base first in the record) of ``d``'s subject,
    ranked: those that part, earliest first, then the rest by their largest gap over its
    threshold. Empty when ``d`` carries no per-part gaps."""
    parts = [
        _part("joint", name, unit, d.time, d.joint_gaps[:, j])
        for j, (name, unit) in enumerate(zip(d.joint_names, d.joint_units, strict=True))
    ]
    parts += [
        _part("link", name, "m", d.time, d.link_gaps[:, k]) for k, name in enumerate(d.link_names)
    ]

    def key(p: Part) -> tuple[int, float, float]:
        return (p.first is None, p.first if p.first is not None else 0.0, -p.ratio)

    return sorted(parts, key=key)
