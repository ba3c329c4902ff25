"""``report.md``'s sections with more than two engines: the pair table (:func:`pairs_section`),
and over time, per phase and per part a row for every pair of engines
(:func:`crossings_section`, :func:`phases_section`, :func:`parts_section`,
:func:`parting_lines`), from ``summary.json``'s ``pairs`` alone
(``pairs[].cross``, ``pairs[].parts``, ``pairs[].parting``). Two engines keep their sections in
:mod:`.gap_sections`, one pair and no pair column."""

from __future__ import annotations

from typing import Any

from ..analysis.diff import QUANTITIES
from .events import parting_words
from .fmt import fmt_threshold, fmt_time, fmt_value, table
from .parts import parts_words
from .verdict import interval_cell, verdict_word

# the notes under the crossings and the parts tables, one pair or many (markdown.py too)
CROSSINGS_NOTE = (
    "A threshold is crossed at the first recorded step whose value reaches it. Joint RMS "
    "is over the subject's movable joints (angles unwrapped: a wheel a turn ahead counts "
    "2π). Heading is meaningful while the robot is upright."
)
PARTS_NOTE = (
    "A joint's gap is the difference of its positions (angles unwrapped), a link's the "
    "distance between its centres of mass; parts that come apart rank first, earliest "
    "first, then the rest by their largest gap over the threshold."
)

__all__ = [
    "MAX_PART_ROWS",
    "pair_name",
    "pairs_section",
    "crossings_section",
    "phases_section",
    "parts_section",
    "parting_lines",
]

MAX_PART_ROWS = 15
"""The most rows of the parts table over every pair (at least 3 per pair)."""


def pair_name(p: dict[str, Any]) -> str:
    """``pybullet and mujoco``: a pair as the pair table and :func:`~.verdict.pair_words` name
    it."""
    a, b = p["labels"]
    return f"{a} and {b}"


def pairs_section(s: dict[str, Any]) -> list[str]:
    """With more than two engines, the pair table: one row per pair with its verdict, its judged
    gap and interval, its nominal runs' gap at the end, where that gap is born and the test's
    p-value.

    Args:
        s: ``summary.json``'s dict.

    Returns:
        The section's lines; empty with two engines.
    """
    pairs = s.get("pairs") or []
    labels = s["labels"]
    if len(labels) <= 2 or not pairs:
        return []
    unit = s["headline"]["unit"]
    rows = [_pair_row(p, unit) for p in pairs]
    lines = ["## Every pair of engines", ""]
    lines += [
        f"Each pair is judged as the first pair below is, on the {s['headline']['title']}: the "
        "judged gap is the median over every pair of runs (one of each engine) at the judged "
        "instant, with its 95% bootstrap interval; the nominal gap is that of the runs with no "
        "offset at the end; the p-value is the two-sample test's, where it ran. Every figure is "
        "in `summary.json` under `pairs`.",
        "",
    ]
    lines += table(
        [
            "pair",
            "verdict",
            "judged gap [95%] (when)",
            "nominal gap (end)",
            "where the nominal gap is born",
            "p",
        ],
        rows,
    )
    lines += [""]
    return lines


def _pair_row(p: dict[str, Any], unit: str) -> list[str]:
    """One pair's row of the pair table (``p``: an entry of ``summary.json``'s ``pairs``)."""
    a, b = p["labels"]
    v = p["verdict"]
    if v:
        t = v["judged_at"]
        when = "end" if t["why"] == "end" else f"t = {fmt_time(t['time'])}"
        judged = f"{interval_cell(v['gap'], unit)} ({when})"
    thr = p["headline"]["crossings"][0]
    if thr["time"] is None:
        born = f"never {fmt_threshold(thr['threshold'], unit)} apart"
    else:
        born = f"t = {fmt_time(thr['time'])} ({fmt_threshold(thr['threshold'], unit)})"
        words = parting_words(p.get("parting") or {})
        born += f", {words}" if words else ""
    return [
        f"{a} and {b}",
        verdict_word(v) if v else "not judged",
        judged if v else "n/a",
        fmt_value(p["headline"]["final"], unit),
        born,
        "n/a" if not v or v["test"] is None else f"{v['test']['p_value']:.2g}",
    ]


def _quantities(pairs: list[dict[str, Any]]) -> list[str]:
    """The quantities every pair's diff holds, in :data:`QUANTITIES` order."""
    held = set.intersection(*(set(p["cross"]["final"]) for p in pairs))
    return [k for k in QUANTITIES if k in held]


def crossings_section(s: dict[str, Any]) -> list[str]:
    """*When each quantity parts*: per quantity, a row per pair of engines (their nominal runs):
    the first instant each threshold is reached, the gap at the end and the largest."""
    pairs = s["pairs"]
    rows = []
    for key in _quantities(pairs):
        q = QUANTITIES[key]
        for p in pairs:
            cross = p["cross"]
            when = {c["threshold"]: c["time"] for c in cross["crossings"][key]}
            cells = [q.title, pair_name(p)]
            cells += [
                f"{fmt_threshold(thr, q.unit)}: {fmt_time(when[thr])}" for thr in q.thresholds
            ]
            cells += [""] * (3 - len(q.thresholds))
            cells += [fmt_value(cross["final"][key], q.unit), fmt_value(cross["max"][key], q.unit)]
            rows.append(cells)
    lines = ["## When each quantity parts", ""]
    lines += [
        f"Every pair of the {len(s['labels'])} engines (their nominal runs, no offset), a row "
        "each under every quantity; each pair's figures are in `summary.json` under "
        "`pairs[].cross`.",
        "",
    ]
    lines += table(["quantity", "pair", "first crossing", "", "", "at the end", "largest"], rows)
    lines += [
        "",
        CROSSINGS_NOTE,
        "",
    ]
    return lines


def phases_section(s: dict[str, Any]) -> list[str]:
    """*Per phase*: per phase, a row per pair of engines: every quantity at the phase's end
    and its largest in the phase."""
    pairs = s["pairs"]
    keys = _quantities(pairs)
    rows = []
    for k in range(max(len(p["cross"]["phases"]) for p in pairs)):
        for p in pairs:
            phases = p["cross"]["phases"]
            if k >= len(phases):  # a pair whose runs end sooner: the phases it reached
                continue
            ph = phases[k]
            rows.append(
                [ph["name"], pair_name(p), f"{ph['start']:.3f} – {ph['end']:.3f} s"]
                + [
                    f"{fmt_value(ph['at_end'][key], QUANTITIES[key].unit)} "
                    f"(max {fmt_value(ph['max'][key], QUANTITIES[key].unit)})"
                    for key in keys
                ]
            )
    lines = ["## Per phase", ""]
    lines += [
        "A row per pair of engines in every phase (their nominal runs); each pair's figures are "
        "in `summary.json` under `pairs[].cross.phases`.",
        "",
    ]
    lines += table(
        ["phase", "pair", "time"] + [QUANTITIES[k].title + " at end" for k in keys], rows
    )
    lines += [""]
    return lines


def _lower_first(text: str) -> str:
    return text[:1].lower() + text[1:]


def parts_section(s: dict[str, Any]) -> list[str]:
    """*Which part parts first*: per pair of engines, a line in words and its first parts in
    one table (at most :data:`MAX_PART_ROWS` rows over every pair, at least 3 each); empty when
    no pair carries per-part gaps."""
    pairs = [p for p in s["pairs"] if p.get("parts")]
    if not pairs:
        return []
    each = max(3, MAX_PART_ROWS // len(pairs))
    lines = ["## Which part parts first", ""]
    lines += [f"- {pair_name(p)}: {_lower_first(parts_words(p['parts']))}" for p in pairs]
    lines += [""]
    rows = []
    for p in pairs:
        for k, part in enumerate(p["parts"][:each]):
            rows.append(
                [
                    pair_name(p),
                    str(k + 1),
                    f"{part['kind']} `{part['name']}`",
                    f"{fmt_threshold(part['threshold'], part['unit'])}: {fmt_time(part['first'])}",
                    f"{fmt_value(part['largest'], part['unit'])} at {fmt_time(part['largest_at'])}",
                    fmt_value(part["at_end"], part["unit"]),
                ]
            )
    lines += table(["pair", "rank", "part", "apart by", "largest gap", "at the end"], rows)
    lines += [
        "",
        PARTS_NOTE,
        "",
    ]
    total = len(pairs[0]["parts"])
    if any(len(p["parts"]) > each for p in pairs):
        lines += [
            f"The first {each} of {total} shown per pair; all in `summary.json` under "
            "`pairs[].parts`.",
            "",
        ]
    return lines


def parting_lines(s: dict[str, Any]) -> list[str]:
    """Where each pair's gap is born, a bullet each (one statement: the bullets are one
    paragraph): when the headline quantity first reaches its threshold and the event it follows;
    empty without pairs."""
    q = QUANTITIES[s["headline_quantity"]]
    lines = []
    for p in s.get("pairs") or []:
        parting = p.get("parting") or {}
        if parting.get("time") is None:
            words = f"never {fmt_threshold(q.thresholds[0], q.unit)} apart"
        else:
            words = (
                f"{fmt_threshold(parting['threshold'], q.unit)} apart at "
                f"t = {fmt_time(parting['time'])}, {parting_words(parting)}"
            )
        lines.append(f"- {pair_name(p)}: {words}.")
    return lines
