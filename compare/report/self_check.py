"""An engine compared with itself: two entries of ``--backends`` with the same engine and the
same profile (and so the same engine settings, which are given per engine) make a null
comparison, a legitimate self-check whose verdict says nothing of two engines
(:func:`self_check_words`)."""

from __future__ import annotations

from collections.abc import Sequence

__all__ = ["same_engine_pairs", "self_check_words"]


def same_engine_pairs(backends: Sequence[str], profiles: Sequence[str]) -> list[tuple[int, int]]:
    """The pairs of slots (a < b) whose engine and profile are the same."""
    n = len(backends)
    return [
        (a, b)
        for a in range(n)
        for b in range(a + 1, n)
        if backends[a] == backends[b] and profiles[a] == profiles[b]
    ]


def self_check_words(
    backends: Sequence[str], profiles: Sequence[str], labels: Sequence[str] | None = None
) -> str | None:
    """``warning: pybullet and pybullet (2) are the same engine with the same profile and
    settings: ...``; None when no two entries are."""
    pairs = same_engine_pairs(backends, profiles)
    if not pairs:
        return None
    names = list(labels) if labels is not None else list(backends)
    which = "; ".join(f"{names[a]} and {names[b]}" for a, b in pairs)
    return (
        f"warning: {which} are the same engine ({backends[pairs[0][0]]}) with the same profile "
        f"({profiles[pairs[0][0]]}) and settings: a null comparison (a self-check), whose "
        "verdict says nothing of two engines."
    )
