"""Link-frame world poses against yourdfpy's forward kinematics, at zero and at random joint
positions, with a fixed and a free base placed at a non-trivial pose.

Tolerance 1e-9 m and 1e-9 in rotation-matrix entries: both sides compose the same double-precision
transforms. Known gap (``conftest.KNOWN_GAPS["link_state_float32"]``): PyBullet's
``getLinkState`` returns poses rounded to float32 (its shared-memory link-state buffer), so on
PyBullet links (and a fixed base) are within the measured float32 rounding instead."""

from __future__ import annotations

from pathlib import Path

import _reference as ref
import numpy as np
import pybullet_data
import pytest
from _gaps import as_stored, gap

DATA = Path(pybullet_data.getDataPath())
TOL = 1e-9
BASE_POSITION = (0.3, -0.2, 0.7)
_axis = np.array([0.2, -0.5, 0.8]) / np.linalg.norm([0.2, -0.5, 0.8])
BASE_ORIENTATION = (*(np.sin(0.35) * _axis), np.cos(0.35))  # 0.7 rad about a skew axis

ROBOTS = [
    ref.robot_path(name)
    for name in (
        "r2d2.urdf",
        "pendulum.urdf",
        "double_pendulum.urdf",
        "wheel.urdf",
        "slider.urdf",
        "free_box.urdf",
    )
] + [
    str(DATA / name)
    for name in (
        "kuka_iiwa/model.urdf",  # base centre of mass off the link origin
        "franka_panda/panda.urdf",  # a <mimic> finger joint
        "quadruped/minitaur.urdf",  # 26 joints, many fixed
        "laikago/laikago_toes.urdf",  # rotated inertial frames
        "cartpole.urdf",  # prismatic then revolute
    )
]


def _random_positions(robot, rng: np.random.Generator) -> dict[str, float]:
    out = {}
    for joint in robot.joints:
        if joint.type == "fixed" or joint.mimic is not None:
            continue
        lim = joint.limit
        lo, hi = -np.pi, np.pi
        if joint.type == "prismatic":
            lo, hi = -0.3, 0.3
        if lim is not None and lim.lower is not None and lim.upper is not None:
            if lim.lower <= lim.upper:
                lo, hi = float(lim.lower), float(lim.upper)
        out[joint.name] = float(rng.uniform(lo, hi))
    return ref.with_mimic(robot, out)


def _check_poses(sim, body, path, positions, fixed_base, tol):
    """Compare every link; return the largest error seen (m or matrix entry)."""
    worst = 0.0
    robot = ref.load(path).robot
    base = ref.pose_matrix(BASE_POSITION, BASE_ORIENTATION)
    expected = ref.forward_kinematics(path, base, positions)
    links = ref.link_by_name(robot)
    for index, name in enumerate(ref.link_names_in_order(robot), start=-1):
        state = sim.link_state(body, index)
        want = expected[name]
        com = want @ ref.inertial_frame(links[name])
        worst = max(
            worst,
            float(np.abs(np.subtract(state.link_frame_position, want[:3, 3])).max()),
            float(np.abs(ref.quat_to_matrix(state.link_frame_orientation) - want[:3, :3]).max()),
            float(np.abs(np.subtract(state.com_position, com[:3, 3])).max()),
        )
        atol = tol
        where = f"{Path(path).name} link {index} {name!r} ({'fixed' if fixed_base else 'free'})"
        np.testing.assert_allclose(
            state.link_frame_position, want[:3, 3], atol=atol, err_msg=where, rtol=0
        )
        np.testing.assert_allclose(
            ref.quat_to_matrix(state.link_frame_orientation),
            want[:3, :3],
            atol=atol,
            rtol=0,
            err_msg=where,
        )
        # the centre of mass sits at the file's inertial origin in the link frame
        np.testing.assert_allclose(state.com_position, com[:3, 3], atol=atol, rtol=0, err_msg=where)
        if index == -1:
            np.testing.assert_allclose(sim.base_state(body).position, com[:3, 3], atol=tol, rtol=0)
    return worst


@pytest.mark.parametrize("fixed_base", [False, True], ids=["free", "fixed"])
@pytest.mark.parametrize("path", ROBOTS, ids=lambda p: Path(p).name)
def test_link_frames_match_yourdfpy(make_sim, path, fixed_base):
    sim = make_sim(gravity=(0, 0, 0))
    robot = ref.load(path).robot
    body = sim.load_urdf(
        path,
        base_position=BASE_POSITION,
        base_orientation=BASE_ORIENTATION,
        fixed_base=fixed_base,
    )
    known = gap(sim.backend, "link_state_float32")
    tol = TOL if known is None else known
    worst = _check_poses(sim, body, path, {}, fixed_base, tol)  # zero configuration
    rng = np.random.default_rng(20261122)
    names = [j.name for j in ref.pybullet_order(robot) if j.type != "fixed"]
    for _ in range(3):
        positions = _random_positions(robot, rng)
        if names:
            sim.reset_joint_state(body, names, [positions[n] for n in names])
            np.testing.assert_array_equal(
                sim.joint_states(body, names).positions,
                as_stored(sim.backend, [positions[n] for n in names]),
            )
        worst = max(worst, _check_poses(sim, body, path, positions, fixed_base, tol))
    print(f"{sim.backend} {Path(path).name}: worst link pose error {worst:.3g}")
    if known is not None:  # keep the gap honest: it must still be there to be excused
        assert worst > TOL, f"{sim.backend} now meets {TOL}: remove its link_state_float32 gap"


@pytest.mark.parametrize("profile_name", ["pybullet", "urdf"])
def test_link_frames_after_a_step_are_current(make_sim, profile_name):
    """link_state read right after step() describes the state after that step (PyBullet's own
    getLinkState is one step stale without computeForwardKinematics): the pendulum's bob must
    sit where the joint angle just read says, by yourdfpy's kinematics."""
    sim = make_sim(profile=profile_name)
    path = ref.robot_path("pendulum.urdf")
    body = sim.load_urdf(
        path, base_position=BASE_POSITION, base_orientation=BASE_ORIENTATION, fixed_base=True
    )
    sim.set_joint_velocity(body, "hinge", 0.0, max_force=0.0)
    sim.reset_joint_state(body, "hinge", 1.0)
    for _ in range(5):
        sim.step(7)
        q = float(sim.joint_states(body, "hinge").positions[0])
        want = ref.forward_kinematics(
            path, ref.pose_matrix(BASE_POSITION, BASE_ORIENTATION), {"hinge": q}
        )["bob"]
        state = sim.link_state(body, "bob")
        tol = gap(sim.backend, "link_state_float32") or TOL
        np.testing.assert_allclose(state.link_frame_position, want[:3, 3], atol=tol, rtol=0)
    assert q != 1.0  # it did swing


def test_reset_base_state_sets_what_it_is_given_and_keeps_the_rest(make_sim):
    """Each argument of reset_base_state sets its own quantity; one left None keeps its value.
    (PyBullet's resetBasePositionAndOrientation also zeroes the base velocity: the PyBullet
    backend puts it back, so a pose-only reset means the same on every backend.)"""
    sim = make_sim(gravity=(0.0, 0.0, 0.0))
    body = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 1))
    lin, ang = (1.0, -0.5, 0.25), (0.0, 0.3, 2.0)
    sim.reset_base_state(body, linear_velocity=lin, angular_velocity=ang)
    orn = (0.0, 0.0, np.sin(0.3), np.cos(0.3))
    for kwargs in ({"position": (0.5, 0.0, 2.0)}, {"orientation": orn}):
        before = sim.base_state(body)
        sim.reset_base_state(body, **kwargs)
        s = sim.base_state(body)
        np.testing.assert_allclose(s.linear_velocity, lin, atol=1e-12)
        np.testing.assert_allclose(s.angular_velocity, ang, atol=1e-12)
        if "position" in kwargs:
            np.testing.assert_allclose(s.position, kwargs["position"], atol=1e-12)
            np.testing.assert_allclose(s.orientation, before.orientation, atol=1e-7)
        else:
            np.testing.assert_allclose(s.position, before.position, atol=1e-12)
            np.testing.assert_allclose(s.orientation, orn, atol=1e-7)
    sim.reset_base_state(body, linear_velocity=(0, 0, 0))
    s = sim.base_state(body)
    np.testing.assert_allclose(s.linear_velocity, 0.0, atol=1e-12)
    np.testing.assert_allclose(s.angular_velocity, ang, atol=1e-12)


def test_a_fixed_base_takes_a_pose_but_no_velocity(make_sim):
    """A fixed base can be moved (the weld moves with it), but a velocity for it is refused:
    PyBullet would carry the welded base along at that velocity, MuJoCo has nothing to carry."""
    from simbridge.exceptions import InvalidArgumentError

    sim = make_sim(gravity=(0.0, 0.0, 0.0))
    body = sim.load_urdf("kuka_iiwa/model.urdf", fixed_base=True)
    sim.reset_base_state(body, position=(0.5, 0.0, 0.2))
    assert sim.base_state(body).position == pytest.approx((0.5, 0.0, 0.2), abs=1e-6)
    sim.reset_base_state(body, linear_velocity=(0, 0, 0))  # zeros are fine
    with pytest.raises(InvalidArgumentError, match="fixed base, which takes no velocity"):
        sim.reset_base_state(body, angular_velocity=(0, 0, 2.0))
    sim.step(10)
    assert sim.base_state(body).position == pytest.approx((0.5, 0.0, 0.2), abs=1e-6)
