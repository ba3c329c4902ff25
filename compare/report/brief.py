"""The terminal's headline (:func:`brief`): the verdict, the key figures and the report's path in
at most :data:`MAX_LINES` lines, from ``summary.json``'s dict alone. The paragraphs stay in
``report.md`` (:func:`~simbridge.compare.report.markdown.headline`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .fmt import fmt_threshold, fmt_time, fmt_value
from .markdown import left_out_words
from .outcomes import outcome_lines

__all__ = ["brief", "MAX_LINES"]

MAX_LINES = 6
"""The most lines :func:`brief` prints."""


def brief(s: dict[str, Any], path: str | Path | None = None) -> list[str]:
    """The verdict (line 1), how far apart the nominal runs end and when they part (line 2),
    the scenario's outcomes, the other pairs and the engines left out (a line each, where
    there are any), and ``report: <path>`` last (with ``path``)."""
    unit = s["headline"]["unit"]
    lines = [_verdict(s), _figures(s)]
    outcomes = [x.replace("**", "") for x in outcome_lines(s)]
    if outcomes:
        lines.append(" ".join(outcomes))
    pairs = s.get("pairs") or []
    if len(s["labels"]) > 2 and len(pairs) > 1:
        words = []
        for p in pairs[1:]:
            v = p["verdict"]
            what = v["verdict"] if v else "not judged"
            words.append(
                f"{' and '.join(p['labels'])} {what}, {fmt_value(p['headline']['final'], unit)}"
            )
        lines.append("Other pairs: " + "; ".join(words) + ".")
    left = left_out_words(s)
    if left:
        lines.append(left)
    if path is not None:
        lines.append(f"report: {path}")
    return lines[: MAX_LINES - 1] + lines[-1:] if len(lines) > MAX_LINES else lines


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
    marginal = " (marginal)" if v["marginal"] else ""
    kind = v["verdict"]
    if kind == "agree":
        return (
            head + f"AGREE{marginal}, the gap below {fmt_threshold(v['tolerance'], unit)} all "
            f"along (largest {fmt_value(v['max_gap']['value'], unit)})."
        )
    if kind == "chaotic":
        who = " and ".join(v["engines"])
        spread = fmt_value(figs[v["engines"][0]]["spread"]["value"], unit)
        return (
            head + f"CHAOTIC ({who}){marginal}: runs {gap} apart {when}, within {who}'s own "
            f"spread ({spread}); the gap says nothing about the physics."
        )
    if kind == "differ":
        t = v["test"]
        return (
            head + f"DIFFER{marginal}: runs {gap} apart {when}, beyond each engine's spread and "
            f"own time-step error (p = {t['p_value']:.2g})."
        )
    reason = v["reason"]
    if reason == "within own time-step error":
        who = " and ".join(v["engines"])
        errs = ", ".join(f"{fmt_value(figs[x]['own_error'], unit)}" for x in v["engines"])
        why = f"within {who}'s own time-step error ({errs}); rerun with a smaller --timestep"
    elif reason == "single run":
        why = "one run per engine cannot tell chaos from a difference; rerun with --ensemble 8"
    else:
        why = "the runs are not told apart; a larger --ensemble may"
    return head + f"UNRESOLVED{marginal}: runs {gap} apart {when}, {why}."


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
