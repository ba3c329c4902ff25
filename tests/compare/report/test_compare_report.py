"""report(): the files a person and a machine read, carrying the same figures.

Runs PyBullet against itself under the two profiles ("pybullet" and "urdf"): a real, nonzero
divergence on any machine, without a second engine."""

from __future__ import annotations

import json

import numpy as np
import pytest

from simbridge.compare import QUANTITIES, Trajectory, compare, diff, report
from simbridge.compare.report import headline
from simbridge.compare.report.fmt import fmt_threshold, fmt_time, fmt_value
from simbridge.compare.report.progress import ProgressBar

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    c = compare(
        "r2d2",
        ["pybullet", "pybullet"],
        profile=["pybullet", "urdf"],
        timesteps=["1/240", "1/480"],
        duration=1.5,
        command_line=["simbridge", "compare", "r2d2"],
        ensemble=4,
    )
    path = report(c, out)
    return c, out, path, json.loads((out / "summary.json").read_text())


def test_files_exist(written):
    c, out, path, summary = written
    assert path == out / "report.md"
    names = ("paths.png", "distance.png", "height.png", "heading.png", "events.png")
    names += ("joints_velocity.png", "motors.png", "sweep.png", "ensemble.png")
    for name in names:
        assert (out / name).read_bytes()[:8] == PNG, name
        assert f"]({name})" in path.read_text()
    for label in ("pybullet-pybullet", "pybullet-urdf"):
        assert (out / "trajectories" / f"{label}.npz").is_file()
        assert (out / "trajectories" / f"{label}.csv").is_file()
    assert set(summary["files"]) >= {"summary.json", "distance.png"}


def test_opening_lines_carry_the_headline_figures(written):
    c, out, path, s = written
    h = s["headline"]
    lines = path.read_text().splitlines()
    n = len(h["text"])
    top = "\n".join(h["text"])
    assert lines[0] == "# r2d2: pybullet (pybullet) against pybullet (urdf)"
    # the verdict first, then the nominal runs' figures
    v = s["verdict"]
    assert v["verdict"] in ("agree", "differ", "chaotic", "unresolved")
    assert lines[2].startswith("**")
    assert f"The nominal runs (no offset) end {fmt_value(h['final'], 'm')} apart" in top
    part = h["crossings"][0]["time"]
    assert part is not None
    assert f"They part at t = {fmt_time(part)} (first 1 cm apart)" in top
    first = h["first_to_diverge"]
    q = QUANTITIES[first["quantity"]]
    assert f"the {q.title}: it reaches {fmt_threshold(first['threshold'], q.unit)}" in top
    for label, e in h["own_error"].items():
        assert f"moves {label}'s end by {fmt_value(e['final'], 'm')}" in top
    # a paragraph each: Markdown viewers keep them apart
    assert path.read_text().split("\n\n")[1 : 1 + n] == h["text"]
    assert h["text"] == headline(s)


def test_summary_figures_match_the_divergence(written):
    c, out, path, s = written
    cross = c.cross[c.timestep]
    h = s["headline"]
    assert h["final"] == cross.final["base_distance"]
    assert h["max"] == cross.maximum["base_distance"]
    assert [x["time"] for x in h["crossings"]] == [
        cross.crossings["base_distance"][t] for t in (0.01, 0.1, 1.0)
    ]
    assert s["duration"] == pytest.approx(1.5)
    assert [r["timestep"] for r in s["sweep"]] == [1 / 240, 1 / 480]
    for r in s["sweep"]:
        for e in r["engines"].values():
            assert e["wall_per_sim_second"] > 0
    assert s["manifest"]["command_line"] == ["simbridge", "compare", "r2d2"]
    m = s["manifest"]["engines"]["pybullet (urdf)"]
    assert m["profile"]["name"] == "urdf" and m["engine_version"]
    assert len(m["urdf"]["r2d2"]["sha256"]) == 64


def test_saved_trajectories_reproduce_the_summary(written):
    c, out, path, s = written
    a = Trajectory.load(out / "trajectories" / "pybullet-pybullet.npz")
    b = Trajectory.load(out / "trajectories" / "pybullet-urdf.npz")
    assert diff(a, b).final == s["cross"]["final"]
    gap = float(np.linalg.norm(a.body.base_position[-1] - b.body.base_position[-1]))
    assert s["headline"]["final"] == gap


def test_report_tables(written):
    c, out, path, s = written
    text = path.read_text()
    for heading in (
        "## Verdict: ",
        "## When each quantity parts",
        "## Per phase",
        "## Final poses",
        "## Each engine against itself at half the time step",
        "## Time-step sweep",
        "## Reproduce",
    ):
        assert heading in text
    for phase in ("settle", "turn"):
        assert f"| {phase} |" in text
    assert "forward" not in [p["name"] for p in s["cross"]["phases"]]  # cut at 1.5 s


def test_progress_bar_is_silent_off_a_terminal():
    import io

    stream = io.StringIO()
    bar = ProgressBar(stream, delay=0)
    bar("run", 5, 10)
    bar.close()
    assert stream.getvalue() == ""
    shown = ProgressBar(stream, delay=0, enabled=True)
    shown("pybullet @ 1/240 s", 5, 10)
    assert "pybullet @ 1/240 s:  50%" in stream.getvalue() and "5/10" in stream.getvalue()
    shown.close()
    assert stream.getvalue().endswith("\r")
