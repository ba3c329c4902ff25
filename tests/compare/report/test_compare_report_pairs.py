"""The report of three engines judges every pair alike: the terminal's headline, report.md's
opening, its pair table, final poses, own-error table and figures, on PyBullet, MuJoCo and PhysX
(r2d2, a short run with small ensembles)."""

from __future__ import annotations

import importlib
import importlib.util
import json
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from simbridge.compare import compare, report
from simbridge.compare.analysis.diff import QUANTITIES
from simbridge.compare.report import brief, plots
from simbridge.compare.report.events import parting_words
from simbridge.compare.report.fmt import fmt_apart, fmt_threshold, fmt_time, fmt_value
from simbridge.compare.report.pair_sections import MAX_PART_ROWS
from simbridge.compare.report.parts import parts_words
from simbridge.compare.report.verdict import interval_cell, pair_words, verdict_word
from simbridge.compare.study import sweep, write_sweep

pytestmark = pytest.mark.needs_backend("physx")  # tests/_engines.py: skipped, or fails in CI
LEFT = {"ghost": "No module named 'ghost'"}


@pytest.fixture(scope="module")
def three():
    c = compare("r2d2", ["pybullet", "mujoco", "physx"], duration=0.5, ensemble=3, workers=0)
    return replace(c, left_out=dict(LEFT))  # as if a registered engine were not installed


@pytest.fixture(scope="module")
def written(three, tmp_path_factory):
    out = tmp_path_factory.mktemp("three")
    path = report(three, out, trajectories=False, replay=False)
    s = json.loads((out / "summary.json").read_text("utf-8"))
    return path.read_text("utf-8"), s


def _judged(p: dict) -> str:
    """The judged gap of a pair as the writers print it: in the report's unit, with more digits
    where its interval is too narrow for the report's rounding."""
    v = p["verdict"]
    g = v["gap"]
    shown = fmt_value(g["value"], v["unit"])
    if g["low"] is not None and g["low"] != g["high"]:
        if len({fmt_value(g[k], v["unit"]) for k in ("low", "value", "high")}) < 3:
            return fmt_apart([g["value"], g["low"], g["high"]], v["unit"])[0]
    return shown


def test_the_terminal_gives_every_pair_the_same_judged_figure(written):
    _, s = written
    lines = brief(s, "out/report.md")
    assert len(lines) <= 6 and lines[-1] == "report: out/report.md"
    assert lines[0].startswith("r2d2 on pybullet, mujoco and physx, every pair judged on the")
    body = lines[1:4]
    for line, p in zip(body, s["pairs"], strict=True):
        a, b = p["labels"]
        v = p["verdict"]
        assert line.startswith(f"  {a} and {b}: {v['verdict'].upper()}"), line
        assert f"a median {_judged(p)}" in line
        if v["gap"]["low"] is not None and v["gap"]["low"] != v["gap"]["high"]:
            assert "95% interval" in line
        if v["verdict"] == "chaotic":  # the engine named, as report.md names it
            assert f"CHAOTIC ({' and '.join(v['engines'])}" in line
        if v["test"] is not None:
            assert "p " in line
        assert "nominal" not in line  # the nominal runs' gap is not the pair's figure
    assert "ghost (No module named 'ghost')" in lines[4]


def test_one_run_per_engine_claims_no_interval(written):
    import copy

    from simbridge.compare.report.markdown import pairs_lines

    _, s = written
    one = copy.deepcopy(s)
    one["ensemble"]["size"] = 1
    head = brief(one, "r.md")[0]
    assert head.endswith("(one run per engine):") and "interval" not in head
    lead = pairs_lines(one)[0]
    assert "the gap of the one run per engine, no interval" in lead and "95%" not in lead
    assert "3 per engine, with its 95% interval" in pairs_lines(s)[0]


def test_the_terminal_leads_with_the_outcomes(written, monkeypatch):
    _, s = written
    module = importlib.import_module("simbridge.compare.report.brief")
    monkeypatch.setattr(module, "outcome_brief", lambda s: "goal: reached 3/3")
    lines = brief(s, "r.md")
    assert lines[0] == "goal: reached 3/3" and len(lines) <= 6
    assert lines[1].startswith("r2d2 on pybullet") and lines[-1] == "report: r.md"
    # every pair still shown; the engine left out named in a word, its reason in report.md
    assert [x.split(":")[0] for x in lines[2:5]] == [
        "  pybullet and mujoco",
        "  pybullet and physx",
        "  mujoco and physx",
    ]
    assert lines[1].endswith("(ghost left out: report.md)")


def test_the_opening_is_paragraphs_and_a_bullet_per_pair(written):
    text, s = written
    head = text.split("\n## ", 1)[0]
    paragraphs = head.split("\n\n")
    assert paragraphs[0].startswith("# r2d2: pybullet, mujoco and physx")
    (bullets,) = [x for x in paragraphs if x.startswith("- ")]  # one list, a pair a line
    assert bullets.splitlines() == [f"- {pair_words(p)}." for p in s["pairs"]]
    others = [x for x in paragraphs[1:] if x != bullets]
    assert all("\n" not in x.strip("\n") for x in others), "a statement per paragraph"
    # the engines left out: a line below the headline, not in it
    n = len(s["headline"]["text"]) - (len(s["pairs"]) - 1)  # paragraphs: the list is one
    assert "\n".join(paragraphs[1 : 1 + n]).splitlines() == s["headline"]["text"]
    assert paragraphs[1 + n] == "*Registered engines left out, not installed here: " + (
        "ghost (No module named 'ghost').*"
    )
    assert not any("left out" in x for x in s["headline"]["text"])
    assert text.count("Registered engines left out") == 1


def test_the_pair_table_has_one_row_per_pair(written):
    text, s = written
    section = text.split("## Every pair of engines\n", 1)[1].split("\n## ", 1)[0]
    rows = [r for r in section.splitlines() if r.startswith("| ")]
    assert rows[0] == (
        "| pair | verdict | judged gap [95%] (when) | nominal gap (end) "
        "| where the nominal gap is born | p |"
    )
    body = [r.strip("| ").split(" | ") for r in rows[1:]]
    assert len(body) == 3
    for cells, p in zip(body, s["pairs"], strict=True):
        v = p["verdict"]
        assert cells[0] == " and ".join(p["labels"])
        assert cells[1] == verdict_word(v)
        assert cells[2].startswith(_judged(p))
        if v["gap"]["low"] is not None:
            assert re.match(r"\S+ \S+ \[\S+ \S+, \S+ \S+\] \((end|t = .+)\)", cells[2])
        assert cells[3] == fmt_value(p["headline"]["final"], v["unit"])
        crossing = p["headline"]["crossings"][0]["time"]
        assert cells[4].startswith("never" if crossing is None else f"t = {crossing:.3f} s")
        assert cells[5] == ("n/a" if v["test"] is None else f"{v['test']['p_value']:.2g}")


def test_final_poses_and_own_errors_show_every_engine(written):
    text, s = written
    poses = text.split("## Final poses\n", 1)[1].split("\n## ", 1)[0]
    header = next(r for r in poses.splitlines() if r.startswith("| at t = "))
    assert header.endswith("| pybullet | mujoco | physx |")
    row = next(r for r in poses.splitlines() if r.startswith("| base position (m) |"))
    assert row.count("(") == 4  # the row's title and one position per engine
    own = text.split("## Each engine against itself at half the time step\n", 1)[1]
    own = own.split("\n## ", 1)[0]
    names = [r.split(" | ")[0].strip("| ") for r in own.splitlines() if r.startswith("| ")][1:]
    assert names == [
        "pybullet",
        "mujoco",
        "physx",
        "pybullet vs mujoco",
        "pybullet vs physx",
        "mujoco vs physx",
    ]


def test_first_pair_sections_name_their_pair_and_departures_link(written):
    text, s = written
    v = s["verdict"]
    assert f"## Verdict (pybullet and mujoco): {verdict_word(v)}" in text
    assert "## pybullet and mujoco, the first pair" in text
    # the sections over time, per phase and per part carry every pair: no pair in their titles
    for title in ("When each quantity parts", "Per phase", "Which part parts first"):
        assert f"\n## {title}\n" in text
        assert f"## {title} (" not in text
    setup = text.split("## Setup\n", 1)[1].split("\n## ", 1)[0]
    assert "(#profile-departures-that-apply-here)" in setup
    assert "## Profile departures that apply here" in text


def test_every_engine_has_its_own_figures(written):
    text, s = written
    section = _section(text, "Every engine")
    rows = _rows(section)
    assert [r[0] for r in rows] == ["pybullet", "mujoco", "physx"]
    for cells, label in zip(rows, s["labels"], strict=True):
        e = s["ensemble"]["engines"][label]
        pert = e["perturbation"]
        assert cells[1] == str(s["ensemble"]["size"])
        assert cells[2] == (
            f"{pert['position']:.3g} m / {pert['orientation']:.3g} rad ({pert['state_dtype']})"
        )
        assert cells[3] == interval_cell(e["spread_end"], "m")
        assert cells[4] == ", ".join(
            f"{fmt_threshold(h['threshold'], 'm')}: {fmt_time(h['time'])}" for h in e["horizons"]
        )
        assert cells[5] == fmt_value(s["own"][label]["final"]["base_distance"], "m")
    # PhysX's figures (float32: offsets raised) are in report.md, and the same as its pairs'
    physx = s["pairs"][1]["verdict"]["engine_figures"]["physx"]
    assert interval_cell(physx["spread_end"], "m") == rows[2][3]
    assert "(float32)" in rows[2][2] and "(float64)" in rows[0][2]
    # the float32 sentence: in the opening and here, not in the first pair's verdict
    assert "An engine keeping its state in float32" in section
    assert "An engine keeping its state in float32" in text.split("\n## ", 1)[0]
    assert text.count("An engine keeping its state in float32") == 2
    verdict = text.split("\n## Verdict (pybullet and mujoco)", 1)[1].split("\n## ", 1)[0]
    assert "physx" not in verdict


def test_each_pair_says_what_decides_its_verdict(written):
    text, s = written
    section = _section(text, "Every pair of engines")
    bullets = [x for x in section.splitlines() if x.startswith("- ")]
    assert len(bullets) == 3
    for b, p in zip(bullets, s["pairs"], strict=True):
        v = p["verdict"]
        assert b.startswith(f"- {' and '.join(p['labels'])}, {verdict_word(v)}: the gap ")
        for lab, f in v["engine_figures"].items():  # each engine's ratios and figures
            assert f"{lab}'s spread ({fmt_value(f['spread']['value'], 'm')})" in b
            assert f"its own error ({fmt_value(f['own_error'], 'm')})" in b
            assert f"{f['gap_over_own_error']:.3g}x its own error" in b
        for reason in v["marginal_reasons"]:
            assert reason in b
        if v["test"] is not None:
            assert f"p = {v['test']['p_value']:.2g}" in b
            # 3 runs against 3: 20 splits, a split and its mirror alike: 0.1 is the floor
            floor = v["test"]["p_value"] <= 2 / v["test"]["resamples"] * (1 + 1e-9)
            assert ("the smallest this test can give with 3 and 3 runs" in b) == floor


def test_resync_judges_every_pair(three, written):
    text, s = written
    section = _section(text, "One step from the same state")
    first = s["pairs"][0]["resync"]
    assert first == s["resync"]  # the top-level key: the first pair's, as with two engines
    for k, p in enumerate(s["pairs"]):
        a, b = p["labels"]
        r = p["resync"]
        assert [(d["source"], d["target"]) for d in r["directions"]] == [(a, b), (b, a)]
        assert all(d["points"] > 0 for d in r["directions"])
        assert f"\n### {a} and {b}\n" in section
        assert f"One step from the same state, {a} and {b} differ by up to " in section
        figure = "resync.png" if k == 0 else f"resync_{a}_{b}.png"
        assert f"![resync]({figure})" in section
        for d in r["directions"]:
            rounding = d.get("rounding")
            assert (rounding is not None) == (d["target"] == "physx")  # PhysX keeps float32
            if rounding is None:
                continue
            assert rounding["state_dtype"] == "float32"
            # at most half a float32 spacing per coordinate, at the source base's largest
            # coordinates (r2d2 leaves the ground: MuJoCo throws it metres up)
            tr = three.runs[(list(three.labels).index(d["source"]), three.timestep)]
            top = np.abs(tr.body.link_positions[:, 0]).max(axis=0).astype(np.float32)
            assert 0 < rounding["max"] <= 0.5 * np.linalg.norm(np.spacing(top).astype(float))
            assert f"physx keeps its state in float32: each of {d['source']}'s states" in section
    # the first pair's line in the opening section names its pair too
    lines = [x for x in text.splitlines() if x.startswith("One step from the same state, ")]
    assert lines[0].startswith("One step from the same state, pybullet and mujoco differ")


def test_the_resync_figure_names_its_pair(three, tmp_path, monkeypatch):
    import matplotlib.figure

    from simbridge.compare.report.resync import plot_resync

    titles: list[str] = []
    save = matplotlib.figure.Figure.savefig

    def spy(fig, *args, **kwargs):
        titles.extend(ax.get_title() for ax in fig.axes)
        return save(fig, *args, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", spy)
    assert plot_resync(three.resync, tmp_path / "r.png", pair="pybullet and mujoco")
    assert titles[0].startswith("One step from the same state (pybullet and mujoco), every ")
    titles.clear()
    plot_resync(three.resync, tmp_path / "r.png")  # two engines: the title as it was
    assert titles[0].startswith("One step from the same state, every ")


def test_each_engines_departures_quote_its_own_figures(written):
    text, s = written
    section = _section(text, "Profile departures that apply here")
    blocks = dict(
        (label, section.split(f"\n{label}:\n", 1)[1].split("\n\n", 1)[0])
        for label in ("mujoco", "physx")
        if f"\n{label}:\n" in section
    )
    assert set(blocks) == {"mujoco", "physx"}
    for label, other in (("mujoco", "physx"), ("physx", "mujoco")):
        rows = _rows(blocks[label])
        measured = [r[3] for r in rows if r[3] != "none"]
        assert measured, blocks[label]
        for cell in measured:
            assert f"({other})" not in cell and f"{other} " not in cell, cell
        contact = next(r[3] for r in rows if r[0] == "`contact`")
        assert f"({label})" in contact and "(pybullet)" in contact


def test_the_one_step_floors_agree(written):
    text, s = written
    r = s["resync"]
    line = next(x for x in text.splitlines() if x.startswith("One step from the same state"))
    assert "each engine's own floor, at its largest: " in line
    if r["born"] is not None:  # the floor at the born step, named as that step's
        b = r["born"]
        assert (
            f"against {b['source']}'s own floor of {fmt_value(b['floor'], r['unit'])} at that "
            "step" in line
        )
    assert "against a floor of" not in text


def test_distance_draws_every_pair(three, tmp_path, monkeypatch):
    seen: list[str] = []

    def keep(fig, path):
        seen.extend(line.get_label() for ax in fig.axes for line in ax.get_lines())
        fig.clf()
        return path

    monkeypatch.setattr(plots, "save", keep)
    plots.distance(three, tmp_path / "distance.png")
    for a, b in (("pybullet", "mujoco"), ("pybullet", "physx"), ("mujoco", "physx")):
        assert f"{a} vs {b}: nominal runs" in seen
        assert any(re.match(f"{a} vs {b}: median gap", x) for x in seen)


def _section(text: str, title: str) -> str:
    return text.split(f"\n## {title}\n", 1)[1].split("\n## ", 1)[0]


def _rows(section: str) -> list[list[str]]:
    """A section's table, its header and separator left out: the cells of each row."""
    rows = [r for r in section.splitlines() if r.startswith("| ")]
    return [r.strip("| ").split(" | ") for r in rows[1:]]


PAIRS = ["pybullet and mujoco", "pybullet and physx", "mujoco and physx"]


def test_each_quantity_parts_in_a_row_per_pair(written):
    text, s = written
    section = _section(text, "When each quantity parts")
    assert "| quantity | pair | first crossing |  |  | at the end | largest |" in section
    rows = _rows(section)
    quantities = [k for k in QUANTITIES if k in s["cross"]["final"]]
    assert len(rows) == 3 * len(quantities)
    for i, key in enumerate(quantities):
        q = QUANTITIES[key]
        for cells, p in zip(rows[3 * i : 3 * i + 3], s["pairs"], strict=True):
            cross = p["cross"]  # the pair's own figures, from summary.json
            assert cells[0] == q.title and cells[1] == " and ".join(p["labels"])
            times = [c["time"] for c in cross["crossings"][key]]
            assert cells[2 : 2 + len(times)] == [
                f"{fmt_threshold(thr, q.unit)}: {fmt_time(t)}"
                for thr, t in zip(q.thresholds, times, strict=True)
            ]
            assert cells[-2:] == [
                fmt_value(cross["final"][key], q.unit),
                fmt_value(cross["max"][key], q.unit),
            ]
    assert [r[1] for r in rows[:3]] == PAIRS
    # the pairs' rows are their own: PhysX parts from the two others by another gap than they
    # from each other (6.38 m, 1.76 m and 8.04 m apart at 0.5 s, measured)
    finals = [p["cross"]["final"]["base_distance"] for p in s["pairs"]]
    assert len({fmt_value(x, "m") for x in finals}) == 3


def test_each_phase_has_a_row_per_pair(written):
    text, s = written
    rows = _rows(_section(text, "Per phase"))
    phases = s["cross"]["phases"]
    assert len(rows) == 3 * len(phases)
    for i, ph in enumerate(phases):
        for cells, p in zip(rows[3 * i : 3 * i + 3], s["pairs"], strict=True):
            own = p["cross"]["phases"][i]
            assert cells[:3] == [
                ph["name"],
                " and ".join(p["labels"]),
                f"{own['start']:.3f} – {own['end']:.3f} s",
            ]
            assert cells[3] == (
                f"{fmt_value(own['at_end']['base_distance'], 'm')} "
                f"(max {fmt_value(own['max']['base_distance'], 'm')})"
            )


def test_which_part_parts_first_for_every_pair(written):
    text, s = written
    section = _section(text, "Which part parts first")
    bullets = [x for x in section.splitlines() if x.startswith("- ")]
    assert [b.split(": ", 1)[0] for b in bullets] == ["- " + x for x in PAIRS]
    for b, p in zip(bullets, s["pairs"], strict=True):
        words = parts_words(p["parts"])
        assert b.split(": ", 1)[1] == words[0].lower() + words[1:]
    rows = _rows(section)
    each = max(3, MAX_PART_ROWS // 3)
    assert [r[0] for r in rows] == [x for x in PAIRS for _ in range(each)]
    for k, p in enumerate(s["pairs"]):
        mine = rows[k * each : (k + 1) * each]
        assert [r[1] for r in mine] == [str(n + 1) for n in range(each)]
        assert [r[2] for r in mine] == [f"{x['kind']} `{x['name']}`" for x in p["parts"][:each]]
    total = len(s["pairs"][0]["parts"])
    assert f"The first {each} of {total} shown per pair" in section


def test_where_the_gap_is_born_for_every_pair(written):
    text, s = written
    section = _section(text, "Where the gap is born")
    bullets = [x for x in section.splitlines() if x.startswith("- ")]
    assert [b.split(": ", 1)[0] for b in bullets] == ["- " + x for x in PAIRS]
    for b, p in zip(bullets, s["pairs"], strict=True):
        t = p["parting"]["time"]
        assert b.split(": ", 1)[1].startswith("never" if t is None else "1 cm apart at t = ")
        if t is not None:
            assert f"t = {fmt_time(t)}, {parting_words(p['parting'])}." in b


def test_a_sweep_of_three_engines_draws_every_pair(tmp_path, monkeypatch):
    import matplotlib.figure

    drawn: list[list[str]] = []
    save = matplotlib.figure.Figure.savefig

    def keep(fig, *args, **kwargs):
        drawn.append([t.get_text() for ax in fig.axes for t in ax.get_legend().get_texts()])
        return save(fig, *args, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", keep)
    slide = Path(__file__).parents[1] / "data" / "incline-slide.toml"
    s = sweep(
        slide,
        ["pybullet", "mujoco", "physx"],
        ["lateral_friction=0.5,0.3"],
        duration=0.5,
        ensemble=3,
        workers=0,
        resync_every=0,
    )
    path = write_sweep(s, tmp_path)
    (legends,) = drawn
    spreads = ["spread of pybullet", "spread of mujoco", "spread of physx"]
    assert legends == ["tolerance", *PAIRS, *spreads]
    data = json.loads((tmp_path / "summary.json").read_text("utf-8"))
    lines = data["figures"]["lateral_friction"]
    assert [x["label"] for x in lines] == PAIRS + spreads
    for k, x in enumerate(lines[:3]):
        assert x["value"] == [pt["pairs"][k]["gap"]["value"] for pt in data["points"]]
        assert x["low"] == [pt["pairs"][k]["gap"]["low"] for pt in data["points"]]
    for slot, x in zip((0, 1, 2), lines[3:], strict=True):  # each engine's, from its first pair
        k, side = {0: (0, 0), 1: (0, 1), 2: (1, 1)}[slot]
        assert x["value"] == [pt["pairs"][k]["spreads"][side]["value"] for pt in data["points"]]
    text = path.read_text("utf-8")
    assert "The gap is the median base position distance between" in text  # not its key
    rows = [r for r in text.splitlines() if r.startswith("| 0.")]
    assert len(rows) == 2 * 3  # a row per pair at each value


def test_a_p_value_at_the_exact_tests_floor_says_so():
    from simbridge.compare.report.engine_figures import p_words

    def test(p, n, m, splits, exact=True):
        return {"p_value": p, "sizes": [n, m], "resamples": splits, "exact": exact}

    # 4 and 4 runs: 70 splits, a split and its mirror alike: 2/70 is the smallest p
    assert p_words(test(2 / 70, 4, 4, 70)) == (
        "p = 0.029 (the smallest this test can give with 4 and 4 runs)"
    )
    assert p_words(test(4 / 70, 4, 4, 70)) == "p = 0.057"
    assert p_words(test(1 / 10, 2, 3, 10)).endswith("with 2 and 3 runs)")  # no mirror: 1/10
    assert p_words(test(1e-4, 9, 9, 9999, exact=False)) == "p < 0.001"
