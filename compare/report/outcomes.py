"""The scenario's outcomes in words: the headline's sentences (:func:`outcome_lines`) and the
report's section (:func:`outcomes_section`), from ``summary.json``'s ``outcomes`` alone."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..run.quantities import DEG
from ..scenario.outcomes import _TITLES
from .fmt import fmt_value

__all__ = ["outcome_lines", "outcomes_section"]


def _pm(dist: dict[str, Any] | None, unit: str, runs: int, none: str = "none") -> str:
    """``mean ± std`` over the runs with a value (``6.6 ± 0.02 s``), the count when some runs
    have none."""
    if dist is None:
        return none
    if dist["runs"] == 1:
        return fmt_value(dist["mean"], unit) + (f" (1 run of {runs})" if runs > 1 else "")
    mean, std = dist["mean"], dist["std"]
    if unit == "m":  # both in the mean's unit: 0.68 ± 0.025 mm
        steps = ((1.0, 1.0, "m"), (0.01, 100.0, "cm"), (1e-4, 1000.0, "mm"))
        factor, name = next(((f, n) for lim, f, n in steps if abs(mean) >= lim), (1.0, "m"))
        text = f"{mean * factor:.3g} ± {std * factor:.2g} {name}"
    elif unit == "rad":
        text = f"{mean / DEG:.3g} ± {std / DEG:.2g}°"
    else:
        text = f"{mean:.3g} ± {std:.2g} {unit}".rstrip()
    if dist["runs"] < runs:
        text += f" ({dist['runs']} runs of {runs})"
    return text


def outcome_lines(summary: Mapping[str, Any]) -> list[str]:
    """The headline's outcome sentences, one per outcome, from ``summary.json`` alone::

        **goal (0, 2)**: reached in 16/16 runs on pybullet [81%, 100%], 16/16 on mujoco
        [81%, 100%]; time to reach 6.1 ± 0.01 s against 6.13 ± 0.002 s.

    Empty when the scenario declares no outcome."""
    out = summary.get("outcomes")
    if not out:
        return []
    labels = list(out["engines"])
    lines = []
    for decl in out["declared"]:
        name, unit = decl["name"], decl["unit"]
        per = [out["engines"][label][name] for label in labels]
        notes = [_note(p) for p in per]
        if all(p["success"] is None and p["value"] is None for p in per) and all(notes):
            # nothing measured (a phase or a function a cut run could not give): say why
            said = dict.fromkeys(n for n in notes if n is not None)
            lines.append(f"**{name}**: not evaluated: " + "; ".join(said) + ".")
            continue
        parts = []
        verb = {
            "reach": "reached",
            "upright": "upright",
            "track": "within bound",
            "final_pose": "within bound",
            "effort": "within bound",
            "function": "succeeded",
        }[decl["kind"]]
        if all(p["success"] is not None for p in per):
            cells = []
            for i, (label, p) in enumerate(zip(labels, per, strict=True)):
                s = p["success"]
                ci = f"[{s['low'] * 100:.0f}%, {s['high'] * 100:.0f}%]"
                head = f"{verb} in " if i == 0 else ""
                cells.append(f"{head}{s['successes']}/{s['runs']} runs on {label} {ci}")
            parts.append(", ".join(cells))
        runs = [len(p["runs"]) for p in per]
        never = "never" if decl["kind"] == "reach" else "none"
        values = [_pm(p["value"], unit, n, never) for p, n in zip(per, runs, strict=True)]
        title = _TITLES[decl["kind"]]
        if decl["kind"] == "reach" and all(p["value"] is None for p in per):
            values_text = "no run reached it"
            closest = [
                min(near)
                for p in per
                if (near := [r["closest"] for r in p["runs"] if r.get("closest") is not None])
            ]
            if len(closest) == len(per):
                values_text += "; closest " + " and ".join(
                    f"{fmt_value(c, 'm')} on {label}"
                    for c, label in zip(closest, labels, strict=True)
                )
            parts.append(values_text)
        elif decl["kind"] == "reach":
            parts.append(
                f"{title}: "
                + ", ".join(f"{v} on {lab}" for v, lab in zip(values, labels, strict=True))
            )
        else:
            parts.append(
                f"{title} "
                + " against ".join(f"{v} on {lab}" for v, lab in zip(values, labels, strict=True))
            )
        lines.append(f"**{name}**: " + "; ".join(parts) + ".")
    return lines


def _note(stats: Mapping[str, Any]) -> str | None:
    """The nominal run's note on an outcome (why it was not measured as declared), if any."""
    nominal = stats.get("nominal")
    return None if nominal is None else nominal.get("note")


def _state(record: Mapping[str, Any], unit: str) -> str:
    ok = {True: "succeeds", False: "fails", None: "has no success"}[record["success"]]
    v = record.get("value")
    return ok + ("" if v is None else f" ({fmt_value(v, unit)})")


def _half_timestep_changes(out: Mapping[str, Any]) -> list[str]:
    """Outcomes whose success differs between an engine's nominal run and its run at half the
    time step, in words."""
    half = out.get("half_timestep") or {}
    words = []
    for decl in out["declared"]:
        name, unit = decl["name"], decl["unit"]
        for label, records in half.items():
            nominal = out["engines"][label][name]["nominal"]
            there = records.get(name)
            if nominal is None or there is None or nominal["success"] == there["success"]:
                continue
            a, b = _state(nominal, unit), _state(there, unit)
            words.append(f"{name} on {label} {a} at dt, {b} at dt/2")
    return words


def outcomes_section(summary: Mapping[str, Any]) -> list[str]:
    """The report's ``## Outcomes`` section (markdown lines): per outcome and engine, the
    success count and rate with its interval, the value's distribution and the nominal run's
    value. Empty when the scenario declares no outcome."""
    out = summary.get("outcomes")
    if not out:
        return []
    pct = f"{out['confidence'] * 100:g}%"
    lines = [
        "## Outcomes",
        "",
        "What the scenario calls success, measured on every run of each engine's ensemble "
        f"(the nominal run first). Success rates carry {pct} Wilson score intervals "
        "(`scipy.stats.binomtest`); values are mean ± standard deviation over the runs that "
        "have one (a goal never reached has no time).",
        "",
        "| outcome | engine | success | rate [interval] | value: mean ± std | median | "
        "min – max | nominal run |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for decl in out["declared"]:
        name, unit = decl["name"], decl["unit"]
        for label, per in out["engines"].items():
            p = per[name]
            s, v, nom = p["success"], p["value"], p["nominal"]
            cells = [f"{name} ({_TITLES[decl['kind']]})", label]
            if s is None:
                cells += ["n/a", "n/a"]
            else:
                cells += [
                    f"{s['successes']}/{s['runs']}",
                    f"{s['rate'] * 100:.0f}% [{s['low'] * 100:.0f}%, {s['high'] * 100:.0f}%]",
                ]
            if v is None:
                cells += ["never" if decl["kind"] == "reach" else "none", "", ""]
            else:
                cells += [
                    _pm(v, unit, len(p["runs"])),
                    fmt_value(v["median"], unit),
                    f"{fmt_value(v['min'], unit)} – {fmt_value(v['max'], unit)}",
                ]
            nv = None if nom is None else nom.get("value")
            if nv is not None:
                cells.append(fmt_value(nv, unit))
            elif decl["kind"] == "reach" and nom is not None and nom.get("closest") is not None:
                cells.append(f"never (closest {fmt_value(nom['closest'], 'm')})")
            elif _note(p) is not None:
                cells.append(f"not evaluated: {_note(p)}")
            else:
                cells.append("none")
            lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    changed = _half_timestep_changes(out)
    if changed:
        lines += [
            "At half the time step (each engine's own-error run) the nominal run's outcome "
            "changes: " + "; ".join(changed) + ".",
            "",
        ]
    for decl in out["declared"]:
        keys = {k: v for k, v in decl.items() if k not in ("name", "kind", "unit")}
        words = ", ".join(f"{k} = {v}" for k, v in keys.items())
        lines.append(f"- `{decl['name']}`: {decl['kind']}" + (f" ({words})" if words else ""))
    lines.append("")
    return lines


MAX_BRIEF_CHARS = 160
"""The longest outcome line of the terminal's headline (:func:`outcome_brief`) before its
pointer to report.md."""


def _brief_one(decl: Mapping[str, Any], per: dict[str, Mapping[str, Any]]) -> tuple[str, str]:
    """The outcome's name and its state: ``every run on every engine``, ``3/4 on mujoco, 0/4 on
    physx (every run on pybullet)``, ``measured``, ``not evaluated``."""
    name = decl["name"]
    stats = list(per.values())
    if all(p["success"] is None and p["value"] is None for p in stats):
        return name, "not evaluated"
    if any(p["success"] is None for p in stats):
        return name, "measured"
    short = [
        (lab, p["success"])
        for lab, p in per.items()
        if p["success"]["successes"] < p["success"]["runs"]
    ]
    if not short:
        return name, "every run on every engine"
    if all(s["successes"] == 0 for _, s in short) and len(short) == len(per):
        return name, "no run on any engine"
    words = ", ".join(f"{s['successes']}/{s['runs']} on {lab}" for lab, s in short)
    full = [lab for lab in per if lab not in dict(short)]
    if full:
        words += f" (every run on {' and '.join(full)})"
    return name, words


def outcome_brief(summary: Mapping[str, Any]) -> str | None:
    """The terminal's outcome line, bounded (:data:`MAX_BRIEF_CHARS` before its pointer): per
    outcome, whether every run of every engine succeeded or which engines fell short (their
    counts), outcomes in the same state named together (``every run on every engine: settles
    at A, settles at B``), as many as fit and how many more; the figures stay in report.md's
    *Outcomes*. None when the scenario declares no outcome."""
    out = summary.get("outcomes")
    if not out or not out.get("declared"):
        return None
    labels = list(out["engines"])
    groups: dict[str, list[str]] = {}  # a state shared by several outcomes: their names
    for decl in out["declared"]:
        name, state = _brief_one(decl, {lab: out["engines"][lab][decl["name"]] for lab in labels})
        key = state if state in _SHARED else f"{name}: {state}"
        groups.setdefault(key, []).append(name)
    said = [
        (
            f"{key}: {', '.join(names)}"
            if key in _SHARED and len(names) > 1
            else f"{names[0]}: {key}"
        )
        if key in _SHARED
        else key
        for key, names in groups.items()
    ]
    shown: list[str] = []
    for k, words in enumerate(said):
        if shown and len("; ".join([*shown, words])) > MAX_BRIEF_CHARS:
            rest = sum(len(names) for names in list(groups.values())[k:])
            shown.append(f"and {rest} more")
            break
        shown.append(words)
    return "outcomes: " + "; ".join(shown) + " (figures: report.md, Outcomes)"


_SHARED = ("every run on every engine", "no run on any engine", "not evaluated", "measured")
