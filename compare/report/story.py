"""What happens to the followed robot, in one sentence for the headline and the opening of
``report.md`` (:func:`story_words`), from ``summary.json``'s ``events`` alone: the largest
thing its events found, where it is large enough to tell the run's story.

- It **starts inside** something, at least :data:`START_DEPTH` deep (the deepest point of its
  first step's contacts, found at the spawn pose): a robot resting on a surface sits within a
  few millimetres of it (PyBullet's collision margin, the MuJoCo backend's 1 mm pair margin),
  so 1 cm is past any resting contact;
- each engine **throws** it, its highest airborne peak at least :data:`THROW` above where it
  left the ground (the wheel and foot hops the events list, measured up to 5.8 cm on the
  shipped scenarios, stay below it), the peak's height given;
- or, neither holding, it **tips over** on some engine.

Nothing holding (a pendulum, a robot driving on its wheels), there is no sentence. Every
engine is named, in the report's order; no scenario or engine is special.
"""

from __future__ import annotations

from typing import Any

from ..run.quantities import QUANTITIES
from .fmt import fmt_distance, fmt_time

__all__ = ["story_words", "START_DEPTH", "THROW"]

START_DEPTH = QUANTITIES["base_distance"].thresholds[0]
"""m (1 cm): a start this deep inside something is told."""
THROW = QUANTITIES["base_distance"].thresholds[1]
"""m (10 cm): an airborne rise this high is a throw."""


def _names(labels: list[str]) -> str:
    return labels[0] if len(labels) == 1 else ", ".join(labels[:-1]) + f" and {labels[-1]}"


def _highest(e: dict[str, Any]) -> dict[str, Any] | None:
    peaks = [x for x in e.get("events", []) if x["kind"] == "peak_height"]
    return max(peaks, key=lambda x: x["figures"]["height"]) if peaks else None


def story_words(s: dict[str, Any]) -> str | None:
    """``r2d2 starts 37.1 cm inside plane: pybullet throws it to a height of 2.43 m, mujoco to
    14.37 m, physx to 85.9 cm.``; None where nothing of the kinds above happened."""
    events: dict[str, Any] = s.get("events") or {}
    labels = [lab for lab in s["labels"] if lab in events]
    if not labels:
        return None
    subject = events[labels[0]].get("body") or s.get("subject") or "the robot"
    parts: list[str] = []
    starts = [events[lab].get("start_depth") for lab in labels]
    deepest = max((x for x in starts if x), key=lambda x: x["depth"], default=None)
    if deepest is not None and deepest["depth"] >= START_DEPTH:
        into = " and ".join(deepest["others"]) if deepest["others"] else "its own links"
        parts.append(f"{subject} starts {fmt_distance(deepest['depth'])} inside {into}")
    thrown: dict[str, float] = {}  # label: the highest peak's height, m
    for lab in labels:
        peak = _highest(events[lab])
        if peak is not None and peak["figures"]["rise"] >= THROW:
            thrown[lab] = peak["figures"]["height"]
    if thrown:
        heights = [
            f"{lab} throws it to a height of {fmt_distance(h)}"
            if k == 0
            else f"{lab} to {fmt_distance(h)}"
            for k, (lab, h) in enumerate(thrown.items())
        ]
        kept = [lab for lab in labels if lab not in thrown]
        throw = ", ".join(heights)
        if kept:
            throw += f" ({_names(kept)}: no throw of {fmt_distance(THROW)} or more)"
        parts.append(throw if parts else f"{subject} is thrown: {throw}")
    elif not parts:
        tipped: dict[str, float] = {}  # label: when it first tipped over, s
        for lab in labels:
            for x in events[lab].get("events", []):
                if x["kind"] == "tipped_over":
                    tipped[lab] = x["time"]
                    break
        over = list(tipped)
        if not over:
            return None
        when = ", ".join(f"{lab} at t = {fmt_time(t)}" for lab, t in tipped.items())
        upright = [lab for lab in labels if lab not in over]
        parts.append(
            f"{subject} tips over ({when})"
            + (f"; on {_names(upright)} it stays upright" if upright else "")
        )
    return ": ".join(parts) + "."
