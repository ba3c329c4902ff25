"""The first screen of ``report.html`` and the folding of the rest (:mod:`.html` assembles the
page): the verdict of every pair in a line each (:func:`verdict_lines_html`), over the 3D replay;
report.md's sections after it, each a ``<details>`` a reader opens and folds
(:func:`fold_sections`)."""

from __future__ import annotations

import html
import re
from typing import Any

from .fmt import fmt_value
from .verdict import interval_cell, one_run, verdict_word

__all__ = ["fold_sections", "verdict_lines_html"]


def _pairs(summary: dict[str, Any]) -> list[dict[str, Any]]:
    """Every judged pair of ``summary.json``'s dict, in its order: its ``pairs`` where there are
    some, else the headline pair alone (its ``verdict`` and ``headline``)."""
    pairs = summary.get("pairs") or []
    if pairs:
        return list(pairs)
    return [
        {
            "labels": list(summary["labels"][:2]),
            "verdict": summary.get("verdict"),
            "headline": summary["headline"],
        }
    ]


def _pair_line(p: dict[str, Any], colours: dict[str, str]) -> str:
    """One pair's ``<li>``: both engines' legend swatches, their names, the verdict word and the
    judged gap with its interval (or the nominal runs' gap where no ensemble judged it)."""
    a, b = p["labels"]
    swatches = "".join(
        f'<span class="swatch" style="background:{colours[x]}"></span>'
        for x in (a, b)
        if x in colours
    )
    v = p.get("verdict")
    names = f"{html.escape(a)} and {html.escape(b)}"
    if not v:
        gap = fmt_value(p["headline"]["final"], p["headline"]["unit"])
        return (
            f'<li>{swatches}<b>{names}</b>: <span class="word">not judged</span> '
            f"(no ensemble); the nominal runs end {html.escape(gap)} apart</li>"
        )
    t = v["judged_at"]
    when = "at the end" if t["why"] == "end" else f"at t = {t['time']:.3f} s"
    what = "the gap" if one_run(v) else "a median gap"
    gap = interval_cell(v["gap"], v["unit"])
    return (
        f'<li data-verdict="{html.escape(v["verdict"])}">{swatches}<b>{names}</b>: '
        f'<span class="word">{html.escape(verdict_word(v))}</span>, '
        f"{what} of {html.escape(gap)} {when}</li>"
    )


def verdict_lines_html(summary: dict[str, Any], colours: dict[str, str]) -> str:
    """The verdict of every pair, one line each, for the top of the page.

    Args:
        summary: ``summary.json``'s dict.
        colours: each engine's legend colour by label (``#rrggbb``), as in the figures and the
            replay; an engine missing from it gets no swatch.

    Returns:
        A ``<section id="verdicts">`` with one ``<li>`` per pair (``data-verdict`` the verdict:
        ``agree``, ``differ``, ``chaotic``, ``unresolved``) and what was judged, in words.
    """
    head = summary["headline"]
    runs = (summary.get("ensemble") or {}).get("size")
    per = f", {runs} runs per engine" if isinstance(runs, int) and runs > 1 else ""
    pairs = _pairs(summary)
    rows = "".join(_pair_line(p, colours) for p in pairs)
    gaps = [(p.get("verdict") or {}).get("gap") or {} for p in pairs]
    brackets = ", 95% intervals in brackets" if any(g.get("low") is not None for g in gaps) else ""
    return (
        '<section id="verdicts"><ul>'
        f"{rows}</ul>"
        f'<p class="note">Judged on the {html.escape(head["title"])}{per}{brackets}; the '
        "sections below say why.</p></section>"
    )


_H2 = re.compile(r"<h2>(.*?)</h2>\n?", re.S)


def fold_sections(body: str, *, opened: int = 0) -> tuple[str, str, str]:
    """Split report.md's HTML at its headings: the title, the opening statements, and every
    ``##`` section wrapped in a ``<details>`` whose ``<summary>`` is its heading.

    Args:
        body: report.md rendered to HTML (headings as ``<h1>``/``<h2>``, nothing else raw).
        opened: how many of the first sections start unfolded.

    Returns:
        ``(title, opening, sections)``: the ``<h1>`` element (empty if none), what comes between
        it and the first ``<h2>``, and the sections, each ``<details class="section">``.
    """
    title = ""
    m = re.match(r"\s*(<h1>.*?</h1>)\n?", body, re.S)
    if m:
        title, body = m.group(1), body[m.end() :]
    heads = list(_H2.finditer(body))
    if not heads:
        return title, body, ""
    opening = body[: heads[0].start()]
    parts = []
    for k, h in enumerate(heads):
        end = heads[k + 1].start() if k + 1 < len(heads) else len(body)
        flag = " open" if k < opened else ""
        parts.append(
            f'<details class="section"{flag}><summary><h2>{h.group(1)}</h2></summary>\n'
            f"{body[h.end() : end]}</details>\n"
        )
    return title, opening, "".join(parts)
