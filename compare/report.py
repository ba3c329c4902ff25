"""The comparison report: ``report.md`` beside its figures, ``summary.json`` for machines, and
the trajectories (``.npz`` and ``.csv``).

The first lines of ``report.md`` give the headline in words: how far apart the engines end,
when they part, which quantity goes first, and whether the gap is larger than what either
engine changes by itself when its time step is halved.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from .diff import DEG, QUANTITIES
from .fmt import fmt_distance, fmt_threshold, fmt_time, fmt_value
from .pipeline import Comparison
from .scenario import format_timestep

__all__ = ["report", "headline", "fmt_distance", "fmt_time", "fmt_value"]


NOISE_FLOOR = {"m": 1e-6, "rad": 1e-6, "rad/s": 1e-6}
"""Below these, a difference is floating-point noise: 1 µm, 1 µrad, 1 µrad/s."""


def _ratio_words(ratio: float | None) -> str:
    return "" if ratio is None else f" (the gap is {ratio:.3g} times that)"


def headline(summary: dict[str, Any]) -> list[str]:
    """The report's opening sentences, from ``summary.json``'s figures alone."""
    h = summary["headline"]
    a, b = summary["labels"]
    unit = h["unit"]
    subject = summary["subject"]
    if h["quantity"] == "base_distance":
        apart = f"{fmt_value(h['final'], unit)} apart** ({subject}'s base position"
    elif h["quantity"] == "link_distance":
        apart = (
            f"{fmt_value(h['final'], unit)} apart** ({subject}'s links' centres of mass, the "
            "farthest pair"
        )
    else:
        apart = f"{fmt_value(h['final'], unit)} apart** (the {h['title']} of {subject}"
    lines = [
        f"**{a} and {b} end {apart}, after {summary['duration']:.3g} s of simulated time at "
        f"dt = {summary['timestep_text']} s; the largest gap on the way was "
        f"{fmt_value(h['max'], unit)})."
    ]
    crossings = [(c["threshold"], c["time"]) for c in h["crossings"]]
    (t1, c1), (t2, c2) = crossings[0], crossings[1]
    if c1 is None:
        lines.append(
            f"They never come {fmt_threshold(t1, unit)} apart: the engines agree on this "
            f"scenario to {fmt_value(h['max'], unit)}."
        )
    elif c2 is None:
        lines.append(
            f"They part at t = {fmt_time(c1)} (first {fmt_threshold(t1, unit)} apart) and never "
            f"reach {fmt_threshold(t2, unit)}."
        )
    else:
        more = ""
        if len(crossings) > 2 and crossings[2][1] is not None:
            more = f", {fmt_threshold(crossings[2][0], unit)} from t = {fmt_time(crossings[2][1])}"
        lines.append(
            f"They part at t = {fmt_time(c1)} (first {fmt_threshold(t1, unit)} apart) and are "
            f"{fmt_threshold(t2, unit)} apart from t = {fmt_time(c2)}{more}."
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
    parts = [
        f"halving the time step moves {label}'s end by {fmt_value(e['final'], unit)}"
        + _ratio_words(e["gap_ratio"])
        for label, e in own.items()
    ]
    exceeds = [e["gap_exceeds"] for e in own.values()]
    if h["max"] < NOISE_FLOOR[unit]:
        verdict = (
            "The engines agree to floating-point noise (under "
            f"{fmt_value(NOISE_FLOOR[unit], unit)} all along), so there is no gap to weigh "
            "against their own time-step errors"
        )
    elif all(exceeds):
        verdict = "The gap between the engines is larger than each engine's own time-step error"
    elif not any(exceeds):
        verdict = (
            "The gap between the engines is NOT larger than either engine's own time-step "
            "error, so at this time step it does not tell the engines apart"
        )
    else:
        within = [label for label, e in own.items() if not e["gap_exceeds"]]
        verdict = (
            "The gap between the engines is larger than one engine's own time-step error but "
            f"not {' and '.join(within)}'s"
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
    unit = QUANTITIES[q].unit
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
                fmt_value(e["final"], unit),
                fmt_value(e["max"], unit),
                "n/a" if e["gap_ratio"] is None else f"{e['gap_ratio']:.3g}",
                "yes" if e["gap_exceeds"] else "**no**",
            ]
        )
    rows.append(
        [
            f"{a} vs {b}",
            fmt_value(s["headline"]["final"], unit),
            fmt_value(s["headline"]["max"], unit),
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
                    fmt_value(e["own_error_final"], unit),
                ]
            cells += [fmt_value(r["gap_final"], unit), fmt_value(r["gap_max"], unit)]
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
