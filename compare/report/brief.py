"""The terminal's headline (:func:`brief`): the verdict, the key figures and the report's path in
at most :data:`MAX_LINES` lines, from ``summary.json``'s dict alone. The paragraphs stay in
``report.md`` (:func:`~simbridge.compare.report.markdown.headline`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..analysis.verdict import OWN_ERROR_REASONS
from .fmt import fmt_threshold, fmt_time, fmt_value
from .markdown import left_out_words
from .outcomes import outcome_brief
from .story import story_words
from .verdict import (
    against_words,
    marginal_note,
    own_error_words,
    pair_words,
    time_step_share,
    verdict_word,
)

__all__ = ["brief", "MAX_LINES"]

MAX_LINES = 6
"""The most lines :func:`brief` prints."""


def brief(s: dict[str, Any], path: str | Path | None = None) -> list[str]:
    """The scenario's outcomes first (one line, where it declares any: what it calls success),
    then the verdict: with two engines, the verdict (a line) and how far apart the nominal runs
    end and when they part (a line); with more, a line naming the engines and one line per pair,
    each with the same judged figure (:func:`~.verdict.pair_words`). Then what happens to the
    robot (a line, where its events tell a story, :func:`~.story.story_words`, and a line is
    left for it), the engines left out (a line, where there are any) and ``report: <path>``
    last (with ``path``)."""
    lines: list[str] = []
    outcomes = outcome_brief(s)  # bounded; the figures in report.md's Outcomes
    if outcomes:
        lines.append(outcomes)
    left = left_out_words(s)
    pairs = s.get("pairs") or []
    if len(s["labels"]) > 2 and len(pairs) > 1:
        room = MAX_LINES - len(lines) - 1 - (path is not None)  # for the pairs first
        head = _pairs_head(s)
        if left and room - len(pairs) < 1:  # no line left for it: named in the head
            head += f" ({', '.join(s['left_out'])} left out: report.md)"
            left = None
        elif left:
            room -= 1
        lines.append(head)
        shown = pairs if len(pairs) <= room else pairs[: max(room - 1, 1)]
        lines += ["  " + pair_words(p, loud=True) + "." for p in shown]
        if len(shown) < len(pairs):
            lines.append(f"  and {len(pairs) - len(shown)} more pairs: report.md.")
    else:
        lines += [_verdict(s), _figures(s)]
    story = story_words(s)
    if story and len(lines) + 1 + bool(left) + (path is not None) <= MAX_LINES:
        lines.append(story)
    if left:
        lines.append(left)
    if path is not None:
        lines.append(f"report: {path}")
    return lines[: MAX_LINES - 1] + lines[-1:] if len(lines) > MAX_LINES else lines


def _pairs_head(s: dict[str, Any]) -> str:
    """``r2d2 on pybullet, mujoco and physx, every pair judged on the base position (median gap
    over every pair of runs, 4 per engine, 95% interval):``"""
    labels = s["labels"]
    names = ", ".join(labels[:-1]) + f" and {labels[-1]}"
    head = f"{s['scenario']} on {names}"
    if not any(p["verdict"] for p in s["pairs"]):
        return head + " (one run per engine: no pair judged, the nominal runs' gaps):"
    size = (s.get("ensemble") or {}).get("size") or 1
    if size < 2:  # one run per engine: one gap, no interval
        return f"{head}, every pair judged on the {s['headline']['title']} (one run per engine):"
    return (
        f"{head}, every pair judged on the {s['headline']['title']} "
        f"(median gap over every pair of runs, {size} per engine, 95% interval):"
    )


def _verdict(s: dict[str, Any]) -> str:
    """``r2d2, pybullet against mujoco: unresolved ...`` in one sentence."""
    a, b = s["labels"][:2]
    head = f"{s['scenario']}, {a} against {b}: "
    v = s.get("verdict")
    if not v:
        return head + "not judged (no ensemble)."
    unit = v["unit"]
    figs = v["engine_figures"]
    gap = fmt_value(v["gap"]["value"], unit)
    if max(f["size"] for f in figs.values()) > 1:
        gap = f"a median {gap}"
    when = (
        "at the end"
        if v["judged_at"]["why"] == "end"
        else (f"at t = {fmt_time(v['judged_at']['time'])}")
    )
    word = verdict_word(v)  # report.md's words: "chaotic (pybullet; marginal)"
    word = v["verdict"].upper() + word[len(v["verdict"]) :]
    if v["marginal"]:  # what marginal means, where it is said
        word = word[: word.rindex("marginal")] + marginal_note(v) + ")"
    kind = v["verdict"]
    if kind == "agree":
        return (
            head + f"{word}, the gap below {fmt_threshold(v['tolerance'], unit)} all "
            f"along (largest {fmt_value(v['max_gap']['value'], unit)})."
        )
    if kind == "chaotic":
        share = time_step_share(v)
        against = " and ".join(
            against_words(figs[lab]["gap_over_spread"], f"{lab}'s own spread")
            + f" ({fmt_value(figs[lab]['spread']['value'], unit)})"
            for lab in v["engines"]
        )
        return (
            head
            + f"{word}: runs {gap} apart {when}, {against}; "
            + (f"{share}: at this time step " if share else "")
            + "the gap says nothing about the physics."
        )
    if kind == "differ":
        t = v["test"]
        return (
            head + f"{word}: runs {gap} apart {when}, beyond each engine's spread and "
            f"own time-step error (p = {t['p_value']:.2g})."
        )
    reason = v["reason"]
    if reason in OWN_ERROR_REASONS:
        why = f"{own_error_words(v)}; rerun with a smaller --timestep"
    elif reason == "single run":
        why = "one run per engine cannot tell chaos from a difference; rerun with --ensemble 8"
    else:
        why = "the runs are not told apart; a larger --ensemble may"
    return head + f"{word}: runs {gap} apart {when}, {why}."


def _figures(s: dict[str, Any]) -> str:
    """``Nominal runs end 1.57 m apart (largest 13.89 m); 1 cm apart at t = 0.004 s, 1 m at
    t = 0.067 s.``"""
    h = s["headline"]
    unit = h["unit"]
    line = (
        f"Nominal runs end {fmt_value(h['final'], unit)} apart ({h['title']}, largest "
        f"{fmt_value(h['max'], unit)}) after {s['duration']:.3g} s at dt = {s['timestep_text']} s"
    )
    reached = [(c["threshold"], c["time"]) for c in h["crossings"] if c["time"] is not None]
    if not reached:
        first = h["crossings"][0]["threshold"]
        return line + f"; never {fmt_threshold(first, unit)} apart."
    shown = [reached[0]] + ([reached[-1]] if len(reached) > 1 else [])
    return (
        line
        + "; "
        + ", ".join(f"{fmt_threshold(t, unit)} apart at t = {fmt_time(c)}" for t, c in shown)
        + "."
    )
