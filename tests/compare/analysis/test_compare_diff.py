"""diff() on synthetic trajectories: known offsets, headings, joint errors and crossing times."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _synthetic import quat_x, quat_z, trajectory

from simbridge.compare import QUANTITIES, diff
from simbridge.compare.report.summary_json import divergence_dict
from simbridge.compare.scenario import HEADLINE_QUANTITIES
from simbridge.exceptions import SimbridgeError

DEG = math.pi / 180


def ramp_x(t):
    return np.stack([t, np.zeros_like(t), np.zeros_like(t)], axis=1)


def test_distance_ramp_crossings_are_the_first_instants_reaching_each_threshold():
    a = trajectory()
    b = trajectory(position=ramp_x)  # distance = t, t = 0, 0.125, ..., 2
    d = diff(a, b)
    np.testing.assert_array_equal(d.time, np.arange(17) * 0.125)
    np.testing.assert_array_equal(d.series["base_distance"], d.time)
    np.testing.assert_array_equal(d.series["link_distance"], d.time)
    assert d.crossings["base_distance"] == {0.01: 0.125, 0.1: 0.125, 1.0: 1.0}
    assert d.final["base_distance"] == 2.0
    assert d.maximum["base_distance"] == 2.0
    assert d.crossings["heading"] == {1 * DEG: None, 10 * DEG: None}
    assert d.final["heading"] == 0.0 and d.final["orientation"] == 0.0
    # base and link distance cross together: the tie goes to the first quantity listed
    assert d.first_to_diverge() == ("base_distance", 0.01, 0.125)


def test_constant_offset_is_crossed_at_time_zero():
    a = trajectory()
    b = trajectory(position=lambda t: np.tile([0.75, 1.0, 0.0], (len(t), 1)))
    d = diff(a, b)
    np.testing.assert_array_equal(d.series["base_distance"], np.full(17, 1.25))
    assert d.crossings["base_distance"] == {0.01: 0.0, 0.1: 0.0, 1.0: 0.0}


def test_heading_difference_is_wrapped():
    a = trajectory(yaw=lambda t: np.full_like(t, 170 * DEG))
    b = trajectory(yaw=lambda t: np.full_like(t, -170 * DEG))
    d = diff(a, b)
    assert d.final["heading"] == pytest.approx(20 * DEG, rel=1e-12)
    assert d.final["orientation"] == pytest.approx(20 * DEG, rel=1e-12)
    assert d.final["base_distance"] == 0.0


def test_heading_ramp_crossings():
    a = trajectory()
    b = trajectory(yaw=lambda t: t * 12 * DEG)  # 1.5° at 0.125 s, 9° at 0.75 s, 10.5° at 0.875 s
    d = diff(a, b)
    np.testing.assert_allclose(d.series["heading"], d.time * 12 * DEG, rtol=1e-12, atol=1e-15)
    assert d.crossings["heading"] == {1 * DEG: 0.125, 10 * DEG: 0.875}
    assert d.crossings["orientation"] == {1 * DEG: 0.125, 10 * DEG: 0.875}
    assert d.final_pose["b"].yaw == pytest.approx(24 * DEG, rel=1e-12)


def test_orientation_angle_sees_a_tilt_that_heading_does_not():
    a = trajectory()
    b = trajectory(orientation=lambda t: np.tile(quat_x(30 * DEG), (len(t), 1)))
    d = diff(a, b)
    assert d.final["orientation"] == pytest.approx(30 * DEG, rel=1e-12)
    assert d.final["heading"] == pytest.approx(0.0, abs=1e-15)
    assert d.final_pose["b"].tilt == pytest.approx(30 * DEG, rel=1e-12)
    assert d.final_pose["a"].tilt == 0.0


def test_orientation_angle_of_opposite_quaternion_signs_is_zero():
    a = trajectory(orientation=lambda t: np.tile(quat_z(0.3), (len(t), 1)))
    b = trajectory(orientation=lambda t: np.tile(-quat_z(0.3), (len(t), 1)))
    d = diff(a, b)
    assert d.final["orientation"] == pytest.approx(0.0, abs=1e-15)


def test_joint_rms():
    a = trajectory()
    b = trajectory(
        q=lambda t: np.tile([0.3, 0.4], (len(t), 1)),
        v=lambda t: np.tile([0.6, 0.8], (len(t), 1)),
    )
    d = diff(a, b)
    assert d.final["joint_position_rms"] == pytest.approx(math.sqrt(0.125), rel=1e-15)
    assert d.final["joint_velocity_rms"] == pytest.approx(math.sqrt(0.5), rel=1e-15)
    assert d.crossings["joint_velocity_rms"] == {0.1: 0.0, 1.0: None, 10.0: None}


def test_first_to_diverge_is_the_earliest_first_threshold():
    a = trajectory()
    b = trajectory(
        position=lambda t: np.stack([np.where(t >= 1.0, 0.5, 0.0), 0 * t, 0 * t], axis=1),
        v=lambda t: np.stack([np.where(t >= 0.5, 0.2, 0.0), 0 * t], axis=1),
    )
    d = diff(a, b)
    # RMS over two joints of (0.2, 0) = 0.1414 rad/s >= 0.1 from t = 0.5
    assert d.first_to_diverge() == ("joint_velocity_rms", 0.1, 0.5)
    assert d.first_crossing("base_distance") == 1.0
    assert d.first_crossing("base_distance", 1.0) is None


def test_nothing_diverges_between_identical_runs():
    d = diff(trajectory(yaw=lambda t: t), trajectory(yaw=lambda t: t))
    assert d.first_to_diverge() is None
    assert all(v == 0.0 for v in d.maximum.values())


def test_phase_table():
    phases = [("first", 0, 8), ("second", 8, 16)]
    d = diff(trajectory(phases=phases), trajectory(position=ramp_x, phases=phases))
    assert [(p.name, p.start, p.end) for p in d.phases] == [
        ("first", 0.0, 1.0),
        ("second", 1.0, 2.0),
    ]
    assert d.phases[0].at_end["base_distance"] == 1.0
    assert d.phases[0].max["base_distance"] == 1.0
    assert d.phases[1].at_end["base_distance"] == 2.0


def test_half_time_step_is_compared_on_the_coarse_grid():
    a = trajectory()  # dt 0.125
    b = trajectory(dt=0.0625, steps=32, position=ramp_x)
    d = diff(a, b)
    assert len(d.time) == 17
    np.testing.assert_array_equal(d.series["base_distance"], d.time)
    # symmetric: the coarse grid is chosen whatever the argument order
    np.testing.assert_array_equal(diff(b, a).series["base_distance"], d.time)


def test_unrelated_time_steps_are_interpolated():
    a = trajectory()  # dt 0.125, to 2 s
    b = trajectory(dt=0.1, steps=20, position=ramp_x)  # dt 0.1, to 2 s
    d = diff(a, b)
    assert d.time[-1] == 2.0
    np.testing.assert_allclose(d.series["base_distance"], d.time, rtol=0, atol=1e-12)


def test_shorter_run_bounds_the_comparison():
    d = diff(trajectory(steps=16), trajectory(steps=8, position=ramp_x))
    assert d.time[-1] == 1.0
    assert d.final["base_distance"] == 1.0


def test_different_robots_are_refused():
    a = trajectory()
    b = trajectory()
    b.body.joint_names = ["x", "y"]
    with pytest.raises(SimbridgeError, match="cannot compare .* joints"):
        diff(a, b)


def test_summary_dict_is_json_ready():
    import json

    d = diff(trajectory(), trajectory(position=ramp_x))
    data = json.loads(json.dumps(divergence_dict(d)))
    assert data["final"]["base_distance"] == 2.0
    assert data["first_to_diverge"] == {
        "quantity": "base_distance",
        "threshold": 0.01,
        "time": 0.125,
    }


def test_scenario_headline_names_match_the_quantities():
    assert tuple(QUANTITIES) == HEADLINE_QUANTITIES
