"""The report's figures (PNG, matplotlib's Agg backend: no display needed): the paths, the
distance, the heading, the height, the sweep and the ensemble here, the joints and motors in
:mod:`.plot_joints`, the events in :mod:`.plot_events`, all in :mod:`.plot_style`'s style;
:func:`all_plots` draws every one.

Each function takes a :class:`~simbridge.compare.pipeline.Comparison` and a path, writes one
PNG and returns the path, or None when the figure has nothing to show.

Both engines are drawn so that neither hides the other: the first solid, the second dashed on
top of it, in distinct colours, with sparse markers of different shapes; legends sit below the
axes, never on the data.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..analysis.diff import DEG, QUANTITIES, yaw
from ..scenario import format_timestep
from .fmt import fmt_threshold
from .plot_events import events
from .plot_joints import JOINT_PLOTS, held_commands, joints, motors
from .plot_style import (
    COLORS,
    PAIR_COLORS,
    engine_style,
    first_pair_mark,
    legend_below,
    pairs_of,
    phase_lines,
    pyplot,
    save,
    save_fixed,
)

if TYPE_CHECKING:
    from ..pipeline import Comparison, Pair

__all__ = [
    "paths",
    "distance",
    "heading",
    "height",
    "joints",
    "motors",
    "events",
    "sweep",
    "ensemble",
    "all_plots",
    "COLORS",
    "JOINT_PLOTS",
    "held_commands",
]


def paths(c: Comparison, path: Path) -> Path:
    """Top-down paths (x, y) of the subject's base, both engines, with phase markers. For a
    fixed-base subject: the side view (x, z) of its last link instead."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 5.6))
    fixed = c.scenario.robot(c.scenario.subject).fixed_base
    markers = "D^vph*"  # phase starts; the lines carry o and s
    for slot, label in enumerate(c.labels):
        tr = c.runs[(slot, c.timestep)]
        body = tr.body
        xy = body.link_positions[:, -1, :][:, [0, 2]] if fixed else body.base_position[:, :2]
        ax.plot(xy[:, 0], xy[:, 1], label=label, **engine_style(slot, len(xy)))
        for k, (_name, first, _) in enumerate(tr.phases):
            ax.plot(
                *xy[first],
                markers[k % len(markers)],
                color=COLORS[slot % len(COLORS)],
                ms=7,
                mfc="none",
            )
        ax.plot(*xy[-1], "x", color=COLORS[slot % len(COLORS)], ms=9, mew=2)
    for k, (name, _, _) in enumerate(c.runs[(0, c.timestep)].phases):
        ax.plot([], [], markers[k % len(markers)], color="0.3", mfc="none", label=f"start: {name}")
    ax.plot([], [], "x", color="0.3", mew=2, label="end")
    ax.set_aspect("equal", adjustable="datalim")
    what = f"{c.runs[(0, c.timestep)].body.link_names[-1]} link, side view" if fixed else "base"
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)" if fixed else "y (m)")
    ax.set_title(f"{c.scenario.name}: path of {c.scenario.subject} ({what})")
    ax.grid(alpha=0.3)
    legend_below(fig, ax, ncol=3)
    return save_fixed(fig, path)


def distance(c: Comparison, path: Path) -> Path:
    """The headline quantity (a distance, unless the scenario names another) over time, log
    scale, with its thresholds (1 cm / 10 cm / 1 m), each engine's own time-step error (the
    same quantity, dt against dt/2) and each engine's ensemble spread (dotted), the yardsticks
    the verdict measures the gap against.

    Args:
        c: the comparison.
        path: the PNG to write.

    Returns:
        ``path``.
    """
    plt = pyplot()
    q = c.headline_quantity
    dt = c.timestep
    fig, ax = plt.subplots(figsize=(8, 5.4))
    v = c.verdict
    floor = max(v.floor, 1e-12) if v is not None else 1e-9
    pairs = pairs_of(c)
    _nominal_and_own_lines(ax, c, pairs, floor)
    lowest = [1e-7] + _judged_lines(ax, c, pairs, floor)
    _threshold_lines(ax, q)
    highest = max(
        float(np.max(x.series[q]))
        for x in [p.cross[dt] for p in pairs] + [c.own[(k, dt)] for k in range(len(c.labels))]
    )
    top = max(QUANTITIES[q].thresholds[-1] * 1.5, highest * 2)
    ax.set_ylim(max(min(lowest), floor), top)
    phase_lines(ax, c)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"{QUANTITIES[q].title} ({QUANTITIES[q].unit})")
    ax.set_title(f"{c.scenario.name}: how far apart, at dt = {format_timestep(dt)} s", pad=14)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, frameon=False)
    return save(fig, path)


def _nominal_and_own_lines(ax: Any, c: Comparison, pairs: list[Pair], floor: float) -> None:
    """Every pair's nominal gap (thick, a colour per pair), then each engine's own time-step
    error (dashed, the engine's colour), each held above ``floor``."""
    q = c.headline_quantity
    dt = c.timestep
    for k, p in enumerate(pairs):  # every pair's nominal gap, thick
        d = p.cross[dt]
        ax.semilogy(
            d.time,
            np.maximum(d.series[q], floor),
            color=PAIR_COLORS[k % len(PAIR_COLORS)],
            lw=2.6 if k == 0 else 2.0,
            label=f"{c.labels[p.a]} vs {c.labels[p.b]}: nominal runs",
        )
    for slot, label in enumerate(c.labels):
        own = c.own[(slot, dt)]
        ax.semilogy(
            own.time,
            np.maximum(own.series[q], floor),
            color=COLORS[slot % len(COLORS)],
            lw=2.2 if slot == 0 else 1.2,
            ls="--" if slot == 0 else (0, (3, 2)),
            label=f"{label}: own error (dt vs dt/2)",
        )


def _judged_lines(ax: Any, c: Comparison, pairs: list[Pair], floor: float) -> list[float]:
    """With ensembles of more than one run: every pair's judged gap (dash-dotted) and each
    engine's spread (dotted). Returns half of each spread's smallest positive value (for the
    y axis's lower limit); empty without ensembles."""
    v = c.verdict
    lowest: list[float] = []
    if v is None or not c.ensembles or c.ensembles[0].size <= 1:
        return lowest
    for k, p in enumerate(pairs):  # every pair's judged gap, thin
        if p.verdict is None:
            continue
        ax.semilogy(
            p.verdict.time,
            np.maximum(p.verdict.gap_series, floor),
            color=PAIR_COLORS[k % len(PAIR_COLORS)] if len(pairs) > 1 else "0.45",
            lw=1.3,
            ls="-.",
            alpha=0.85,
            label=f"{c.labels[p.a]} vs {c.labels[p.b]}: median gap over every pair of runs "
            "(judged)",
        )
    for slot, e in enumerate(c.ensembles):
        spread = v.spreads[slot] if slot < 2 else e.spread  # the first pair's, the others'
        ax.semilogy(
            v.time,
            np.maximum(spread, floor),
            color=COLORS[slot % len(COLORS)],
            lw=2.4 if slot == 0 else 1.3,
            ls=":",
            label=f"{e.label}: spread of {e.size} perturbed runs",
        )
        positive = spread[spread > 0]
        if positive.size:
            lowest.append(float(positive.min()) / 2)
    return lowest


def _threshold_lines(ax: Any, q: str) -> None:
    """The quantity ``q``'s thresholds: a red line each, named right of the axes."""
    for thr in QUANTITIES[q].thresholds:
        ax.axhline(thr, color="tab:red", lw=0.7, alpha=0.6)
        ax.annotate(  # right of the axes, over no data
            fmt_threshold(thr, QUANTITIES[q].unit),
            (1.0, thr),
            xycoords=ax.get_yaxis_transform(),
            xytext=(3, 0),
            textcoords="offset points",
            ha="left",
            va="center",
            fontsize=8,
            color="tab:red",
        )


def heading(c: Comparison, path: Path) -> Path | None:
    """Base yaw of each engine over time (unwrapped, degrees) and their wrapped difference.
    None for a fixed base (its heading never changes)."""
    if c.scenario.robot(c.scenario.subject).fixed_base:
        return None
    plt = pyplot()
    fig, (ax, ax2) = plt.subplots(
        2, 1, figsize=(8, 5.5), sharex=True, gridspec_kw={"height_ratios": [2, 1]}
    )
    for slot, label in enumerate(c.labels):
        tr = c.runs[(slot, c.timestep)]
        ax.plot(
            tr.time,
            np.unwrap(yaw(tr.body.base_orientation)) / DEG,
            label=label,
            **engine_style(slot, len(tr.time)),
        )
    pairs = pairs_of(c)
    for k, p in enumerate(pairs):
        d = p.cross[c.timestep]
        ax2.plot(
            d.time,
            d.series["heading"] / DEG,
            color=PAIR_COLORS[k % len(PAIR_COLORS)],
            lw=1.2,
            label=f"|{c.labels[p.a]} - {c.labels[p.b]}|" if len(pairs) > 1 else None,
        )
    for thr in QUANTITIES["heading"].thresholds:
        ax2.axhline(thr / DEG, color="tab:red", lw=0.7, alpha=0.6)
    ax.ticklabel_format(axis="y", useOffset=False)  # no "+1.8e2" over the phase names
    ax.set_ylabel("heading (yaw, deg, unwrapped)")
    ax2.set_ylabel("|difference| (deg)")
    ax2.set_xlabel("time (s)")
    ax.set_title(f"{c.scenario.name}: heading of {c.scenario.subject}", pad=14)
    ax.grid(alpha=0.3)
    ax2.grid(alpha=0.3)
    if len(pairs) == 1:
        ax2.plot([], [], color="k", lw=1.2, label="|difference|")
    ax2.plot([], [], color="tab:red", lw=0.7, label="1° and 10°")
    phase_lines(ax, c)
    handles, labels = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    fig.legend(handles + h2, labels + l2, loc="lower center", ncol=4, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    return save_fixed(fig, path)


def height(c: Comparison, path: Path) -> Path:
    """Height over time (along the world's up, against gravity): the base link frame of a
    mobile subject, the last link's centre of mass of a fixed one; both engines, with the
    instant the gap first reaches its threshold."""
    from ..run.quantities import up_of

    plt = pyplot()
    fixed = c.scenario.robot(c.scenario.subject).fixed_base
    fig, ax = plt.subplots(figsize=(8, 4.6))
    for slot, label in enumerate(c.labels):
        tr = c.runs[(slot, c.timestep)]
        up = up_of(tr)
        pts = tr.body.link_positions[:, -1, :] if fixed else tr.body.base_position
        ax.plot(tr.time, pts @ up, label=label, **engine_style(slot, len(tr.time)))
    q = c.headline_quantity
    thr = QUANTITIES[q].thresholds[0]
    t = c.cross[c.timestep].first_crossing(q, thr)
    if t is not None:
        ax.axvline(t, color="tab:red", lw=1.0, ls="-.", alpha=0.8)
        ax.plot(
            [],
            [],
            color="tab:red",
            lw=1.0,
            ls="-.",
            label=(
                f"the gap{first_pair_mark(c)} reaches {fmt_threshold(thr, QUANTITIES[q].unit)} "
                f"(t = {t:.3f} s)"
            ),
        )
    phase_lines(ax, c)
    what = f"{c.runs[(0, c.timestep)].body.link_names[-1]}'s centre of mass" if fixed else "base"
    ax.set_xlabel("time (s)")
    ax.set_ylabel("height (m, against gravity)")
    ax.set_title(f"{c.scenario.name}: height of {c.scenario.subject} ({what})", pad=14)
    ax.grid(alpha=0.3)
    legend_below(fig, ax, ncol=3)
    return save_fixed(fig, path)


def sweep(c: Comparison, path: Path) -> Path | None:
    """Speed against self-consistency per engine, and the cross-engine gap against the time
    step. None with a single time step."""
    if len(c.timesteps) < 2:
        return None
    plt = pyplot()
    q = c.headline_quantity
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(10, 4.2))
    floor = 1e-9
    for slot, label in enumerate(c.labels):
        speed = [c.runs[(slot, t)].wall_per_sim_second() for t in c.timesteps]
        err = [max(c.own[(slot, t)].final[q], floor) for t in c.timesteps]
        ax.loglog(speed, err, "o-", color=COLORS[slot % len(COLORS)], label=label)
        for s, e, t in zip(speed, err, c.timesteps, strict=True):
            ax.annotate(
                format_timestep(t), (s, e), xytext=(4, 4), textcoords="offset points", fontsize=8
            )
    ax.set_xlabel("wall time per simulated second (s)")
    ax.set_ylabel(f"own error: final {QUANTITIES[q].title}, dt vs dt/2 ({QUANTITIES[q].unit})")
    ax.set_title("speed against self-consistency")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    pairs = pairs_of(c)
    for k, p in enumerate(pairs):
        gap = [max(p.cross[t].final[q], floor) for t in c.timesteps]
        gmax = [max(p.cross[t].maximum[q], floor) for t in c.timesteps]
        color = PAIR_COLORS[k % len(PAIR_COLORS)]
        name = f"{c.labels[p.a]} vs {c.labels[p.b]}: " if len(pairs) > 1 else ""
        ax2.loglog(c.timesteps, gap, "o-", color=color, label=f"{name}final")
        ax2.loglog(
            c.timesteps,
            gmax,
            "s--",
            color=color if len(pairs) > 1 else "0.5",
            alpha=0.6 if len(pairs) > 1 else 1.0,
            label=f"{name}largest",
        )
    ax2.set_xlabel("time step (s)")
    ax2.set_ylabel(
        f"{c.labels[0]} vs {c.labels[1]} ({QUANTITIES[q].unit})"
        if len(pairs) == 1
        else f"{QUANTITIES[q].title} between each pair ({QUANTITIES[q].unit})"
    )
    ax2.set_title("cross-engine gap against the time step")
    ax2.grid(alpha=0.3, which="both")
    ax2.legend(fontsize=8)
    return save(fig, path)


def ensemble(c: Comparison, path: Path) -> Path | None:
    """Where every ensemble run ends, both engines: top view (x, y) and side view (x, z) of the
    followed robot's base (of its last link's centre of mass for a fixed base), member 0 (the
    nominal run) ringed. The legend sits below the axes. None without perturbed runs."""
    if not c.ensembles or c.ensembles[0].size < 2:
        return None
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.9))
    markers = ("o", "x", "+", "^", "D", "v")
    fixed = c.scenario.robot(c.scenario.subject).fixed_base
    for ax, (i, j, names) in zip(axes, ((0, 1, "xy"), (0, 2, "xz")), strict=True):
        for slot, e in enumerate(c.ensembles):
            pts = e.end_points
            ax.plot(
                pts[:, i],
                pts[:, j],
                markers[slot % len(markers)],
                color=COLORS[slot % len(COLORS)],
                ms=6,
                mfc="none" if slot % len(markers) == 0 else COLORS[slot % len(COLORS)],
                alpha=0.8,
                label=f"{e.label}: {e.size} runs",
            )
            ax.plot(
                pts[0, i],
                pts[0, j],
                "s",
                color=COLORS[slot % len(COLORS)],
                ms=11,
                mfc="none",
                mew=1.2,
                label=f"{e.label}: nominal run",
            )
        ax.set_xlabel(f"{names[0]} (m)")
        ax.set_ylabel(f"{names[1]} (m)")
        ax.set_title("top view" if names == "xy" else "side view")
        ax.grid(alpha=0.3)
        ax.margins(0.15)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=8, frameon=False)
    what = "last link" if fixed else "base"
    v = c.verdict
    title = f"{c.scenario.name}: where each run ends ({c.scenario.subject}'s {what})"
    if v is not None and len(pairs_of(c)) == 1:  # more pairs: their verdicts are report.md's
        title += f"; verdict: {v.verdict}"
    fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def all_plots(c: Comparison, out: Path) -> dict[str, Path]:
    """Every figure into folder ``out``: name -> path (figures with nothing to show left out)."""
    made: dict[str, Path | None] = {
        "paths": paths(c, out / "paths.png"),
        "distance": distance(c, out / "distance.png"),
        "height": height(c, out / "height.png"),
        "heading": heading(c, out / "heading.png"),
        "events": events(c, out / "events.png"),
    }
    made.update(joints(c, out))
    made["motors"] = motors(c, out / "motors.png")
    made["sweep"] = sweep(c, out / "sweep.png")
    made["ensemble"] = ensemble(c, out / "ensemble.png")
    return {k: v for k, v in made.items() if v is not None}
