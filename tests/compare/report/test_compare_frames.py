"""The pictures of the runs in report.md (compare/report/frames.py) and the terminal's short
headline (compare/report/brief.py).

One comparison of r2d2's first second on PyBullet and MuJoCo (one run each): it leaves the
ground and lands, so the events give key frames and the pictures move."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from PIL import Image

from simbridge.compare import compare, report
from simbridge.compare.report import brief
from simbridge.compare.report.frames import (
    GIF_FRAMES,
    HEADER,
    MAX_KEY_EVENTS,
    PANEL,
    key_instants,
)


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("frames")
    c = compare("r2d2", ["pybullet", "mujoco"], duration=1.0, ensemble=1, workers=0,
                resync_every=0, command_line=["simbridge"])  # fmt: skip
    path = report(c, out, plots=False, trajectories=False)
    return c, out, path.read_text("utf-8"), json.loads((out / "summary.json").read_text())


def _panels(file) -> list[np.ndarray]:
    img = np.asarray(Image.open(file).convert("RGB"))
    w, h = PANEL
    return [img[HEADER:, k * w : (k + 1) * w] for k in range(img.shape[1] // w)]


def _blue(panel: np.ndarray) -> int:
    r, g, b = (panel[..., k].astype(int) for k in range(3))
    return int(np.count_nonzero((b > 100) & (r < 60) & (g < 60)))


def test_every_still_shows_every_engines_robot(written):
    c, out, text, _ = written
    stills = re.findall(r"!\[t = [^]]+\]\((frames/[^)]+\.png)\)", text)
    assert stills[0] == "frames/start.png" and stills[-1] == "frames/end.png"
    for still in stills:
        panels = _panels(out / still)
        assert len(panels) == len(c.labels)
        assert all(_blue(p) > 200 for p in panels), still  # r2d2's body in each panel


def test_the_pictures_move(written):
    c, out, _, _ = written
    starts, ends = _panels(out / "frames/start.png"), _panels(out / "frames/end.png")
    for start, end in zip(starts, ends, strict=True):
        changed = np.abs(start.astype(int) - end).sum(axis=2) > 30
        assert changed.mean() > 0.05  # thrown and landed: another picture


def test_a_key_frame_for_each_event_instant(written):
    c, out, text, s = written
    frames, left = key_instants(s, float(s["duration"]))
    assert 1 <= len(frames) <= MAX_KEY_EVENTS
    for k in frames:
        name = "frames/" + f"t{k.time:.3f}".replace(".", "_") + ".png"
        assert f"]({name})" in text and (out / name).is_file(), k.time
    # the first event of each kind in each engine has a frame, or joins one, or is counted
    firsts = {(lab, e["kind"]) for lab, ev in s["events"].items() for e in ev["events"]}
    said = sum(len(k.events) for k in frames)
    assert said + left == len(firsts) + (s["parting"].get("time") is not None)
    assert all(e in text for k in frames for e in k.events)


def test_the_animation(written):
    c, out, text, s = written
    gif = out / "frames" / "replay.gif"
    assert "![the nominal runs](frames/replay.gif)" in text
    img = Image.open(gif)
    assert 2 <= img.n_frames <= GIF_FRAMES
    assert img.size == (PANEL[0] * len(c.labels), PANEL[1] + HEADER)
    assert gif.stat().st_size < 2_000_000
    assert "frames/replay.gif" in s["files"]


def test_no_replay_writes_no_pictures(written, tmp_path):
    c = written[0]
    text = report(c, tmp_path, plots=False, trajectories=False, replay=False).read_text()
    assert not (tmp_path / "frames").exists()
    assert "## The runs, seen" not in text and "](frames/" not in text


def test_key_instants_merge_close_events_and_keep_the_first_of_each_kind():
    figures = {"duration": 1.0, "height": 1.0, "rise": 0.5, "tilt": 1.0, "limit": 1.0,
               "losses": 3.0, "max_force": 5.0}  # fmt: skip

    def ev(kind, t):
        return {"kind": kind, "time": t, "body": "r", "part": "wheel", "others": ["plane"],
                "side": None, "end": None, "phase": "p", "figures": figures}  # fmt: skip

    s = {
        "parting": {"time": None},
        "events": {
            "a": {"events": [ev("airborne", 0.10), ev("airborne", 2.0), ev("peak_height", 0.5)]},
            "b": {"events": [ev("airborne", 0.12), ev("tipped_over", 3.0)]},
        },
    }
    frames, left = key_instants(s, 4.0)
    assert [k.time for k in frames] == [0.10, 0.5, 3.0]  # 0.12 joins 0.10 (within 2% of 4 s)
    assert len(frames[0].events) == 2 and left == 0
    many = {"parting": {"time": None},
            "events": {"a": {"events": [ev(k, float(i)) for i, k in enumerate(
                ["tipped_over", "airborne", "peak_height", "contact_made", "joint_limit",
                 "contact_chatter", "contact_lost", "motor_saturated"])]}}}  # fmt: skip
    frames, left = key_instants(many, 10.0)
    assert len(frames) == MAX_KEY_EVENTS and left == 8 - MAX_KEY_EVENTS
    assert frames[0].events[0].startswith("a's r tipped over")  # first in priority, kept


def test_the_short_headline(written):
    c, out, text, s = written
    lines = brief(s, out / "report.md")
    assert len(lines) <= 6
    assert lines[0].startswith("r2d2, pybullet against mujoco: ")
    assert s["verdict"]["verdict"].upper() in lines[0]
    assert lines[-1] == f"report: {out / 'report.md'}"
    assert sum(map(len, lines)) < 800  # the paragraphs stay in report.md
