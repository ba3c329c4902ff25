"""``report.md``: every section written here from the one ``summary.json`` dict
(:func:`markdown`), so the document's layout reads top to bottom in one place.

The first lines of ``report.md`` give the headline in words: the verdict (``agree``,
``differ``, ``chaotic`` naming the engine, or ``unresolved``) with its test and intervals, the
predictability horizons, then how far apart the nominal runs end, when they part, which quantity
goes first, and what halving the time step changes in each engine.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..analysis.diff import DEG, QUANTITIES, Divergence, FinalPose
from ..pipeline import Comparison
from ..run.events import KINDS, TIP_ANGLE
from ..scenario import format_timestep
from .departures import checked
from .engine_figures import engines_section, p_words, pair_reasons
from .engine_settings import settings_section
from .events import event_words, parting_words, with_start
from .fmt import fmt_threshold, fmt_time, fmt_value
from .outcomes import outcome_lines, outcomes_section
from .pair_sections import (
    CROSSINGS_NOTE,
    PARTS_NOTE,
    crossings_section,
    parting_lines,
    parts_section,
    phases_section,
)
from .parts import parts_words
from .resync import resync_lines, resync_section
from .self_check import self_check_words
from .story import story_words
from .verdict import (
    interval_cell,
    one_run,
    pair_words,
    perturbation_words,
    spread_ratio,
    verdict_lines,
    verdict_word,
    within_words,
)

__all__ = ["headline", "markdown"]


def headline(summary: dict[str, Any]) -> list[str]:
    """The report's opening statements (one paragraph each, or one bullet), from
    ``summary.json``'s figures alone. Two engines: the scenario's outcomes, the verdict
    (:func:`~simbridge.compare.verdict.verdict_lines`), then the nominal runs' figures. More:
    the outcomes, then every pair's verdict with its judged gap, one bullet each; the first
    pair's figures follow in their own section (:func:`first_pair_lines`)."""
    lines: list[str] = outcome_lines(summary)  # what the scenario calls success, first
    story = story_words(summary)  # what happens to the robot, after the verdict
    if len(summary["labels"]) > 2 and len(summary.get("pairs") or []) > 1:
        lines += pairs_lines(summary) + ([story] if story else [])
    else:
        lines += first_pair_lines(summary, story=story)
    raised = perturbation_words(summary.get("ensemble"))  # a float32 engine's own offsets
    if raised:
        lines.append(raised)
    return lines


def first_pair_lines(summary: dict[str, Any], story: str | None = None) -> list[str]:
    """The first pair's verdict in words (then ``story``, where given: what happens to the
    robot) and its nominal runs' figures: when they part, which quantity goes first, what
    halving the time step changes, the one-step error."""
    h = summary["headline"]
    unit = h["unit"]
    subject = summary["subject"]
    many = len(summary["labels"]) > 2
    a, b = summary["labels"][:2]
    lines: list[str] = []
    if summary.get("verdict"):
        lines += verdict_lines(summary)
    if story:
        lines.append(story)
    if h["quantity"] == "base_distance":
        apart = f"{fmt_value(h['final'], unit)} apart ({subject}'s base position"
    elif h["quantity"] == "link_distance":
        apart = (
            f"{fmt_value(h['final'], unit)} apart ({subject}'s links' centres of mass, the "
            "farthest pair"
        )
    else:
        apart = f"{fmt_value(h['final'], unit)} apart (the {h['title']} of {subject}"
    runs = f"The nominal runs of {a} and {b}" if many else "The nominal runs"
    lines += [
        f"{runs} (no offset) end {apart}, after {summary['duration']:.3g} s of "
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
    born = parting_words(summary.get("parting") or {})
    if born:
        lines[-1] += f" The gap is born {born}."
    first = h["first_to_diverge"]
    if first is None:
        lines.append("No quantity reaches its first threshold (1 cm, 1°, 0.1 rad/s).")
    else:
        qq = QUANTITIES[first["quantity"]]
        lines.append(
            f"The first quantity to diverge is the {qq.title}: it reaches "
            f"{fmt_threshold(first['threshold'], qq.unit)} at t = {fmt_time(first['time'])}."
        )
    if summary.get("parts"):
        lines.append(parts_words(summary["parts"]))
    own = h["own_error"]
    parts = [f"moves {label}'s end by {fmt_value(e['final'], unit)}" for label, e in own.items()]
    lines.append("Halving the time step " + "; it ".join(parts) + ".")
    lines += resync_lines(summary)  # one step from the same state: the model error
    return lines


def _is_resync(key: str) -> bool:
    """A resync figure's key: ``resync`` (the first pair's), ``resync_<a>_<b>``."""
    return key == "resync" or key.startswith("resync_")


def left_out_words(summary: dict[str, Any]) -> str | None:
    """With the backends chosen by default: the registered engines left out and why, in one
    sentence; None when none was (or the backends were named)."""
    left = summary.get("left_out") or {}
    if not left:
        return None
    why = "; ".join(f"{name} ({reason})" for name, reason in left.items())
    return f"Registered engines left out, not installed here: {why}."


def pairs_lines(summary: dict[str, Any]) -> list[str]:
    """With more than two engines, every pair's verdict with its judged gap: a lead and one
    bullet per pair (:func:`~.verdict.pair_words`); empty with two."""
    pairs = summary.get("pairs") or []
    if len(summary["labels"]) <= 2 or not pairs:
        return []
    ens = summary.get("ensemble") or {}
    gap = "the gap of the one run per engine, no interval"  # --ensemble 1
    if ens.get("size", 1) > 1:
        gap = (
            f"the median gap over every pair of runs, {ens['size']} per engine, with its 95% "
            "interval"
        )
    return [
        f"Every pair of the {len(summary['labels'])} engines, judged on the "
        f"{summary['headline']['title']} ({gap}; the table below has each pair's nominal gap "
        "and where it is born):"
    ] + [f"- {pair_words(p)}." for p in pairs]


def pairs_section(s: dict[str, Any]) -> list[str]:
    """With more than two engines, the pair table: one row per pair with its verdict, its judged
    gap and interval, its nominal runs' gap at the end, where that gap is born and the test's
    p-value; empty with two."""
    pairs = s.get("pairs") or []
    labels = s["labels"]
    if len(labels) <= 2 or not pairs:
        return []
    unit = s["headline"]["unit"]
    rows = []
    for p in pairs:
        a, b = p["labels"]
        v = p["verdict"]
        if v:
            t = v["judged_at"]
            when = "end" if t["why"] == "end" else f"t = {fmt_time(t['time'])}"
            judged = f"{interval_cell(v['gap'], unit)} ({when})"
        thr = p["headline"]["crossings"][0]
        if thr["time"] is None:
            born = f"never {fmt_threshold(thr['threshold'], unit)} apart"
        else:
            born = f"t = {fmt_time(thr['time'])} ({fmt_threshold(thr['threshold'], unit)})"
            words = parting_words(p.get("parting") or {})
            born += f", {words}" if words else ""
        rows.append(
            [
                f"{a} and {b}",
                verdict_word(v) if v else "not judged",
                judged if v else "n/a",
                fmt_value(p["headline"]["final"], unit),
                born,
                "n/a" if not v or v["test"] is None else f"{v['test']['p_value']:.2g}",
            ]
        )
    lines = ["## Every pair of engines", ""]
    lines += [
        f"Each pair is judged as the first pair below is, on the {s['headline']['title']}: the "
        "judged gap is the median over every pair of runs (one of each engine) at the judged "
        "instant, with its 95% bootstrap interval; the nominal gap is that of the runs with no "
        "offset at the end; the p-value is the two-sample test's, where it ran. Every figure is "
        "in `summary.json` under `pairs`.",
        "",
    ]
    lines += _table(
        [
            "pair",
            "verdict",
            "judged gap [95%] (when)",
            "nominal gap (end)",
            "where the nominal gap is born",
            "p",
        ],
        rows,
    )
    lines += [""]
    return lines


# ---------------------------------------------------------------- markdown


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return out


def markdown(
    c: Comparison,
    s: dict[str, Any],
    images: dict[str, Path],
    files: list[str],
    pictures: list[str] | None = None,
) -> str:
    """``report.md`` from ``summary.json``'s dict ``s``; ``pictures``: the lines of the runs'
    pictures (:func:`~simbridge.compare.report.frames.frames_section`), after the headline."""
    a, b = s["labels"][:2]
    cross = c.cross[c.timestep]
    if len(s["labels"]) > 2:
        title = ", ".join(s["labels"][:-1]) + f" and {s['labels'][-1]}"
    else:
        title = f"{a} against {b}"
    many = len(s["labels"]) > 2 and len(s.get("pairs") or []) > 1
    of = f" ({a} and {b})" if many else ""  # a section on the first pair alone
    lines = [f"# {s['scenario']}: {title}", ""]
    for statement in headline(s):  # a paragraph each; the pairs' bullets one list
        if statement.startswith("- ") and lines[-2].startswith("- "):
            lines.pop()
        lines += [statement, ""]
    left = left_out_words(s)
    if left:
        lines += [f"*{left}*", ""]
    same = self_check_words(s["backends"], s["profiles"], s["labels"])
    if same:  # an engine compared with itself
        lines += [f"**{same[0].upper()}{same[1:]}**", ""]
    if s["description"]:
        lines += [f"*Scenario:* {s['description']}", ""]
    lines += pictures or []
    # -- verdict
    lines += outcomes_section(s)
    lines += pairs_section(s) + pair_reasons(s)  # with more than two: what decides each
    lines += engines_section(s)  # and every engine's own figures
    if many:
        lines += [f"## {a} and {b}, the first pair", ""]
        for statement in first_pair_lines(s):
            lines += [statement, ""]
    if s.get("verdict"):
        lines += _verdict_section(s, of)
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
                _departure_count(s, label, m),
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
            "profile departures that apply here",
        ],
        rows,
    )
    lines += [
        "",
        "A profile departure is a documented place where an engine cannot reproduce the "
        "chosen profile (every one is in the README's departures table and in `summary.json` "
        "under `manifest`); the count is those that apply to this scenario out of the engine's "
        "all, each named in [Profile departures that apply here]"
        "(#profile-departures-that-apply-here).",
        "",
        f"Scenario file: `{s['scenario_file']}`. Followed robot: `{s['subject']}`.",
        "",
    ]
    lines += settings_section(s)
    # -- over time
    if many:  # a row per pair in each (:mod:`.pair_sections`)
        lines += crossings_section(s) + phases_section(s)
    else:
        lines += _over_time(cross)
    # -- where the gap is born, which part
    lines += _born_section(s)
    lines += parts_section(s) if many else _parts_section(s)
    resync_images = {k: images.pop(k) for k in list(images) if _is_resync(k)}
    lines += resync_section(s, resync_images)  # their figures here, not in Figures
    # -- final poses
    lines += ["## Final poses", ""]
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
    lines += _table([f"at t = {cross.time[-1]:.3f} s"] + list(s["labels"]), rows)
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
    lines += _table(
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
    # -- sweep
    if len(c.timesteps) > 1:
        lines += ["## Time-step sweep", ""]
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
        lines += _table(header, rows)
        lines += [
            "",
            "Wall time counts commands and steps only (recording excluded), on this machine, "
            "in one process; compare ratios, not absolute times.",
            "",
        ]
    # -- figures
    captions = {
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
    if images:
        lines += ["## Figures", ""]
        for key, path in images.items():
            lines += [f"![{key}]({path.name})", "", captions.get(key, ""), ""]
    # -- departures
    lines += _departures_section(s)
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


def _over_time(cross: Divergence) -> list[str]:
    """*When each quantity parts* and *Per phase* of two engines' nominal runs (``cross``)."""
    lines: list[str] = []
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
        CROSSINGS_NOTE,
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
    t = pose.tilt_from_spawn
    return f"{t / DEG:.1f}°" + (" (tipped over)" if t > TIP_ANGLE else "")


def _departure_count(s: dict[str, Any], label: str, manifest: dict[str, Any]) -> str:
    total = len(manifest.get("departures", {}) or {})
    deps = (s.get("departures") or {}).get(label)
    if deps is None:
        return str(total)
    found = sum(checked(x) for x in deps["apply"])  # one not checked is not said to apply
    return f"[{found} of {total}](#profile-departures-that-apply-here)"


MAX_EVENT_ROWS = 40
MAX_PART_ROWS = 15


def _born_section(s: dict[str, Any]) -> list[str]:
    """Each engine's events, the one the gap parted after, and the counts of each kind."""
    events = s.get("events")
    if not events:
        return []
    labels = list(events)
    p = s.get("parting") or {}
    q = QUANTITIES[s["headline_quantity"]]
    lines = ["## Where the gap is born", ""]
    many = len(s["labels"]) > 2 and len(s.get("pairs") or []) > 1
    first = " and ".join(s["labels"][:2])
    if many:  # every pair's parting, a bullet each; the events are every engine's
        lines += [
            f"Where each pair's {q.title} first comes "
            f"{fmt_threshold(q.thresholds[0], q.unit)} apart, and after what (each pair's "
            "figures: `summary.json` under `pairs[].parting`); the events below are every "
            "engine's.",
            "",
        ]
        lines += parting_lines(s) + [""]
    if p.get("time") is not None:
        if not many:
            lines += [
                f"The {q.title} first reaches {fmt_threshold(p['threshold'], q.unit)} at "
                f"t = {fmt_time(p['time'])}, {parting_words(p)}.",
                "",
            ]
        if p["ongoing"]:
            shown = [with_start(event_words(o, o["label"]), o["time"]) for o in p["ongoing"][:6]]
            more = len(p["ongoing"]) - len(shown)
            lines += [
                (f"Going on when {first} part: " if many else "Going on at that instant: ")
                + "; ".join(shown)
                + (f"; and {more} more" if more > 0 else "")
                + ".",
                "",
            ]
    elif not many:
        lines += [f"The {q.title} never reaches {fmt_threshold(q.thresholds[0], q.unit)}.", ""]
    rows = [
        [kind.replace("_", " ")] + [str(events[lab]["counts"][kind]) for lab in labels]
        for kind in KINDS
    ]
    rows.append(
        ["touching from the first step"]
        + [", ".join(events[lab]["initial_contacts"]) or "nothing" for lab in labels]
    )
    rows.append(
        ["at a joint limit from the start"]
        + [
            ", ".join(f"{x['joint']} ({x['side']})" for x in events[lab]["initial_limits"])
            or "none"
            for lab in labels
        ]
    )
    lines += _table(["events of " + s["subject"]] + labels, rows)
    lines += [
        "",
        "Contacts are per link (with the other bodies touching anything at that instant); a "
        "contact or condition interrupted for less than 0.05 s counts as going on; tilt is "
        "measured from the spawn orientation, about the world's up (against gravity).",
        "",
    ]
    merged = sorted(
        ((e["time"], k, lab, e) for k, lab in enumerate(labels) for e in events[lab]["events"]),
        key=lambda x: (x[0], x[1]),
    )
    if merged:
        chosen = merged
        t = p.get("time")
        if len(merged) > MAX_EVENT_ROWS:
            if t is None:
                chosen = merged[:MAX_EVENT_ROWS]
            else:
                before = [x for x in merged if x[0] <= t][-MAX_EVENT_ROWS // 2 :]
                after = [x for x in merged if x[0] > t]
                chosen = before + after[: MAX_EVENT_ROWS - len(before)]
        mark = p.get("event")
        rows = []
        for time, _, lab, e in chosen:
            words = event_words(e, lab)
            if mark and mark["label"] == lab and {**e, "label": lab} == mark:
                whose = f" between {first}" if many else ""
                words = f"**{words}** (the gap{whose} parts {p['relation']} this)"
            until = (
                ""
                if e["end"] is None
                and e["kind"]
                not in (
                    "airborne",
                    "tipped_over",
                    "contact_chatter",
                    "joint_limit",
                    "motor_saturated",
                )
                else ("the end" if e["end"] is None else fmt_time(e["end"]))
            )
            rows.append([fmt_time(time), e["phase"], lab, words, until])
        total = sum(events[lab]["total"] for lab in labels)
        lines += _table(["t", "phase", "engine", "event", "until"], rows)
        lines += [""]
        if len(chosen) < total:
            lines += [
                f"{len(chosen)} of {total} events shown (those around the parting); every one "
                "is in `summary.json` under `events`.",
                "",
            ]
    return lines


def _parts_section(s: dict[str, Any]) -> list[str]:
    """Joints and links ranked by when the engines part there, and how far."""
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
    lines += _table(["rank", "part", "apart by", "largest gap", "at the end"], rows)
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


def _departures_section(s: dict[str, Any]) -> list[str]:
    """The profile departures that apply to this scenario, with this run's figures."""
    deps = s.get("departures")
    if not deps:
        return []
    lines = ["## Profile departures that apply here", ""]
    for label, d in deps.items():
        if not d["apply"] and not d["left_out"]:
            lines += [f"{label}: none (it reproduces the profile).", ""]
            continue
        found = [x for x in d["apply"] if checked(x)]
        unchecked = [x["key"] for x in d["apply"] if not checked(x)]
        if found:
            rows = [[f"`{x['key']}`", x["text"], x["why"], x["measured"] or "none"] for x in found]
            lines += [f"{label}:", ""]
            lines += _table(
                ["departure", "what", "why it applies here", "measured in this run"], rows
            )
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


def failed_members_lines(e: dict[str, Any]) -> list[str]:
    """One line per engine whose ensemble members failed (killed their worker): how many, why,
    and on how many runs it was judged."""
    lines = []
    for label, f in e.get("engines", {}).items():
        if "failed" in f:
            lines += [
                f"**{f['failed']['members']} of {e['size']} {label} runs failed: "
                f"{', '.join(f['failed']['causes'])}; judged on {f['failed']['judged_on']}.**",
                "",
            ]
    return lines


def _verdict_section(s: dict[str, Any], of: str = "") -> list[str]:
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
        f"## Verdict{of}: {verdict_word(v)}",
        "",
    ]
    if e:
        pert = e["perturbation"]
        runs = (
            "Each engine ran the scenario once (the nominal run: no offsets, no spread). The "
            if e["size"] < 2
            else f"Each engine ran the scenario {e['size']} times: the nominal run and "
            f"{e['size'] - 1} with every spawn pose moved by {pert['position']:g} m and turned "
            f"by {pert['orientation']:g} rad in random directions (seed {e['seed']}). The "
        )
        lines += [
            runs
            + f"{q.title} is judged at every one of {v['instants']['total']} recorded instants "
            f"against each engine's own spread (the {v['spread_percentile']:g}th percentile of "
            "the distances between its runs) and its own time-step error (dt against dt/2, the "
            "position gains sent as the same controller at dt/2: PyBullet's position law has "
            f"the step in it); figures below are {where}, with 95% bootstrap intervals in "
            "brackets.",
            "",
        ]
        raised = perturbation_words(e)
        if raised and not of:  # with more engines, said in *Every engine*
            lines += [raised, ""]
        lines += failed_members_lines(e)
    rows = []
    for label, f in v["engine_figures"].items():
        hz = ", ".join(
            f"{fmt_threshold(h['threshold'], unit)}: {fmt_time(h['time'])}" for h in f["horizons"]
        )
        one = f["size"] < 2  # one run: no spread, no ratio to it
        rows.append(
            [
                label,
                str(f["size"]),
                "n/a (one run)" if one else iv(f["spread"]),
                "n/a" if one else iv(f["spread_end"]),
                "n/a" if one else fmt_value(f["largest_pair"], unit),
                f"{f['gap_over_spread']:.3g}" if spread_ratio(f, v["floor"]) else "n/a",
                fmt_value(f["own_error"], unit),
                f"{f['gap_over_own_error']:.3g}" if f["own_error"] > v["floor"] else "n/a",
                "n/a" if one else hz,
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
        f"({'every split' if test['exact'] else str(test['resamples']) + ' random splits'}"
        f"{_floor_words(test)}; alpha {test['alpha']:g})"
    )
    n = v["instants"]
    hi = v["marginal_range"][1]
    lines += [
        "",
        (
            "Gap between the engines (one run each): "
            if one_run(v)
            else "Gap between the engines (median over every pair of runs, one of each engine): "
        )
        + f"{iv(v['gap'])}; the nominal runs' gap: {fmt_value(v['nominal_gap'], unit)}; largest "
        f"on the way {fmt_value(v['max_gap']['value'], unit)} at t = "
        f"{fmt_time(v['max_gap']['time'])}. Tolerance for `agree`: "
        f"{fmt_threshold(v['tolerance'], unit)}; precision floor {v['floor']:.2g} {unit}.",
        "",
        f"Two-sample test on the runs' states {where}: {test_words}.",
        "",
        f"Instants: {n['agree']} below the tolerance, {n['chaotic']} at most {hi:g}x an "
        f"engine's spread, {n['unresolved']} at most {hi:g}x an engine's own time-step error "
        f"(and over {hi:g}x both spreads), {n['differ']} beyond every one of them (of "
        f"{n['total']}). "
        + (f"{within} " if (within := within_words(v)) else "")
        + f"A ratio between {v['marginal_range'][0]:g} and "
        f"{v['marginal_range'][1]:g} is near 1: the gap is not clearly larger, and the verdict "
        "says marginal.",
        "",
    ]
    if v["marginal_reasons"]:
        lines += ["Marginal: " + "; ".join(v["marginal_reasons"]) + ".", ""]
    return lines


def _floor_words(test: dict[str, Any]) -> str:
    """``, the smallest p-value 3 and 3 runs can give`` where the exact test's p-value is its
    floor (:func:`~.engine_figures.p_words`), else empty."""
    words = p_words(test)
    if "(" not in words:
        return ""
    n, m = test["sizes"]
    return f", the smallest p-value {n} and {m} runs can give"
