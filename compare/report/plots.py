"""The report's figures (PNG, matplotlib's Agg backend: no display needed).

One file of about 650 lines: one function per figure, all sharing the style helpers at the top.

Each function takes a :class:`~simbridge.compare.pipeline.Comparison` and a path, writes one
PNG and returns the path, or None when the figure has nothing to show.

Both engines are drawn so that neither hides the other: the first solid, the second dashed on
top of it, in distinct colours, with sparse markers of different shapes; legends sit below the
axes, never on the data.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..analysis.diff import DEG, QUANTITIES, yaw
from ..scenario import format_timestep
from .fmt import fmt_threshold

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
    "JOINT_PLOTS",
]

COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown")
PAIR_COLORS = ("k", "tab:purple", "tab:brown", "tab:olive", "tab:cyan", "tab:pink", "0.5")
"""A pair's gap, one colour each (the first pair black), apart from the engines' first four."""
LINES = ("-", (0, (5, 3)), (0, (1, 2)), "-.", (0, (3, 1, 1, 1)), (0, (5, 1)))
MARKERS = ("o", "s", "^", "D", "v", "P")
"""Engine slot -> its colour, line and marker (a comparison of more engines than this cycles)."""
JOINT_PLOTS = {1: "velocity", 2: "position", 3: "torque"}
"""Command mode code -> the name of its figure (``joints_<name>.png``)."""


def _style(slot: int, n: int) -> dict[str, Any]:
    """Line keywords of engine ``slot`` for a series of ``n`` points: a wide solid line or a
    thinner dashed one drawn over it, its colour, a marker every ``n // 12`` points (offset so
    the two engines' markers alternate)."""
    every = max(1, n // 12)
    return {
        "color": COLORS[slot % len(COLORS)],
        "ls": LINES[slot % len(LINES)],
        "lw": 2.0 if slot == 0 else 1.3,  # the wider solid line shows under the dashed one
        "marker": MARKERS[slot % len(MARKERS)],
        "ms": 4,
        "mfc": "none" if slot == 0 else COLORS[slot % len(COLORS)],
        "markevery": (slot * every // 2, every),
        "zorder": 2 + slot,
    }


def _legend_below(fig: Any, ax: Any, ncol: int = 3) -> None:
    """One legend for the figure, centred below its axes (out of the data's way)."""
    handles, labels = ax.get_legend_handles_labels()
    if not handles:  # nothing to name: the axes alone, laid out
        fig.tight_layout()
        return
    rows = math.ceil(len(handles) / ncol)
    fig.legend(handles, labels, loc="lower center", ncol=ncol, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.035 + 0.035 * rows, 1, 1))


def _save_fixed(fig: Any, path: Path) -> Path:
    """Save without a further tight_layout (the layout already leaves room for the legend)."""
    fig.savefig(path, dpi=110)
    _plt().close(fig)
    return path


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def _phase_lines(ax: Any, c: Comparison) -> None:
    """Dotted lines at phase starts, names just above the axes (over no data: callers lift
    their title with ``pad=14``)."""
    tr = c.runs[(0, c.timestep)]
    for _name, first, _ in tr.phases[1:]:
        ax.axvline(tr.time[first], color="0.6", lw=0.8, ls=":")
    for name, first, _ in tr.phases:
        ax.annotate(
            name,
            (tr.time[first], 1.0),
            xycoords=ax.get_xaxis_transform(),
            xytext=(3, 2),
            textcoords="offset points",
            va="bottom",
            fontsize=7.5,
            color="0.35",
        )


def _save(fig: Any, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    _plt().close(fig)
    return path


def _pairs(c: Comparison) -> list[Pair]:
    """Every pair of ``c`` (one made by hand without ``pairs``: engines 0 and 1)."""
    from ..pipeline import Pair

    return c.pairs or [Pair(0, 1, c.cross, c.verdict)]


def _first_pair(c: Comparison) -> str:
    """`` (pybullet - mujoco)`` with more than two engines: the pair a first-pair mark is of."""
    return f" ({c.labels[0]} - {c.labels[1]})" if len(c.labels) > 2 else ""


def paths(c: Comparison, path: Path) -> Path:
    """Top-down paths (x, y) of the subject's base, both engines, with phase markers. For a
    fixed-base subject: the side view (x, z) of its last link instead."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.4, 5.6))
    fixed = c.scenario.robot(c.scenario.subject).fixed_base
    markers = "D^vph*"  # phase starts; the lines carry o and s
    for slot, label in enumerate(c.labels):
        tr = c.runs[(slot, c.timestep)]
        body = tr.body
        xy = body.link_positions[:, -1, :][:, [0, 2]] if fixed else body.base_position[:, :2]
        ax.plot(xy[:, 0], xy[:, 1], label=label, **_style(slot, len(xy)))
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
    _legend_below(fig, ax, ncol=3)
    return _save_fixed(fig, path)


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
    pairs = _pairs(c)
    lowest = [1e-7]
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
    if v is not None and c.ensembles and c.ensembles[0].size > 1:
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
    highest = max(
        float(np.max(x.series[q]))
        for x in [p.cross[dt] for p in pairs] + [c.own[(k, dt)] for k in range(len(c.labels))]
    )
    top = max(QUANTITIES[q].thresholds[-1] * 1.5, highest * 2)
    ax.set_ylim(max(min(lowest), floor), top)
    _phase_lines(ax, c)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"{QUANTITIES[q].title} ({QUANTITIES[q].unit})")
    ax.set_title(f"{c.scenario.name}: how far apart, at dt = {format_timestep(dt)} s", pad=14)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, frameon=False)
    return _save(fig, path)


def heading(c: Comparison, path: Path) -> Path | None:
    """Base yaw of each engine over time (unwrapped, degrees) and their wrapped difference.
    None for a fixed base (its heading never changes)."""
    if c.scenario.robot(c.scenario.subject).fixed_base:
        return None
    plt = _plt()
    fig, (ax, ax2) = plt.subplots(
        2, 1, figsize=(8, 5.5), sharex=True, gridspec_kw={"height_ratios": [2, 1]}
    )
    for slot, label in enumerate(c.labels):
        tr = c.runs[(slot, c.timestep)]
        ax.plot(
            tr.time,
            np.unwrap(yaw(tr.body.base_orientation)) / DEG,
            label=label,
            **_style(slot, len(tr.time)),
        )
    pairs = _pairs(c)
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
    _phase_lines(ax, c)
    handles, labels = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    fig.legend(handles + h2, labels + l2, loc="lower center", ncol=4, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    return _save_fixed(fig, path)


def held_commands(modes: np.ndarray, targets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One joint's recorded command modes and targets (T,) with the velocity and position
    commands carried into the later rows that record none, as the engines hold them until
    replaced (a torque command lasts its own steps)."""
    rows = np.arange(len(modes))
    last = np.maximum.accumulate(np.where(modes != 0, rows, 0))
    held = (modes == 0) & np.isin(modes[last], (1, 2))
    return np.where(held, modes[last], modes), np.where(held, targets[last], targets)


def _joint_columns(c: Comparison, mode: int) -> list[int]:
    """The subject's joints commanded in ``mode`` (1 velocity, 2 position, 3 torque) at some
    step, by either engine's record."""
    cols: set[int] = set()
    for slot in range(len(c.labels)):
        modes = c.runs[(slot, c.timestep)].body.joint_modes
        cols |= {j for j in range(modes.shape[1]) if np.any(modes[:, j] == mode)}
    return sorted(cols)


_WHAT = {
    "speed ({unit})": "velocity",
    "position ({unit})": "position",
    "torque ({unit})": "force",
    "|force| ({unit})": "force",
}
_UNITS = {
    "position": ("rad", "m"),
    "velocity": ("rad/s", "m/s"),
    "force": ("N·m", "N"),
}


def _unit(body: Any, j: int, what: str) -> str:
    """The unit of joint ``j``'s ``what`` (position, velocity, force): prismatic or not."""
    prismatic = body.joint_types is not None and body.joint_types[j] == "prismatic"
    return _UNITS[what][1 if prismatic else 0]


def _joint_grid(
    c: Comparison,
    cols: list[int],
    series: Any,
    target: Any,
    ylabel: str,
    title: str,
    target_label: str,
    path: Path,
    target_axis: str | None = None,
) -> Path:
    """One panel per joint: ``series(body, j)`` of both engines, ``target(body, j)`` (NaN where
    none) as a thin black dotted line (on a second y axis labelled ``target_axis`` when given:
    another quantity than the series); the legend below every panel."""
    plt = _plt()
    n = len(cols)
    ncols = 1 if n == 1 else 2 if n <= 4 else 3
    nrows = math.ceil(n / ncols)
    fig, axes = plt.subplots(
        nrows,
        ncols,
        figsize=(max(7.5, 4.2 * ncols + 1.0), 2.3 * nrows + 1.3),
        sharex=True,
        squeeze=False,
    )
    tr0 = c.runs[(0, c.timestep)]
    for k, j in enumerate(cols):
        ax = axes[k // ncols][k % ncols]
        for slot, label in enumerate(c.labels):
            tr = c.runs[(slot, c.timestep)]
            ax.plot(tr.time, series(tr.body, j), label=label, **_style(slot, len(tr.time)))
        tgt = target(tr0.body, j)
        if tgt is not None and np.isfinite(tgt).any():
            tax = ax
            if target_axis is not None:
                tax = ax.twinx()
                tax.set_ylabel(target_axis.format(unit=_unit(tr0.body, j, "force")), fontsize=8)
                tax.tick_params(labelsize=8)
                lo, hi = float(np.nanmin(tgt)), float(np.nanmax(tgt))
                if max(abs(lo), abs(hi)) > 0:  # from zero: the torque's size, not its noise
                    tax.set_ylim(1.15 * min(lo, 0.0), 1.15 * max(hi, 0.0))
            tax.plot(tr0.time, tgt, color="k", lw=1.0, ls=":", zorder=5)
            ax.plot([], [], color="k", lw=1.0, ls=":", label=target_label)  # in the legend
        ax.set_title(tr0.body.joint_names[j], fontsize=9, pad=11)  # above a "1e-5" offset
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=8)
        ax.set_ylabel(ylabel.format(unit=_unit(tr0.body, j, _WHAT[ylabel])), fontsize=8)
    for k in range(n, nrows * ncols):
        axes[k // ncols][k % ncols].set_visible(False)
    for k in range(min(ncols, n)):
        bottom = k + ncols * ((n - 1 - k) // ncols)  # the lowest panel of column k
        axes[bottom // ncols][bottom % ncols].set_xlabel("time (s)", fontsize=8)
        axes[bottom // ncols][bottom % ncols].xaxis.set_tick_params(labelbottom=True)
    fig.suptitle(title, fontsize=10)
    handles, labels = [], []
    for ax in axes.flat:
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            if lab not in labels:
                handles.append(h)
                labels.append(lab)
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.45 / (2.3 * nrows + 1.3), 1, 1))
    return _save_fixed(fig, path)


def joints(c: Comparison, out: Path) -> dict[str, Path]:
    """One figure per command mode the subject's joints get (``joints_velocity.png``: speed
    against its target; ``joints_position.png``: position against its target;
    ``joints_torque.png``: the joint's speed under the commanded torque, on a second axis; the
    force an engine reports is its motor's, not the torque applied: on spinning-wheel PyBullet
    reports 0.0625 N·m, its velocity motor's last, and MuJoCo 0 while 0.05 N·m is applied),
    both engines, one panel per commanded joint. Returns name -> path (``joints_velocity``...),
    modes without a commanded joint left out."""
    made = {}
    sc = c.scenario.name

    def where(mode: int) -> Any:
        def target(body: Any, j: int) -> np.ndarray:
            modes, targets = held_commands(body.joint_modes[:, j], body.joint_targets[:, j])
            return np.where(modes == mode, targets, np.nan)

        return target

    specs = {
        1: (lambda b, j: b.joint_velocities[:, j], "speed ({unit})", "joint speed", "target speed"),
        2: (lambda b, j: b.joint_positions[:, j], "position ({unit})", "joint position", "target"),
        3: (lambda b, j: b.joint_velocities[:, j], "speed ({unit})", "", "commanded torque"),
    }
    for mode, name in JOINT_PLOTS.items():
        cols = _joint_columns(c, mode)
        if not cols:
            continue
        series, unit, what, target_label = specs[mode]
        title = f"{sc}: {what} against its target ({name}-commanded joints)"
        if mode == 3:
            title = f"{sc}: joint speed under the commanded torque (dotted, right axis)"
        made[f"joints_{name}"] = _joint_grid(
            c,
            cols,
            series,
            where(mode),
            unit,
            title,
            target_label,
            out / f"joints_{name}.png",
            target_axis="torque ({unit})" if mode == 3 else None,
        )
    return made


def motors(c: Comparison, path: Path) -> Path | None:
    """The force (absolute) of every velocity- or position-commanded joint of the subject
    against its ``max_force`` (dotted): where a line runs along it, the motor saturates.
    None when no joint has such a command (or the runs did not record ``max_force``)."""
    cols = sorted(set(_joint_columns(c, 1)) | set(_joint_columns(c, 2)))
    if not cols or c.runs[(0, c.timestep)].body.joint_max_forces is None:
        return None

    def limit(body: Any, j: int) -> np.ndarray:
        mf = body.joint_max_forces[:, j]
        return mf

    path = _joint_grid(
        c,
        cols,
        lambda b, j: np.abs(b.joint_forces[:, j]),
        limit,
        "|force| ({unit})",
        f"{c.scenario.name}: motor force against its max_force (saturated where they meet)",
        "max_force",
        path,
    )
    return path


def height(c: Comparison, path: Path) -> Path:
    """Height over time (along the world's up, against gravity): the base link frame of a
    mobile subject, the last link's centre of mass of a fixed one; both engines, with the
    instant the gap first reaches its threshold."""
    from ..run.quantities import up_of

    plt = _plt()
    fixed = c.scenario.robot(c.scenario.subject).fixed_base
    fig, ax = plt.subplots(figsize=(8, 4.6))
    for slot, label in enumerate(c.labels):
        tr = c.runs[(slot, c.timestep)]
        up = up_of(tr)
        pts = tr.body.link_positions[:, -1, :] if fixed else tr.body.base_position
        ax.plot(tr.time, pts @ up, label=label, **_style(slot, len(tr.time)))
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
                f"the gap{_first_pair(c)} reaches {fmt_threshold(thr, QUANTITIES[q].unit)} "
                f"(t = {t:.3f} s)"
            ),
        )
    _phase_lines(ax, c)
    what = f"{c.runs[(0, c.timestep)].body.link_names[-1]}'s centre of mass" if fixed else "base"
    ax.set_xlabel("time (s)")
    ax.set_ylabel("height (m, against gravity)")
    ax.set_title(f"{c.scenario.name}: height of {c.scenario.subject} ({what})", pad=14)
    ax.grid(alpha=0.3)
    _legend_below(fig, ax, ncol=3)
    return _save_fixed(fig, path)


_LANE_KINDS = (
    "contact_made",
    "contact_lost",
    "contact_chatter",
    "airborne",
    "peak_height",
    "tipped_over",
    "joint_limit",
    "motor_saturated",
)

_MARKED = {"contact_made": "v", "contact_lost": "^", "peak_height": "*"}
"""The events drawn as instants, by their marker (the others are bars)."""


def events(c: Comparison, path: Path) -> Path | None:
    """A timeline of both engines' events (:mod:`.events`), one lane per engine and kind:
    intervals as bars, instants as markers; the instant the gap first reaches its threshold
    as a vertical line. None when neither engine has an event."""
    from ..analysis.events import engine_events

    found = engine_events(c)
    lanes = [
        (slot, kind)
        for slot, e in enumerate(found)
        for kind in _LANE_KINDS
        if any(x.kind == kind for x in e.events)
    ]
    if not lanes:
        return None
    plt = _plt()
    fig, ax = plt.subplots(figsize=(9, 1.2 + 0.32 * len(lanes) + 0.6))
    end = float(c.runs[(0, c.timestep)].time[-1])
    for y, (slot, kind) in enumerate(lanes):
        for x in found[slot].events:
            if x.kind != kind:
                continue
            if kind in (
                "airborne",
                "tipped_over",
                "contact_chatter",
                "joint_limit",
                "motor_saturated",
            ):
                stop = end if x.end is None else x.end
                ax.broken_barh(
                    [(x.time, max(stop - x.time, c.timestep))],
                    (y - 0.3, 0.6),
                    facecolors=COLORS[slot % len(COLORS)],
                    alpha=0.55,
                    edgecolor=COLORS[slot % len(COLORS)],
                )
            else:
                ax.plot(
                    x.time,
                    y,
                    _MARKED[kind],
                    color=COLORS[slot % len(COLORS)],
                    ms=6,
                    mfc="none" if kind == "contact_lost" else COLORS[slot % len(COLORS)],
                )
    ax.set_yticks(range(len(lanes)))
    ax.set_yticklabels([f"{c.labels[s]}: {k.replace('_', ' ')}" for s, k in lanes], fontsize=8)
    ax.set_ylim(len(lanes) - 0.5, -0.5)
    ax.set_xlim(0, end)
    q = c.headline_quantity
    thr = QUANTITIES[q].thresholds[0]
    t = c.cross[c.timestep].first_crossing(q, thr)
    if t is not None:
        ax.axvline(t, color="tab:red", lw=1.0, ls="-.")
        ax.plot(
            [],
            [],
            color="tab:red",
            lw=1.0,
            ls="-.",
            label=(
                f"the gap{_first_pair(c)} reaches {fmt_threshold(thr, QUANTITIES[q].unit)} "
                f"(t = {t:.3f} s)"
            ),
        )
    drawn = {kind for _, kind in lanes}
    for kind, marker in _MARKED.items():  # the legend names only the markers drawn
        if kind in drawn:
            mfc = "none" if kind == "contact_lost" else "0.3"
            ax.plot([], [], marker, color="0.3", mfc=mfc, label=kind.replace("_", " "))
    tr = c.runs[(0, c.timestep)]
    for _name, first, _ in tr.phases[1:]:
        ax.axvline(tr.time[first], color="0.6", lw=0.8, ls=":")
    ax.set_xlabel("time (s); dotted: phase starts " + ", ".join(f"'{n}'" for n, _, _ in tr.phases))
    ax.set_title(f"{c.scenario.name}: events of {c.scenario.subject} (bars: how long they last)")
    ax.grid(alpha=0.3, axis="x")
    _legend_below(fig, ax, ncol=4)
    return _save_fixed(fig, path)


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
    pairs = _pairs(c)
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
    return _save(fig, path)


def ensemble(c: Comparison, path: Path) -> Path | None:
    """Where every ensemble run ends, both engines: top view (x, y) and side view (x, z) of the
    followed robot's base (of its last link's centre of mass for a fixed base), member 0 (the
    nominal run) ringed. The legend sits below the axes. None without perturbed runs."""
    if not c.ensembles or c.ensembles[0].size < 2:
        return None
    plt = _plt()
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
    if v is not None and len(_pairs(c)) == 1:  # more pairs: their verdicts are report.md's
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
