"""The studies' reports: the resolve table added to a comparison's report, a sweep's and an
explain's own folders (``report.md``, ``summary.json``, PNG figures)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..analysis.diff import QUANTITIES
from ..analysis.verdict import MARGINAL, Interval
from ..report.fmt import fmt_value
from ..report.verdict import verdict_word
from ..scenario import format_timestep
from .points import PairFigures, format_value, interval_dict, split_slot

if TYPE_CHECKING:
    from .explain import Explanation
    from .resolve import Resolution
    from .sweep import Sweep, SweepPoint

__all__ = [
    "write_resolution",
    "resolution_lines",
    "write_sweep",
    "write_explanation",
    "point_line",
    "sweep_lines",
]


def _iv(x: Interval, unit: str) -> str:
    if x.low is None or x.high is None:
        return fmt_value(x.value, unit)
    return f"{fmt_value(x.value, unit)} [{fmt_value(x.low, unit)}, {fmt_value(x.high, unit)}]"


def _ratio(a: float, b: float) -> str:
    if b <= 0 or not math.isfinite(b):
        return "n/a"
    return f"{a / b:.3g}x"


def _verdict(p: PairFigures) -> str:
    """The verdict in the comparison report's words: ``agree (marginal)``, ``chaotic
    (pybullet)``."""
    return verdict_word({"verdict": p.verdict, "engines": p.engines, "marginal": p.marginal})


def point_line(p: SweepPoint) -> str:
    """A sweep point in one terminal line, in report.md's words and units:
    ``solver_iterations=10: agree (marginal), gap 8.17 mm [7.90 mm, 8.40 mm]`` (more than one
    pair: each named)."""
    values = ", ".join(f"{k}={p.shown(k)}" for k in p.values)
    words = []
    for (a, b), f in zip(_pairs(len(p.labels)), p.pairs, strict=False):
        who = f"{p.labels[a]} - {p.labels[b]} " if len(p.pairs) > 1 else ""
        words.append(f"{who}{_verdict(f)}, gap {_iv(f.gap, f.unit)}")
    return f"{values}: " + "; ".join(words)


def _dump(path: Path, data: Any) -> None:
    path.write_text(json.dumps(data, indent=2, default=_default) + "\n", encoding="utf-8")


def _default(obj: Any) -> Any:
    import numpy as np

    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.integer, np.floating, np.bool_)):
        return obj.item()
    return str(obj)


# ---------------------------------------------------------------- resolve


def resolution_lines(r: Resolution) -> list[str]:
    """The resolve section of report.md: the verdict at each time step."""
    head = r.steps[0].headline
    a, b = head.labels
    lines = [
        "",
        "## Resolve: the verdict at each time step",
        "",
        "Where the verdict is unresolved because an engine's own time-step error (dt against "
        f"dt/2) covers the gap (it is at most {MARGINAL[1]:g}x that error), the time step is "
        f"halved, at most {r.limit} times. "
        "The rest of this report is that of the last time step.",
        "",
        f"| dt (s) | verdict | gap ({a} - {b}) [95%] | own error {a} | own error {b} "
        "| gap / larger own error | wall time |",
        "|---|---|---|---|---|---|---|",
    ]
    for s in r.steps:
        p = s.headline
        lines.append(
            f"| {format_timestep(s.timestep)} | {p.verdict} ({p.reason}"
            f"{', marginal' if p.marginal else ''}) | {_iv(p.gap, p.unit)} "
            f"| {fmt_value(p.own_errors[0], p.unit)} | {fmt_value(p.own_errors[1], p.unit)} "
            f"| {_ratio(p.gap.value, max(p.own_errors))} | {s.wall_time:.1f} s |"
        )
    last = r.steps[-1]
    lines.append("")
    if r.outcome == "not needed":
        lines.append(
            f"The verdict at dt = {format_timestep(last.timestep)} s is not unresolved by the "
            "time step: nothing to halve."
        )
    elif r.outcome == "resolved":
        lines.append(
            f"Resolved after {r.halvings} halving(s): at dt = {format_timestep(last.timestep)} s "
            f"the verdict is **{last.headline.verdict}**."
        )
    else:
        lines.append(
            f"Still unresolved after {r.halvings} halving(s) (dt = "
            f"{format_timestep(last.timestep)} s): an engine's own time-step error still covers "
            "the gap; raise --resolve-limit or start from a smaller --timestep."
        )
    return lines


def resolution_headline(r: Resolution) -> str:
    """One terminal line: the verdicts over the halvings."""
    seq = " -> ".join(
        f"{s.headline.verdict} at {format_timestep(s.timestep)} s" for s in r.steps if s.pairs
    )
    return f"resolve ({r.outcome}, {r.halvings} halving(s)): {seq}"


def write_resolution(r: Resolution, out: str | Path) -> None:
    """Add the resolve table to ``out``'s report.md and ``resolve`` to its summary.json (the
    comparison's report written there first)."""
    from ..report.study import add_resolution  # also into study.json, for `simbridge report`

    add_resolution(out, r.as_dict(), resolution_lines(r))


# ---------------------------------------------------------------- sweep


PAIR_COLORS = ("k", "tab:purple", "tab:brown", "tab:olive", "tab:cyan", "tab:pink", "0.5")
"""A pair's colour in a sweep's figure (as the comparison's ``distance.png`` colours them)."""
ENGINE_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown")
GROUP_MARKERS = ("o", "s", "^", "D", "v", "P")
"""A grid's other settings (one line each) by marker and dash."""
GROUP_LINES = ("-", "--", ":", "-.")


def sweep_lines(s: Sweep, key: str) -> list[dict[str, Any]]:
    """What a sweep's figure of ``key`` draws, a dict per line: ``panel`` (``gap`` or
    ``spread``), ``name`` (a gap's: its pair, ``pybullet and mujoco``; a spread's: ``spread of
    mujoco``), ``others`` (on a grid, the other settings' values of the line, else empty),
    ``label`` (the legend's: the name, and the others in brackets), ``x`` (the values; their
    places for values that are not numbers), ``value``, ``low`` and ``high`` (the 95%
    interval; None where there is none). One gap line per pair of engines and one spread line
    per engine, each for every combination of the other settings on a grid. A spread is the
    engine's in the first pair that holds it (at that pair's judged instant)."""
    pts = s.points_of(key)
    if not pts or not pts[0].pairs:
        return []
    numeric = all(
        isinstance(p.values[key], (int, float)) and not isinstance(p.values[key], bool) for p in pts
    )
    others = [k for k in pts[0].values if k != key]
    groups: dict[str, list[Any]] = {}
    for p in pts:
        tag = ", ".join(f"{k}={p.shown(k)}" for k in others)
        groups.setdefault(tag, []).append(p)
    ticks = [p.shown(key) for p in pts]
    names = _engine_names(s)
    pairs = _pairs(len(names))
    holder = {}  # engine slot -> (the first pair holding it, its place in that pair)
    for k, (a, b) in reversed(list(enumerate(pairs))):
        holder[a], holder[b] = (k, 0), (k, 1)
    out: list[dict[str, Any]] = []

    def line(panel: str, label: str, tag: str, group: list[Any], xi: list[Interval]) -> None:
        out.append(
            {
                "panel": panel,
                "name": label,
                "others": tag,
                "label": label + (f" ({tag})" if tag else ""),
                "x": [p.values[key] if numeric else ticks.index(p.shown(key)) for p in group],
                "value": [x.value for x in xi],
                "low": [interval_dict(x)["low"] for x in xi],  # None: none, or not finite
                "high": [interval_dict(x)["high"] for x in xi],
            }
        )

    for tag, group in groups.items():
        for k, (a, b) in enumerate(pairs):
            if all(len(p.pairs) > k for p in group):
                line(
                    "gap", f"{names[a]} and {names[b]}", tag, group, [p.pairs[k].gap for p in group]
                )
        for slot in range(len(names)):
            k, side = holder[slot]
            if all(len(p.pairs) > k for p in group):
                sp = [p.pairs[k].spreads[side] for p in group]
                line("spread", f"spread of {names[slot]}", tag, group, sp)
    return out


def _plot_sweep(s: Sweep, key: str, path: Path) -> bool:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lines = sweep_lines(s, key)
    if not lines:
        return False
    pts = s.points_of(key)
    numeric = all(
        isinstance(p.values[key], (int, float)) and not isinstance(p.values[key], bool) for p in pts
    )
    head = pts[0].pairs[0]
    names = _engine_names(s)
    many = len(names) > 2
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.8) if many else (11, 4.2))
    ticks = [p.shown(key) for p in pts]
    written = {p.values[key]: p.shown(key) for p in pts}
    if all(text == format_value(v) for v, text in written.items()):
        written = {}
    tags = list(dict.fromkeys(x["others"] for x in lines))
    pair_labels = [f"{names[a]} and {names[b]}" for a, b in _pairs(len(names))]
    spots = [v for x in lines for v in x["x"]]
    dodge = 0.06 if not numeric else 0.012 * ((max(spots) - min(spots)) or 1.0)
    for x in lines:
        color: str | None
        base = x["name"]
        g = tags.index(x["others"])
        if x["panel"] == "gap":
            ax, slot = ax1, 0
            color = PAIR_COLORS[pair_labels.index(base) % len(PAIR_COLORS)]
            if not many:
                color = None  # two engines: matplotlib's colours, as before
        else:
            ax = ax2
            slot = [f"spread of {n}" for n in names].index(base)
            color = ENGINE_COLORS[slot % len(ENGINE_COLORS)]
            g = slot if len(tags) == 1 else g  # one line each: the engine's marker
        lo = [v - (v if low is None else low) for v, low in zip(x["value"], x["low"], strict=True)]
        hi = [(v if h is None else h) - v for v, h in zip(x["value"], x["high"], strict=True)]
        xs = x["x"]
        if many:  # side by side at each value: equal lines stay visible
            k, n = (pair_labels.index(base), len(pair_labels)) if ax is ax1 else (slot, len(names))
            xs = [v + dodge * (k - (n - 1) / 2) for v in xs]
        ax.errorbar(
            xs,
            x["value"],
            yerr=[lo, hi],
            marker=GROUP_MARKERS[g % len(GROUP_MARKERS)],
            ls=GROUP_LINES[g % len(GROUP_LINES)],
            color=color,
            capsize=3,
            label=x["label"],
        )
    ax1.axhline(head.tolerance, color="grey", ls=":", lw=1, label="tolerance")
    gap_title = "cross-engine gap" + (", each pair" if many else "")
    for ax, title in (
        (ax1, f"{gap_title} (median, 95% interval)"),
        (ax2, "ensemble spread" + (", each engine" if many else "")),
    ):
        ax.set_xlabel(key)
        ax.set_ylabel(f"{head.quantity} ({head.unit})")
        ax.set_title(title, fontsize=10)
        if not numeric:
            ax.set_xticks(range(len(ticks)), ticks)
        elif written:  # the values as written (1/240) where the numbers would read otherwise
            ax.set_xticks(list(written), list(written.values()))
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    if all(v > 0 for x in lines if x["panel"] == "gap" for v in x["value"]):
        ax1.set_yscale("log")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def _engine_names(s: Sweep) -> tuple[str, ...]:
    """The engines by place (the headline pair's), numbered when a backend is named twice:
    a point's labels carry its changed profiles, these do not."""
    if len(set(s.backends)) == len(s.backends):
        return s.backends
    return tuple(f"{b} #{k + 1}" for k, b in enumerate(s.backends))


def write_sweep(s: Sweep, out: str | Path, *, plots: bool = True) -> Path:
    """report.md, summary.json and one figure per setting (``sweep_<key>.png``) into ``out``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    images = []
    if plots:
        for setting in s.settings:
            name = "sweep_" + "".join(c if c.isalnum() else "_" for c in setting.key) + ".png"
            if _plot_sweep(s, setting.key, out / name):
                images.append((setting.key, name))
    data = s.as_dict()
    data["figures"] = {x.key: sweep_lines(s, x.key) for x in s.settings}
    data["files"] = ["summary.json", "report.md"] + [n for _, n in images]
    _dump(out / "summary.json", data)
    names = _engine_names(s)
    lines = [
        f"# Sweep of {s.scenario}: {', '.join(s.backends)}",
        "",
        f"{len(s.points)} comparisons ({'every combination' if s.grid else 'one setting at a time'}"
        f"), {s.ensemble} runs per engine each"
        + (f", the first {s.duration:g} s" if s.duration else "")
        + f"; {s.wall_time:.0f} s in all.",
        "",
        "Varied: "
        + "; ".join(
            f"`{x.key}` = {', '.join(map(x.shown, x.values))}{_on_whom(x.key, names)}"
            for x in s.settings
        )
        + ". Engines: "
        + ", ".join(f"{n} (profile {p})" for n, p in zip(names, s.profiles, strict=True))
        + ".",
        "",
    ]
    if s.points and s.points[0].pairs:
        head = s.points[0].pairs[0]
        lines += [
            f"The gap is the median {_title(head.quantity)} between the two engines' runs"
            + (" of a pair" if len(names) > 2 else "")
            + " at the judged instant (the end, or the largest gap when the end is below the "
            "tolerance), with its 95% bootstrap interval; a spread is the 90th percentile of "
            "the distances between one engine's runs.",
            "",
        ]
    keys = [x.key for x in s.settings]
    lines.append(
        "| "
        + " | ".join(keys)
        + " | pair | verdict | gap [95%] | at | spread of the first | spread of the second "
        "| own errors | wall |"
    )
    lines.append("|" + "---|" * (len(keys) + 8))
    for p in s.points:
        for (a, b), f in zip(_pairs(len(names)), p.pairs, strict=False):
            cells = [p.shown(k) if k in p.values else "·" for k in keys]
            lines.append(
                "| "
                + " | ".join(cells)
                + f" | {names[a]} - {names[b]} | {_verdict(f)} | {_iv(f.gap, f.unit)} "
                f"| {f.judged_time:.3f} s | {_iv(f.spreads[0], f.unit)} "
                f"| {_iv(f.spreads[1], f.unit)} | {fmt_value(f.own_errors[0], f.unit)}, "
                f"{fmt_value(f.own_errors[1], f.unit)} | {p.wall_time:.1f} s |"
            )
    for key, name in images:
        lines += ["", f"## {key}", "", f"![gap and spread against {key}]({name})"]
        if len(names) > 2:
            lines += [
                "",
                f"Left, each pair's gap against `{key}`; right, each engine's spread (its "
                "first pair's, at that pair's judged instant); the lines are drawn side by side "
                "at each value, so that equal ones stay in sight. Their figures are in "
                f"`summary.json` under `figures.{key}`.",
            ]
    path = out / "report.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _on_whom(key: str, names: tuple[str, ...]) -> str:
    """`` (on mujoco alone)`` for a key changed on one engine (``KEY@N``); empty otherwise."""
    slot = split_slot(key)[1]
    if slot is None or slot >= len(names):
        return ""
    return f" (on {names[slot]} alone)"


def _pairs(n: int) -> list[tuple[int, int]]:
    return [(i, j) for i in range(n) for j in range(i + 1, n)]


# ---------------------------------------------------------------- explain


def write_explanation(e: Explanation, out: str | Path, *, plots: bool = True) -> Path:
    """report.md, summary.json and the figures of an explain study into ``out``."""
    from .explain_report import explanation_lines, plot_explanation

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    images = plot_explanation(e, out) if plots else []
    data = e.as_dict()
    data["files"] = ["summary.json", "report.md"] + images
    _dump(out / "summary.json", data)
    lines = explanation_lines(e)
    for name in images:
        lines += ["", f"![{name}]({name})"]
    path = out / "report.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _title(quantity: str) -> str:
    """``base position distance`` for ``base_distance``: a quantity as the reports name it."""
    q = QUANTITIES.get(quantity)
    return quantity.replace("_", " ") if q is None else q.title
