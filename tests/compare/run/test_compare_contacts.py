"""run() records each link's contacts per step (count and total normal force) beside the
trajectory, saved and loaded with it and kept out of the trajectory hashes."""

from __future__ import annotations

import csv

import numpy as np

from simbridge.compare import Trajectory, run
from simbridge.compare.run.trajectory import _BODY_ARRAYS, _CONTACT_ARRAYS

WHEELS = ["right_front_wheel", "right_back_wheel", "left_front_wheel", "left_back_wheel"]


def test_r2d2_stands_on_its_wheels_in_the_record(backend, tmp_path):
    tr = run("r2d2-gentle", backend, duration=0.5)  # settling, then turning in place
    robot, plane = tr.bodies["r2d2"], tr.bodies["plane"]
    n = tr.steps + 1
    assert robot.contact_counts.shape == robot.contact_normal_forces.shape == (n, 16)
    assert robot.contact_counts.dtype == np.int32
    assert (robot.contact_counts[0] == 0).all()  # no step yet: no contact
    wheels = [robot.link_names.index(w) for w in WHEELS]
    others = [k for k in range(16) if k not in wheels]
    assert (robot.contact_counts[:, others] == 0).all()
    assert (robot.contact_normal_forces[:, others] == 0).all()
    # at rest (the settle phase's end, row 120) the wheels carry the weight, 65.25 kg x 9.8
    settled = robot.contact_normal_forces[120]
    assert (settled[wheels] > 0).all()
    np.testing.assert_allclose(settled.sum(), plane.contact_normal_forces[120, 0], rtol=1e-12)
    assert abs(settled.sum() - 65.25 * 9.8) < 0.01 * 65.25 * 9.8
    # the plane's one link counts every point the robot's links count
    np.testing.assert_array_equal(plane.contact_counts[:, 0], robot.contact_counts.sum(axis=1))
    back = Trajectory.load(tr.save(tmp_path / "t.npz"))
    for key in _CONTACT_ARRAYS:
        np.testing.assert_array_equal(getattr(back.bodies["r2d2"], key), getattr(robot, key))
    with tr.save_csv(tmp_path / "t.csv").open() as f:
        header = next(csv.reader(f))
    assert "r2d2.contact_counts.right_front_wheel" in header
    assert "r2d2.contact_normal_forces.base" in header


def test_contacts_are_not_hashed_and_may_be_missing(tmp_path):
    assert not set(_CONTACT_ARRAYS) & set(_BODY_ARRAYS)
    tr = run("pendulum", "pybullet", duration=0.05)
    body = tr.body
    assert (body.contact_counts == 0).all()  # a pendulum in the air touches nothing
    body.contact_counts = body.contact_normal_forces = None  # as a file written before them
    back = Trajectory.load(tr.save(tmp_path / "old.npz"))
    assert back.body.contact_counts is None and back.body.contact_normal_forces is None
