"""``Sim.contact_points``: PyBullet's ``getContactPoints`` fields on every backend.

Expectations from statics: a body at rest on the ground is held up by its weight, so the
normal forces sum to m g and the contact forces on it sum to (0, 0, m g) on a slope too, the
friction taking m g sin(angle) along it. Measured on pybullet 3.2.7 and mujoco 4.0 (both
profiles) with the settle times below; each tolerance says what it covers.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from _gaps import gap, tolerance

from simbridge import exceptions as exc
from simbridge.transforms import quat_rotate
from simbridge.types import ContactPoint

G = 9.8
BOX_MASS = 3.0  # robots/free_box.urdf: 0.2 x 0.3 x 0.4 m, 3 kg
SLOPE = """<robot name="slope"><link name="slope">
<inertial><mass value="0"/><inertia ixx="0" iyy="0" izz="0" ixy="0" ixz="0" iyz="0"/></inertial>
<collision><geometry><box size="4 4 0.2"/></geometry></collision></link></robot>"""
WHEELS = {"left_back_wheel", "left_front_wheel", "right_back_wheel", "right_front_wheel"}


def _force_on_a(points: tuple[ContactPoint, ...]) -> np.ndarray:
    total = np.zeros(3)
    for c in points:
        total += c.normal_force * np.asarray(c.normal_on_b)
        total += c.lateral_friction_1 * np.asarray(c.lateral_friction_dir_1)
        total += c.lateral_friction_2 * np.asarray(c.lateral_friction_dir_2)
    return total


def _resting_box(make_sim, profile):
    sim = make_sim(profile=profile)
    plane = sim.load_urdf("plane.urdf")
    box = sim.load_urdf("free_box.urdf", base_position=(0.0, 0.0, 0.2))
    return sim, plane, box


def test_no_contact_before_the_first_step(make_sim):
    sim = make_sim()
    plane = sim.load_urdf("plane.urdf")
    sim.load_urdf("free_box.urdf", base_position=(0.0, 0.0, 0.2))
    assert sim.contact_points() == ()
    assert sim.contact_points(plane) == ()


def test_a_resting_box_is_held_up_by_its_weight(make_sim, profile):
    sim, plane, box = _resting_box(make_sim, profile)
    sim.step(240)  # 1 s: settled (the base moves less than 1e-9 m per step)
    points = sim.contact_points(box, plane)
    # one point per corner of the bottom face on both engines
    assert len(points) == 4
    assert {(c.body_a, c.body_b, c.link_a, c.link_b) for c in points} == {(box, plane, -1, -1)}
    # measured |sum / (m g) - 1|: pybullet 1.2e-12, mujoco 1.5e-9 (its soft contact still
    # settling); 1e-6 leaves room for neither a missing corner (25 %) nor a wrong sign
    total = sum(c.normal_force for c in points)
    assert total == pytest.approx(BOX_MASS * G, rel=1e-6)
    for c in points:
        assert c.contact_flag == 0
        assert c.normal_on_b == pytest.approx((0.0, 0.0, 1.0), abs=1e-12)  # from B up to A
        assert c.normal_force > 0
        # the bottom corners: +-0.1, +-0.15 m; the plane's top at z 0 (PyBullet, measured
        # 2e-16), or the backend's known height above it (MuJoCo: half its 1 mm pair margin:
        # the surfaces are inflated by half the margin each, so that distance 0 is where the
        # force starts)
        assert np.abs(c.position_on_a[:2]) == pytest.approx((0.1, 0.15), abs=1e-4)
        above = gap(sim.backend, "contact_point_above_surface")
        assert c.position_on_b[2] == pytest.approx(0.0, abs=1e-5) or (
            above is not None and c.position_on_b[2] == pytest.approx(above, abs=1e-12)
        )
        # penetration: pybullet 0.9e-5..1.6e-5 m, mujoco 3.0e-6 m (dist less its 1 mm margin)
        assert -2e-5 < c.distance < 0
        # PyBullet's identity between the two points, exact to rounding on both
        expected = np.add(c.position_on_b, np.multiply(c.distance, c.normal_on_b))
        assert c.position_on_a == pytest.approx(tuple(expected), abs=1e-12)
        # nothing pushes sideways: measured <= 2.4e-5 N (pybullet), 1.7e-15 N (mujoco)
        assert abs(c.lateral_friction_1) + abs(c.lateral_friction_2) < 1e-4
        d1, d2 = np.asarray(c.lateral_friction_dir_1), np.asarray(c.lateral_friction_dir_2)
        frame = np.array([c.normal_on_b, d1, d2])
        assert frame @ frame.T == pytest.approx(np.eye(3), abs=1e-12)


def test_the_other_order_swaps_a_and_b(make_sim):
    sim, plane, box = _resting_box(make_sim, "pybullet")
    sim.step(240)
    ab = sim.contact_points(box, plane)
    ba = sim.contact_points(plane, box)
    assert len(ab) == len(ba) == 4
    for x, y in zip(ab, ba, strict=True):
        assert (y.body_a, y.body_b, y.link_a, y.link_b) == (plane, box, -1, -1)
        assert y.position_on_a == x.position_on_b and y.position_on_b == x.position_on_a
        assert y.normal_on_b == pytest.approx(tuple(-np.asarray(x.normal_on_b)), abs=0)
        assert y.normal_force == x.normal_force and y.distance == x.distance
    # the forces on A are the forces on the other body, reversed
    assert _force_on_a(ba) == pytest.approx(tuple(-_force_on_a(ab)), abs=1e-12)
    assert _force_on_a(ab) == pytest.approx((0.0, 0.0, BOX_MASS * G), abs=1e-4)
    # all points, and one body's points, are the same set
    assert len(sim.contact_points()) == 4 and len(sim.contact_points(box)) == 4


def test_a_box_resting_on_a_slope(make_sim, profile):
    angle = math.radians(10)  # below the friction angle: product friction 0.5 x 0.5
    tilt = (math.sin(angle / 2), 0.0, 0.0, math.cos(angle / 2))
    normal = np.asarray(quat_rotate(tilt, (0.0, 0.0, 1.0)))
    sim = make_sim(profile=profile)
    slope = sim.load_urdf(SLOPE, fixed_base=True, base_orientation=tilt)
    # the box's bottom face 0.5 mm above the slope's top face, its sides along the slope's
    box = sim.load_urdf(
        "free_box.urdf", base_position=tuple(normal * (0.1 + 0.2 + 0.0005)), base_orientation=tilt
    )
    sim.step(480)
    points = sim.contact_points(box, slope)
    assert len(points) == 4
    for c in points:
        assert c.normal_on_b == pytest.approx(tuple(normal), abs=tolerance(sim.backend, 1e-9))
    # the contact forces on the box carry its weight: measured worst component error 0.058 N
    # (pybullet "pybullet" profile: its box creeps down at 9e-5 m/s), 3.7e-5 N (mujoco)
    force = _force_on_a(points)
    if "contact friction" in sim.manifest()["departures"]:
        # no friction force is reported (a listed departure): the fields are 0 but for the
        # normal impulse's float32 residue (PhysX measured 4.6e-7 N), and the normal forces
        # alone carry m g cos(angle) (PhysX measured 28.953351 N for 28.953348: 9e-8)
        assert all(abs(c.lateral_friction_1) + abs(c.lateral_friction_2) < 1e-5 for c in points)
        total = sum(c.normal_force for c in points)
        assert total == pytest.approx(abs(BOX_MASS * G) * math.cos(angle), rel=1e-6)
        return
    assert force == pytest.approx((0.0, 0.0, BOX_MASS * G), abs=0.1)
    # ... friction taking m g sin(angle) = 5.105 N up the slope: measured 5.162 N (pybullet),
    # 5.1052 N (mujoco); a friction sign error would give a force down the slope
    friction = force - sum(c.normal_force for c in points) * normal
    up_slope = np.cross(normal, (1.0, 0.0, 0.0))  # (0, cos, sin): the slope rises along +y
    assert np.linalg.norm(friction) == pytest.approx(BOX_MASS * G * math.sin(angle), rel=0.02)
    # pointing up the slope: measured cosine 0.99998 (pybullet), 1 - 1e-16 (mujoco)
    assert friction @ up_slope > 0.999 * np.linalg.norm(friction)


def test_r2d2_at_rest_stands_on_its_four_wheels(make_sim, profile):
    sim = make_sim(profile=profile)
    plane = sim.load_urdf("plane.urdf")
    r2d2 = sim.load_urdf("r2d2.urdf", base_position=(0.0, 0.0, 0.5))
    sim.step(240)
    points = sim.contact_points(r2d2, plane)
    touching = {sim.joint_info(r2d2, c.link_a).link_name for c in points if c.normal_force > 0}
    assert touching == WHEELS
    mass = sum(sim.dynamics_info(r2d2, link).mass for link in range(-1, sim.num_joints(r2d2)))
    # measured |sum / (m g) - 1| <= 4.2e-8 (pybullet), 3.3e-12 (mujoco)
    rel = tolerance(sim.backend, 1e-6, "resting_normal_force_sum")
    assert sum(c.normal_force for c in points) == pytest.approx(mass * G, rel=rel)
    # the link filter, by name and by index, keeps that wheel's points alone
    wheel = sim.contact_points(r2d2, plane, link_a="right_front_wheel")
    assert wheel and {c.link_a for c in wheel} == {sim.link_index(r2d2, "right_front_wheel")}
    assert sim.contact_points(r2d2, plane, link_a=sim.link_index(r2d2, "right_front_wheel")) == (
        wheel
    )
    assert sim.contact_points(r2d2, plane, link_a=-1) == ()  # the base touches nothing
    assert sim.contact_points(r2d2, plane, link_a="base_link", link_b=-1) == ()
    assert len(sim.contact_points(plane, r2d2, link_b="left_back_wheel")) >= 1


def test_a_removed_body_leaves_the_contacts_of_the_last_step(make_sim):
    """After ``remove`` and before the next step, no point names a body that is gone, through
    a teleport and a second remove too; the next step finds the contacts afresh. (Found by
    test_state_machine.py: the PhysX backend read SAPIEN's report of the last step, which still
    named the removed plane's components, and the process died of a segmentation fault.) The
    points that remain differ between engines and are not pinned here: PyBullet keeps the other
    pairs' points (4 of 8 here), MuJoCo drops them all until the next step."""
    sim = make_sim()
    plane = sim.load_urdf("plane.urdf")
    one = sim.load_urdf("r2d2.urdf", base_position=(0.0, 0.0, 0.475))
    two = sim.load_urdf("r2d2.urdf", base_position=(2.0, 0.0, 0.475))
    sim.step(30)
    assert {c.body_a for c in sim.contact_points(plane)} == {plane}
    assert {c.body_b for c in sim.contact_points(plane)} == {one, two}
    sim.remove(one)
    assert all(one not in (c.body_a, c.body_b) for c in sim.contact_points())
    sim.reset_base_state(two, position=(2.0, 0.0, 1.0))  # a write after the remove
    assert all(one not in (c.body_a, c.body_b) for c in sim.contact_points())
    sim.remove(plane)  # the static body under the robot that stays
    assert sim.contact_points() == ()
    sim.reset_base_state(two, position=(2.0, 0.0, 0.475))
    assert sim.contact_points() == ()
    sim.step()
    assert sim.contact_points() == ()  # nothing left to touch


def test_contact_errors(make_sim):
    sim = make_sim()
    plane = sim.load_urdf("plane.urdf")
    box = sim.load_urdf("free_box.urdf", base_position=(0.0, 0.0, 0.2))
    with pytest.raises(exc.UnknownBodyError, match=r"unknown body 7; bodies in this Sim: \[0, 1\]"):
        sim.contact_points(7)
    with pytest.raises(exc.UnknownBodyError, match=r"unknown body 9"):
        sim.contact_points(box, 9)
    with pytest.raises(
        exc.UnknownLinkError, match=r"body 1 \('free_box', free_box\.urdf\) has no link 3; valid"
    ):
        sim.contact_points(box, plane, link_a=3)
    with pytest.raises(
        exc.UnknownLinkError, match=r"body 0 \('plane', plane\.urdf\) has no link 'wheel'"
    ):
        sim.contact_points(box, plane, link_b="wheel")
    with pytest.raises(exc.InvalidArgumentError, match=r"'body_b': give body_a too"):
        sim.contact_points(body_b=plane)
    with pytest.raises(exc.InvalidArgumentError, match=r"'link_a': a link filter needs its body"):
        sim.contact_points(link_a=-1)
    with pytest.raises(exc.InvalidArgumentError, match=r"'link_b': a link filter needs its body"):
        sim.contact_points(box, link_b=-1)
    sim.close()
    with pytest.raises(exc.SimClosedError):
        sim.contact_points()
