"""The studies' reports: the resolve table added to a comparison's report, a sweep's and an
explain's own folders (``report.md``, ``summary.json``, PNG figures)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..analysis.verdict import Interval
from ..report.fmt import fmt_value
from ..report.verdict import verdict_word
from ..scenario import format_timestep
from .points import PairFigures, format_value, split_slot

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
    values = ", ".join(f"{k}={format_value(v)}" for k, v in p.values.items())
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
        "Where the verdict is unresolved because the gap lies within an engine's own time-step "
        f"error (dt against dt/2), the time step is halved, at most {r.limit} times. "
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
            f"{format_timestep(last.timestep)} s): the gap still lies within an engine's own "
            "time-step error; raise --resolve-limit or start from a smaller --timestep."
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


def _plot_sweep(s: Sweep, key: str, path: Path) -> bool:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pts = s.points_of(key)
    if not pts or not pts[0].pairs:
        return False
    numeric = all(
        isinstance(p.values[key], (int, float)) and not isinstance(p.values[key], bool) for p in pts
    )
    others = [k for k in pts[0].values if k != key]
    groups: dict[str, list[Any]] = {}
    for p in pts:
        tag = ", ".join(f"{k}={format_value(p.values[k])}" for k in others)
        groups.setdefault(tag, []).append(p)
    head = pts[0].pairs[0]
    names = _engine_names(s)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    ticks = [format_value(p.values[key]) for p in pts]
    for tag, group in groups.items():
        xs: list[Any] = [
            p.values[key] if numeric else ticks.index(format_value(p.values[key])) for p in group
        ]
        g = [p.pairs[0].gap for p in group]
        lo = [x.value - (x.low if x.low is not None else x.value) for x in g]
        hi = [(x.high if x.high is not None else x.value) - x.value for x in g]
        label = f"gap {names[0]} - {names[1]}" + (f" ({tag})" if tag else "")
        ax1.errorbar(xs, [x.value for x in g], yerr=[lo, hi], marker="o", capsize=3, label=label)
        for slot in (0, 1):
            sp = [p.pairs[0].spreads[slot] for p in group]
            ax2.errorbar(
                xs,
                [x.value for x in sp],
                yerr=[
                    [x.value - (x.low if x.low is not None else x.value) for x in sp],
                    [(x.high if x.high is not None else x.value) - x.value for x in sp],
                ],
                marker="s" if slot else "o",
                capsize=3,
                label=f"spread of {names[slot]}" + (f" ({tag})" if tag else ""),
            )
    ax1.axhline(head.tolerance, color="grey", ls=":", lw=1, label="tolerance")
    for ax, title in ((ax1, "cross-engine gap (median, 95% interval)"), (ax2, "ensemble spread")):
        ax.set_xlabel(key)
        ax.set_ylabel(f"{head.quantity} ({head.unit})")
        ax.set_title(title, fontsize=10)
        if not numeric:
            ax.set_xticks(range(len(ticks)), ticks)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    if all(p.pairs[0].gap.value > 0 for p in pts):
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
            f"`{x.key}` = {', '.join(map(format_value, x.values))}{_on_whom(x.key, names)}"
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
            f"The gap is the median {head.quantity} between the two engines' runs at the judged "
            "instant (the end, or the largest gap when the end is below the tolerance), with its "
            "95% bootstrap interval; a spread is the 90th percentile of the distances between "
            "one engine's runs.",
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
            cells = [format_value(p.values[k]) if k in p.values else "·" for k in keys]
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
    from .explain import explanation_lines, plot_explanation

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
