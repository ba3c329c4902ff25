"""PyBullet against every other registered backend, through compare().

Contact-free scenarios: the engines integrate the same equations, so they must agree far better
than either engine's own time-step error (measured with MuJoCo 4.0 against PyBullet 3.2.7:
gaps of 1e-10 m to 1e-16 m against own errors of 0.75 mm to 2 mm). r2d2: the drive is chaotic
and the engines end metres apart; the test checks that the report records whatever happens,
from the trajectories themselves.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from _precision import float32

from simbridge.compare import QUANTITIES, Trajectory, compare, diff, report
from simbridge.compare.report.fmt import fmt_value

CONTACT_FREE = ["pendulum", "double-pendulum", "spinning-wheel"]


@pytest.mark.parametrize("profile", ["pybullet", "urdf"])
@pytest.mark.parametrize("scenario", CONTACT_FREE)
def test_contact_free_scenarios_agree_across_engines(other, scenario, profile):
    c = compare(scenario, ["pybullet", other], profile=profile, ensemble=3)
    assert c.verdict.verdict == "agree" and not c.verdict.marginal, c.verdict
    cross = c.cross[c.timestep]
    # no quantity ever reaches its first threshold (1 cm, 1°, 0.1 rad/s)
    assert cross.first_to_diverge() is None, cross.maximum
    # and the gap is under 1% of what each engine changes by itself at half the step
    q = c.headline_quantity
    for slot in (0, 1):
        own = c.own[(slot, c.timestep)].final[q]
        assert own > 0, "the own-error run changed nothing: the measure is blind"
        # a float32 engine: PhysX's spinning wheel measured 8.7e-5 against PyBullet's own 5.6e-3
        share = 0.03 if float32(other) else 0.01
        assert cross.maximum[q] < share * own, (c.labels[slot], cross.maximum[q], own)


def test_r2d2_report_records_the_divergence_from_the_trajectories(other, tmp_path):
    # two runs per engine: the report's figures are checked against the saved trajectories,
    # which an ensemble's size does not change (4 took 47 s on PhysX on the loaded machine)
    c = compare("r2d2", ["pybullet", other], ensemble=2)
    path = report(c, tmp_path, plots=False)
    summary = json.loads((tmp_path / "summary.json").read_text())
    h = summary["headline"]
    # recompute from the saved trajectories, independently of the Comparison object
    a = Trajectory.load(tmp_path / "trajectories" / "pybullet.npz")
    b = Trajectory.load(tmp_path / "trajectories" / f"{other}.npz")
    gap = float(np.linalg.norm(a.body.base_position[-1] - b.body.base_position[-1]))
    assert h["quantity"] == "base_distance" and h["final"] == gap
    d = diff(a, b)
    hit = np.flatnonzero(d.series["base_distance"] >= 0.01)
    assert h["crossings"][0]["time"] == (float(d.time[hit[0]]) if hit.size else None)
    for slot, label in enumerate(c.labels):
        own = h["own_error"][label]
        assert own["final"] == c.own[(slot, c.timestep)].final["base_distance"]
        assert own["gap_exceeds"] == (gap > own["final"])
    text = path.read_text()
    assert text.splitlines()[2] == h["text"][0]  # the verdict first
    assert f"The nominal runs (no offset) end {fmt_value(gap, 'm')} apart" in text
    assert summary["verdict"]["verdict"] == c.verdict.verdict
    assert summary["manifest"]["engines"][other]["backend"] == other
    assert set(QUANTITIES) <= set(summary["cross"]["final"])
