"""What the figures show is what matters: the key frames and the 3D replay framed on the
robot (a fixed arm was drawn small in a wide empty view), and events.png's legend naming only
the markers drawn (it named contacts that never occur).

One comparison of kuka-reach's first 1.5 s on PyBullet and MuJoCo (one run each): a fixed arm
under position control, no contact."""

from __future__ import annotations

import pytest

from simbridge.compare import compare
from simbridge.compare.report import plots


@pytest.fixture(scope="module")
def kuka():
    return compare("kuka-reach", ["pybullet", "mujoco"], duration=1.5, ensemble=1, workers=0,
                   resync_every=0, cache=False, command_line=["simbridge"])  # fmt: skip


def _legend(monkeypatch, c, path) -> list[str]:
    """events.png drawn, and its legend's entries."""
    seen = {}

    def keep(fig, where):
        seen["texts"] = [t.get_text() for lg in fig.legends for t in lg.get_texts()]
        return where

    monkeypatch.setattr(plots, "_save_fixed", keep)
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
