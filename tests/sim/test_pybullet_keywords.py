"""PyBullet's keyword names on Sim calls: a PyBulletKeywordError (a TypeError) naming the
keyword and simbridge's name for it, or the valid keywords; a missing argument still says so
as Python does."""

from __future__ import annotations

import pytest

import simbridge
from simbridge.exceptions import PyBulletKeywordError


@pytest.fixture(scope="module")
def r2d2():
    with simbridge.Sim("pybullet") as sim:
        sim.load_urdf("plane.urdf")
        yield sim, sim.load_urdf("r2d2.urdf")


@pytest.mark.parametrize(
    "keyword, value, ours",
    [
        ("basePosition", [0, 0, 1], "base_position"),
        ("baseOrientation", [0, 0, 0, 1], "base_orientation"),
        ("useFixedBase", True, "fixed_base"),
        ("globalScaling", 2.0, "global_scaling"),
        ("flags", 8, "self_collision"),
        ("physicsClientId", 0, "a Sim is its own connection"),
    ],
)
def test_load_urdf_names_simbridges_keyword(r2d2, keyword, value, ours):
    sim, _ = r2d2
    with pytest.raises(PyBulletKeywordError) as err:
        sim.load_urdf("r2d2.urdf", **{keyword: value})
    text = str(err.value)
    assert text.startswith(f"Sim.load_urdf() got PyBullet's keyword {keyword!r}"), text
    assert ours in text and "valid keywords: source, base_position" in text
    assert isinstance(err.value, TypeError)


@pytest.mark.parametrize(
    "call, kwargs, keyword, ours",
    [
        ("set_joint_velocity", {"target": 1.0, "force": 10}, "force", "max_force"),
        ("set_joint_velocity", {"targetVelocity": 1.0, "force": 10}, "targetVelocity", "target"),
        (
            "set_joint_velocity",
            {"target": 1.0, "max_force": 10, "maxVelocity": 5},
            "maxVelocity",
            "max_joint_velocity",
        ),
        (
            "set_joint_position",
            {"target": 0.1, "max_force": 10, "positionGain": 0.3},
            "positionGain",
            "kp",
        ),
        (
            "set_joint_position",
            {"target": 0.1, "max_force": 10, "velocityGain": 1.0},
            "velocityGain",
            "kd",
        ),
        ("set_joint_torque", {"force": 1.0}, "force", "torque"),
        ("reset_joint_state", {"targetValue": 0.2}, "targetValue", "positions"),
        (
            "reset_joint_state",
            {"positions": 0.2, "targetVelocity": 0.0},
            "targetVelocity",
            "velocities",
        ),
    ],
)
def test_joint_calls_name_simbridges_keyword(r2d2, call, kwargs, keyword, ours):
    sim, body = r2d2
    before = sim.joint_states(body, 2)
    with pytest.raises(PyBulletKeywordError) as err:
        getattr(sim, call)(body, 2, **kwargs)
    text = str(err.value)
    assert f"Sim.{call}() got PyBullet's keyword {keyword!r}" in text, text
    assert ours in text and "valid keywords: body, joints" in text
    after = sim.joint_states(body, 2)
    assert after.positions.tolist() == before.positions.tolist()  # nothing was done


def test_an_unknown_keyword_gets_a_did_you_mean_and_the_valid_ones(r2d2):
    sim, body = r2d2
    with pytest.raises(PyBulletKeywordError) as err:
        sim.set_joint_velocity(body, 2, 1.0, max_forc=10)
    text = str(err.value)
    assert "got an unexpected keyword argument 'max_forc' (did you mean 'max_force'?)" in text
    assert text.endswith("valid keywords: body, joints, target, max_force"), text


def test_a_missing_argument_still_says_so(r2d2):
    sim, body = r2d2
    with pytest.raises(
        TypeError,
        match=r"^Sim\.set_joint_velocity\(\) missing 1 required "
        r"keyword-only argument: 'max_force'$",
    ):
        sim.set_joint_velocity(body, 2, 1.0)
    with pytest.raises(
        TypeError,
        match=r"^Sim\.set_joint_position\(\) missing 1 required "
        r"positional argument: 'target'$",
    ):
        sim.set_joint_position(body, 2, max_force=1.0)
    with pytest.raises(
        TypeError,
        match=r"^Sim\.reset_joint_state\(\) missing 1 required "
        r"positional argument: 'positions'$",
    ):
        sim.reset_joint_state(body, 2)


def test_the_calls_work_as_before(r2d2):
    sim, body = r2d2
    sim.set_joint_velocity(body, 2, 1.0, max_force=10)
    sim.set_joint_position(body, 2, 0.1, max_force=10, kp=0.2, kd=1.0)
    sim.set_joint_torque(body, 2, 0.5)
    sim.reset_joint_state(body, 2, 0.3, 0.0)
    assert sim.joint_states(body, 2).positions.tolist() == [0.3]


def test_a_spherical_joint_missing_an_argument_says_so_too():
    with simbridge.Sim("pybullet") as sim:
        body = sim.load_urdf("spherical_pendulum.urdf", fixed_base=True)
        ball = [j.index for j in sim.joints(body) if j.type == simbridge.JointType.SPHERICAL]
        assert ball
        with pytest.raises(PyBulletKeywordError, match=r"missing 1 required keyword-only "):
            sim.set_joint_velocity(body, ball, 0.0)
        with pytest.raises(PyBulletKeywordError, match=r"missing 1 required positional "):
            sim.set_joint_position(body, ball, max_force=1.0)
        with pytest.raises(PyBulletKeywordError, match=r"got PyBullet's keyword 'force'"):
            sim.set_joint_velocity(body, ball, 0.0, force=1.0)
