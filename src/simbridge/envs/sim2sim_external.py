"""A policy trained outside simbridge (Isaac Lab, MuJoCo Playground, Gymnasium):
``--trained-on external:NAME`` (:mod:`simbridge.envs.trained_on` reads the name).

Such a policy has no training engine here. The task states its contract: joint order,
observation layout and scales, action meaning and scale, gains, dt and decimation (the task's
own fields), and the joints' dynamics the training simulator had (its ``[trained]`` table:
:class:`~simbridge.envs.task.TrainedSpec`). Every engine is evaluated against that stated
contract:

- no engine is the training engine: every pair of engines is judged by McNemar's exact test on
  their paired seeds (:func:`pairs`; all pairs, not each against the best engine, whose choice
  would depend on the very successes tested); the rates table's columns against a training
  engine are left empty;
- the contract table shows the stated contract as its first column (:func:`with_stated`), and
  marks a row where an engine departs from it; a row the task does not state says so and is
  not marked;
- a policy that succeeds on fewer than half of the seeds on every engine points at the stated
  contract.
- ``--fail-on-drop`` fails on any pair that differs significantly (:func:`dropped`); report.html's
  headline lists every pair, and the replayed seed is the first where any two engines part.

An unknown name is taken only in the form ``external:NAME``: a misspelt engine
(``--trained-on pybulet``) is still an error naming the engines
(:class:`~simbridge.envs.errors.UnknownTrainingEngineError`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, NamedTuple

from simbridge.envs.trained_on import outside

if TYPE_CHECKING:
    from simbridge.envs.sim2sim import Sim2SimResult

__all__ = [
    "ARMATURE",
    "NOT_STATED",
    "UNREAD",
    "PAIRED_COLUMNS",
    "PAIRED_FIELDS",
    "Pair",
    "apart",
    "blank_paired_columns",
    "dropped",
    "headline",
    "pairs",
    "pairs_section",
    "summary",
    "with_stated",
]

NOT_STATED = "not stated"
"""The stated column's value where the task does not state the row."""
ARMATURE = "armature (not read from an engine)"
"""The contract table's row of a stated armature."""
UNREAD = (ARMATURE,)
"""Rows the engines' columns cannot fill (``-``): never marked as departing."""
PAIRED_COLUMNS = ("discordant (lost, won)", "McNemar p", "verdict", "return minus training")
"""The rates table's columns against a training engine: empty for an outside policy."""
PAIRED_FIELDS = ("discordant", "p_value", "verdict", "return_difference")
"""summary.json's fields of an engine against a training engine: None for an outside policy."""


class Pair(NamedTuple):
    """Two engines' paired successes."""

    first: str
    """The first engine's label."""
    second: str
    """The second's."""
    lost: int
    """Seeds that succeeded on the first only."""
    won: int
    """Seeds that succeeded on the second only."""
    p_value: float
    """McNemar's exact test (1.0 without a discordant seed)."""
    verdict: str
    """``same`` (p >= alpha), ``drop`` or ``rise`` of the second against the first."""


def pairs(result: Sim2SimResult) -> list[Pair]:
    """Every pair of engines (in the run's order), judged by McNemar's exact test.

    Args:
        result: the run.

    Returns:
        One :class:`Pair` per pair of engines.
    """
    from simbridge.envs.paired import mcnemar
    from simbridge.envs.sim2sim import ALPHA

    out = []
    runs = result.runs
    for i, a in enumerate(runs):
        for b in runs[i + 1 :]:
            lost, won, p = mcnemar([r.success for r in a.records], [r.success for r in b.records])
            verdict = "same" if p >= ALPHA else ("drop" if lost > won else "rise")
            out.append(Pair(a.engine.label, b.engine.label, lost, won, p, verdict))
    return out


def apart(result: Sim2SimResult) -> list[Pair]:
    """The pairs of engines whose successes differ significantly (:func:`pairs` whose verdict
    is not ``same``).

    Args:
        result: the run.

    Returns:
        Those pairs, in :func:`pairs`' order.
    """
    return [p for p in pairs(result) if p.verdict != "same"]


def dropped(result: Sim2SimResult) -> list[str]:
    """What ``--fail-on-drop`` fails on, in words: each engine whose success drops
    significantly against the training engine (its label); for a policy trained outside
    simbridge, no engine being the training engine, each pair of engines whose successes
    differ significantly (McNemar p < alpha, :func:`apart`), as ``LOWER below HIGHER``.

    The stated contract names no expected success rate, so an outside policy's drop is one
    engine against another, not against a number.

    Args:
        result: the run.

    Returns:
        The drops (empty: none).
    """
    if outside(result.trained_on) is None:
        return [f.label for f in result.figures[1:] if f.verdict == "drop"]
    return [
        f"{p.second} below {p.first}" if p.verdict == "drop" else f"{p.first} below {p.second}"
        for p in apart(result)
    ]


def _rate(result: Sim2SimResult, i: int) -> str:
    r = result.figures[i].rate
    return f"{r.successes}/{r.n} ({r.low:.2f}-{r.high:.2f})"


def headline(result: Sim2SimResult) -> list[str]:
    """The terminal's lines for an outside policy: each engine's success, the pairs that
    differ, and the contract's pointer.

    Args:
        result: the run (``trained_on`` is ``external:NAME``).

    Returns:
        The lines.
    """
    from simbridge.envs.sim2sim import TRAINED_FLOOR

    name = outside(result.trained_on)
    lines = [
        f"{f.label}: success {_rate(result, i)}"
        + (f", {f.nan_actions} NaN action(s)" if f.nan_actions else "")
        for i, f in enumerate(result.figures)
    ]
    parted = apart(result)
    lines.append(
        f"trained outside simbridge ({name}): no training engine; every pair of engines by "
        "McNemar's exact test: "
        + (
            "; ".join(
                f"{p.second} {p.verdict} against {p.first} (p = {p.p_value:.3g})" for p in parted
            )
            if parted
            else "no pair differs significantly"
        )
    )
    if result.points_at_contract:
        lines.append(
            f"the policy succeeds on less than {TRAINED_FLOOR:.0%} of the seeds on every engine: "
            f"look at the contract stated for {name} (joint order, observation layout and "
            "scales, action meaning, gains, dt and decimation) before the engines"
        )
    return lines


def pairs_section(result: Sim2SimResult) -> list[str]:
    """report.md's table of every pair (an outside policy's; none otherwise).

    Args:
        result: the run.

    Returns:
        The Markdown lines.
    """
    name = outside(result.trained_on)
    if name is None:
        return []
    out = [
        "",
        "## Every pair of engines",
        "",
        f"Trained outside simbridge ({name}), so no engine is the training engine: each pair "
        "is judged on its paired seeds by McNemar's exact test (lost: succeeded on the first "
        "engine only; won: on the second only).",
        "",
        "| first | second | lost, won | McNemar p | second against first |",
        "|---|---|---|---|---|",
    ]
    for p in pairs(result):
        out.append(
            f"| {p.first} | {p.second} | {p.lost}, {p.won} | {p.p_value:.3g} | {p.verdict} |"
        )
    out.append("")
    return out


def blank_paired_columns(lines: list[str]) -> list[str]:
    """The rates table with its columns against a training engine (:data:`PAIRED_COLUMNS`)
    emptied (``-``), found by their headers.

    Args:
        lines: the table's Markdown lines (header, rule, rows).

    Returns:
        The lines, changed.
    """
    header = [c.strip() for c in lines[0].strip().strip("|").split("|")]
    drop = {i for i, c in enumerate(header) if c in PAIRED_COLUMNS}
    out = lines[:2]
    for line in lines[2:]:
        cells = line.strip().strip("|").split("|")
        cells = [" - " if i in drop else c for i, c in enumerate(cells)]
        out.append("|" + "|".join(cells) + "|")
    return out


def _per_joint(values: Sequence[float]) -> str:
    return ", ".join(f"{v:g}" for v in values) if values else NOT_STATED


def _stated(result: Sim2SimResult, rows: list[tuple[str, list[str]]]) -> dict[str, str]:
    """The stated contract's value of each contract row it states (the task's rows from the
    first engine's column: every engine runs the same task; the joints' dynamics from the
    task's ``[trained]``)."""
    trained = result.runs[0].contract.get("trained") or {}
    task_rows = {
        "dt x decimation",
        "joint order (action)",
        "observation layout",
        "observation normalisation",
        "action meaning",
        "gains kp / kd / max_force",
    }
    out = {name: values[0] for name, values in rows if name in task_rows}
    out["backend"] = f"outside simbridge: {outside(result.trained_on)}"
    out["effort limit (joint table)"] = _per_joint(trained.get("effort_limit", ()))
    out["velocity limit"] = _per_joint(trained.get("velocity_limit", ()))
    out["joint damping"] = _per_joint(trained.get("damping", ()))
    out["joint friction"] = _per_joint(trained.get("friction", ()))
    return out


def with_stated(
    result: Sim2SimResult, labels: list[str], rows: list[tuple[str, list[str]]]
) -> tuple[list[str], list[tuple[str, list[str]]]]:
    """The contract table with the stated contract as its first column (an outside policy's;
    unchanged otherwise).

    Args:
        result: the run.
        labels: the engines' column names.
        rows: :func:`~simbridge.envs.sim2sim_report.contract_rows`.

    Returns:
        The column names and rows, the stated ones first (:data:`NOT_STATED` where the task
        states nothing), and an ``armature`` row when the task states one (the engines' cells
        ``-``: the Sim interface does not read an engine's armature).
    """
    name = outside(result.trained_on)
    if name is None:
        return labels, rows
    stated = _stated(result, rows)
    out = [(row, [stated.get(row, NOT_STATED), *values]) for row, values in rows]
    armature = (result.runs[0].contract.get("trained") or {}).get("armature", ())
    if armature:
        out.append(
            ("armature (not read from an engine)", [_per_joint(armature)] + ["-"] * len(labels))
        )
    return [f"stated ({name})", *labels], out


def summary(result: Sim2SimResult, rows: list[tuple[str, list[str]]]) -> dict[str, Any] | None:
    """summary.json's ``external`` (None for a policy trained on an engine).

    Args:
        result: the run.
        rows: :func:`~simbridge.envs.sim2sim_report.contract_rows`.

    Returns:
        ``{"framework", "pairs", "stated"}``: where it was trained, every pair's McNemar test,
        the stated contract's rows.
    """
    name = outside(result.trained_on)
    if name is None:
        return None
    return {
        "framework": name,
        "pairs": [p._asdict() for p in pairs(result)],
        "stated": _stated(result, rows),
    }
