"""The comparison report: ``report.md`` beside its figures, ``summary.json`` for machines, and
the trajectories (``.npz`` and ``.csv``).

The first lines of ``report.md`` give the headline in words: the verdict (``agree``,
``differ``, ``chaotic`` naming the engine, or ``unresolved``) with its test and intervals, the
predictability horizons, then how far apart the nominal runs end, when they part, which quantity
goes first, and what halving the time step changes in each engine.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from .diff import DEG, QUANTITIES
from .fmt import fmt_distance, fmt_threshold, fmt_time, fmt_value
from .outcomes import outcome_lines, outcomes_section
from .pipeline import Comparison
from .scenario import format_timestep
from .verdict import verdict_lines

__all__ = ["report", "headline", "fmt_distance", "fmt_time", "fmt_value"]


def headline(summary: dict[str, Any]) -> list[str]:
    """The report's opening sentences, from ``summary.json``'s figures alone: the verdict
    (:func:`~simbridge.compare.verdict.verdict_lines`), then the nominal runs' figures."""
    h = summary["headline"]
    a, b = summary["labels"]
    unit = h["unit"]
    subject = summary["subject"]
    lines: list[str] = outcome_lines(summary)  # what the scenario calls success, first
    if summary.get("verdict"):
        lines += verdict_lines(summary)
    if h["quantity"] == "base_distance":
        apart = f"{fmt_value(h['final'], unit)} apart ({subject}'s base position"
    elif h["quantity"] == "link_distance":
        apart = (
            f"{fmt_value(h['final'], unit)} apart ({subject}'s links' centres of mass, the "
            "farthest pair"
        )
    else:
        apart = f"{fmt_value(h['final'], unit)} apart (the {h['title']} of {subject}"
    lines += [
        f"The nominal runs (no offset) end {apart}, after {summary['duration']:.3g} s of "
        f"simulated time at dt = {summary['timestep_text']} s; the largest gap on the way was "
        f"{fmt_value(h['max'], unit)})."
    ]
    crossings = [(c["threshold"], c["time"]) for c in h["crossings"]]
    (t1, c1), (t2, c2) = crossings[0], crossings[1]
    if c1 is None:
        lines.append(f"They never come {fmt_threshold(t1, unit)} apart.")
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
    parts = [f"moves {label}'s end by {fmt_value(e['final'], unit)}" for label, e in own.items()]
    lines.append("Halving the time step " + "; it ".join(parts) + ".")
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
    # -- verdict
    lines += outcomes_section(s)
    if s.get("verdict"):
        lines += _verdict_section(s)
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
        "dashed: each engine against itself at half the time step; dotted: the spread of each "
        "engine's perturbed runs.",
        "ensemble": "Where every run of each engine's ensemble ends (top and side views); the "
        "squares ring the nominal runs.",
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


def _verdict_section(s: dict[str, Any]) -> list[str]:
    """The judgement in a table: each engine's spread, own error and their ratios to the gap,
    the test, the instants of each kind, the horizons."""
    v = s["verdict"]
    e = s.get("ensemble") or {}
    unit = v["unit"]
    q = QUANTITIES[v["quantity"]]
    t = v["judged_at"]
    where = "at the end" if t["why"] == "end" else f"at t = {fmt_time(t['time'])} (largest gap)"

    def iv(x: dict[str, Any]) -> str:
        if x.get("low") is None:
            return fmt_value(x["value"], unit)
        return (
            f"{fmt_value(x['value'], unit)} [{fmt_value(x['low'], unit)}, "
            f"{fmt_value(x['high'], unit)}]"
        )

    lines = [
        f"## Verdict: {v['verdict']}" + (" (marginal)" if v["marginal"] else ""),
        "",
    ]
    if e:
        pert = e["perturbation"]
        lines += [
            f"Each engine ran the scenario {e['size']} times: the nominal run and "
            f"{e['size'] - 1} with every spawn pose moved by {pert['position']:g} m and turned "
            f"by {pert['orientation']:g} rad in random directions (seed {e['seed']}). The "
            f"{q.title} is judged at every one of {v['instants']['total']} recorded instants "
            f"against each engine's own spread (the {v['spread_percentile']:g}th percentile of "
            "the distances between its runs) and its own time-step error (dt against dt/2); "
            f"figures below are {where}, with 95% bootstrap intervals in brackets.",
            "",
        ]
    rows = []
    for label, f in v["engine_figures"].items():
        hz = ", ".join(
            f"{fmt_threshold(h['threshold'], unit)}: {fmt_time(h['time'])}" for h in f["horizons"]
        )
        rows.append(
            [
                label,
                str(f["size"]),
                iv(f["spread"]),
                iv(f["spread_end"]),
                fmt_value(f["largest_pair"], unit),
                f"{f['gap_over_spread']:.3g}",
                fmt_value(f["own_error"], unit),
                f"{f['gap_over_own_error']:.3g}",
                hz,
            ]
        )
    lines += _table(
        [
            "engine",
            "runs",
            "spread",
            "spread at the end",
            "farthest pair",
            "gap / spread",
            "own error",
            "gap / own error",
            "spread first reaches",
        ],
        rows,
    )
    test = v["test"]
    test_words = (
        "not run (the gap stays below the tolerance, or one run per engine)"
        if test is None
        else f"{test['name']}: statistic {test['statistic']:.3g}, p = {test['p_value']:.3g} "
        f"({'every split' if test['exact'] else str(test['resamples']) + ' random splits'}; "
        f"alpha {test['alpha']:g})"
    )
    n = v["instants"]
    lines += [
        "",
        f"Gap between the engines (median over every pair of runs, one of each engine): "
        f"{iv(v['gap'])}; the nominal runs' gap: {fmt_value(v['nominal_gap'], unit)}; largest "
        f"on the way {fmt_value(v['max_gap']['value'], unit)} at t = "
        f"{fmt_time(v['max_gap']['time'])}. Tolerance for `agree`: "
        f"{fmt_threshold(v['tolerance'], unit)}; precision floor {v['floor']:.2g} {unit}.",
        "",
        f"Two-sample test on the runs' states {where}: {test_words}.",
        "",
        f"Instants: {n['agree']} below the tolerance, {n['chaotic']} within an engine's spread, "
        f"{n['unresolved']} within an engine's own time-step error, {n['differ']} beyond every "
        f"one of them (of {n['total']}). A ratio between {v['marginal_range'][0]:g} and "
        f"{v['marginal_range'][1]:g} is near 1: the gap is not clearly larger, and the verdict "
        "says marginal.",
        "",
    ]
    if v["marginal_reasons"]:
        lines += ["Marginal: " + "; ".join(v["marginal_reasons"]) + ".", ""]
    return lines


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
