"""Events in words: one event (:func:`event_words`), the instant the gap parts
(:func:`parting_words`), from ``summary.json``'s dicts alone."""

from __future__ import annotations

from typing import Any

from ..run.events import TIP_ANGLE
from ..run.quantities import DEG
from .fmt import fmt_distance, fmt_time

__all__ = ["event_words", "parting_words", "with_start"]


def event_words(e: dict[str, Any], label: str) -> str:
    """An event's dict (as ``summary.json`` holds it:
    :func:`~simbridge.compare.report.summary_json.event_dict`) in words."""
    who = f"{label}'s {e['body']}"
    others = " and ".join(e["others"]) if e["others"] else "another of its own links"
    f = e["figures"]
    kind = e["kind"]
    if kind == "contact_made":
        return f"{who} touched {others} with {e['part']}"
    if kind == "contact_lost":
        return f"{who} lost contact with {others} at {e['part']}"
    if kind == "contact_chatter":
        return (
            f"{who}'s {e['part']} chattered on {others} (lost and regained contact "
            f"{f['losses']:.0f} times in {f['duration']:.3g} s)"
        )
    if kind == "airborne" and f.get("from_start"):
        return f"{who} starts in the air (falls for {f['duration']:.3g} s before touching down)"
    if kind == "airborne":
        return f"{who} left the ground (airborne for {f['duration']:.3g} s)"
    if kind == "peak_height":
        return (
            f"{who} peaked at a height of {fmt_distance(f['height'])} "
            f"({fmt_distance(f['rise'])} above "
            + ("its spawn height)" if f.get("from_start") else "where it left the ground)")
        )
    if kind == "tipped_over":
        return (
            f"{who} tipped over (more than {TIP_ANGLE / DEG:g}° from its spawn orientation, "
            f"up to {f['tilt'] / DEG:.0f}°)"
        )
    if kind == "joint_limit":
        return f"{who} reached the {e['side']} limit of {e['part']} ({f['limit']:.4g})"
    if kind == "motor_saturated":
        return f"{who}'s {e['part']} motor saturated at its max_force {f['max_force']:g}"
    return f"{who}: {kind}"


def with_start(words: str, time: float) -> str:
    """``words`` with ``from t = ...`` in its closing parenthesis (or a new one)."""
    start = f"from t = {fmt_time(time)}"
    return words[:-1] + f", {start})" if words.endswith(")") else f"{words} ({start})"


def parting_words(p: dict[str, Any]) -> str:
    """``during 'turn', 0.021 s after pybullet's r2d2 lost contact with plane at
    right_back_wheel`` (empty when they never part)."""
    if p.get("time") is None:
        return ""
    words = f"during '{p['phase']}'" if p.get("phase") else ""
    e = p.get("event")
    sep = ", " if words else ""
    if e is None:
        touching = p.get("initial_contacts") or {}
        if not touching:
            return words + sep + "before any event of either engine"
        links = sorted({k for v in touching.values() for k in v})
        shown = ", ".join(links[:4]) + (f" and {len(links) - 4} more" if len(links) > 4 else "")
        first = p["time"] <= p.get("step", 0.0) + 1e-12
        return (
            words
            + sep
            + ("in the first step" if first else "before any event")
            + f", with {p.get('body') or 'the robot'} touching something from its first step at "
            + f"{shown} ({' and '.join(touching)})"
        )
    what = event_words(e, e["label"])
    if p["relation"] == "during":
        return words + sep + f"while {with_start(what, e['time'])}"
    since = p["since"]
    step = float(p.get("step") or 0.0)
    if since > 0:
        when = f"{fmt_time(since)} after"
    elif step > 0 and since <= -step * (1 - 1e-6):  # the event is stamped a step after it parts
        when = f"{fmt_time(-since)} before"
    else:
        when = "in the same step as"
    return words + sep + f"{when} {what}"
