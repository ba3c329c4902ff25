"""A verdict kept in the study's cache: :func:`judged`."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..run.cache import Cache, derived_key
from . import verdict as _verdict
from .verdict import Verdict

if TYPE_CHECKING:
    from ..run.studyjobs import JobCounts

__all__ = ["judged"]

log = logging.getLogger("simbridge.compare.cache")


def judged(
    counts: JobCounts | None,
    time: np.ndarray,
    quantity: str,
    labels: Sequence[str],
    members: Sequence[np.ndarray],
    own_errors: Sequence[np.ndarray],
    *,
    tolerance: float | None = None,
    seed: int = 0,
) -> Verdict:
    """:func:`~simbridge.compare.analysis.verdict.judge`'s verdict, kept in the study's cache
    (``counts.cache``; none: judged here) under the sha256 of every argument (the arrays by
    their bytes) and :func:`~.cache.code_digest` (simbridge's code, numpy's and scipy's
    versions): its bootstrap and permutation test are the costly part of a report rebuilt from
    the cache, and are deterministic given the seed. ``counts.fresh``: judged again."""

    def run() -> Verdict:
        return _verdict.judge(
            time, quantity, labels, members, own_errors, tolerance=tolerance, seed=seed
        )

    if counts is None or counts.cache is None:
        return run()
    store = Cache(counts.cache)
    key = derived_key(
        "verdicts",
        np.asarray(time, dtype=np.float64),
        quantity,
        list(labels),
        [np.asarray(m, dtype=np.float64) for m in members],
        [np.asarray(o, dtype=np.float64) for o in own_errors],
        tolerance,
        seed,
    )
    if not counts.fresh:
        got = store.get(key, "verdicts")
        if isinstance(got, Verdict):
            return got
    verdict = run()
    try:
        store.put(key, verdict, "verdicts")
    except OSError as exc:
        log.warning("cannot write the cache entry of a verdict: %s", exc)
    return verdict
