"""``report.md``'s *Where the gap is born*: each engine's events, the one the gap parted after,
and the counts of each kind (:func:`born_section`), from ``summary.json``'s ``events`` and
``parting`` alone."""

from __future__ import annotations

from typing import Any

from ..analysis.diff import QUANTITIES
from ..run.events import KINDS
from .events import event_words, parting_words, with_start
from .fmt import fmt_threshold, fmt_time, table
from .pair_sections import parting_lines

__all__ = ["MAX_EVENT_ROWS", "born_section"]

MAX_EVENT_ROWS = 40
"""The most rows of the events table (those around the parting)."""

# kinds whose ``end`` is None while they last to the end of the run
_LASTING = ("airborne", "tipped_over", "contact_chatter", "joint_limit", "motor_saturated")


def born_section(s: dict[str, Any]) -> list[str]:
    """Each engine's events, the one the gap parted after, and the counts of each kind.

    Args:
        s: ``summary.json``'s dict.

    Returns:
        The section's lines; empty when the summary holds no events.
    """
    events = s.get("events")
    if not events:
        return []
    lines = ["## Where the gap is born", ""]
    lines += _parting_paragraphs(s)
    lines += _counts_table(s, events)
    lines += _events_table(s, events)
    return lines


def _many(s: dict[str, Any]) -> bool:
    """Whether the report speaks of more than one pair."""
    return len(s["labels"]) > 2 and len(s.get("pairs") or []) > 1


def _parting_paragraphs(s: dict[str, Any]) -> list[str]:
    """Where the gap parts and what was going on then; with more than one pair, a bullet per
    pair's parting first."""
    p = s.get("parting") or {}
    q = QUANTITIES[s["headline_quantity"]]
    many = _many(s)
    first = " and ".join(s["labels"][:2])
    lines: list[str] = []
    if many:  # every pair's parting, a bullet each; the events are every engine's
        lines += [
            f"Where each pair's {q.title} first comes "
            f"{fmt_threshold(q.thresholds[0], q.unit)} apart, and after what (each pair's "
            "figures: `summary.json` under `pairs[].parting`); the events below are every "
            "engine's.",
            "",
        ]
        lines += parting_lines(s) + [""]
    if p.get("time") is not None:
        if not many:
            lines += [
                f"The {q.title} first reaches {fmt_threshold(p['threshold'], q.unit)} at "
                f"t = {fmt_time(p['time'])}, {parting_words(p)}.",
                "",
            ]
        if p["ongoing"]:
            shown = [with_start(event_words(o, o["label"]), o["time"]) for o in p["ongoing"][:6]]
            more = len(p["ongoing"]) - len(shown)
            lines += [
                (f"Going on when {first} part: " if many else "Going on at that instant: ")
                + "; ".join(shown)
                + (f"; and {more} more" if more > 0 else "")
                + ".",
                "",
            ]
    elif not many:
        lines += [f"The {q.title} never reaches {fmt_threshold(q.thresholds[0], q.unit)}.", ""]
    return lines


def _counts_table(s: dict[str, Any], events: dict[str, Any]) -> list[str]:
    """Each engine's count of events of each kind, what it touches and which joints sit at a
    limit from the first step, and the note on how they are counted."""
    labels = list(events)
    rows = [
        [kind.replace("_", " ")] + [str(events[lab]["counts"][kind]) for lab in labels]
        for kind in KINDS
    ]
    rows.append(
        ["touching from the first step"]
        + [", ".join(events[lab]["initial_contacts"]) or "nothing" for lab in labels]
    )
    rows.append(
        ["at a joint limit from the start"]
        + [
            ", ".join(f"{x['joint']} ({x['side']})" for x in events[lab]["initial_limits"])
            or "none"
            for lab in labels
        ]
    )
    lines = table(["events of " + s["subject"]] + labels, rows)
    lines += [
        "",
        "Contacts are per link (with the other bodies touching anything at that instant); a "
        "contact or condition interrupted for less than 0.05 s counts as going on; tilt is "
        "measured from the spawn orientation, about the world's up (against gravity).",
        "",
    ]
    return lines


def _chosen_events(merged: list[tuple[Any, ...]], t: float | None) -> list[tuple[Any, ...]]:
    """At most :data:`MAX_EVENT_ROWS` of the time-ordered ``merged`` events: the first ones, or
    with a parting at ``t`` half before it and the rest after."""
    if len(merged) <= MAX_EVENT_ROWS:
        return merged
    if t is None:
        return merged[:MAX_EVENT_ROWS]
    before = [x for x in merged if x[0] <= t][-MAX_EVENT_ROWS // 2 :]
    after = [x for x in merged if x[0] > t]
    return before + after[: MAX_EVENT_ROWS - len(before)]


def _events_table(s: dict[str, Any], events: dict[str, Any]) -> list[str]:
    """Every engine's events in time order (those around the parting where there are many),
    the one the gap parts after in bold."""
    labels = list(events)
    p = s.get("parting") or {}
    merged = sorted(
        ((e["time"], k, lab, e) for k, lab in enumerate(labels) for e in events[lab]["events"]),
        key=lambda x: (x[0], x[1]),
    )
    if not merged:
        return []
    chosen = _chosen_events(merged, p.get("time"))
    rows = [_event_row(s, p, time, lab, e) for time, _, lab, e in chosen]
    total = sum(events[lab]["total"] for lab in labels)
    lines = table(["t", "phase", "engine", "event", "until"], rows)
    lines += [""]
    if len(chosen) < total:
        lines += [
            f"{len(chosen)} of {total} events shown (those around the parting); every one "
            "is in `summary.json` under `events`.",
            "",
        ]
    return lines


def _event_row(
    s: dict[str, Any], p: dict[str, Any], time: float, lab: str, e: dict[str, Any]
) -> list[str]:
    """One event's row: when, in which phase, whose, what (in bold where the gap parts after
    it), until when."""
    words = event_words(e, lab)
    mark = p.get("event")
    if mark and mark["label"] == lab and {**e, "label": lab} == mark:
        whose = f" between {' and '.join(s['labels'][:2])}" if _many(s) else ""
        words = f"**{words}** (the gap{whose} parts {p['relation']} this)"
    until = (
        ""
        if e["end"] is None and e["kind"] not in _LASTING
        else ("the end" if e["end"] is None else fmt_time(e["end"]))
    )
    return [fmt_time(time), e["phase"], lab, words, until]
