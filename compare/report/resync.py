"""The one-step error (:mod:`.resync`) in words and in a figure: the headline's line, the
report's section (from ``summary.json``'s ``resync``) and ``resync.png``."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..run.quantities import FEATURE_SOURCES, QUANTITIES
from ..run.resync import PARTS, WORST, Direction, Resync
from .fmt import fmt_time, fmt_value

__all__ = ["resync_lines", "resync_section", "plot_resync"]


# ---------------------------------------------------------------- words


def resync_lines(summary: dict[str, Any]) -> list[str]:
    """The headline's line on the one-step error, from ``summary.json``'s ``resync`` (empty
    when there is none)."""
    r = summary.get("resync")
    if not r:
        return []
    unit = r["unit"]
    dirs = r["directions"]
    big = r["largest"]
    if big["value"] is None:
        return ["One step from the same state: no resync point could be stepped."]
    each = "; ".join(
        f"{d['source']} -> {d['target']} {fmt_value(d['max']['value'], unit)}"
        for d in dirs
        if d["max"]["value"] is not None
    )
    floors = ", ".join(
        f"{label} {'n/a' if v is None else fmt_value(v, unit)}" for label, v in r["floors"].items()
    )
    line = (
        f"One step from the same state, the engines differ by up to "
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


def resync_section(summary: dict[str, Any], image: Path | None = None, of: str = "") -> list[str]:
    """The report's section ``## One step from the same state`` (markdown lines); ``of``: the
    pair it runs between, `` (pybullet and mujoco)``, named in the title with more than two
    engines (resync runs between the first pair alone)."""
    r = summary.get("resync")
    if not r:
        return []
    unit = r["unit"]
    title = QUANTITIES[r["quantity"]].title
    lines = [f"## One step from the same state{of}", ""]
    lines += resync_lines(summary)
    lines += [
        "",
        f"Every {r['every']} steps each engine's state (after that step's commands, before the "
        "step) was set into the other engine and into a second Sim of its own engine (the "
        "floor: what a portable restore alone costs there); each stepped once and was compared "
        f"with the source's next state ({title}, and the largest error of each quantity). "
        "Nothing accumulates. What a portable state cannot carry, per engine: "
        "docs/state_and_contacts.md.",
        "",
    ]
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
        for src, tgt, w in worst[: 2 * WORST]:
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
    if image is not None:
        lines += [
            f"![resync]({image.name})",
            "",
            "One-step error from the same state (log scale): solid, each engine's states "
            "stepped by the other engine; dashed, by a second Sim of the same engine (the "
            "floor; 0 drawn at the precision floor).",
            "",
        ]
    return lines


def _pair(a: float | None, b: float | None, unit: str) -> str:
    return f"{_fmt(a, unit)}, {_fmt(b, unit)}"


def _fmt(v: float | None, unit: str) -> str:
    return "n/a" if v is None else fmt_value(v, unit)


def _md_table(header: list[str], rows: list[list[str]]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return out + ["| " + " | ".join(r) + " |" for r in rows]


# ---------------------------------------------------------------- the figure

_COLORS = ("tab:blue", "tab:orange")


def plot_resync(r: Resync, path: str | Path, *, pair: str | None = None) -> Path | None:
    """``resync.png``: the one-step error over time, log scale, both directions (solid) and
    both floors (dashed), phases marked, the legend below the axes; a second panel with the
    largest joint velocity error when the subject has joints. ``pair``: the engines it runs
    between (``pybullet and mujoco``), named in the title where the study has more. None when
    there is no point."""
    if not any(len(d.rows) for d in r.directions):
        return None
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    path = Path(path)
    joints = any(
        np.nan_to_num(d.parts["joint_velocities"]).any()
        or np.nan_to_num(d.floor_parts["joint_velocities"]).any()
        for d in r.directions
    )
    panels: list[tuple[str, str, Callable[[Direction], tuple[np.ndarray, np.ndarray]]]] = [
        (QUANTITIES[r.quantity].title, r.unit, lambda d: (d.error, d.floor))
    ]
    if joints:
        panels.append(
            (
                "largest joint velocity error",
                "rad/s",
                lambda d: (d.parts["joint_velocities"], d.floor_parts["joint_velocities"]),
            )
        )
    fig, axes = plt.subplots(
        len(panels), 1, figsize=(7.6, 2.2 + 2.3 * len(panels)), sharex=True, squeeze=False
    )
    for ax, (title, unit, pick) in zip(axes[:, 0], panels, strict=True):
        lo = r.precision_floor
        for slot, d in enumerate(r.directions):
            err, flo = pick(d)
            c = _COLORS[slot % 2]
            ax.plot(
                d.time,
                np.maximum(err, lo),
                color=c,
                lw=1.4,
                marker="o",
                ms=2.5,
                label=f"{d.source}'s states, stepped by {d.target}",
            )
            ax.plot(
                d.time,
                np.maximum(flo, lo),
                color=c,
                lw=1.1,
                ls=(0, (4, 2)),
                marker="x",
                ms=2.5,
                alpha=0.8,
                label=f"{d.source}'s states, stepped by {d.source} (floor)",
            )
        ax.set_yscale("log")
        ax.set_ylabel(f"{title} ({unit})", fontsize=9)
        ax.grid(True, which="major", alpha=0.3)
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
