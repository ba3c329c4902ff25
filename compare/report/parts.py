"""The ranking of joints and links in words, from ``summary.json``'s ``parts`` alone."""

from __future__ import annotations

from typing import Any

from .fmt import fmt_threshold, fmt_time, fmt_value

__all__ = ["parts_words"]


def parts_words(parts: list[dict[str, Any]], n: int = 3) -> str:
    """The ranking's head in one sentence, from ``summary.json``'s ``parts``."""
    if not parts:
        return ""
    parted = [p for p in parts if p["first"] is not None]

    def one(p: dict[str, Any]) -> str:
        return (
            f"{p['kind']} `{p['name']}` ({fmt_threshold(p['threshold'], p['unit'])} apart at "
            f"t = {fmt_time(p['first'])}, largest {fmt_value(p['largest'], p['unit'])})"
        )

    if not parted:
        top = parts[0]
        return (
            "No joint or link comes 1° or 1 cm apart; the nearest to it is "
            f"{top['kind']} `{top['name']}` (largest gap {fmt_value(top['largest'], top['unit'])}"
            f" at t = {fmt_time(top['largest_at'])})."
        )
    words = "The first part to come apart is " + one(parted[0])
    if len(parted) > 1:
        words += ", then " + ", ".join(one(p) for p in parted[1:n])
    rest = len(parted) - min(n, len(parted))
    if rest:
        words += f", and {rest} more"
    return words + f" (of {len(parts)} joints and links)."
