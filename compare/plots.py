"""The report's figures (PNG, matplotlib's Agg backend: no display needed).

Each function takes a :class:`~simbridge.compare.pipeline.Comparison` and a path, writes one
PNG and returns the path, or None when the figure has nothing to show.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .diff import DEG, QUANTITIES, yaw
from .fmt import fmt_threshold
from .scenario import format_timestep

if TYPE_CHECKING:
    from .pipeline import Comparison

__all__ = ["paths", "distance", "heading", "joints", "sweep", "ensemble", "all_plots"]

COLORS = ("tab:blue", "tab:orange")


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def _phase_lines(ax: Any, c: Comparison) -> None:
    """Dotted lines at phase starts, names along the bottom of the axes."""
    tr = c.runs[(0, c.timestep)]
    for _name, first, _ in tr.phases[1:]:
        ax.axvline(tr.time[first], color="0.6", lw=0.8, ls=":")
    for name, first, _ in tr.phases:
        ax.annotate(
            name,
            (tr.time[first], 0.02),
            xycoords=ax.get_xaxis_transform(),
            xytext=(3, 0),
            textcoords="offset points",
            fontsize=8,
            color="0.4",
        )


def _save(fig: Any, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    _plt().close(fig)
    return path


def paths(c: Comparison, path: Path) -> Path:
    """Top-down paths (x, y) of the subject's base, both engines, with phase markers. For a
    fixed-base subject: the side view (x, z) of its last link instead."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.4, 5.6))
    fixed = c.scenario.robot(c.scenario.subject).fixed_base
    markers = "os^Dvp*"
    for slot, label in enumerate(c.labels):
        tr = c.runs[(slot, c.timestep)]
        body = tr.body
        xy = body.link_positions[:, -1, :][:, [0, 2]] if fixed else body.base_position[:, :2]
        ax.plot(xy[:, 0], xy[:, 1], color=COLORS[slot], lw=1.4, label=label)
        for k, (_name, first, _) in enumerate(tr.phases):
            ax.plot(*xy[first], markers[k % len(markers)], color=COLORS[slot], ms=7, mfc="none")
        ax.plot(*xy[-1], "x", color=COLORS[slot], ms=9, mew=2)
    for k, (name, _, _) in enumerate(c.runs[(0, c.timestep)].phases):
        ax.plot([], [], markers[k % len(markers)], color="0.3", mfc="none", label=f"start: {name}")
    ax.plot([], [], "x", color="0.3", mew=2, label="end")
    ax.set_aspect("equal", adjustable="datalim")
    what = f"{c.runs[(0, c.timestep)].body.link_names[-1]} link, side view" if fixed else "base"
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)" if fixed else "y (m)")
    ax.set_title(f"{c.scenario.name}: path of {c.scenario.subject} ({what})")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    return _save(fig, path)


def distance(c: Comparison, path: Path) -> Path:
    """The headline quantity (a distance, unless the scenario names another) over time, log
    scale, with its thresholds (1 cm / 10 cm / 1 m), each engine's own time-step error (the
    same quantity, dt against dt/2) and each engine's ensemble spread (dotted), the yardsticks
    the verdict measures the gap against."""
    plt = _plt()
    q = c.headline_quantity
    dt = c.timestep
    fig, ax = plt.subplots(figsize=(8, 5.4))
    v = c.verdict
    floor = max(v.floor, 1e-12) if v is not None else 1e-9
    d = c.cross[dt]
    lowest = [1e-7]
    ax.semilogy(
        d.time,
        np.maximum(d.series[q], floor),
        color="k",
        lw=1.6,
        label=f"{c.labels[0]} vs {c.labels[1]}",
    )
    for slot, label in enumerate(c.labels):
        own = c.own[(slot, dt)]
        ax.semilogy(
            own.time,
            np.maximum(own.series[q], floor),
            color=COLORS[slot],
            lw=1.1,
            ls="--",
            label=f"{label}: own error (dt vs dt/2)",
        )
    if v is not None and c.ensembles and c.ensembles[0].size > 1:
        ax.semilogy(
            v.time,
            np.maximum(v.gap_series, floor),
            color="0.45",
            lw=1.2,
            label="median gap over every pair of runs (judged)",
        )
        for slot, e in enumerate(c.ensembles):
            ax.semilogy(
                v.time,
                np.maximum(v.spreads[slot], floor),
                color=COLORS[slot],
                lw=1.3,
                ls=":",
                label=f"{e.label}: spread of {e.size} perturbed runs",
            )
            positive = v.spreads[slot][v.spreads[slot] > 0]
            if positive.size:
                lowest.append(float(positive.min()) / 2)
    for thr in QUANTITIES[q].thresholds:
        ax.axhline(thr, color="tab:red", lw=0.7, alpha=0.6)
        ax.annotate(
            fmt_threshold(thr, QUANTITIES[q].unit),
            (d.time[-1], thr),
            xytext=(-2, 2),
            textcoords="offset points",
            ha="right",
            fontsize=8,
            color="tab:red",
        )
    highest = max(float(np.max(x.series[q])) for x in [d] + [c.own[(k, dt)] for k in (0, 1)])
    top = max(QUANTITIES[q].thresholds[-1] * 1.5, highest * 2)
    ax.set_ylim(max(min(lowest), floor), top)
    _phase_lines(ax, c)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"{QUANTITIES[q].title} ({QUANTITIES[q].unit})")
    ax.set_title(f"{c.scenario.name}: how far apart, at dt = {format_timestep(dt)} s")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, frameon=False)
    return _save(fig, path)


def heading(c: Comparison, path: Path) -> Path:
    """Base yaw of each engine over time (unwrapped, degrees) and their wrapped difference."""
    plt = _plt()
    fig, (ax, ax2) = plt.subplots(
        2, 1, figsize=(8, 5.5), sharex=True, gridspec_kw={"height_ratios": [2, 1]}
    )
    for slot, label in enumerate(c.labels):
        tr = c.runs[(slot, c.timestep)]
        ax.plot(
            tr.time, np.unwrap(yaw(tr.body.base_orientation)) / DEG, color=COLORS[slot], label=label
        )
    d = c.cross[c.timestep]
    ax2.plot(d.time, d.series["heading"] / DEG, color="k", lw=1.2)
    for thr in QUANTITIES["heading"].thresholds:
        ax2.axhline(thr / DEG, color="tab:red", lw=0.7, alpha=0.6)
    ax.set_ylabel("heading (yaw, deg, unwrapped)")
    ax2.set_ylabel("|difference| (deg)")
    ax2.set_xlabel("time (s)")
    ax.set_title(f"{c.scenario.name}: heading of {c.scenario.subject}")
    ax.grid(alpha=0.3)
    ax2.grid(alpha=0.3)
    ax.legend(fontsize=8)
    _phase_lines(ax, c)
    return _save(fig, path)


def joints(c: Comparison, path: Path) -> Path | None:
    """Speed of every velocity-commanded joint of the subject against its target, both
    engines. None when no joint of the subject gets a velocity command."""
    tr0 = c.runs[(0, c.timestep)]
    modes = tr0.body.joint_modes
    cols = [j for j in range(modes.shape[1]) if np.any(modes[:, j] == 1)]
    if not cols:
        cols = [j for j in range(modes.shape[1]) if np.any(modes[:, j] > 0)]
    if not cols:
        return None
    plt = _plt()
    n = len(cols)
    ncols = 2 if n > 1 else 1
    nrows = math.ceil(n / ncols)
    fig, axes = plt.subplots(
        nrows, ncols, figsize=(8, 2.6 * nrows + 0.6), sharex=True, squeeze=False
    )
    for k, j in enumerate(cols):
        ax = axes[k // ncols][k % ncols]
        for slot, label in enumerate(c.labels):
            tr = c.runs[(slot, c.timestep)]
            ax.plot(tr.time, tr.body.joint_velocities[:, j], color=COLORS[slot], lw=1, label=label)
        target = np.where(tr0.body.joint_modes[:, j] == 1, tr0.body.joint_targets[:, j], np.nan)
        ax.plot(tr0.time, target, color="k", lw=1, ls="--", label="target")
        ax.set_title(tr0.body.joint_names[j], fontsize=9)
        ax.grid(alpha=0.3)
        ax.set_ylabel("rad/s")
    for k in range(n, nrows * ncols):
        axes[k // ncols][k % ncols].set_visible(False)
    axes[0][0].legend(fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    fig.suptitle(f"{c.scenario.name}: joint speed against its target")
    return _save(fig, path)


def sweep(c: Comparison, path: Path) -> Path | None:
    """Speed against self-consistency per engine, and the cross-engine gap against the time
    step. None with a single time step."""
    if len(c.timesteps) < 2:
        return None
    plt = _plt()
    q = c.headline_quantity
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(10, 4.2))
    floor = 1e-9
    for slot, label in enumerate(c.labels):
        speed = [c.runs[(slot, t)].wall_per_sim_second() for t in c.timesteps]
        err = [max(c.own[(slot, t)].final[q], floor) for t in c.timesteps]
        ax.loglog(speed, err, "o-", color=COLORS[slot], label=label)
        for s, e, t in zip(speed, err, c.timesteps, strict=True):
            ax.annotate(
                format_timestep(t), (s, e), xytext=(4, 4), textcoords="offset points", fontsize=8
            )
    ax.set_xlabel("wall time per simulated second (s)")
    ax.set_ylabel(f"own error: final {QUANTITIES[q].title}, dt vs dt/2 ({QUANTITIES[q].unit})")
    ax.set_title("speed against self-consistency")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    gap = [max(c.cross[t].final[q], floor) for t in c.timesteps]
    gmax = [max(c.cross[t].maximum[q], floor) for t in c.timesteps]
    ax2.loglog(c.timesteps, gap, "o-", color="k", label="final")
    ax2.loglog(c.timesteps, gmax, "s--", color="0.5", label="largest")
    ax2.set_xlabel("time step (s)")
    ax2.set_ylabel(f"{c.labels[0]} vs {c.labels[1]} ({QUANTITIES[q].unit})")
    ax2.set_title("cross-engine gap against the time step")
    ax2.grid(alpha=0.3, which="both")
    ax2.legend(fontsize=8)
    return _save(fig, path)


def ensemble(c: Comparison, path: Path) -> Path | None:
    """Where every ensemble run ends, both engines: top view (x, y) and side view (x, z) of the
    followed robot's base (of its last link's centre of mass for a fixed base), member 0 (the
    nominal run) ringed. The legend sits below the axes. None without perturbed runs."""
    if not c.ensembles or c.ensembles[0].size < 2:
        return None
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.9))
    markers = ("o", "x")
    fixed = c.scenario.robot(c.scenario.subject).fixed_base
    for ax, (i, j, names) in zip(axes, ((0, 1, "xy"), (0, 2, "xz")), strict=True):
        for slot, e in enumerate(c.ensembles):
            pts = e.end_points
            ax.plot(
                pts[:, i],
                pts[:, j],
                markers[slot],
                color=COLORS[slot],
                ms=6,
                mfc="none" if markers[slot] == "o" else COLORS[slot],
                alpha=0.8,
                label=f"{e.label}: {e.size} runs",
            )
            ax.plot(
                pts[0, i],
                pts[0, j],
                "s",
                color=COLORS[slot],
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
    if v is not None:
        title += f"; verdict: {v.verdict}"
    fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def all_plots(c: Comparison, out: Path) -> dict[str, Path]:
    """Every figure into folder ``out``: name -> path (figures with nothing to show left out)."""
    made = {
        "paths": paths(c, out / "paths.png"),
        "distance": distance(c, out / "distance.png"),
        "heading": heading(c, out / "heading.png"),
        "joints": joints(c, out / "joints.png"),
        "sweep": sweep(c, out / "sweep.png"),
        "ensemble": ensemble(c, out / "ensemble.png"),
    }
    return {k: v for k, v in made.items() if v is not None}
