"""Words that match the numbers: wherever a report, the terminal headline or summary.json's
``reason`` says the gap is "within" an engine's spread or own time-step error, the ratio beside
it is at most 1; above 1 the words give the ratio itself, as summary.json does.

Checked on every shipped scenario's recorded report (tests/compare/data/baseline: each
scenario's report.md and summary.json, which test_compare_same_results proves the code still
writes) and on verdicts made to fall on either side of 1 and of the marginal range's end."""

from __future__ import annotations

import gzip
import json
import re
from pathlib import Path

import numpy as np
import pytest

from simbridge.compare.analysis.verdict import MARGINAL, OWN_ERROR_REASONS, judge
from simbridge.compare.report.brief import brief
from simbridge.compare.report.summary_json import verdict_dict
from simbridge.compare.report.verdict import pair_words, verdict_lines

BASELINE = Path(__file__).resolve().parents[1] / "data" / "baseline"
CASES = sorted(p.name for p in BASELINE.iterdir() if (p / "report.md").exists())


def _x(r: float) -> str:
    return f"{r:.3g}x"


def check_words(text: str, v: dict) -> list[str]:
    """What in ``text`` contradicts the verdict ``v`` (summary.json's): "within" beside a
    ratio above 1, a ratio that is not the figure's, a reason that is not the ratios'."""
    wrong = []
    figs = v["engine_figures"]
    keys = {"own time-step error": "gap_over_own_error", "own spread": "gap_over_spread"}
    keys["spread"] = "gap_over_spread"
    # "within X's <figure>", "within X and Y's <figure>"; not a count ("... at 980 instants")
    for m in re.finditer(
        r"within ([^;:,()]{1,80}?)'s (own time-step error|own spread|spread)"
        r"(?! at \d)",
        text,
    ):
        for name in m.group(1).split(" and "):
            if name in figs and figs[name][keys[m.group(2)]] > 1.0:
                ratio = figs[name][keys[m.group(2)]]
                wrong.append(f"{m.group(0)!r} beside {name}'s ratio {ratio:.3g}")
    for label, f in figs.items():
        for m in re.finditer(rf"([0-9.e+]+)x {re.escape(label)}'s own time-step error", text):
            if m.group(1) + "x" != _x(f["gap_over_own_error"]):
                wrong.append(f"{m.group(0)!r}: the figure is {_x(f['gap_over_own_error'])}")
    reason = v["reason"]
    if reason in OWN_ERROR_REASONS or reason in ("within spread", "near spread"):
        key = "gap_over_own_error" if reason in OWN_ERROR_REASONS else "gap_over_spread"
        least = min(figs[lab][key] for lab in v["engines"])
        if reason.startswith("within") != (least <= 1.0) or least > MARGINAL[1]:
            wrong.append(f"reason {reason!r} with the smallest ratio {least:.3g}")
    if "marginal" in text and v["marginal"] and "near 1" not in text:
        wrong.append("marginal, with no word of what its range means")
    return wrong


@pytest.mark.parametrize("case", CASES)
def test_every_shipped_scenarios_report_says_what_its_figures_say(case):
    with gzip.open(BASELINE / case / "summary.json.gz", "rt", encoding="utf-8") as f:
        summary = json.load(f)
    report = (BASELINE / case / "report.md").read_text(encoding="utf-8")
    v = summary["verdict"]
    assert check_words(report, v) == []
    assert check_words(" ".join(verdict_lines(summary)), v) == []
    for pair in summary.get("pairs") or []:
        if pair["verdict"]:
            assert check_words(pair_words(pair), pair["verdict"]) == []


def _summary(own_b: float, spread_b: float = 0.0) -> dict:
    """A made verdict: engine A's runs 1e-6 m apart, B's ``spread_b`` apart, the engines 1 m
    apart, B's own time-step error ``own_b`` (m)."""
    t = np.linspace(0.0, 1.0, 5)
    a = np.zeros((4, 5, 3))
    a[:, :, 0] = (np.arange(4) * 1e-6)[:, None]
    b = np.zeros((4, 5, 3))
    b[:, :, 0] = 1.0 + (np.arange(4) * spread_b / 3)[:, None]
    own = [np.full(5, 1e-3), np.full(5, own_b)]
    v = judge(t, "base_distance", ["A", "B"], [a, b], own)
    return {
        "scenario": "made",
        "labels": ["A", "B"],
        "verdict": verdict_dict(v),
        "ensemble": {"perturbation": {"position": 1e-9, "orientation": 1e-9}, "size": 4},
        "headline": {
            "final": 1.0,
            "max": 1.0,
            "unit": "m",
            "title": "base position distance",
            "crossings": [{"threshold": 0.01, "time": 0.0}],
        },
        "duration": 1.0,
        "timestep_text": "1/240",
    }


@pytest.mark.parametrize(
    "own_b, reason",
    [
        (1.25, "within own time-step error"),  # 0.8x
        (1.0 / 1.13, "near own time-step error"),  # the Panda's 1.13x
        (1.0 / 1.93, "near own time-step error"),  # laikago-stand's 1.93x, before
        (1.0 / 2.5, None),  # beyond 2x: not covered
    ],
)
def test_either_side_of_one_and_of_the_marginal_range(own_b, reason):
    s = _summary(own_b)
    v = s["verdict"]
    if reason is None:
        assert v["reason"] not in OWN_ERROR_REASONS
    else:
        assert v["verdict"] == "unresolved" and v["reason"] == reason
    words = [*verdict_lines(s), pair_words({**s, "verdict": v}), brief(s)[0]]
    for text in words:
        assert check_words(text, v) == [], text
    if reason == "near own time-step error":
        ratio = v["engine_figures"]["B"]["gap_over_own_error"]
        assert f"{_x(ratio)} B's own time-step error" in verdict_lines(s)[0]
        assert "not clearly larger" in verdict_lines(s)[0]


def test_the_checker_catches_the_old_words():
    """The words the Panda's report had: "within" beside 1.13x."""
    s = _summary(1.0 / 1.13)
    assert check_words("(within B's own time-step error)", s["verdict"]) != []
    assert check_words("which lies within A and B's own time-step error", s["verdict"]) != []
    assert check_words("the gap is 1.5x B's own time-step error", s["verdict"]) != []
