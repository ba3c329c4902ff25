"""``report.md``'s opening statements in words, from ``summary.json``'s figures alone
(:func:`headline`): the scenario's outcomes, the verdict, then how far apart the nominal runs
end, when they part, which quantity goes first, and what halving the time step changes in each
engine; with more than two engines every pair's verdict, a bullet each (:func:`pairs_lines`)."""

from __future__ import annotations

from typing import Any

from ..analysis.diff import QUANTITIES
from .events import parting_words
from .fmt import fmt_threshold, fmt_time, fmt_value
from .outcomes import outcome_lines
from .parts import parts_words
from .resync import resync_lines
from .story import story_words
from .verdict import pair_words, perturbation_words, verdict_lines

__all__ = ["first_pair_lines", "headline", "left_out_words", "pairs_lines"]


def headline(summary: dict[str, Any]) -> list[str]:
    """The report's opening statements (one paragraph each, or one bullet), from
    ``summary.json``'s figures alone. Two engines: the scenario's outcomes, the verdict
    (:func:`~simbridge.compare.verdict.verdict_lines`), then the nominal runs' figures. More:
    the outcomes, then every pair's verdict with its judged gap, one bullet each; the first
    pair's figures follow in their own section (:func:`first_pair_lines`).

    Args:
        summary: ``summary.json``'s dict.

    Returns:
        The statements, in order.
    """
    lines: list[str] = outcome_lines(summary)  # what the scenario calls success, first
    story = story_words(summary)  # what happens to the robot, after the verdict
    if len(summary["labels"]) > 2 and len(summary.get("pairs") or []) > 1:
        lines += pairs_lines(summary) + ([story] if story else [])
    else:
        lines += first_pair_lines(summary, story=story)
    raised = perturbation_words(summary.get("ensemble"))  # a float32 engine's own offsets
    if raised:
        lines.append(raised)
    return lines


def first_pair_lines(summary: dict[str, Any], story: str | None = None) -> list[str]:
    """The first pair's verdict in words (then ``story``, where given: what happens to the
    robot) and its nominal runs' figures: when they part, which quantity goes first, what
    halving the time step changes, the one-step error.

    Args:
        summary: ``summary.json``'s dict.
        story: what happens to the robot, in words, said after the verdict; None says nothing.

    Returns:
        The statements, one paragraph each.
    """
    lines: list[str] = []
    if summary.get("verdict"):
        lines += verdict_lines(summary)
    if story:
        lines.append(story)
    lines.append(_apart_line(summary))
    lines.append(_parting_line(summary))
    lines.append(_first_quantity_line(summary["headline"]["first_to_diverge"]))
    if summary.get("parts"):
        lines.append(parts_words(summary["parts"]))
    lines.append(_own_error_line(summary["headline"]))
    lines += resync_lines(summary)  # one step from the same state: the model error
    return lines


def _apart_line(summary: dict[str, Any]) -> str:
    """How far apart the first pair's nominal runs end, after how long, and their largest gap."""
    h = summary["headline"]
    unit = h["unit"]
    subject = summary["subject"]
    a, b = summary["labels"][:2]
    if h["quantity"] == "base_distance":
        apart = f"{fmt_value(h['final'], unit)} apart ({subject}'s base position"
    elif h["quantity"] == "link_distance":
        apart = (
            f"{fmt_value(h['final'], unit)} apart ({subject}'s links' centres of mass, the "
            "farthest pair"
        )
    else:
        apart = f"{fmt_value(h['final'], unit)} apart (the {h['title']} of {subject}"
    many = len(summary["labels"]) > 2
    runs = f"The nominal runs of {a} and {b}" if many else "The nominal runs"
    return (
        f"{runs} (no offset) end {apart}, after {summary['duration']:.3g} s of "
        f"simulated time at dt = {summary['timestep_text']} s; the largest gap on the way was "
        f"{fmt_value(h['max'], unit)})."
    )


def _parting_line(summary: dict[str, Any]) -> str:
    """When the nominal runs first cross each threshold, then where the gap is born."""
    h = summary["headline"]
    unit = h["unit"]
    crossings = [(c["threshold"], c["time"]) for c in h["crossings"]]
    (t1, c1), (t2, c2) = crossings[0], crossings[1]
    if c1 is None:
        line = f"They never come {fmt_threshold(t1, unit)} apart."
    elif c2 is None:
        line = (
            f"They part at t = {fmt_time(c1)} (first {fmt_threshold(t1, unit)} apart) and never "
            f"reach {fmt_threshold(t2, unit)}."
        )
    else:
        more = ""
        if len(crossings) > 2 and crossings[2][1] is not None:
            more = f", {fmt_threshold(crossings[2][0], unit)} from t = {fmt_time(crossings[2][1])}"
        line = (
            f"They part at t = {fmt_time(c1)} (first {fmt_threshold(t1, unit)} apart) and are "
            f"{fmt_threshold(t2, unit)} apart from t = {fmt_time(c2)}{more}."
        )
    born = parting_words(summary.get("parting") or {})
    if born:
        line += f" The gap is born {born}."
    return line


def _first_quantity_line(first: dict[str, Any] | None) -> str:
    """The first quantity to reach its first threshold (``headline.first_to_diverge``)."""
    if first is None:
        return "No quantity reaches its first threshold (1 cm, 1°, 0.1 rad/s)."
    qq = QUANTITIES[first["quantity"]]
    return (
        f"The first quantity to diverge is the {qq.title}: it reaches "
        f"{fmt_threshold(first['threshold'], qq.unit)} at t = {fmt_time(first['time'])}."
    )


def _own_error_line(h: dict[str, Any]) -> str:
    """What halving the time step moves each engine's end by (``headline.own_error``)."""
    own = h["own_error"]
    unit = h["unit"]
    parts = [f"moves {label}'s end by {fmt_value(e['final'], unit)}" for label, e in own.items()]
    return "Halving the time step " + "; it ".join(parts) + "."


def left_out_words(summary: dict[str, Any]) -> str | None:
    """With the backends chosen by default: the registered engines left out and why, in one
    sentence.

    Args:
        summary: ``summary.json``'s dict.

    Returns:
        The sentence; None when none was left out (or the backends were named).
    """
    left = summary.get("left_out") or {}
    if not left:
        return None
    why = "; ".join(f"{name} ({reason})" for name, reason in left.items())
    return f"Registered engines left out, not installed here: {why}."


def pairs_lines(summary: dict[str, Any]) -> list[str]:
    """With more than two engines, every pair's verdict with its judged gap: a lead and one
    bullet per pair (:func:`~.verdict.pair_words`).

    Args:
        summary: ``summary.json``'s dict.

    Returns:
        The lead and the bullets; empty with two engines.
    """
    pairs = summary.get("pairs") or []
    if len(summary["labels"]) <= 2 or not pairs:
        return []
    ens = summary.get("ensemble") or {}
    gap = "the gap of the one run per engine, no interval"  # --ensemble 1
    if ens.get("size", 1) > 1:
        gap = (
            f"the median gap over every pair of runs, {ens['size']} per engine, with its 95% "
            "interval"
        )
    return [
        f"Every pair of the {len(summary['labels'])} engines, judged on the "
        f"{summary['headline']['title']} ({gap}; the table below has each pair's nominal gap "
        "and where it is born):"
    ] + [f"- {pair_words(p)}." for p in pairs]
