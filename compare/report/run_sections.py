"""``report.md``'s sections on what ran and how to run it again: *Setup* (each engine's version,
profile, time step, steps, wall time and departures, :func:`setup_section`), *Figures*
(:func:`figures_section`), *Profile departures that apply here* (:func:`departures_section`)
and *Reproduce* (:func:`reproduce_section`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..pipeline import Comparison
from ..scenario import format_timestep
from .departures import checked
from .fmt import table

__all__ = [
    "CAPTIONS",
    "departures_section",
    "figures_section",
    "reproduce_section",
    "setup_section",
]

CAPTIONS = {
    "paths": "Paths of every engine (phase starts marked, x = end).",
    "distance": "Distance over time (log scale) with the 1 cm / 10 cm / 1 m thresholds: "
    "solid, each pair's nominal runs; dash-dotted, each pair's median gap over every pair "
    "of runs (judged), in the pair's colour; dashed: each engine against itself at half the "
    "time step; dotted: the spread of each engine's perturbed runs.",
    "ensemble": "Where every run of each engine's ensemble ends (top and side views); the "
    "squares ring the nominal runs.",
    "height": "Height of the followed robot over time (against gravity; a fixed base's last "
    "link), with the instant the gap first reaches its threshold.",
    "heading": "Heading of each engine and, below, each pair's difference.",
    "events": "Each engine's events: bars last as long as the condition, markers are "
    "instants; the dash-dotted line is where the gap first reaches its threshold.",
    "joints_velocity": "Velocity-commanded joints: speed against the target.",
    "joints_position": "Position-commanded joints: position against the target.",
    "joints_torque": "Torque-commanded joints: speed under the commanded torque (dotted, "
    "right axis).",
    "motors": "Velocity- and position-commanded joints: motor force against its max_force.",
    "sweep": "Speed against self-consistency, and each pair's gap against the time step.",
}
"""The caption under each figure of *Figures*, by its key."""


def setup_section(c: Comparison, s: dict[str, Any]) -> list[str]:
    """*Setup*: a row per engine (version, profile, time step, steps, wall time per simulated
    second, the profile departures that apply), the scenario file and the followed robot.

    Args:
        c: the comparison.
        s: its ``summary.json`` dict.

    Returns:
        The section's lines.
    """
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
                _departure_count(s, label, m),
            ]
        )
    lines = ["## Setup", ""]
    lines += table(
        [
            "engine",
            "version",
            "profile",
            "time step",
            "steps",
            "wall per sim. second",
            "profile departures that apply here",
        ],
        rows,
    )
    lines += [
        "",
        "A profile departure is a documented place where an engine cannot reproduce the "
        "chosen profile (every one is in the departures table of the documentation's engines "
        "page, docs/engines.md, and in `summary.json` "
        "under `manifest`); the count is those that apply to this scenario out of the engine's "
        "all, each named in [Profile departures that apply here]"
        "(#profile-departures-that-apply-here).",
        "",
        f"Scenario file: `{s['scenario_file']}`. Followed robot: `{s['subject']}`.",
        "",
    ]
    return lines


def _departure_count(s: dict[str, Any], label: str, manifest: dict[str, Any]) -> str:
    """The engine's count of departures that apply (``2 of 5``, linked to their section), or
    its count of all where none was checked."""
    total = len(manifest.get("departures", {}) or {})
    deps = (s.get("departures") or {}).get(label)
    if deps is None:
        return str(total)
    found = sum(checked(x) for x in deps["apply"])  # one not checked is not said to apply
    return f"[{found} of {total}](#profile-departures-that-apply-here)"


def figures_section(images: dict[str, Path]) -> list[str]:
    """*Figures*: each figure with its caption (:data:`CAPTIONS`).

    Args:
        images: the figures' paths by key, in the order shown.

    Returns:
        The section's lines; empty without figures.
    """
    if not images:
        return []
    lines = ["## Figures", ""]
    for key, path in images.items():
        lines += [f"![{key}]({path.name})", "", CAPTIONS.get(key, ""), ""]
    return lines


def departures_section(s: dict[str, Any]) -> list[str]:
    """The profile departures that apply to this scenario, with this run's figures.

    Args:
        s: ``summary.json``'s dict.

    Returns:
        The section's lines; empty when the summary holds no departures.
    """
    deps = s.get("departures")
    if not deps:
        return []
    lines = ["## Profile departures that apply here", ""]
    for label, d in deps.items():
        lines += _engine_departures(label, d)
    return lines


def _engine_departures(label: str, d: dict[str, Any]) -> list[str]:
    """One engine's departures (``d``: its entry of ``summary.json``'s ``departures``): those
    that apply in a table, those no rule checks, those left out."""
    if not d["apply"] and not d["left_out"]:
        return [f"{label}: none (it reproduces the profile).", ""]
    lines: list[str] = []
    found = [x for x in d["apply"] if checked(x)]
    unchecked = [x["key"] for x in d["apply"] if not checked(x)]
    if found:
        rows = [[f"`{x['key']}`", x["text"], x["why"], x["measured"] or "none"] for x in found]
        lines += [f"{label}:", ""]
        lines += table(["departure", "what", "why it applies here", "measured in this run"], rows)
        lines += [""]
    else:
        lines += [f"{label}: none of its departures applies here.", ""]
    if unchecked:
        n = len(unchecked)
        lines += [
            f"Not checked for {label}: {n} departure{'s' if n != 1 else ''} no rule checks "
            "against this scenario, not counted as applying: "
            + ", ".join(f"`{k}`" for k in unchecked)
            + ".",
            "",
        ]
    if d["left_out"]:
        lines += [
            f"Left out for {label} (they do not apply to this scenario): "
            + ", ".join(f"`{k}`" for k in d["left_out"])
            + ".",
            "",
        ]
    return lines


def reproduce_section(c: Comparison, s: dict[str, Any], files: list[str]) -> list[str]:
    """*Reproduce*: the command line, the simbridge version, each robot's URDF and its hash,
    and the files written.

    Args:
        c: the comparison.
        s: its ``summary.json`` dict.
        files: the report's files, as named in the last line.

    Returns:
        The section's lines.
    """
    lines = ["## Reproduce", ""]
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
    lines += table(["engine", "robot", "URDF", "sha256"], rows)
    lines += [
        "",
        "Full manifests (engine versions, profile entries, native defaults, departures, URDF "
        "hashes) are in `summary.json` under `manifest`.",
        "",
        "Files: " + ", ".join(f"`{f}`" for f in files),
        "",
    ]
    return lines
