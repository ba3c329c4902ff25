"""The terminal's headline keeps the outcomes to one bounded line that points to report.md,
where every figure stays: a closed-loop scenario (kuka-reach, several outcomes) on every engine,
and outcomes built by hand."""

from __future__ import annotations

import json

import pytest

from simbridge.compare import Outcome, compare, report
from simbridge.compare.analysis.outcomes import summarize
from simbridge.compare.report import brief
from simbridge.compare.report.brief import MAX_LINES
from simbridge.compare.report.outcomes import MAX_BRIEF_CHARS, outcome_brief, outcome_lines
from simbridge.compare.report.summary_json import outcome_stats_dict
from simbridge.compare.run.outcomes import OutcomeRecord

POINTER = " (figures: report.md, Outcomes)"


def _summary(n_outcomes: int, *, short: dict[str, int] | None = None) -> dict:
    """``n_outcomes`` reach outcomes with long names on three engines of 4 runs, every run
    reaching but ``short``'s (engine: successes)."""
    short = short or {}
    declared, engines = [], {lab: {} for lab in ("pybullet", "mujoco", "physx")}
    for k in range(n_outcomes):
        o = Outcome.reach(f"the end effector settles within 1 cm of target {k}", (0, 2), 0.05)
        declared.append(o.to_dict())
        for lab in engines:
            ok = [j < short.get(lab, 4) for j in range(4)]
            recs = [OutcomeRecord(o.name, o.kind, o.unit, 1.0 if s else None, s) for s in ok]
            engines[lab][o.name] = outcome_stats_dict(summarize(o, recs))
    return {"outcomes": {"declared": declared, "confidence": 0.95, "engines": engines}}


def test_outcomes_are_one_bounded_line():
    s = _summary(12, short={"physx": 1})
    full = " ".join(outcome_lines(s))
    line = outcome_brief(s)
    assert line is not None and line.endswith(POINTER) and line.startswith("outcomes: ")
    assert len(line) <= len("outcomes: ") + MAX_BRIEF_CHARS + len(POINTER) + len("; and 12 more")
    assert len(full) > 3 * len(line)  # the full sentences stay in report.md
    assert "1/4 on physx (every run on pybullet and mujoco)" in line
    assert line.split(POINTER)[0].endswith(" more")
    shown = line.count("settles within")
    assert f"and {12 - shown} more" in line


def test_every_run_reaching_is_said_in_a_word():
    assert outcome_brief(_summary(1)) == (
        "outcomes: the end effector settles within 1 cm of target 0: every run on every engine"
        + POINTER
    )
    none = _summary(1, short={"pybullet": 0, "mujoco": 0, "physx": 0})
    assert ": no run on any engine" in (outcome_brief(none) or "")
    assert outcome_brief({"outcomes": None}) is None


@pytest.mark.needs_backend("physx")
def test_a_closed_loop_headline_stays_short(tmp_path):
    # the first phase of kuka-reach (to A, 2 s), 2 runs per engine
    c = compare("kuka-reach", ["pybullet", "mujoco", "physx"], duration=2.0, ensemble=2, workers=0)
    path = report(c, tmp_path, plots=False, trajectories=False, replay=False)
    s = json.loads((tmp_path / "summary.json").read_text("utf-8"))
    lines = brief(s, tmp_path / "report.md")
    assert len(lines) <= MAX_LINES
    assert lines[0].startswith("outcomes: ") and lines[0].endswith(POINTER)
    # the move to A reaches on every run of every engine (1 s minimum-jerk, measured); the
    # outcomes of the later phases, cut off at 2 s, are named together
    assert "every run on every engine: settles at A" in lines[0]
    assert "not evaluated: settles at B, settles at C" in lines[0]
    assert len(lines[0]) <= len("outcomes: ") + MAX_BRIEF_CHARS + len(POINTER) + 20
    assert all(len(x) < 400 for x in lines), [len(x) for x in lines]
    text = path.read_text("utf-8")
    for sentence in outcome_lines(s):  # every figure still in report.md
        assert sentence in text
    assert "## Outcomes" in text
