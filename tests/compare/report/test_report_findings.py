"""Report findings on two and three engines (PyBullet, MuJoCo and, where installed, PhysX):
which profile departures are counted as applying, whose figures a departure row quotes.

Measured (r2d2, 0.3 s, ensemble of 2, PyBullet 3.2.7, MuJoCo 4.0, SAPIEN 3.0.3): PhysX lists 16
departures; 8 of them no rule checks against the scenario (applied torques, snapshot, ...);
before the count said 13 "apply here", rows marked "not checked" included.
"""

from __future__ import annotations

import json
import re

import pytest
from _engines import installed_backends, require_backend

from simbridge.compare import compare, report
from simbridge.compare.report.departures import NOT_CHECKED, checked
from simbridge.compare.report.verdict import interval_cell


def _section(text: str, title: str) -> str:
    start = text.index(f"## {title}")
    end = text.find("\n## ", start + 1)
    return text[start:end]


@pytest.fixture(scope="module")
def three(tmp_path_factory):
    require_backend("physx")
    out = tmp_path_factory.mktemp("three")
    c = compare(
        "r2d2",
        ["pybullet", "mujoco", "physx"],
        duration=0.3,
        ensemble=2,
        workers=0,
        resync_every=0,
    )
    path = report(c, out, trajectories=False)
    return c, out, path.read_text(), json.loads((out / "summary.json").read_text())


def test_departures_not_checked_are_not_counted_as_applying(three):
    c, out, text, s = three
    deps = s["departures"]["physx"]
    unchecked = [d["key"] for d in deps["apply"] if not checked(d)]
    found = [d for d in deps["apply"] if checked(d)]
    assert unchecked, "a departure no rule checks (applied torques, snapshot...)"
    total = len(s["manifest"]["engines"]["physx"]["departures"])
    setup = _section(text, "Setup")
    row = next(r for r in setup.splitlines() if r.startswith("| physx |"))
    assert f"[{len(found)} of {total}]" in row, row
    section = _section(text, "Profile departures that apply here")
    assert NOT_CHECKED not in section
    line = next(x for x in section.splitlines() if x.startswith("Not checked for physx"))
    assert all(f"`{k}`" in line for k in unchecked), line
    table_keys = re.findall(r"^\| `([^`]+)` \|", section.split("physx:")[1], re.M)
    assert not set(table_keys) & set(unchecked)


def test_float32_precision_applies_to_every_scenario(three):
    c, out, text, s = three
    deps = s["departures"]["physx"]
    precision = next(d for d in deps["apply"] if d["key"] == "precision")
    assert checked(precision) and "every scenario" in precision["why"]
    assert "float32" in precision["why"]
    section = _section(text, "Profile departures that apply here")
    assert "| `precision` |" in section.split("physx:")[1]


def test_a_departure_row_quotes_no_third_engines_figures(three):
    c, out, text, s = three
    rows = s["departures"]["physx"]["apply"]
    damping = next(d for d in rows if d["key"] == "link damping")
    assert "physx:" in damping["why"]
    for d in rows:
        for field in ("why", "measured"):
            assert "mujoco" not in (d[field] or ""), (d["key"], field, d[field])


# ---------------------------------------------------------------- one run per engine


@pytest.fixture(scope="module")
def single(tmp_path_factory):
    """pendulum with --ensemble 1 on PyBullet, MuJoCo and (where installed) PhysX, a float32
    engine whose perturbation would be raised."""
    engines = ["pybullet", "mujoco"] + [b for b in installed_backends() if b == "physx"]
    out = tmp_path_factory.mktemp("single")
    c = compare("pendulum", engines, duration=0.5, ensemble=1, workers=0, resync_every=0)
    path = report(c, out, trajectories=False)
    return c, out, path.read_text(), json.loads((out / "summary.json").read_text())


def test_one_run_reports_no_ratio_to_a_spread(single):
    c, out, text, s = single
    assert not re.search(r"x \S+'s (own )?spread", text), "a ratio to an absent spread"
    for lab in c.labels:
        assert f"{lab} has no spread (one run)" in text
    verdict = _section(text, "Verdict")
    rows = [r for r in verdict.splitlines() if r.startswith(("| pybullet |", "| mujoco |"))]
    assert rows and all(r.split("|")[6].strip() == "n/a" for r in rows), rows  # gap / spread


def test_one_run_says_the_gap_not_a_median_and_moves_nothing(single):
    c, out, text, s = single
    bullets = [x for x in text.splitlines() if x.startswith("- ") and " apart" in x or "gap" in x]
    assert "a median" not in text.split("## ")[0]  # the opening
    assert any(x.startswith("- pybullet and mujoco: agree, the gap ") for x in bullets)
    assert "were moved" not in text and "Each engine ran the scenario once" in text
    every = _section(text, "Every engine") if len(c.labels) > 2 else ""
    for lab in c.labels[2:]:
        row = next(r for r in every.splitlines() if r.startswith(f"| {lab} |"))
        assert "none (one run)" in row, row


# ---------------------------------------------------------------- lengths in one format


@pytest.mark.parametrize(
    ("interval", "cell"),
    [  # the figures the Every engine table printed as 0.0001612 m and 0.02955 m
        ((0.0001612, 2.806e-06, 0.0001612), "0.16 mm [2.8e-06 m, 0.16 mm]"),
        ((0.02955, 0.0002329, 0.02965), "2.955 cm [0.23 mm, 2.965 cm]"),
    ],
)
def test_an_interval_cell_writes_lengths_as_the_report_does(interval, cell):
    value, low, high = interval
    assert interval_cell({"value": value, "low": low, "high": high}, "m") == cell


def test_every_engine_table_writes_lengths_as_the_report_does(three):
    c, out, text, s = three
    every = _section(text, "Every engine")
    rows = [r for r in every.splitlines() if r.startswith(("| pybullet |", "| physx |"))]
    assert len(rows) == 2
    for r in rows:
        spread, own = r.split("|")[4], r.split("|")[6]
        for cell in (spread, own):
            # the report's lengths: m from 1 m, cm, mm, or 1.2e-06 m; never 0.0001612 m
            assert not re.search(r"(?<![\d.e-])0\.\d+ m\b", cell), r
            assert not re.search(r"\d\.\d{3,}e-\d+ m", cell), r


# ---------------------------------------------------------------- key frames' headers


def test_key_frame_headers_give_the_time_as_the_caption_does(three, tmp_path, monkeypatch):
    """r2d2's first event is at t = 0.004 s: its panels read 't = 0.00 s' before, as the start's."""
    from PIL import ImageDraw

    from simbridge.compare.report.frames import write_frames

    c, out, text, s = three
    said: list[str] = []
    real = ImageDraw.ImageDraw.text

    def text_of(self, xy, words, *args, **kwargs):
        said.append(str(words))
        return real(self, xy, words, *args, **kwargs)

    monkeypatch.setattr(ImageDraw.ImageDraw, "text", text_of)
    f = write_frames(c, s, tmp_path)
    captions = {k.time for k in f.key_frames}
    for t in captions:
        shown = f"t = {t:.3f} s"
        assert sum(shown in x for x in said) >= len(c.labels), (shown, said[:6])
    first = min(t for t in captions if t > 0)
    assert f"{first:.2f}" == "0.00"  # the case the two-decimal header could not tell apart


# ---------------------------------------------------------------- an engine against itself


def test_an_engine_against_itself_is_warned_of_and_still_judged(tmp_path, capsys):
    from simbridge.cli import main
    from simbridge.compare.report.replay import engines_from_report

    out = tmp_path / "self"
    argv = ["compare", "pendulum", "--backends", "pybullet", "pybullet", "--duration", "0.2"]
    argv += ["--ensemble", "1", "--no-replay", "--no-plots", "--no-cache", "--out", str(out)]
    assert main(argv) == 0  # a self-check is legitimate: it runs
    printed = capsys.readouterr()
    warned = [x for x in printed.err.splitlines() if x.startswith("warning: ")]
    assert len(warned) == 1 and "pybullet and pybullet (2)" in warned[0]
    assert "null comparison" in warned[0] and "same profile" in warned[0]
    opening = (out / "report.md").read_text("utf-8").split("## ")[0]
    assert "null comparison" in opening
    names = sorted(p.name for p in (out / "trajectories").glob("*.npz"))
    assert names == ["pybullet-2.npz", "pybullet.npz"]
    assert [e.label for e in engines_from_report(out)] == ["pybullet", "pybullet (2)"]


def test_two_profiles_of_one_engine_are_no_self_check(tmp_path, capsys):
    from simbridge.cli import main

    out = tmp_path / "two"
    argv = ["compare", "pendulum", "--backends", "pybullet", "pybullet", "--profile"]
    argv += ["pybullet", "urdf", "--duration", "0.2", "--ensemble", "1", "--no-replay"]
    argv += ["--no-plots", "--no-cache", "--out", str(out)]
    assert main(argv) == 0
    assert "null comparison" not in capsys.readouterr().err
    assert "null comparison" not in (out / "report.md").read_text("utf-8")


# ---------------------------------------------------------------- the default run's time


def test_docs_say_the_default_run_is_three_engines_with_physx_installed():
    """docs/compare.md gave 16 runs as the default 'because it stays under 30 s on two busy
    cores', measured on two engines; with PhysX installed the default run is three engines
    (2 min 19 s measured; docs/comparing.md's table: 117 s)."""
    from pathlib import Path

    docs = Path(__file__).resolve().parents[3] / "docs" / "compare.md"
    text = " ".join(docs.read_text("utf-8").split())
    assert "a two-engine run stays under 30 s" in text
    assert "because it stays under 30 s" not in text
    start = text.index("**The default run with PhysX installed.**")
    para = text[start : text.index("###", start)]
    assert "three-engine run" in para and "`--backends pybullet mujoco`" in para
    assert "117 s" in para and "`physx` extra" in para


# ---------------------------------------------------------------- a scenario's name as written


def test_the_terminal_headline_keeps_a_hyphenated_name_as_written(tmp_path, capsys):
    """A guard, passing before as after: the bytes printed start with the name as written
    ('my-pendulum'); a display that capitalised the first character of a command's output
    showed 'My-pendulum' (od -c of the same output: 'm y - p e n d ...')."""
    from pathlib import Path

    from simbridge.cli import main

    shipped = Path(__file__).resolve().parents[3] / "compare" / "scenarios" / "pendulum.toml"
    text = shipped.read_text("utf-8")
    first = next(x for x in text.splitlines() if x.startswith("name"))
    toml = tmp_path / "my-pendulum.toml"
    toml.write_text(text.replace(first, 'name = "my-pendulum"', 1), "utf-8")
    out = tmp_path / "out"
    argv = ["compare", str(toml), "--backends", "pybullet", "mujoco", "--duration", "0.2"]
    argv += ["--ensemble", "1", "--no-replay", "--no-plots", "--no-cache", "--out", str(out)]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert printed.startswith("my-pendulum, pybullet against mujoco: ")
    assert (out / "report.md").read_text("utf-8").startswith("# my-pendulum: ")
