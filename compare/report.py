"""The comparison report: ``report.md`` beside its figures, ``summary.json`` for machines, and
the trajectories (``.npz`` and ``.csv``).

The first lines of ``report.md`` give the headline in words: how far apart the engines end,
when they part, which quantity goes first, and whether the gap is larger than what either
engine changes by itself when its time step is halved.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from .diff import DEG, QUANTITIES
from .pipeline import Comparison
from .scenario import format_timestep

__all__ = ["report", "headline", "fmt_distance", "fmt_time", "fmt_value"]


# ---------------------------------------------------------------- numbers in words


def fmt_distance(x: float | None) -> str:
    """Metres for people: ``3.27 m``, ``4.2 cm``, ``0.83 mm``, ``2.1e-06 m``."""
    if x is None:
        return "n/a"
    if not math.isfinite(x):
        return str(x)
    a = abs(x)
    if a >= 1:
        return f"{x:.2f} m"
    if a >= 0.01:
        return f"{x * 100:.1f} cm"
    if a >= 1e-4:
        return f"{x * 1000:.2f} mm"
    if a == 0:
        return "0 m"
    return f"{x:.1e} m"


def fmt_time(t: float | None) -> str:
    return "never" if t is None else f"{t:.3f} s"


def fmt_value(x: float, unit: str) -> str:
    """A quantity in its report unit: distances as :func:`fmt_distance`, angles in degrees."""
    if unit == "m":
        return fmt_distance(x)
    if unit == "rad":
        return f"{x / DEG:.3g}°" if abs(x) < 2 * math.pi else f"{x:.3g} rad"
    return f"{x:.3g} {unit}"


def fmt_threshold(x: float, unit: str) -> str:
    if unit == "m":
        return f"{x * 100:g} cm" if x < 1 else f"{x:g} m"
    if unit == "rad":
        return f"{x / DEG:g}°"
    return f"{x:g} {unit}"


def _ratio_words(ratio: float | None, gap: float) -> str:
    if ratio is None:
        return "and both are zero" if gap == 0 else "the engine's own error being zero"
    return f"{ratio:.3g} times that"


# ---------------------------------------------------------------- headline


def headline(summary: dict[str, Any]) -> list[str]:
    """The report's opening sentences, from ``summary.json``'s figures alone."""
    h = summary["headline"]
    a, b = summary["labels"]
    q = summary["headline_quantity"]
    what = (
        f"{summary['subject']}'s base position"
        if q == "base_distance"
        else f"{summary['subject']}'s links (the farthest pair)"
    )
    dur = summary["duration"]
    lines = [
        f"**{a} and {b} end {fmt_distance(h['final_distance'])} apart** ({what}, after "
        f"{dur:.3g} s of simulated time at dt = {summary['timestep_text']} s; the largest gap "
        f"on the way was {fmt_distance(h['max_distance'])})."
    ]
    if h["part_1cm"] is None:
        lines.append(
            f"They never come 1 cm apart: the engines agree on this scenario to "
            f"{fmt_distance(h['max_distance'])}."
        )
    elif h["part_10cm"] is None:
        lines.append(
            f"They part at t = {fmt_time(h['part_1cm'])} (first 1 cm apart) and never reach 10 cm."
        )
    else:
        lines.append(
            f"They part at t = {fmt_time(h['part_1cm'])} (first 1 cm apart) and are 10 cm apart "
            f"from t = {fmt_time(h['part_10cm'])}"
            + (f", 1 m from t = {fmt_time(h['part_1m'])}." if h["part_1m"] is not None else ".")
        )
    first = h["first_to_diverge"]
    if first is None:
        lines.append("No quantity reaches its first threshold (1 cm, 1°, 0.1 rad/s).")
    else:
        qq = QUANTITIES[first["quantity"]]
        lines.append(
            f"The first quantity to diverge is the {qq.title}: it reaches "
            f"{fmt_threshold(first['threshold'], qq.unit)} at t = {fmt_time(first['time'])}."
        )
    own = h["own_error"]
    parts = []
    for label, e in own.items():
        parts.append(
            f"halving the time step moves {label}'s end by {fmt_distance(e['final'])} "
            f"(the gap is {_ratio_words(e['gap_ratio'], h['final_distance'])})"
        )
    exceeds = [e["gap_exceeds"] for e in own.values()]
    if all(exceeds):
        verdict = "The gap between the engines is larger than each engine's own time-step error"
    elif not any(exceeds):
        verdict = (
            "The gap between the engines is NOT larger than either engine's own time-step "
            "error, so at this time step it does not tell the engines apart"
        )
    else:
        bigger = [label for label, e in own.items() if not e["gap_exceeds"]]
        verdict = (
            "The gap between the engines is larger than one engine's own time-step error but "
            f"not {' and '.join(bigger)}'s"
        )
    lines.append(verdict + ": " + "; ".join(parts) + ".")
    return lines


# ---------------------------------------------------------------- markdown


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return out


def _markdown(c: Comparison, s: dict[str, Any], images: dict[str, Path], files: list[str]) -> str:
    a, b = s["labels"]
    cross = c.cross[c.timestep]
    lines = [f"# {s['scenario']}: {a} against {b}", ""]
    lines += headline(s)
    lines += [""]
    if s["description"]:
        lines += [f"*Scenario:* {s['description']}", ""]
    # -- setup
    lines += ["## Setup", ""]
    rows = []
    for slot, label in enumerate(s["labels"]):
        m = c.runs[(slot, c.timestep)].manifest
        rows.append(
            [
                label,
                str(m.get("engine_version", "?")),
                c.profiles[slot],
                f"{format_timestep(c.timestep)} s",
                str(c.runs[(slot, c.timestep)].steps),
                f"{c.runs[(slot, c.timestep)].wall_per_sim_second() * 1000:.1f} ms",
                str(len(m.get("departures", {}) or {})),
            ]
        )
    lines += _table(
        [
            "engine",
            "version",
            "profile",
            "time step",
            "steps",
            "wall per sim. second",
            "profile departures",
        ],
        rows,
    )
    lines += ["", f"Scenario file: `{s['scenario_file']}`. Followed robot: `{s['subject']}`.", ""]
    # -- over time
    lines += ["## When each quantity parts", ""]
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
    lines += _table(["quantity", "first crossing", "", "", "at the end", "largest"], rows)
    lines += [
        "",
        "A threshold is crossed at the first recorded step whose value reaches it. Joint RMS "
        "is over the subject's movable joints (angles unwrapped: a wheel a turn ahead counts "
        "2π). Heading is meaningful while the robot is upright.",
        "",
    ]
    # -- phases
    lines += ["## Per phase", ""]
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
    lines += _table(["phase", "time"] + [QUANTITIES[k].title + " at end" for k in keys], rows)
    lines += [""]
    # -- final poses
    lines += ["## Final poses", ""]
    pa, pb = cross.final_pose["a"], cross.final_pose["b"]

    def xyz(v: list[float]) -> str:
        return "(" + ", ".join(f"{x:.4f}" for x in v) + ")"

    rows = [
        ["base position (m)", xyz(pa["position"]), xyz(pb["position"])],
        ["base orientation (x, y, z, w)", xyz(pa["orientation"]), xyz(pb["orientation"])],
        ["heading (yaw)", f"{pa['yaw'] / DEG:.2f}°", f"{pb['yaw'] / DEG:.2f}°"],
        [
            "tilt from upright",
            f"{pa['tilt'] / DEG:.1f}°" + (" (tipped over)" if pa["tilt"] > 45 * DEG else ""),
            f"{pb['tilt'] / DEG:.1f}°" + (" (tipped over)" if pb["tilt"] > 45 * DEG else ""),
        ],
    ]
    for j, name in enumerate(pa["joint_names"]):
        rows.append(
            [
                f"joint `{name}`: position, velocity",
                f"{pa['joint_positions'][j]:.4g}, {pa['joint_velocities'][j]:.4g}",
                f"{pb['joint_positions'][j]:.4g}, {pb['joint_velocities'][j]:.4g}",
            ]
        )
    lines += _table([f"at t = {cross.time[-1]:.3f} s", a, b], rows)
    lines += [""]
    # -- own error
    q = s["headline_quantity"]
    lines += [
        "## Each engine against itself at half the time step",
        "",
        f"Each engine reran the scenario at dt = {format_timestep(c.timestep / 2)} s (same "
        "simulated time, every phase twice as many steps). What it changes by itself bounds "
        "what its time step alone explains.",
        "",
    ]
    rows = []
    for label, e in s["headline"]["own_error"].items():
        rows.append(
            [
                label,
                fmt_distance(e["final"]),
                fmt_distance(e["max"]),
                "n/a" if e["gap_ratio"] is None else f"{e['gap_ratio']:.3g}",
                "yes" if e["gap_exceeds"] else "**no**",
            ]
        )
    rows.append(
        [
            f"{a} vs {b}",
            fmt_distance(s["headline"]["final_distance"]),
            fmt_distance(s["headline"]["max_distance"]),
            "",
            "",
        ]
    )
    lines += _table(
        ["", f"{QUANTITIES[q].title}: end", "largest", "cross-engine gap / this", "gap larger?"],
        rows,
    )
    lines += [""]
    # -- sweep
    if len(c.timesteps) > 1:
        lines += ["## Time-step sweep", ""]
        header = ["time step"]
        for label in s["labels"]:
            header += [f"{label}: wall per sim. s", f"{label}: own error (end)"]
        header += ["cross-engine gap (end)", "largest gap"]
        rows = []
        for r in s["sweep"]:
            cells = [f"{format_timestep(r['timestep'])} s"]
            for label in s["labels"]:
                e = r["engines"][label]
                cells += [
                    f"{e['wall_per_sim_second'] * 1000:.1f} ms",
                    fmt_distance(e["own_error_final"]),
                ]
            cells += [fmt_distance(r["gap_final"]), fmt_distance(r["gap_max"])]
            rows.append(cells)
        lines += _table(header, rows)
        lines += [
            "",
            "Wall time counts commands and steps only (recording excluded), on this machine, "
            "in one process; compare ratios, not absolute times.",
            "",
        ]
    # -- figures
    captions = {
        "paths": "Paths of both engines (phase starts marked, x = end).",
        "distance": "Distance over time (log scale) with the 1 cm / 10 cm / 1 m thresholds; "
        "dashed: each engine against itself at half the time step.",
        "heading": "Heading of each engine and their difference.",
        "joints": "Commanded joints: speed against the target.",
        "sweep": "Speed against self-consistency, and the cross-engine gap against the time step.",
    }
    if images:
        lines += ["## Figures", ""]
        for key, path in images.items():
            lines += [f"![{key}]({path.name})", "", captions.get(key, ""), ""]
    # -- manifest
    lines += ["## Reproduce", ""]
    lines += [
        "```",
        " ".join(s["manifest"]["command_line"]) or "(library call)",
        "```",
        "",
        f"simbridge {s['manifest']['simbridge_version']}.",
        "",
    ]
    rows = []
    for slot, label in enumerate(s["labels"]):
        m = c.runs[(slot, c.timestep)].manifest
        for robot, u in (m.get("urdf") or {}).items():
            rows.append([label, robot, f"`{u['urdf']}`", f"`{u['sha256'][:16]}…`"])
        deps = m.get("departures") or {}
        for k, v in deps.items():
            rows.append([label, "departure", f"`{k}`", str(v)])
    lines += _table(["engine", "robot", "URDF", "sha256"], rows)
    lines += [
        "",
        "Full manifests (engine versions, profile entries, native defaults, departures, URDF "
        "hashes) are in `summary.json` under `manifest`.",
        "",
        "Files: " + ", ".join(f"`{f}`" for f in files),
        "",
    ]
    return "\n".join(lines)


# ---------------------------------------------------------------- entry point


def report(
    comparison: Comparison,
    out: str | Path,
    *,
    plots: bool = True,
    trajectories: bool = True,
) -> Path:
    """Write the report of ``comparison`` into folder ``out`` (created if needed).

    Writes ``report.md`` (the file a person opens), ``summary.json`` (every headline figure
    plus the manifests), the PNG figures beside them, and with ``trajectories`` the two
    headline runs as ``trajectories/<engine>.npz`` and ``.csv``. Returns the path of
    ``report.md``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    summary = comparison.summary()
    files = ["summary.json"]
    if trajectories:
        folder = out / "trajectories"
        folder.mkdir(exist_ok=True)
        for slot, label in enumerate(comparison.labels):
            tr = comparison.runs[(slot, comparison.timestep)]
            stem = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in label)
            tr.save(folder / f"{stem}.npz")
            tr.save_csv(folder / f"{stem}.csv")
            files += [f"trajectories/{stem}.npz", f"trajectories/{stem}.csv"]
    images = {}
    if plots:
        from .plots import all_plots

        images = all_plots(comparison, out)
    summary["files"] = files + [p.name for p in images.values()]
    summary["headline"]["text"] = headline(summary)
    (out / "summary.json").write_text(
        json.dumps(summary, indent=2, default=_json_default, allow_nan=True) + "\n",
        encoding="utf-8",
    )
    path = out / "report.md"
    path.write_text(_markdown(comparison, summary, images, files), encoding="utf-8")
    return path


def _json_default(obj: Any) -> Any:
    import numpy as np

    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.integer, np.floating, np.bool_)):
        return obj.item()
    return str(obj)
