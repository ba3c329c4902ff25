"""The report's joint figures (PNG): each commanded joint against its target, one figure per
command mode (:func:`joints`), and the motors' force against their ``max_force``
(:func:`motors`); one panel per joint, every engine in it (:mod:`.plot_style`)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .plot_style import engine_style, pyplot, save_fixed

if TYPE_CHECKING:
    from ..pipeline import Comparison

__all__ = ["JOINT_PLOTS", "held_commands", "joints", "motors"]


JOINT_PLOTS = {1: "velocity", 2: "position", 3: "torque"}
"""Command mode code -> the name of its figure (``joints_<name>.png``)."""


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
    plt = pyplot()
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
            ax.plot(tr.time, series(tr.body, j), label=label, **engine_style(slot, len(tr.time)))
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
    return save_fixed(fig, path)


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
