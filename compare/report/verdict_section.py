"""``report.md``'s *Verdict* section of the first pair (:func:`verdict_section`): the judgement in
a table, each engine's spread, own error and their ratios to the gap, the test, the instants of
each kind, the horizons; from ``summary.json``'s ``verdict`` and ``ensemble`` alone. The verdict
in words is :func:`~.verdict.verdict_lines`'s."""

from __future__ import annotations

from typing import Any

from ..analysis.diff import QUANTITIES
from .engine_figures import p_words
from .fmt import fmt_threshold, fmt_time, fmt_value, table
from .verdict import one_run, perturbation_words, spread_ratio, verdict_word, within_words

__all__ = ["failed_members_lines", "verdict_section"]


def verdict_section(s: dict[str, Any], of: str = "") -> list[str]:
    """The judgement in a table: each engine's spread, own error and their ratios to the gap,
    the test, the instants of each kind, the horizons.

    Args:
        s: ``summary.json``'s dict, with a ``verdict``.
        of: what the title adds after *Verdict* (`` (pybullet and mujoco)`` where the report
            has more pairs; then the float32 offsets are said elsewhere).

    Returns:
        The section's lines.
    """
    v = s["verdict"]
    e = s.get("ensemble") or {}
    lines = [
        f"## Verdict{of}: {verdict_word(v)}",
        "",
    ]
    if e:
        lines += _ensemble_paragraph(v, e)
        raised = perturbation_words(e)
        if raised and not of:  # with more engines, said in *Every engine*
            lines += [raised, ""]
        lines += failed_members_lines(e)
    lines += _engines_table(v)
    lines += _gap_paragraphs(v)
    if v["marginal_reasons"]:
        lines += ["Marginal: " + "; ".join(v["marginal_reasons"]) + ".", ""]
    return lines


def _where(v: dict[str, Any]) -> str:
    """The instant judged: ``at the end`` or ``at t = 1.20 s (largest gap)``."""
    t = v["judged_at"]
    return "at the end" if t["why"] == "end" else f"at t = {fmt_time(t['time'])} (largest gap)"


def _bracketed(x: dict[str, Any], unit: str) -> str:
    """A figure with its interval in brackets where it has one."""
    if x.get("low") is None:
        return fmt_value(x["value"], unit)
    return (
        f"{fmt_value(x['value'], unit)} [{fmt_value(x['low'], unit)}, {fmt_value(x['high'], unit)}]"
    )


def _ensemble_paragraph(v: dict[str, Any], e: dict[str, Any]) -> list[str]:
    """How many runs each engine ran, how they were moved, and what each instant is judged
    against."""
    q = QUANTITIES[v["quantity"]]
    pert = e["perturbation"]
    runs = (
        "Each engine ran the scenario once (the nominal run: no offsets, no spread). The "
        if e["size"] < 2
        else f"Each engine ran the scenario {e['size']} times: the nominal run and "
        f"{e['size'] - 1} with every spawn pose moved by {pert['position']:g} m and turned "
        f"by {pert['orientation']:g} rad in random directions (seed {e['seed']}). The "
    )
    return [
        runs + f"{q.title} is judged at every one of {v['instants']['total']} recorded instants "
        f"against each engine's own spread (the {v['spread_percentile']:g}th percentile of "
        "the distances between its runs) and its own time-step error (dt against dt/2, the "
        "position gains sent as the same controller at dt/2: PyBullet's position law has "
        f"the step in it); figures below are {_where(v)}, with 95% bootstrap intervals in "
        "brackets.",
        "",
    ]


def failed_members_lines(e: dict[str, Any]) -> list[str]:
    """One line per engine whose ensemble members failed (killed their worker): how many, why,
    and on how many runs it was judged.

    Args:
        e: ``summary.json``'s ``ensemble``.

    Returns:
        A bold paragraph per such engine; empty when none failed.
    """
    lines = []
    for label, f in e.get("engines", {}).items():
        if "failed" in f:
            lines += [
                f"**{f['failed']['members']} of {e['size']} {label} runs failed: "
                f"{', '.join(f['failed']['causes'])}; judged on {f['failed']['judged_on']}.**",
                "",
            ]
    return lines


def _engines_table(v: dict[str, Any]) -> list[str]:
    """A row per engine: its runs, spread, farthest pair, own error, the gap's ratios to them
    and its horizons."""
    unit = v["unit"]
    rows = []
    for label, f in v["engine_figures"].items():
        hz = ", ".join(
            f"{fmt_threshold(h['threshold'], unit)}: {fmt_time(h['time'])}" for h in f["horizons"]
        )
        one = f["size"] < 2  # one run: no spread, no ratio to it
        rows.append(
            [
                label,
                str(f["size"]),
                "n/a (one run)" if one else _bracketed(f["spread"], unit),
                "n/a" if one else _bracketed(f["spread_end"], unit),
                "n/a" if one else fmt_value(f["largest_pair"], unit),
                f"{f['gap_over_spread']:.3g}" if spread_ratio(f, v["floor"]) else "n/a",
                fmt_value(f["own_error"], unit),
                f"{f['gap_over_own_error']:.3g}" if f["own_error"] > v["floor"] else "n/a",
                "n/a" if one else hz,
            ]
        )
    return table(
        [
            "engine",
            "runs",
            "spread",
            "spread at the end",
            "farthest pair",
            "gap / spread",
            "own error",
            "gap / own error",
            "spread first reaches",
        ],
        rows,
    )


def _test_words(test: dict[str, Any] | None) -> str:
    """The two-sample test's name and figures, or why it did not run."""
    if test is None:
        return "not run (the gap stays below the tolerance, or one run per engine)"
    return (
        f"{test['name']}: statistic {test['statistic']:.3g}, p = {test['p_value']:.3g} "
        f"({'every split' if test['exact'] else str(test['resamples']) + ' random splits'}"
        f"{_floor_words(test)}; alpha {test['alpha']:g})"
    )


def _gap_paragraphs(v: dict[str, Any]) -> list[str]:
    """The gap between the engines and the tolerance, the test, and how many instants fell
    in each kind."""
    unit = v["unit"]
    n = v["instants"]
    hi = v["marginal_range"][1]
    nominal = fmt_value(v["nominal_gap"], unit)
    return [
        "",
        (
            "Gap between the engines (one run each): "
            if one_run(v)
            else "Gap between the engines (median over every pair of runs, one of each engine): "
        )
        + f"{_bracketed(v['gap'], unit)}; the nominal runs' gap: {nominal}; largest "
        f"on the way {fmt_value(v['max_gap']['value'], unit)} at t = "
        f"{fmt_time(v['max_gap']['time'])}. Tolerance for `agree`: "
        f"{fmt_threshold(v['tolerance'], unit)}; precision floor {v['floor']:.2g} {unit}.",
        "",
        f"Two-sample test on the runs' states {_where(v)}: {_test_words(v['test'])}.",
        "",
        f"Instants: {n['agree']} below the tolerance, {n['chaotic']} at most {hi:g}x an "
        f"engine's spread, {n['unresolved']} at most {hi:g}x an engine's own time-step error "
        f"(and over {hi:g}x both spreads), {n['differ']} beyond every one of them (of "
        f"{n['total']}). "
        + (f"{within} " if (within := within_words(v)) else "")
        + f"A ratio between {v['marginal_range'][0]:g} and "
        f"{v['marginal_range'][1]:g} is near 1: the gap is not clearly larger, and the verdict "
        "says marginal.",
        "",
    ]


def _floor_words(test: dict[str, Any]) -> str:
    """``, the smallest p-value 3 and 3 runs can give`` where the exact test's p-value is its
    floor (:func:`~.engine_figures.p_words`), else empty."""
    words = p_words(test)
    if "(" not in words:
        return ""
    n, m = test["sizes"]
    return f", the smallest p-value {n} and {m} runs can give"
