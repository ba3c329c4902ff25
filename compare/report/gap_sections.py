"""``report.md``'s sections on how the runs come apart and end: over time and per phase
(:func:`over_time_section`) and per part (:func:`parts_section`) of two engines' nominal runs,
each engine's final pose (:func:`final_poses_section`), each engine against itself at half the
time step (:func:`own_error_section`) and the time-step sweep (:func:`sweep_section`). With more
than two engines the over-time and per-part sections are :mod:`.pair_sections`'."""

from __future__ import annotations

from typing import Any

from ..analysis.diff import DEG, QUANTITIES, Divergence, FinalPose
from ..pipeline import Comparison
from ..run.events import TIP_ANGLE
from ..scenario import format_timestep
from .fmt import fmt_threshold, fmt_time, fmt_value, table
from .pair_sections import CROSSINGS_NOTE, PARTS_NOTE
from .parts import parts_words

__all__ = [
    "MAX_PART_ROWS",
    "final_poses_section",
    "over_time_section",
    "own_error_section",
    "parts_section",
    "sweep_section",
]

MAX_PART_ROWS = 15
"""The most rows of the parts table of one pair."""


def over_time_section(cross: Divergence) -> list[str]:
    """*When each quantity parts* and *Per phase* of two engines' nominal runs.

    Args:
        cross: the diff of the two nominal runs at the comparison's time step.

    Returns:
        The two sections' lines.
    """
    return _crossings_table(cross) + _phases_table(cross)


def _crossings_table(cross: Divergence) -> list[str]:
    """*When each quantity parts*: each quantity's first crossing of each threshold, its gap
    at the end and its largest."""
    lines = ["## When each quantity parts", ""]
    rows = []
    for key, q in QUANTITIES.items():
        if key not in cross.series:
            continue
        cells = [q.title]
        cells += [
            f"{fmt_threshold(thr, q.unit)}: {fmt_time(cross.crossings[key][thr])}"
            for thr in q.thresholds
        ]
        cells += [""] * (3 - len(q.thresholds))
        cells += [fmt_value(cross.final[key], q.unit), fmt_value(cross.maximum[key], q.unit)]
        rows.append(cells)
    lines += table(["quantity", "first crossing", "", "", "at the end", "largest"], rows)
    lines += [
        "",
        CROSSINGS_NOTE,
        "",
    ]
    return lines


def _phases_table(cross: Divergence) -> list[str]:
    """*Per phase*: each quantity's gap at the end of each phase, and its largest in it."""
    lines = ["## Per phase", ""]
    rows = []
    keys = [k for k in QUANTITIES if k in cross.series]
    for p in cross.phases:
        rows.append(
            [p.name, f"{p.start:.3f} – {p.end:.3f} s"]
            + [
                f"{fmt_value(p.at_end[k], QUANTITIES[k].unit)} "
                f"(max {fmt_value(p.max[k], QUANTITIES[k].unit)})"
                for k in keys
            ]
        )
    lines += table(["phase", "time"] + [QUANTITIES[k].title + " at end" for k in keys], rows)
    lines += [""]
    return lines


def parts_section(s: dict[str, Any]) -> list[str]:
    """Joints and links of the first pair ranked by when the engines part there, and how far.

    Args:
        s: ``summary.json``'s dict.

    Returns:
        The section's lines; empty when the summary ranks no parts.
    """
    parts = s.get("parts")
    if not parts:
        return []
    lines = [
        "## Which part parts first"
        + (f" ({' and '.join(s['labels'][:2])})" if len(s["labels"]) > 2 else ""),
        "",
    ]
    lines += [parts_words(parts), ""]
    rows = []
    for k, p in enumerate(parts[:MAX_PART_ROWS]):
        rows.append(
            [
                str(k + 1),
                f"{p['kind']} `{p['name']}`",
                f"{fmt_threshold(p['threshold'], p['unit'])}: {fmt_time(p['first'])}",
                f"{fmt_value(p['largest'], p['unit'])} at {fmt_time(p['largest_at'])}",
                fmt_value(p["at_end"], p["unit"]),
            ]
        )
    lines += table(["rank", "part", "apart by", "largest gap", "at the end"], rows)
    lines += [
        "",
        PARTS_NOTE,
        "",
    ]
    if len(parts) > MAX_PART_ROWS:
        lines += [
            f"{MAX_PART_ROWS} of {len(parts)} shown; all in `summary.json` under `parts`.",
            "",
        ]
    return lines


def final_poses_section(c: Comparison, s: dict[str, Any]) -> list[str]:
    """*Final poses*: every engine's base pose, heading, tilt and joint states at the end.

    Args:
        c: the comparison.
        s: its ``summary.json`` dict.

    Returns:
        The section's lines.
    """
    cross = c.cross[c.timestep]
    poses = _final_poses(c)

    def xyz(v: list[float]) -> str:
        return "(" + ", ".join(f"{x:.4f}" for x in v) + ")"

    rows = [
        ["base position (m)"] + [xyz(x.position) for x in poses],
        ["base orientation (x, y, z, w)"] + [xyz(x.orientation) for x in poses],
        ["heading (yaw)"] + [f"{x.yaw / DEG:.2f}°" for x in poses],
        ["tilt from its spawn orientation"] + [_tilt_cell(x) for x in poses],
    ]
    for j, name in enumerate(poses[0].joint_names):
        rows.append(
            [f"joint `{name}`: position, velocity"]
            + [f"{x.joint_positions[j]:.4g}, {x.joint_velocities[j]:.4g}" for x in poses]
        )
    lines = ["## Final poses", ""]
    lines += table([f"at t = {cross.time[-1]:.3f} s"] + list(s["labels"]), rows)
    lines += [""]
    return lines


def _final_poses(c: Comparison) -> list[FinalPose]:
    """Every engine's final pose, in ``c.labels`` order, from the pairs' diffs (each pose is
    the engine's own, whichever pair holds it)."""
    poses: dict[int, FinalPose] = {}
    for p in c.pairs or []:
        cross = p.cross[c.timestep]
        poses.setdefault(p.a, cross.final_pose["a"])
        poses.setdefault(p.b, cross.final_pose["b"])
    cross = c.cross[c.timestep]
    poses.setdefault(0, cross.final_pose["a"])
    poses.setdefault(1, cross.final_pose["b"])
    return [poses[k] for k in sorted(poses)]


def _tilt_cell(pose: FinalPose) -> str:
    """The tilt from the spawn orientation in degrees, ``(tipped over)`` past the tip angle."""
    t = pose.tilt_from_spawn
    return f"{t / DEG:.1f}°" + (" (tipped over)" if t > TIP_ANGLE else "")


def own_error_section(c: Comparison, s: dict[str, Any]) -> list[str]:
    """*Each engine against itself at half the time step*: a row per engine (its own error),
    then one per pair (the cross-engine gap against the pair's larger own error).

    Args:
        c: the comparison.
        s: its ``summary.json`` dict.

    Returns:
        The section's lines.
    """
    a, b = s["labels"][:2]
    q = s["headline_quantity"]
    unit = QUANTITIES[q].unit
    lines = [
        "## Each engine against itself at half the time step",
        "",
        f"Each engine reran the scenario at dt = {format_timestep(c.timestep / 2)} s (same "
        "simulated time, every phase twice as many steps). What it changes by itself bounds "
        "what its time step alone explains.",
        "",
    ]
    rows = []
    for label in s["labels"]:
        e = s["own"][label]
        rows.append([label, fmt_value(e["final"][q], unit), fmt_value(e["max"][q], unit), "", ""])
    for p in s.get("pairs") or [{"labels": [a, b], "headline": s["headline"]}]:
        h = p["headline"]
        ratios = [e["gap_ratio"] for e in h["own_error"].values()]
        ratio = "n/a" if None in ratios else f"{min(ratios):.3g}"
        rows.append(
            [
                " vs ".join(p["labels"]),
                fmt_value(h["final"], unit),
                fmt_value(h["max"], unit),
                ratio,
                "yes" if h["gap_exceeds_all_own_errors"] else "**no**",
            ]
        )
    lines += table(
        [
            "",
            f"{QUANTITIES[q].title}: end",
            "largest",
            "gap / the pair's larger own error",
            "gap larger than both?",
        ],
        rows,
    )
    lines += [
        "",
        "One row per engine (its own error: dt against dt/2), then one per pair (the "
        "cross-engine gap of the nominal runs).",
        "",
    ]
    return lines


def sweep_section(c: Comparison, s: dict[str, Any], of: str = "") -> list[str]:
    """*Time-step sweep*: at each time step, each engine's wall time and own error and the
    first pair's gap.

    Args:
        c: the comparison.
        s: its ``summary.json`` dict.
        of: what the gap's column title adds (`` (pybullet and mujoco)`` with more pairs).

    Returns:
        The section's lines; empty with one time step.
    """
    if len(c.timesteps) <= 1:
        return []
    unit = QUANTITIES[s["headline_quantity"]].unit
    lines = ["## Time-step sweep", ""]
    header = ["time step"]
    for label in s["labels"]:
        header += [f"{label}: wall per sim. s", f"{label}: own error (end)"]
    header += [f"cross-engine gap{of} (end)", "largest gap"]
    rows = []
    for r in s["sweep"]:
        cells = [f"{format_timestep(r['timestep'])} s"]
        for label in s["labels"]:
            e = r["engines"][label]
            cells += [
                f"{e['wall_per_sim_second'] * 1000:.1f} ms",
                fmt_value(e["own_error_final"], unit),
            ]
        cells += [fmt_value(r["gap_final"], unit), fmt_value(r["gap_max"], unit)]
        rows.append(cells)
    lines += table(header, rows)
    lines += [
        "",
        "Wall time counts commands and steps only (recording excluded), on this machine, "
        "in one process; compare ratios, not absolute times.",
        "",
    ]
    return lines
