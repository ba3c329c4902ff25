"""run(): a scenario on one backend, every step recorded, saved and loaded back."""

from __future__ import annotations

import csv

import numpy as np
import pytest
from _precision import float32

import simbridge
from simbridge.compare import Trajectory, loads_scenario, run
from simbridge.compare.errors import ScenarioError
from simbridge.exceptions import UnknownJointError


def test_every_step_is_recorded(backend):
    tr = run("pendulum", backend, duration=0.25)
    body = tr.body
    assert tr.backend == backend and tr.subject == "pendulum" and tr.steps == 60
    np.testing.assert_allclose(tr.time, np.arange(61) / 240, rtol=1e-15, atol=0)
    assert body.base_position.shape == (61, 3) and body.base_orientation.shape == (61, 4)
    assert body.joint_names == ["hinge"] and body.joint_positions.shape == (61, 1)
    assert body.link_names == ["base", "bob"] and body.link_positions.shape == (61, 2, 3)
    assert tr.phases == [("swing", 0, 60)]
    # released from 0.5 rad: the bob's centre of mass stays 0.5 m from the pivot as it falls
    assert body.joint_positions[0, 0] == 0.5
    assert body.joint_positions[-1, 0] < 0.3
    arm = np.linalg.norm(body.link_positions[:, 1] - body.link_positions[:, 0], axis=1)
    np.testing.assert_allclose(arm, 0.5, atol=1e-9)
    np.testing.assert_allclose(body.base_position, np.tile([0, 0, 1.0], (61, 1)), atol=1e-9)
    # the command held during each step is recorded with it
    assert np.all(body.joint_modes[1:, 0] == 1) and body.joint_modes[0, 0] == 0
    assert np.all(body.joint_targets[1:, 0] == 0.0) and np.isnan(body.joint_targets[0, 0])
    assert tr.manifest["backend"] == backend
    assert len(tr.manifest["urdf"]["pendulum"]["sha256"]) == 64
    assert tr.wall_time > 0 and tr.wall_total >= tr.wall_time


def test_r2d2_run_is_the_tutorial_drive(backend):
    """run("r2d2") gives, bit for bit, what the tutorial's loop written against Sim gives."""
    tr = run("r2d2", backend)
    with simbridge.Sim(backend) as sim:
        sim.load_urdf("plane.urdf")
        robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.1))
        sim.step(240)
        for _ in range(240):
            for j, v in ((2, -100), (3, -100), (6, 100), (7, 100)):
                sim.set_joint_velocity(robot, j, v, max_force=50)
            sim.step()
        for _ in range(500):
            for j in (2, 3, 6, 7):
                sim.set_joint_velocity(robot, j, -100, max_force=10)
            sim.step()
        base = sim.link_state(robot, -1)
        assert tuple(tr.body.base_position[-1]) == base.link_frame_position
        assert tuple(tr.body.base_orientation[-1]) == base.link_frame_orientation
    assert tr.steps == 980 and tr.phases == [
        ("settle", 0, 240),
        ("turn", 240, 480),
        ("forward", 480, 980),
    ]
    wheels = [
        tr.body.joint_names.index(n) for n in ("right_front_wheel_joint", "left_back_wheel_joint")
    ]
    assert list(tr.body.joint_targets[300, wheels]) == [-100.0, 100.0]
    assert list(tr.body.joint_targets[900, wheels]) == [-100.0, -100.0]


def test_torque_and_velocity_commands_on_the_wheel(backend):
    """Profile "urdf" (no damping, no brake), wheel Izz = 0.01: the motor (1 N·m) brings it to
    10 rad/s, 0.05 N·m for 1 s adds 5 rad/s, then it coasts at 15 rad/s."""
    tr = run("spinning-wheel", backend, profile="urdf")
    v = tr.body.joint_velocities[:, 0]
    # a float32 state (PhysX) adds its rounding each step: measured 15 - 7.6e-5 at step 480
    tol = 2e-4 if float32(backend) else 1e-6
    assert v[240] == pytest.approx(10.0, abs=tol)
    assert v[480] == pytest.approx(15.0, abs=tol)
    assert v[720] == pytest.approx(15.0, abs=tol)
    assert list(tr.body.joint_modes[[240, 241, 481], 0]) == [1, 3, 1]


def test_overrides_keep_the_simulated_time(backend):
    tr = run("pendulum", backend, timestep="1/480", duration=0.5)
    assert tr.timestep == 1 / 480 and tr.steps == 240
    assert tr.time[-1] == pytest.approx(0.5, rel=1e-12)
    with pytest.raises(ScenarioError, match="timestep"):
        run("pendulum", backend, timestep="soon")


def test_unknown_joint_names_the_joint():
    s = loads_scenario(
        '[[robots]]\nurdf = "pendulum.urdf"\nfixed_base = true\n'
        '[[phases]]\nsteps = 2\n[[phases.commands]]\njoints = "elbow"\nmode = "torque"\n'
        "target = 1\n"
    )
    with pytest.raises(UnknownJointError, match="'elbow'.*'hinge'"):
        run(s, "pybullet")


def test_save_and_load_round_trip(tmp_path):
    tr = run("double-pendulum", "pybullet", duration=0.1)
    path = tr.save(tmp_path / "t.npz")
    back = Trajectory.load(path)
    for key in ("scenario", "backend", "profile", "timestep", "subject", "phases", "wall_time"):
        assert getattr(back, key) == getattr(tr, key)
    np.testing.assert_array_equal(back.time, tr.time)
    for name, body in tr.bodies.items():
        other = back.bodies[name]
        assert other.joint_names == body.joint_names and other.link_names == body.link_names
        for key in (
            "base_position",
            "base_orientation",
            "joint_positions",
            "joint_velocities",
            "joint_forces",
            "joint_targets",
            "joint_modes",
            "link_positions",
        ):
            np.testing.assert_array_equal(getattr(other, key), getattr(body, key))
    assert back.manifest["urdf"] == tr.manifest["urdf"]


def test_csv_has_one_row_per_instant(tmp_path):
    tr = run("pendulum", "pybullet", duration=0.05)
    path = tr.save_csv(tmp_path / "t.csv")
    with path.open() as f:
        rows = list(csv.reader(f))
    header = rows[0]
    assert header[0] == "time" and "pendulum.joint_positions.hinge" in header
    assert "pendulum.link_positions.bob.z" in header
    assert len(rows) == tr.steps + 2
    col = header.index("pendulum.joint_positions.hinge")
    assert [float(r[col]) for r in rows[1:]] == list(tr.body.joint_positions[:, 0])
