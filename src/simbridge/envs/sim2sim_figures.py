"""The survival figure of ``simbridge sim2sim`` (:func:`survival_figure`, ``survival.png`` in
report.md and report.html): every engine's Kaplan-Meier curve of time to failure
(:func:`simbridge.envs.survival.kaplan_meier`) with its 95% band.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from simbridge.envs.survival import kaplan_meier

if TYPE_CHECKING:
    from simbridge.envs.sim2sim import Sim2SimResult

__all__ = ["FIGURE", "survival_figure"]

FIGURE = "survival.png"
"""The figure's file name in the report folder."""


def survival_figure(result: Sim2SimResult, path: Path) -> Path:
    """Every engine's Kaplan-Meier curve of time to failure, with its 95% band, in compare's
    figure style (:mod:`simbridge.compare.report.plot_style`): each engine's colour and line as
    in compare's figures and the replay's legend, the legend below the axes.

    Args:
        result: the run.
        path: the PNG to write.

    Returns:
        ``path``.
    """
    from simbridge.compare.report.plot_style import COLORS, LINES, legend_below, pyplot, save_fixed

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7.2, 4.4))
    end = 0.0
    for slot, (run, f) in enumerate(zip(result.runs, result.figures, strict=True)):
        dt = float(run.contract["control_dt"])
        horizon = int(run.contract["episode_steps"])
        end = max(end, horizon * dt)
        km = kaplan_meier(run.records)
        x = np.append(km.times, horizon) * dt
        colour = COLORS[slot % len(COLORS)]
        fails = sum(f.failures.values())
        label = f"{f.label}: {fails}/{f.rate.n} failed"
        if slot == 0:
            label += " (training engine)"
        ax.step(
            x,
            np.append(km.survival, km.survival[-1]),
            where="post",
            color=colour,
            ls=LINES[slot % len(LINES)],
            lw=2.0 if slot == 0 else 1.3,
            label=label,
            zorder=2 + slot,
        )
        ax.fill_between(
            x,
            np.append(km.low, km.low[-1]),
            np.append(km.high, km.high[-1]),
            step="post",
            color=colour,
            alpha=0.12,
            lw=0,
        )
    ax.set_xlim(0.0, end)
    ax.set_ylim(-0.02, 1.05)
    ax.set_xlabel("time in the episode (s)")
    ax.set_ylabel("share of episodes not failed")
    ax.set_title(
        f"Time to failure on {result.task}, {len(result.seeds)} paired episodes per engine "
        "(Kaplan-Meier, 95% band)",
        fontsize=10,
    )
    ax.grid(alpha=0.3)
    legend_below(fig, ax, ncol=2)
    return save_fixed(fig, path)
