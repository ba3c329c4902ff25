"""The one-step error (:mod:`.resync`) in words and in a figure: the headline's line, the
report's section (from ``summary.json``'s ``resync`` and, with more than two engines, every
pair's ``pairs[].resync``) and ``resync.png`` (the first pair's; each other pair's
``resync_<a>_<b>.png``, :func:`resync_file`)."""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..run.quantities import FEATURE_SOURCES, QUANTITIES
from ..run.resync import PARTS, WORST, Direction, Resync
from .fmt import fmt_time, fmt_value

__all__ = [
    "resync_lines",
    "resync_words",
    "rounding_words",
    "resync_section",
    "resync_file",
    "plot_resync",
    "plot_resyncs",
]


# ---------------------------------------------------------------- words


def _pair_of(r: dict[str, Any]) -> str:
    """``pybullet and mujoco``: the engines of a resync, as the pair sections name them."""
    d = r["directions"][0]
    return f"{d['source']} and {d['target']}"


def resync_lines(summary: dict[str, Any]) -> list[str]:
    """The headline's line on the one-step error, from ``summary.json``'s ``resync`` (the first
    pair's; empty when there is none). With more than two engines it names the pair."""
    r = summary.get("resync")
    if not r:
        return []
    return resync_words(r, _pair_of(r) if len(summary["labels"]) > 2 else None)


def resync_words(r: dict[str, Any], pair: str | None = None) -> list[str]:
    """One resync (``summary.json``'s ``resync`` or a ``pairs[].resync``) in one line;
    ``pair``: its engines, ``pybullet and physx``, named in place of "the engines"."""
    unit = r["unit"]
    dirs = r["directions"]
    big = r["largest"]
    if big["value"] is None:
        of = f" ({pair})" if pair else ""
        return [f"One step from the same state{of}: no resync point could be stepped."]
    each = "; ".join(
        f"{d['source']} -> {d['target']} {fmt_value(d['max']['value'], unit)}"
        for d in dirs
        if d["max"]["value"] is not None
    )
    floors = ", ".join(
        f"{label} {'n/a' if v is None else fmt_value(v, unit)}" for label, v in r["floors"].items()
    )
    line = (
        f"One step from the same state, {pair or 'the engines'} differ by up to "
        f"{fmt_value(big['value'], unit)} ({each}; each engine's own floor, at its largest: "
        f"{floors})"
    )
    born = r["born"]
    same = born is not None and (born["time"], born["source"]) == (big["time"], big["source"])
    if born is None:
        line += (
            f": no step's error exceeds {r['born_factor']:g}x its floor and "
            f"{fmt_value(r['significant'], unit)} (an error that, at every step, would add up to "
            "the tolerance over the run): no model error shows at this scale."
        )
    else:
        where = f"in '{born['phase']}' at t = {fmt_time(born['time'])}"
        line += (
            f": the model error is born {'and largest ' if same else ''}{where} "
            f"({born['source']} -> {born['target']} {fmt_value(born['error'], unit)} against "
            f"{born['source']}'s own floor of {fmt_value(born['floor'], unit)} at that step)"
        )
        if not same:
            line += f" and is largest in '{big['phase']}' at t = {fmt_time(big['time'])}"
        typical = [
            (p["median"], p["phase"], d["source"], d["target"], p["floor_median"])
            for d in dirs
            for p in d["phases"]
            if p["median"] is not None
        ]
        if typical and len({p["phase"] for d in dirs for p in d["phases"]}) > 1:
            med, phase, src, tgt, flo = max(typical, key=lambda x: x[0])
            line += (
                f"; the median step is farthest apart in '{phase}' ({src} -> {tgt} "
                f"{fmt_value(med, unit)}, floor {'n/a' if flo is None else fmt_value(flo, unit)})"
            )
        line += "."
    return [line]


def rounding_words(r: dict[str, Any]) -> list[str]:
    """Where a target keeps its state in a narrower type than float64 (PhysX: float32), a
    sentence per such direction: each state set into it is rounded first, by how much, against
    the one-step error it is part of; empty where every target keeps float64."""
    unit = r["unit"]
    dirs = r["directions"]
    out = []
    for d in dirs:
        rounding = d.get("rounding")
        if not rounding:
            continue
        src, tgt = d["source"], d["target"]
        parts = rounding["parts"]
        size = ", ".join(
            f"{PARTS[k][0]} {_fmt(parts[k], PARTS[k][1])}"
            for k in ("base_position", "base_linear_velocity", "joint_velocities")
        )
        line = (
            f"{tgt} keeps its state in {rounding['state_dtype']}: each of {src}'s states is "
            f"rounded to it as it is set into {tgt}, so {src} -> {tgt} steps from the rounded "
            f"state and its error holds the rounding (largest: {size})"
        )
        med, rmed = d["median"], rounding["median"]
        if med is not None and rmed:
            title = QUANTITIES[r["quantity"]].title
            line += (
                f"; in the {title} the rounding's median is {fmt_value(rmed, unit)}, the "
                f"median one-step error {fmt_value(med, unit)} ({_times(med / rmed)})"
            )
        out.append(line + ".")
    return out


def resync_file(labels: Sequence[str], first: bool) -> str:
    """The figure of one pair's resync: ``resync.png`` for the first pair, else
    ``resync_<a>_<b>.png`` from its engines' labels (``mujoco (2)``: ``mujoco-2``)."""
    if first:
        return "resync.png"

    def slug(label: str) -> str:
        return re.sub(r"[^a-z0-9]+", "-", label.lower()).strip("-") or "engine"

    return "resync_" + "_".join(slug(x) for x in labels) + ".png"


def _resync_pairs(summary: dict[str, Any]) -> list[tuple[list[str], dict[str, Any]]]:
    """Every pair with a resync, ``(labels, resync)``, the first pair first (a summary without
    ``pairs[].resync``: its ``resync`` alone)."""
    got = [(list(p["labels"]), p["resync"]) for p in summary.get("pairs") or [] if p.get("resync")]
    if not got and summary.get("resync"):
        r = summary["resync"]
        d = r["directions"][0]
        got = [([d["source"], d["target"]], r)]
    return got


def resync_section(summary: dict[str, Any], images: dict[str, Path] | None = None) -> list[str]:
    """The report's section ``## One step from the same state`` (markdown lines); ``images``:
    the figures by key (``resync``, ``resync_<a>_<b>``: :func:`resync_file`'s stem). Two
    engines: one pair, its tables and figure. More: a table of every direction of every pair,
    then a part per pair (``### pybullet and physx``) with its line, tables and figure."""
    images = images or {}
    pairs = _resync_pairs(summary)
    if not pairs:
        return []
    r0 = pairs[0][1]
    title = QUANTITIES[r0["quantity"]].title
    if len(summary["labels"]) <= 2:
        r = summary.get("resync") or r0
        lines = ["## One step from the same state", ""]
        lines += resync_lines(summary)
        lines += ["", _method(r["every"], title, "the other engine"), ""]
        lines += _paragraphs(rounding_words(r))
        lines += _tables(r, 2 * WORST)
        lines += _figure(images.get("resync"))
        return lines
    lines = ["## One step from the same state", ""]
    lines += [
        _method(r0["every"], title, "the other engine of each pair"),
        "",
        f"Every pair of the {len(summary['labels'])} engines, each way (largest and median "
        f"over the resync points, {title}), and where the target keeps its state in float32 the "
        "largest rounding of the state set into it, which its step starts from; each pair's "
        "figures are in `summary.json` under `pairs[].resync`:",
        "",
    ]
    rows = []
    for labels, r in pairs:
        unit = r["unit"]
        for d in r["directions"]:
            rounding = d.get("rounding")
            rows.append(
                [
                    " and ".join(labels),
                    f"{d['source']} -> {d['target']}",
                    _fmt(d["max"]["value"], unit),
                    _fmt(d["median"], unit),
                    _pair(d["floor_max"]["value"], d["floor_median"], unit),
                    "-"
                    if not rounding
                    else f"{rounding['state_dtype']}: {_fmt(rounding['max'], unit)}",
                ]
            )
    lines += _md_table(
        ["pair", "direction", "largest", "median", "floor: largest, median", "state set: rounded"],
        rows,
    )
    lines += [""]
    for k, (labels, r) in enumerate(pairs):
        name = " and ".join(labels)
        lines += [f"### {name}", ""]
        lines += resync_words(r, name) + [""]
        lines += _paragraphs(rounding_words(r))
        lines += _tables(r, WORST)
        lines += _figure(images.get(Path(resync_file(labels, k == 0)).stem))
    return lines


def _method(every: int, title: str, other: str) -> str:
    return (
        f"Every {every} steps each engine's state (after that step's commands, before the "
        f"step) was set into {other} and into a second Sim of its own engine (the "
        "floor: what a portable restore alone costs there); each stepped once and was compared "
        f"with the source's next state ({title}, and the largest error of each quantity). "
        "Nothing accumulates. What a portable state cannot carry, per engine: "
        "docs/state_and_contacts.md."
    )


def _paragraphs(texts: list[str]) -> list[str]:
    return [x for t in texts for x in (t, "")]


def _figure(image: Path | None) -> list[str]:
    if image is None:
        return []
    return [
        f"![resync]({image.name})",
        "",
        "One-step error from the same state (log scale): solid, each engine's states "
        "stepped by the other engine; dashed, by a second Sim of the same engine (the "
        "floor; 0 drawn at the precision floor).",
        "",
    ]


def _tables(r: dict[str, Any], worst_rows: int) -> list[str]:
    """The largest error of each quantity each way beside the floors, the median and largest
    per phase, and the ``worst_rows`` worst steps."""
    unit = r["unit"]
    title = QUANTITIES[r["quantity"]].title
    lines: list[str] = []
    header = ["quantity"]
    for d in r["directions"]:
        header += [f"{d['source']} -> {d['target']}", f"{d['source']} -> {d['source']} (floor)"]
    dirs = r["directions"]
    rows = [
        [title]
        + [_fmt(v, unit) for d in dirs for v in (d["max"]["value"], d["floor_max"]["value"])]
    ]
    for k, (name, u) in PARTS.items():
        if FEATURE_SOURCES[r["quantity"]] == k and r["quantity"] == "base_distance":
            continue  # the headline row already
        pairs = [(d["parts"][k]["max"], d["parts"][k]["floor_max"]) for d in dirs]
        rows.append([name] + [_fmt(v, u) for pair in pairs for v in pair])
    lines += _md_table(header, rows)
    lines += ["", "Largest over the resync points; the floor is measured at the same states.", ""]
    header = ["phase"]
    for d in r["directions"]:
        header += [f"{d['source']} -> {d['target']}: median, largest", "floor: median, largest"]
    per: dict[str, list[str]] = {}
    for i, d in enumerate(r["directions"]):
        for row in d["phases"]:
            cells = per.setdefault(row["phase"], ["-"] * (2 * len(r["directions"])))
            cells[2 * i] = _pair(row["median"], row["max"], unit)
            cells[2 * i + 1] = _pair(row["floor_median"], row["floor_max"], unit)
    lines += _md_table(header, [[name] + cells for name, cells in per.items()])
    lines += [""]
    worst = [(d["source"], d["target"], w) for d in r["directions"] for w in d["worst"]]
    worst.sort(key=lambda x: -x[2]["error"])
    if worst:
        rows = []
        for src, tgt, w in worst[:worst_rows]:
            floor = "n/a" if w["floor"] is None else fmt_value(w["floor"], unit)
            events = "; ".join(e["words"] for e in w["events"][:2]) or "-"
            if len(w["events"]) > 2:
                events += f" (and {len(w['events']) - 2} more)"
            rows.append(
                [
                    f"{src} -> {tgt}",
                    fmt_time(w["time"]),
                    w["phase"],
                    fmt_value(w["error"], unit),
                    floor,
                    f"{w['parts']['joint_velocities']:.3g}",
                    events,
                ]
            )
        lines += ["Worst steps:", ""]
        lines += _md_table(
            [
                "direction",
                "from t",
                "phase",
                title,
                "floor there",
                "joint velocity rad/s",
                "events of the source around it",
            ],
            rows,
        )
        lines += [""]
    return lines


def _times(ratio: float) -> str:
    """``9.56x``, ``25,100x``."""
    return f"{ratio:,.0f}x" if ratio >= 1000 else f"{ratio:.3g}x"


def _pair(a: float | None, b: float | None, unit: str) -> str:
    return f"{_fmt(a, unit)}, {_fmt(b, unit)}"


def _fmt(v: float | None, unit: str) -> str:
    return "n/a" if v is None else fmt_value(v, unit)


def _md_table(header: list[str], rows: list[list[str]]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return out + ["| " + " | ".join(r) + " |" for r in rows]


# ---------------------------------------------------------------- the figure

_COLORS = ("tab:blue", "tab:orange")
_ENGINE_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown")


def _direction_lines(
    ax: Any, d: Direction, picked: tuple[Any, Any, Any], color: str, lo: float
) -> None:
    """One direction's lines in a panel, each held above the precision floor ``lo``: its error
    (solid), its floor (dashed) and, where given, the rounding of its states (dotted).
    ``picked``: the panel's (error, floor, rounding or None) of ``d``."""
    err, flo, loss = picked
    ax.plot(
        d.time,
        np.maximum(err, lo),
        color=color,
        lw=1.4,
        marker="o",
        ms=2.5,
        label=f"{d.source}'s states, stepped by {d.target}",
    )
    ax.plot(
        d.time,
        np.maximum(flo, lo),
        color=color,
        lw=1.1,
        ls=(0, (4, 2)),
        marker="x",
        ms=2.5,
        alpha=0.8,
        label=f"{d.source}'s states, stepped by {d.source} (floor)",
    )
    if loss is not None and len(loss) == len(d.time):
        ax.plot(
            d.time,
            np.maximum(loss, lo),
            color=color,
            lw=0.9,
            ls=":",
            alpha=0.9,
            label=f"{d.source}'s states rounded to {d.target}'s {d.target_dtype}",
        )


def _phase_marks(ax: Any, r: Resync) -> None:
    """Dotted lines at the phase starts, the phases' names at the top of the panel."""
    d0 = r.directions[0]
    tr_time = r.trajectories[0].time if r.trajectories else d0.time
    for _name, first, _ in d0.phases[1:]:
        ax.axvline(tr_time[first], color="0.6", lw=0.8, ls=":")
    for name, first, _ in d0.phases:
        ax.annotate(
            name,
            (tr_time[first], 0.98),
            xycoords=ax.get_xaxis_transform(),
            xytext=(3, 0),
            textcoords="offset points",
            fontsize=8,
            color="0.4",
            va="top",
        )


def _panels(
    r: Resync,
) -> list[tuple[str, str, Callable[[Direction], tuple[np.ndarray, np.ndarray, Any]]]]:
    """The figure's panels: title, unit, and per direction its error, its floor and what
    setting the state lost (None: not measured)."""
    joints = any(
        np.nan_to_num(d.parts["joint_velocities"]).any()
        or np.nan_to_num(d.floor_parts["joint_velocities"]).any()
        for d in r.directions
    )
    panels: list[tuple[str, str, Callable[[Direction], tuple[np.ndarray, np.ndarray, Any]]]] = [
        (
            QUANTITIES[r.quantity].title,
            r.unit,
            lambda d: (d.error, d.floor, (d.rounding or {}).get(FEATURE_SOURCES[r.quantity])),
        )
    ]
    if joints:
        panels.append(
            (
                "largest joint velocity error",
                "rad/s",
                lambda d: (
                    d.parts["joint_velocities"],
                    d.floor_parts["joint_velocities"],
                    None if d.rounding is None else d.rounding["joint_velocities"],
                ),
            )
        )
    return panels


def _limits(rs: Sequence[Resync]) -> list[tuple[float, float]] | None:
    """Shared y limits for the figures of several pairs, panel by panel (None: a pair whose
    panels differ from the first's)."""
    panels = [[t for t, _, _ in _panels(r)] for r in rs]
    if any(p != panels[0] for p in panels):
        return None
    out = []
    for k in range(len(panels[0])):
        values = []
        for r in rs:
            pick = _panels(r)[k][2]
            for d in r.directions:
                for v in pick(d):
                    if v is not None and len(v):
                        values.append(np.maximum(np.asarray(v, dtype=float), r.precision_floor))
        got = np.concatenate(values) if values else np.zeros(0)
        got = got[np.isfinite(got) & (got > 0)]
        if not got.size:
            return None
        out.append((float(got.min()) / 2.0, float(got.max()) * 2.0))
    return out


def plot_resyncs(
    resyncs: Sequence[tuple[Resync, str | None]], folder: str | Path
) -> dict[str, Path]:
    """Every pair's figure, ``resyncs`` ``(resync, pair name or None)`` the first pair first:
    into ``folder``, :func:`resync_file`'s names, the pair named in its title where given and,
    with more than one pair, every figure on the same y scale panel by panel. Returns the paths
    by key (the file's stem)."""
    folder = Path(folder)
    limits = _limits([r for r, _ in resyncs]) if len(resyncs) > 1 else None
    engines = list(dict.fromkeys(label for r, _ in resyncs for label in r.labels))
    colors = {label: _ENGINE_COLORS[k % len(_ENGINE_COLORS)] for k, label in enumerate(engines)}
    out = {}
    for k, (r, pair) in enumerate(resyncs):
        name = resync_file(r.labels, k == 0)
        got = plot_resync(r, folder / name, pair=pair, ylims=limits, colors=colors)
        if got is not None:
            out[Path(name).stem] = got
    return out


def plot_resync(
    r: Resync,
    path: str | Path,
    *,
    pair: str | None = None,
    ylims: Sequence[tuple[float, float]] | None = None,
    colors: dict[str, str] | None = None,
) -> Path | None:
    """``resync.png``: the one-step error over time, log scale, both directions (solid) and
    both floors (dashed), phases marked, the legend below the axes; a second panel with the
    largest joint velocity error when the subject has joints. Where a target keeps its state in
    float32, the rounding of each state set into it (which its step starts from), dotted.
    ``pair``: the engines it runs between (``pybullet and mujoco``), named in the title where
    the study has more; ``ylims``: each panel's y limits (several pairs on one scale);
    ``colors``: per engine label, the colour of its states' lines (one engine one colour over
    several pairs' figures; default blue for the first direction, orange for the second).

    Args:
        r: the one-step resync of a pair.
        path: the PNG to write.
        pair: the pair's name for the title, or None.
        ylims: each panel's y limits, or None for matplotlib's.
        colors: each engine label's colour, or None for the defaults.

    Returns:
        ``path``, or None when there is no point to draw.
    """
    if not any(len(d.rows) for d in r.directions):
        return None
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    path = Path(path)
    panels = _panels(r)
    fig, axes = plt.subplots(
        len(panels), 1, figsize=(7.6, 2.2 + 2.3 * len(panels)), sharex=True, squeeze=False
    )
    for p, (ax, (title, unit, pick)) in enumerate(zip(axes[:, 0], panels, strict=True)):
        for slot, d in enumerate(r.directions):
            c = (colors or {}).get(d.source, _COLORS[slot % 2])
            _direction_lines(ax, d, pick(d), c, r.precision_floor)
        ax.set_yscale("log")
        if ylims is not None:
            ax.set_ylim(*ylims[p])
        ax.set_ylabel(f"{title} ({unit})", fontsize=9)
        ax.grid(True, which="major", alpha=0.3)
        _phase_marks(ax, r)
    between = f" ({pair})" if pair else ""
    axes[0, 0].set_title(
        f"One step from the same state{between}, every {r.every} steps (log scale)", fontsize=10
    )
    axes[-1, 0].set_xlabel("time of the state the step starts from (s)")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.01 + 0.028 * math.ceil(len(handles) / 2), 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
