"""The report's figures' shared style (:mod:`.plots`, :mod:`.plot_joints`,
:mod:`.plot_events`): each engine's colour, line and marker, the pairs' colours, the legend
below the axes, the phase marks, and saving a figure with matplotlib's Agg backend (no display
needed).

Both engines are drawn so that neither hides the other: the first solid, the second dashed on
top of it, in distinct colours, with sparse markers of different shapes; legends sit below the
axes, never on the data.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ..pipeline import Comparison, Pair

__all__ = [
    "COLORS",
    "LINES",
    "MARKERS",
    "PAIR_COLORS",
    "engine_style",
    "first_pair_mark",
    "legend_below",
    "pairs_of",
    "phase_lines",
    "pyplot",
    "save",
    "save_fixed",
]


COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown")
PAIR_COLORS = ("k", "tab:purple", "tab:brown", "tab:olive", "tab:cyan", "tab:pink", "0.5")
"""A pair's gap, one colour each (the first pair black), apart from the engines' first four."""
LINES = ("-", (0, (5, 3)), (0, (1, 2)), "-.", (0, (3, 1, 1, 1)), (0, (5, 1)))
MARKERS = ("o", "s", "^", "D", "v", "P")
"""Engine slot -> its colour, line and marker (a comparison of more engines than this cycles)."""


def engine_style(slot: int, n: int) -> dict[str, Any]:
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


def legend_below(fig: Any, ax: Any, ncol: int = 3) -> None:
    """One legend for the figure, centred below its axes (out of the data's way)."""
    handles, labels = ax.get_legend_handles_labels()
    if not handles:  # nothing to name: the axes alone, laid out
        fig.tight_layout()
        return
    rows = math.ceil(len(handles) / ncol)
    fig.legend(handles, labels, loc="lower center", ncol=ncol, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.035 + 0.035 * rows, 1, 1))


def save_fixed(fig: Any, path: Path) -> Path:
    """Save without a further tight_layout (the layout already leaves room for the legend)."""
    fig.savefig(path, dpi=110)
    pyplot().close(fig)
    return path


def pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def phase_lines(ax: Any, c: Comparison) -> None:
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


def save(fig: Any, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    pyplot().close(fig)
    return path


def pairs_of(c: Comparison) -> list[Pair]:
    """Every pair of ``c`` (one made by hand without ``pairs``: engines 0 and 1)."""
    from ..pipeline import Pair

    return c.pairs or [Pair(0, 1, c.cross, c.verdict)]


def first_pair_mark(c: Comparison) -> str:
    """`` (pybullet - mujoco)`` with more than two engines: the pair a first-pair mark is of."""
    return f" ({c.labels[0]} - {c.labels[1]})" if len(c.labels) > 2 else ""
