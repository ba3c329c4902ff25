"""``Sim.external_forces`` and ``Sim.body_external_forces``: the contact wrench on each link
(each MuJoCo body), MuJoCo's ``cfrc_ext`` convention, on every backend.

Expectations from statics: a body at rest is held up by its weight, so the contact forces on
its links sum to (0, 0, m g) and their torques about its centre of mass to 0; the ground takes
the opposite force, its torque about its own origin the lever arm of the point where the
body stands. Measured on pybullet 3.2.7, mujoco 4.0 and SAPIEN 3.0.3 (both profiles); each
tolerance says what it covers.
"""

from __future__ import annotations

import numpy as np
import pytest
from _gaps import tolerance

from simbridge import exceptions as exc

G = 9.8
BOX_MASS = 3.0  # robots/free_box.urdf: 0.2 x 0.3 x 0.4 m, 3 kg
ANT = "package://gymnasium/envs/mujoco/assets/ant.xml"


def test_a_resting_box_takes_its_weight_about_its_centre(make_sim, profile):
    sim = make_sim(profile=profile)
    plane = sim.load_urdf("plane.urdf")
    box = sim.load_urdf("free_box.urdf", base_position=(0.3, 0.1, 0.2))
    # before the first step: no contact, no force (one row: the base)
    assert sim.external_forces(box).tolist() == [[0.0] * 6]
    sim.step(240)
    w = sim.external_forces(box)
    assert w.shape == (1, 6) and w.dtype == np.float64
    # the force: measured |f - (0, 0, m g)| 1.0e-6 N (pybullet), 4e-16 (mujoco), 2.1e-6
    # (physx, float32 impulses); a missing corner would be 7 N, a wrong sign 59 N
    assert w[0, 3:] == pytest.approx((0.0, 0.0, BOX_MASS * G), abs=1e-4)
    # the torque about the box's centre of mass: the corners balance (measured 1.0e-6 N m
    # pybullet, 1e-15 mujoco, 9e-8 physx); about the plane's origin it would be 9.3 N m
    assert np.abs(w[0, :3]).max() < 1e-4
    # the plane takes the opposite force, its torque about its own origin (its massless
    # base's centre) (p - 0) x f with p = (0.3, 0.1, ~0): (-0.1 m g, 0.3 m g, 0)
    ground = sim.external_forces(plane)
    assert ground[0, 3:] == pytest.approx(-w[0, 3:], abs=1e-9)
    mg = BOX_MASS * G
    assert ground[0, :3] == pytest.approx((-0.1 * mg, 0.3 * mg, 0.0), abs=1e-3)


def test_r2d2_at_rest_stands_on_its_wheels(make_sim, profile):
    sim = make_sim(profile=profile)
    sim.load_urdf("plane.urdf")
    r2d2 = sim.load_urdf("r2d2.urdf", base_position=(0.0, 0.0, 0.5))
    sim.step(240)
    w = sim.external_forces(r2d2)
    n = sim.num_joints(r2d2)
    assert w.shape == (n + 1, 6)
    loaded = {sim.joint_info(r2d2, k - 1).link_name for k in np.flatnonzero(w[:, 5] > 1.0)}
    assert loaded == {
        "left_back_wheel",
        "left_front_wheel",
        "right_back_wheel",
        "right_front_wheel",
    }
    assert not w[0].any()  # the base touches nothing
    mass = sum(sim.dynamics_info(r2d2, link).mass for link in range(-1, n))
    total = w.sum(axis=0)
    rel = tolerance(sim.backend, 1e-6, "resting_normal_force_sum")
    assert total[5] == pytest.approx(mass * G, rel=rel)
    # about r2d2's centre of mass the wheels' torques cancel (statics); about its base's
    # centre (0.9 m above the wheels' plane, off the centre of mass) they would not
    torque = float(np.abs(total[:3]).max())
    assert torque <= tolerance(sim.backend, 1e-2, "resting_contact_torque")
    # each wheel's torque is its own lever arm: large against the sum (measured >= 9 N m)
    assert np.abs(w[1:, :3]).max() > 5.0


def test_the_rows_of_mujocos_bodies_sum_to_the_links(make_sim):
    """An MJCF read as MuJoCo reads it: ``body_external_forces`` has one row per MuJoCo
    body (Gymnasium's Ant-v5 observes rows 1..13), zeros before a step and after a restore;
    at rest on its four feet the rows carry the ant's weight, and ``external_forces`` of the
    ant is the same wrench, gathered per link."""
    sim = make_sim()
    ant = sim.load_mjcf(ANT, semantics="mujoco")[0]
    assert sim.body_external_forces().shape == (14, 6)
    assert not sim.body_external_forces().any()
    sim.step(200)  # 2 s: settled on its feet
    lift = []  # the vertical force on the bodies at each step of the third second
    for _ in range(100):
        sim.step()
        lift.append(sim.body_external_forces()[:, 5].sum())
    rows = sim.body_external_forces()
    assert not rows[0].any()  # the world's row
    n = sim.num_joints(ant)
    links = sim.external_forces(ant)
    assert links.shape == (n + 1, 6)
    assert links.sum(axis=0) == pytest.approx(rows.sum(axis=0), abs=1e-9)
    # the feet carry it, over a second (the impulse: at rest it is the weight's): measured, the
    # mean over the third second 8.9354 N (mujoco), 8.9368 (pybullet), 8.9357 (physx) for
    # ant.xml's 0.91088 kg (MuJoCo's compiled subtree mass of the torso) times the file's
    # 9.81 m/s^2, within 1.2e-4 of it. An instant's force is not the weight on PyBullet: the
    # armature force's trial passes leave the resting ant a jitter (the force's standard
    # deviation over that second 0.048 N; 9.032 N at 3 s), MuJoCo's 1.2e-4, PhysX's 0.0079.
    # The feet (the ankles' links) alone carry it
    g = -float(sim.manifest()["option"]["gravity"][2])
    assert np.mean(lift) == pytest.approx(0.91088 * g, rel=1e-3)
    feet = [j + 1 for j in range(n) if sim.joint_info(ant, j).name.startswith("ankle")]
    assert links[feet, 5].sum() == pytest.approx(rows[:, 5].sum(), rel=1e-9)
    # each foot's friction holds it from splaying (measured 0.22-0.28 N sideways on
    # pybullet), and the four cancel: nothing pushes the ant sideways at rest
    assert np.abs(links[feet, 3:5].sum(axis=0)).max() < 1e-2
    state = sim.get_state()
    sim.set_state(state)
    assert not sim.body_external_forces().any()


def test_external_force_errors(make_sim):
    sim = make_sim()
    with pytest.raises(exc.UnknownBodyError):
        sim.external_forces(7)
    with pytest.raises(exc.BackendUnsupportedError, match="semantics='mujoco'"):
        sim.body_external_forces()


def test_xpos_is_mujocos_body_frames(make_sim):
    """``Sim.xpos``: MuJoCo's ``d.xpos``; after a write, of the state written (the torso's
    frame origin is its free joint's qpos), after a step within that step's motion of the
    state (MuJoCo under RK4 keeps its last stage's, which Ant-v5 reads)."""
    sim = make_sim()
    sim.load_mjcf(ANT, semantics="mujoco")
    q = sim.qpos()
    q[0:3] = (0.2, -0.1, 0.7)
    sim.set_qpos_qvel(q, None)
    x = sim.xpos()
    assert x.shape == (14, 3) and not x[0].any()
    assert x[1] == pytest.approx((0.2, -0.1, 0.7), abs=tolerance(sim.backend, 1e-12))
    sim.step(10)  # falling: 0.1 s, about 0.5 m/s at the end
    q, v = sim.qpos(), sim.qvel()
    assert np.abs(sim.xpos()[1] - q[0:3]).max() <= np.abs(v[0:3]).max() * 0.01 + 1e-9
