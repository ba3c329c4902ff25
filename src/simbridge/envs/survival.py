"""Time to failure: the Kaplan-Meier estimate of a set of episodes' survival
(:func:`kaplan_meier`), which ``simbridge sim2sim`` reports per engine (the shares at four points
in report.md, the curve in survival.png: :mod:`simbridge.envs.sim2sim_figures`).

An episode that ends on a termination (a fall, the cart leaving its rail, a NaN action, a
diverged engine) fails at its length; one that ends otherwise (a success that ends it early,
the episode's last step) is censored there: it counts as at risk up to and including its length
and never fails. At each failure time ``t``, with ``n`` episodes at risk (length ``>= t``) and
``d`` failing there, the survival is multiplied by ``1 - d / n``.

The 95% band is the log-log (exponential Greenwood) interval:
``S ** exp(+-1.96 * sqrt(sum d / (n (n - d))) / |log S|)``; it is ``[S, S]`` where ``S`` is 1 (no
failure yet) and ``[0, 0]`` once ``S`` is 0.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

if TYPE_CHECKING:
    from simbridge.envs.paired import Record

__all__ = ["Z95", "KaplanMeier", "kaplan_meier"]

Z95 = 1.959964
"""The normal quantile of a two-sided 95% interval."""


class KaplanMeier(NamedTuple):
    """A Kaplan-Meier survival curve, a step function: ``survival[k]`` holds from
    ``times[k]`` (inclusive) to ``times[k + 1]``."""

    times: np.ndarray
    """``(k + 1,)`` control steps: 0, then each step at which an episode failed, ascending."""
    survival: np.ndarray
    """``(k + 1,)`` the share not failed from that step on (1 at step 0)."""
    low: np.ndarray
    """``(k + 1,)`` the 95% band's lower end."""
    high: np.ndarray
    """``(k + 1,)`` its upper end."""
    at_risk: np.ndarray
    """``(k + 1,)`` episodes still running at that step (all of them at step 0)."""
    failed: np.ndarray
    """``(k + 1,)`` episodes that failed at that step (0 at step 0)."""

    def at(self, step: float) -> float:
        """The survival at control step ``step`` (after the failures at that step).

        Args:
            step: a control step (0 or more).

        Returns:
            The share not failed by then.
        """
        k = int(np.searchsorted(self.times, step, side="right")) - 1
        return float(self.survival[max(k, 0)])


def kaplan_meier(records: Sequence[Record], *, z: float = Z95) -> KaplanMeier:
    """The Kaplan-Meier estimate of the episodes' time to failure, with its band.

    Args:
        records: the episodes (their ``steps`` and ``failure``: None for a censored one).
        z: the band's normal quantile (1.96: 95%).

    Returns:
        The :class:`KaplanMeier` curve.
    """
    steps = np.array([r.steps for r in records], dtype=np.int64)
    failed = np.array([r.failure is not None for r in records], dtype=bool)
    times = np.unique(steps[failed])
    s, greenwood = 1.0, 0.0
    rows = [(0, 1.0, 1.0, 1.0, len(records), 0)]
    for t in times:
        n = int(np.sum(steps >= t))
        d = int(np.sum((steps == t) & failed))
        s *= 1.0 - d / n
        greenwood = greenwood + d / (n * (n - d)) if n > d else np.inf
        rows.append((int(t), s, *_band(s, greenwood, z), n, d))
    cols = list(zip(*rows, strict=True))
    return KaplanMeier(
        np.array(cols[0], dtype=np.int64),
        np.array(cols[1]),
        np.array(cols[2]),
        np.array(cols[3]),
        np.array(cols[4], dtype=np.int64),
        np.array(cols[5], dtype=np.int64),
    )


def _band(s: float, greenwood: float, z: float) -> tuple[float, float]:
    """The log-log interval of survival ``s`` with Greenwood's sum ``greenwood``."""
    if s <= 0.0:
        return 0.0, 0.0
    if s >= 1.0:
        return s, s
    half = z * np.sqrt(greenwood) / abs(np.log(s))
    return float(s ** np.exp(half)), float(s ** np.exp(-half))
