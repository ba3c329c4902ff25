"""``report.md``'s sections on every engine and every pair with more than two engines, from
``summary.json`` alone: each engine's own figures (:func:`engines_section`: its perturbation,
spread at the end with its interval, when that spread first reaches each threshold, its own
error at dt/2) and the figures that decide each pair's verdict (:func:`pair_reasons`: the gap
over each engine's spread and own error, the test). Two engines keep these in the verdict
section (:mod:`.markdown`)."""

from __future__ import annotations

from typing import Any

from ..analysis.diff import QUANTITIES
from .fmt import fmt_threshold, fmt_time, fmt_value, table
from .verdict import interval_cell, perturbation_words, spread_ratio, verdict_word

__all__ = ["engines_section", "pair_reasons", "p_words"]


def _ratio(r: float) -> str:
    """``0.588x``, ``299x``, ``1.1e8x``."""
    if r < 1000:
        return f"{r:.3g}x"
    return f"{r:.1e}x".replace("e+0", "e").replace("e+", "e")


def p_words(test: dict[str, Any]) -> str:
    """``p = 0.1 (the smallest this test can give with 3 and 3 runs)`` where the exact test's
    p-value is its floor (no other split is as extreme: 1 / the number of splits, 2 / it with
    as many runs on each side, where a split and its mirror give the same statistic),
    ``p = 0.029`` otherwise; ``p < 0.001`` from random splits below that."""
    p = test["p_value"]
    if not test["exact"]:
        return "p < 0.001" if p < 0.001 else f"p = {p:.2g}"
    text = f"p = {p:.2g}"
    sizes = test.get("sizes")
    if sizes and test.get("resamples"):
        n, m = sizes
        floor = (2 if n == m else 1) / test["resamples"]
        if p <= floor * (1 + 1e-9):
            text += f" (the smallest this test can give with {n} and {m} runs)"
    return text


def engines_section(s: dict[str, Any]) -> list[str]:
    """*Every engine*: a row per engine of the study with its own figures (the perturbation
    its runs got, its spread at the end with the 95% interval, when that spread first reaches
    each threshold, what halving the time step moves its end by) and, where a float32 engine
    got larger offsets, the sentence saying so. Empty with two engines."""
    labels = s["labels"]
    if len(labels) <= 2 or len(s.get("pairs") or []) <= 1:
        return []
    q = s["headline_quantity"]
    unit = QUANTITIES[q].unit
    ens = s.get("ensemble") or {}
    per = ens.get("engines") or {}
    req = ens.get("perturbation")
    rows = []
    for label in labels:
        e = per.get(label) or {}
        pert = e.get("perturbation") or req
        if pert is None or ens.get("size", 1) < 2:  # one run: nothing was moved
            moved = "none (one run)"
        else:
            dtype = f" ({pert['state_dtype']})" if pert.get("state_dtype") else ""
            moved = f"{pert['position']:.3g} m / {pert['orientation']:.3g} rad{dtype}"
        if ens.get("size", 1) > 1 and e.get("spread_end") is not None:
            spread = interval_cell(e["spread_end"], unit)
            hz = ", ".join(
                f"{fmt_threshold(h['threshold'], unit)}: {fmt_time(h['time'])}"
                for h in e["horizons"]
            )
        else:
            spread, hz = "n/a (one run)", "n/a"
        own = s["own"][label]["final"][q]
        rows.append([label, str(ens.get("size", 1)), moved, spread, hz, fmt_value(own, unit)])
    lines = ["## Every engine", ""]
    lines += [
        f"Each engine's own figures on the {QUANTITIES[q].title}: its runs (the nominal one and "
        "the rest with every spawn pose moved and turned by the offsets shown, in random "
        "directions), their spread at the end (the 90th percentile of the distances between "
        "its runs, with its 95% bootstrap interval), when that spread first reaches each "
        "threshold, and how far halving the time step moves its end (its own error, dt "
        "against dt/2). Every figure is in `summary.json` under `ensemble.engines` and `own`.",
        "",
    ]
    lines += table(
        [
            "engine",
            "runs",
            "offsets",
            "spread at the end [95%]",
            "spread first reaches",
            "own error at the end (dt/2)",
        ],
        rows,
    )
    lines += [""]
    raised = perturbation_words(ens or None)
    if raised:
        lines += [raised, ""]
    return lines


def _against(lab: str, f: dict[str, Any], floor: float, unit: str) -> str:
    """The judged gap against one engine's spread and own error, with no ratio to one that is
    absent (one run) or at the precision floor."""
    # no ratio to a spread or an error that is absent (one run) or at the float floor
    if spread_ratio(f, floor):
        spread = (
            f"{_ratio(f['gap_over_spread'])} {lab}'s spread "
            f"({fmt_value(f['spread']['value'], unit)})"
        )
    elif f["size"] < 2:
        spread = f"{lab} has no spread (one run)"
    else:
        spread = f"{lab}'s spread is at the precision floor"
    if f["own_error"] > floor:
        own = f"{_ratio(f['gap_over_own_error'])} its own error ({fmt_value(f['own_error'], unit)})"
    else:
        own = "its own error is at the precision floor"
    return f"{spread}, {own}" if not spread_ratio(f, floor) else f"{spread} and {own}"


def pair_reasons(s: dict[str, Any]) -> list[str]:
    """A bullet per judged pair with the figures that decide its verdict: the judged gap over
    each engine's spread and over its own time-step error (with those figures), what makes it
    marginal, and the test; empty with two engines."""
    pairs = s.get("pairs") or []
    if len(s["labels"]) <= 2 or len(pairs) <= 1:
        return []
    out = []
    for p in pairs:
        v = p["verdict"]
        if not v:
            continue
        unit = v["unit"]
        figs = v["engine_figures"]
        t = v["judged_at"]
        when = "at the end" if t["why"] == "end" else f"at t = {fmt_time(t['time'])}"
        floor = v["floor"]

        each = "; ".join(_against(lab, f, floor, unit) for lab, f in figs.items())
        words = (
            f"- {p['labels'][0]} and {p['labels'][1]}, {verdict_word(v)}: the gap "
            f"{interval_cell(v['gap'], unit)} {when}"
            + (" is " if all(spread_ratio(f, floor) for f in figs.values()) else ": ")
            + each
        )
        if v["marginal_reasons"]:
            words += "; marginal because " + " and ".join(v["marginal_reasons"])
        if v["test"] is not None:
            words += f"; {p_words(v['test'])}"
        out.append(words + ".")
    if not out:
        return []
    lo, hi = pairs[0]["verdict"]["marginal_range"] if pairs[0]["verdict"] else (0.5, 2)
    return [
        "What decides each verdict: the judged gap against each engine's spread (its runs' "
        f"own scatter: chaotic where the gap is at most {hi:g}x it) and against its own "
        f"time-step error (unresolved where the gap is at most {hi:g}x it); a ratio between "
        f"{lo:g} and {hi:g} makes the verdict marginal.",
        "",
        *out,
        "",
    ]
