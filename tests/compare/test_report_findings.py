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

from simbridge import registry
from simbridge.compare import compare, report
from simbridge.compare.report.departures import NOT_CHECKED, checked


def _section(text: str, title: str) -> str:
    start = text.index(f"## {title}")
    end = text.find("\n## ", start + 1)
    return text[start:end]


@pytest.fixture(scope="module")
def three(tmp_path_factory):
    if registry.unavailable_reason("physx") is not None:
        pytest.skip("PhysX (sapien) is not installed")
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
