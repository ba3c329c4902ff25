"""The report's events figure (PNG, :func:`events`): each engine's events of the followed robot
in lanes over time, with the instant the gap first reaches its threshold."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..analysis.diff import QUANTITIES
from .fmt import fmt_threshold
from .plot_style import COLORS, first_pair_mark, legend_below, pyplot, save_fixed

if TYPE_CHECKING:
    from ..pipeline import Comparison

__all__ = ["events"]


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
    as a vertical line.

    Args:
        c: the comparison.
        path: the PNG to write.

    Returns:
        ``path``; None when neither engine has an event.
    """
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
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 1.2 + 0.32 * len(lanes) + 0.6))
    end = float(c.runs[(0, c.timestep)].time[-1])
    for y, (slot, kind) in enumerate(lanes):
        _lane(ax, c, [x for x in found[slot].events if x.kind == kind], y, slot, end)
    ax.set_yticks(range(len(lanes)))
    ax.set_yticklabels([f"{c.labels[s]}: {k.replace('_', ' ')}" for s, k in lanes], fontsize=8)
    ax.set_ylim(len(lanes) - 0.5, -0.5)
    ax.set_xlim(0, end)
    _parting_line(ax, c)
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
    legend_below(fig, ax, ncol=4)
    return save_fixed(fig, path)


def _lane(ax: Any, c: Comparison, found: list[Any], y: int, slot: int, end: float) -> None:
    """One lane at height ``y``: the events ``found`` (all of one kind, of the engine in
    ``slot``) as bars lasting until their end (``end``: the run's) or as markers."""
    for x in found:
        kind = x.kind
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


def _parting_line(ax: Any, c: Comparison) -> None:
    """The instant the first pair's gap first reaches its first threshold, a red dash-dotted
    line named in the legend; nothing where it never does."""
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
                f"the gap{first_pair_mark(c)} reaches {fmt_threshold(thr, QUANTITIES[q].unit)} "
                f"(t = {t:.3f} s)"
            ),
        )
