"""The open-loop replays' report (:mod:`.sim2sim_openloop`): a line per engine
(:func:`engine_line`, :func:`lines`), report.md's section (:func:`section`) and summary.json's
``openloop`` (:func:`summary`), compare's verdicts written as compare writes them
(:func:`simbridge.compare.report.summary_dicts.verdict_dict`,
:func:`~simbridge.compare.report.verdict.verdict_word`)."""

from __future__ import annotations

from typing import Any

from simbridge.envs.sim2sim_openloop import SEVERITY, OpenLoop

__all__ = ["engine_line", "lines", "section", "summary"]


def _engines(ol: OpenLoop) -> list[str]:
    return list(dict.fromkeys(r.engine for r in ol.replays))


def engine_line(ol: OpenLoop, label: str) -> str:
    """One engine's replays in a line: the seeds per verdict and where it parts first.

    Args:
        ol: the replays.
        label: an engine's label.

    Returns:
        ``mujoco: open loop, 4 seeds: differ 3, chaotic 1; parts first at 0.42 s (seed 2,
        base_distance)``.
    """
    rs = [r for r in ol.replays if r.engine == label]
    counts = {v: sum(r.verdict == v for r in rs) for v in reversed(SEVERITY)}
    said = ", ".join(f"{v} {n}" for v, n in counts.items() if n)
    firsts = [(t, r.seed, q) for r in rs for q, t in r.parts_at.items() if t is not None]
    if firsts:
        t, s, q = min(firsts)
        where = f"parts first at {t:.3g} s (seed {s}, {q})"
    else:
        where = f"never leaves {ol.trained_on}'s envelope"
    return f"{label}: open loop, {len(rs)} seed(s): {said}; {where}"


def lines(ol: OpenLoop | None) -> list[str]:
    """Every engine's :func:`engine_line` (none without the replays).

    Args:
        ol: the replays, or None.

    Returns:
        One line per engine replayed.
    """
    return [] if ol is None else [engine_line(ol, e) for e in _engines(ol)]


def section(ol: OpenLoop | None) -> list[str]:
    """report.md's section on the open-loop replays (none without them).

    Args:
        ol: the replays, or None.

    Returns:
        The Markdown lines.
    """
    if ol is None:
        return []
    from simbridge.compare.report.summary_dicts import verdict_dict
    from simbridge.compare.report.verdict import interval_cell, verdict_word

    whose = "the training engine's" if not ol.outside else "the first engine's"
    out = [
        "",
        f"## Where the physics parts: {whose} actions replayed open loop",
        "",
    ]
    if ol.outside:
        out += [
            f"The policy was trained outside simbridge ({ol.outside}), whose run's actions "
            f"simbridge has no log of: {ol.trained_on}, the first engine evaluated, stands in "
            "for it. The replays then say where the engines' physics part under the same "
            f"actions, not where {ol.outside}'s does.",
            "",
        ]
    out += [
        f"The actions {ol.trained_on} sent in seeds {', '.join(map(str, ol.seeds))} are sent "
        f"again, open loop, from the same initial state, on every engine: {ol.ensemble} runs "
        "per engine and seed, each but the first with the robot's joints (and a free base's "
        "pose) moved by a tiny offset ("
        + ", ".join(f"{k} {v:.2g}" for k, v in ol.perturbation.items())
        + " rad or m), and one at half the time step. compare's verdict judges each engine's "
        f"runs against {ol.trained_on}'s: its own runs' spread is the chaos floor. A seed's "
        "verdict is its quantities' most severe; *parts at* is the first instant its runs "
        f"leave {ol.trained_on}'s envelope (the gap at least the tolerance and more than twice "
        f"{ol.trained_on}'s spread).",
        "",
    ]
    if ol.reproduces:
        worst = max(ol.reproduces.values())
        within = (
            "exactly" if worst == 0 else f"within {worst:.3g} rad or m (the largest difference)"
        )
        out += [
            f"{ol.trained_on}'s unperturbed replay repeats its closed-loop episodes {within}.",
            "",
        ]
    for s, why in ol.skipped.items():
        out.append(f"- seed {s} not replayed: {why}")
    out += [f"- {line}" for line in lines(ol)]
    out += [
        "",
        "| engine | seed | steps | quantity | verdict | gap (95% interval) | at | "
        f"{ol.trained_on}'s spread there | parts at |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in ol.replays:
        q = r.deciding
        v = verdict_dict(r.verdicts[q])
        spread = v["engine_figures"][v["labels"][0]]["spread"]
        t = r.parts_at[q]
        note = "" if r.diverged_at is None else f" (diverged at {r.diverged_at:.3g} s)"
        out.append(
            f"| {r.engine} | {r.seed} | {r.steps} | {q} | {verdict_word(v)}{note} | "
            f"{interval_cell(v['gap'], v['unit'])} | {v['judged_at']['time']:.3g} s "
            f"({v['judged_at']['why']}) | {interval_cell(spread, v['unit'])} | "
            f"{'-' if t is None else f'{t:.3g} s'} |"
        )
    out.append("")
    return out


def summary(ol: OpenLoop | None) -> dict[str, Any] | None:
    """summary.json's ``openloop`` (None without the replays).

    Args:
        ol: the replays, or None.

    Returns:
        JSON-ready: the inputs, per engine its line, per replay every quantity's verdict
        (compare's ``verdict`` dict) and where it parts.
    """
    if ol is None:
        return None
    from simbridge.compare.report.summary_dicts import verdict_dict

    return {
        "trained_on": ol.trained_on,
        "outside": ol.outside or None,
        "seeds": ol.seeds,
        "ensemble": ol.ensemble,
        "perturbation": ol.perturbation,
        "steps": {str(k): v for k, v in ol.steps.items()},
        "reproduces": {str(k): v for k, v in ol.reproduces.items()},
        "skipped": {str(k): v for k, v in ol.skipped.items()},
        "engines": {e: engine_line(ol, e) for e in _engines(ol)},
        "replays": [
            {
                "engine": r.engine,
                "seed": r.seed,
                "steps": r.steps,
                "verdict": r.verdict,
                "deciding": r.deciding,
                "parts_at": r.parts_at,
                "diverged_at": r.diverged_at,
                "quantities": {q: verdict_dict(v) for q, v in r.verdicts.items()},
            }
            for r in ol.replays
        ],
    }
