"""What the figures show is what matters: the key frames and the 3D replay framed on the
robot (a fixed arm was drawn small in a wide empty view), and events.png's legend naming only
the markers drawn (it named contacts that never occur).

One comparison of kuka-reach's first 1.5 s on PyBullet and MuJoCo (one run each): a fixed arm
under position control, no contact."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from PIL import Image

from simbridge.compare import compare
from simbridge.compare.report import plot_events, plots, replay
from simbridge.compare.report.frames import HEADER, PANEL, write_frames


@pytest.fixture(scope="module")
def kuka():
    return compare("kuka-reach", ["pybullet", "mujoco"], duration=1.5, ensemble=1, workers=0,
                   resync_every=0, cache=False, command_line=["simbridge"])  # fmt: skip


def _ink(panel: np.ndarray) -> tuple[float, float]:
    """The share of the panel's height and width that the drawn robot spans."""
    ink = np.abs(panel.astype(int) - 255).sum(axis=2) > 40
    ys, xs = np.nonzero(ink)
    return (ys.max() - ys.min() + 1) / panel.shape[0], (xs.max() - xs.min() + 1) / panel.shape[1]


def test_the_key_frames_are_framed_on_the_robot(kuka, tmp_path):
    """The arm standing at the start spans most of the panel's height (it was 60%), inside
    the panel, and every frame holds the whole arm."""
    frames = write_frames(kuka, {}, tmp_path)
    assert frames.note is None
    w, h = PANEL
    for k in frames.key_frames:
        img = np.asarray(Image.open(tmp_path / k.file).convert("RGB"))
        for slot in range(len(kuka.labels)):
            panel = img[HEADER:, slot * w : (slot + 1) * w]
            tall, wide = _ink(panel)
            edges = np.concatenate([panel[0], panel[-1], panel[:, 0], panel[:, -1]]).astype(int)
            assert (np.abs(edges - 255).sum(axis=1) <= 40).all(), k.file  # nothing cut off
            if k.title == "the start":
                assert 0.7 <= tall <= 0.95, tall


def test_the_replay_camera_is_framed_on_the_robot(kuka):
    """The replay's first view: the arm's drawn points over the run fill most of the view's
    height (the camera stood 3.5 m off, the arm about a quarter of the view)."""
    engines = replay.replay_engines(kuka, ghosts=False)
    extent = []
    for eng in engines:
        tr = eng.trajectory
        extent.append(replay.body_points(tr, tr.subject, replay.frame_rows(tr)))
    view = replay.camera_view(extent)
    assert view is not None
    target, eye = (np.asarray(x) for x in view)
    distance = float(np.linalg.norm(eye - target))
    pts = np.concatenate([x.reshape(-1, 3) for x in extent])
    # the arm (1.3 m tall) stands between the ground and its reach
    assert pts[:, 2].min() > -0.05 and 1.1 < pts[:, 2].max() < 1.4
    # every point within the view's height, the arm's height more than half of it
    sight = (target - eye) / distance
    up = np.cross(np.cross(sight, [0.0, 0.0, 1.0]), sight)
    up /= np.linalg.norm(up)
    rel = pts - eye
    angle = np.degrees(np.arctan2(rel @ up, rel @ sight))
    half = replay.CAMERA_FOV / 2
    assert np.abs(angle).max() < half
    assert angle.max() - angle.min() > 0.5 * replay.CAMERA_FOV
    assert distance < 2.0


def test_body_points_bound_the_drawn_links(kuka):
    """The points are the corners of the visuals' boxes, posed: they hold every link's centre
    of mass, and a body without a URDF falls back to its centres of mass with a margin."""
    tr = kuka.runs[(0, kuka.timestep)]
    rows = np.array([0, len(tr.time) - 1])
    pts = replay.body_points(tr, tr.subject, rows)
    com = tr.body.link_positions[rows]
    for k in range(len(rows)):
        lo, hi = pts[k].min(axis=0), pts[k].max(axis=0)
        assert (com[k] >= lo - 1e-6).all() and (com[k] <= hi + 1e-6).all()
    bare = dataclasses.replace(tr, manifest={})
    fallback = replay.body_points(bare, tr.subject, rows)
    assert fallback.shape == (2, 8 * com.shape[1], 3)
    assert np.allclose(fallback.reshape(2, -1, 8, 3).mean(axis=2), com)


def _legend(monkeypatch, c, path) -> list[str]:
    """events.png drawn, and its legend's entries."""
    seen = {}

    def keep(fig, where):
        seen["texts"] = [t.get_text() for lg in fig.legends for t in lg.get_texts()]
        return where

    monkeypatch.setattr(plot_events, "save_fixed", keep)
    assert plots.events(c, path) is not None
    return seen["texts"]


def test_the_events_legend_names_only_what_is_drawn(kuka, tmp_path, monkeypatch):
    from simbridge.compare.analysis import events as analysis
    from simbridge.compare.run.events import Event

    texts = _legend(monkeypatch, kuka, tmp_path / "events.png")
    assert not {"contact made", "contact lost", "peak height"} & set(texts), texts
    # a contact made in one engine: its marker, and only it, in the legend
    found = analysis.engine_events(kuka)
    tr = kuka.runs[(0, kuka.timestep)]
    found[0].events.append(Event("contact_made", 0.5, 120, "to A", tr.subject, "lbr_iiwa_link_7"))
    monkeypatch.setattr(analysis, "engine_events", lambda c: found)
    texts = _legend(monkeypatch, kuka, tmp_path / "events.png")
    assert "contact made" in texts and not {"contact lost", "peak height"} & set(texts), texts
