"""Bound commands (``Sim.velocity_command``, ``Sim.position_command``) on every backend: the
same trajectory, bit for bit, as the plain ``set_joint_velocity`` / ``set_joint_position``
drive sent before each step; the checks made when a command is bound and when a step reads
it; ownership of the joints; the end of a binding at a world change."""

from __future__ import annotations

import numpy as np
import pytest

from simbridge.exceptions import (
    InvalidArgumentError,
    StaleCommandError,
    UnknownJointError,
)

WHEELS = [2, 3, 6, 7]
TURN = np.array([-10.0, -10.0, 10.0, 10.0])
FORWARD = np.array([-10.0, -10.0, -10.0, -10.0])
KUKA = "kuka_iiwa/model.urdf"


def _r2d2(make_sim):
    sim = make_sim()
    sim.load_urdf("plane.urdf")
    return sim, sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))


def _state(sim, body) -> bytes:
    """Every number of the body's state, as raw bytes (equal only if bit for bit equal)."""
    b = sim.base_state(body)
    js = sim.joint_states(body)
    flat = np.array([*b.position, *b.orientation, *b.linear_velocity, *b.angular_velocity])
    return (
        flat.tobytes()
        + js.positions.tobytes()
        + js.velocities.tobytes()
        + (js.applied_torques.tobytes())
    )


def _drive(make_sim, bound: bool) -> list[bytes]:
    """r2d2 on the plane: settle, turn at 50 N·m, then forward at 10 N·m with a new target
    every step; the targets through set_joint_velocity, or through one bound command."""
    sim, robot = _r2d2(make_sim)
    out, cmd = [], None
    for k in range(150):
        if k >= 20:
            target = TURN if k < 70 else FORWARD * (1.0 + 0.01 * (k % 7))
            force = 50.0 if k < 70 else 10.0
            if not bound:
                sim.set_joint_velocity(robot, WHEELS, target, max_force=force)
            elif cmd is None:
                cmd = sim.velocity_command(robot, WHEELS, target, max_force=force)
            else:
                cmd.targets[:] = target
                cmd.max_force[:] = force
        sim.step()
        out.append(_state(sim, robot))
    return out


def test_bound_velocity_command_gives_the_plain_drive_bit_for_bit(make_sim):
    plain = _drive(make_sim, bound=False)
    bound = _drive(make_sim, bound=True)
    assert len(plain) == len(bound) == 150
    first = next((k for k, (a, b) in enumerate(zip(plain, bound, strict=True)) if a != b), None)
    assert first is None, f"the bound drive departs from the plain one at step {first}"
    assert plain[-1] != plain[20]  # the robot moved: the comparison means something


def _arm(make_sim, how: str, kp: float = 0.1, kd: float = 1.0) -> list[bytes]:
    """A fixed KUKA following a new position target every step (its force limit changed
    halfway), through set_joint_position or a bound position command."""
    sim = make_sim()
    arm = sim.load_urdf(KUKA, fixed_base=True)
    joints = np.arange(7)
    out, cmd = [], None
    for k in range(120):
        q = 0.8 * np.sin(0.05 * k + joints)
        q[1] = 2.5 + 0.2 * np.sin(0.1 * k)  # past joint 1's limit (2.09 rad): clamped
        force = 300.0 if k < 60 else 150.0
        if how == "plain":
            sim.set_joint_position(arm, joints, q, max_force=force, kp=kp, kd=kd)
        elif cmd is None:
            cmd = sim.position_command(arm, joints, q, max_force=force, kp=kp, kd=kd)
        else:
            cmd.targets = q
            cmd.max_force = force
        sim.step()
        out.append(_state(sim, arm))
    return out


@pytest.mark.parametrize(("kp", "kd"), [(0.1, 1.0), (0.3, 0.6)])
def test_bound_position_command_gives_the_plain_drive_bit_for_bit(make_sim, kp, kd):
    plain = _arm(make_sim, "plain", kp, kd)
    bound = _arm(make_sim, "bound", kp, kd)
    first = next((k for k, (a, b) in enumerate(zip(plain, bound, strict=True)) if a != b), None)
    assert first is None, f"the bound command departs from the plain one at step {first}"
    assert plain[-1] != plain[0]


def _release_and_grip(make_sim, bound: bool) -> list[bytes]:
    """A force limit of 0 releases a joint and a positive one takes it back (the motor rows
    change): bound or plain, the same bits."""
    sim = make_sim()
    arm = sim.load_urdf(KUKA, fixed_base=True)
    joints = [0, 1, 2]
    out, cmd = [], None
    for k in range(60):
        target = [0.5, -0.5, 1.0]
        force = [0.0, 50.0, 20.0] if 20 <= k < 40 else [80.0, 50.0, 20.0]
        if not bound:
            sim.set_joint_velocity(arm, joints, target, max_force=force)
        elif cmd is None:
            cmd = sim.velocity_command(arm, joints, target, max_force=force)
        else:
            cmd.max_force[:] = force
        sim.step()
        out.append(_state(sim, arm))
    return out


def test_a_force_of_zero_through_a_bound_command_releases_as_the_plain_call(make_sim):
    assert _release_and_grip(make_sim, True) == _release_and_grip(make_sim, False)


# ---------------------------------------------------------------- checks


def test_binding_checks_joints_shapes_and_values(make_sim):
    sim, robot = _r2d2(make_sim)
    with pytest.raises(UnknownJointError, match="no joint 99"):
        sim.velocity_command(robot, [2, 99], 0.0, max_force=1.0)
    with pytest.raises(InvalidArgumentError, match="is fixed and takes no command"):
        sim.velocity_command(robot, [0, 2], 0.0, max_force=1.0)  # joint 0 of r2d2 is fixed
    with pytest.raises(InvalidArgumentError, match=r"shape \(4,\)"):
        sim.velocity_command(robot, WHEELS, [1.0, 2.0], max_force=1.0)
    with pytest.raises(InvalidArgumentError, match="finite"):
        sim.velocity_command(robot, WHEELS, [1.0, np.nan, 0.0, 0.0], max_force=1.0)
    with pytest.raises(InvalidArgumentError, match=">= 0"):
        sim.position_command(robot, WHEELS, 0.0, max_force=-1.0)
    with pytest.raises(InvalidArgumentError, match=">= 0"):
        sim.position_command(robot, WHEELS, 0.0, max_force=1.0, kp=-0.1)
    cmd = sim.velocity_command(robot, WHEELS, 0.0, max_force=1.0)  # nothing bound before
    assert cmd.targets.shape == cmd.max_force.shape == (4,)
    assert cmd.joints.tolist() == WHEELS and cmd.mode == "velocity" and cmd.bound


def test_a_bad_value_is_refused_by_the_step_before_any_step(make_sim):
    sim, robot = _r2d2(make_sim)
    cmd = sim.velocity_command(robot, WHEELS, 1.0, max_force=5.0)
    sim.step()
    t = sim.time
    for arr, value, argument in (
        ("targets", np.nan, "targets"),
        ("targets", np.inf, "targets"),
        ("max_force", -1.0, "max_force"),
        ("max_force", np.inf, "max_force"),
    ):
        before = _state(sim, robot)
        getattr(cmd, arr)[1] = value
        with pytest.raises(InvalidArgumentError, match=argument) as err:
            sim.step(3)
        assert "velocity command on body" in str(err.value)
        assert sim.time == t and _state(sim, robot) == before  # nothing stepped
        getattr(cmd, arr)[1] = 2.0
        sim.step()
        t = sim.time


def test_an_infinite_position_target_clamped_to_the_one_in_force_is_refused(make_sim):
    # gripper_extension's upper limit is 0, the target in force 0: +inf clamps to 0. Found by
    # test_state_machine.py: the MuJoCo backend compared the clamped value with the command in
    # force before checking it, and stepped.
    sim, robot = _r2d2(make_sim)
    joint = sim.joint_index(robot, "gripper_extension")
    assert sim.joint_info(robot, joint).upper_limit == 0.0
    cmd = sim.position_command(robot, [joint], 0.0, max_force=1.0)
    sim.step()
    t, before = sim.time, _state(sim, robot)
    cmd.targets[0] = np.inf
    with pytest.raises(InvalidArgumentError, match="targets"):
        sim.step()
    with pytest.raises(InvalidArgumentError, match="targets"):
        sim.get_state()  # as step would
    assert sim.time == t and _state(sim, robot) == before  # nothing stepped


def test_assigning_an_array_copies_it_in_with_its_shape_checked(make_sim):
    sim, robot = _r2d2(make_sim)
    cmd = sim.velocity_command(robot, WHEELS, 0.0, max_force=5.0)
    targets = cmd.targets
    cmd.targets = [1.0, 2.0, 3.0, 4.0]
    cmd.max_force = 7.0  # a number fills every joint
    assert cmd.targets is targets and targets.tolist() == [1.0, 2.0, 3.0, 4.0]
    assert cmd.max_force.tolist() == [7.0] * 4
    with pytest.raises(InvalidArgumentError, match=r"shape \(4,\)"):
        cmd.targets = [1.0, 2.0]
    with pytest.raises(InvalidArgumentError, match="targets"):
        cmd.targets = "fast"
    with pytest.raises(AttributeError, match="fixed when the command is bound"):
        cmd.joints = np.array([2])
    with pytest.raises(ValueError):  # numpy's own shape check on an in-place write
        cmd.targets[:] = [1.0, 2.0]


# ---------------------------------------------------------------- ownership


def test_a_bound_command_owns_its_joints_until_released(make_sim):
    sim, robot = _r2d2(make_sim)
    cmd = sim.velocity_command(robot, WHEELS, 0.0, max_force=5.0)
    with pytest.raises(InvalidArgumentError, match="driven by a bound velocity command"):
        sim.set_joint_velocity(robot, [3], 1.0, max_force=1.0)
    with pytest.raises(InvalidArgumentError, match="driven by a bound velocity command"):
        sim.set_joint_position(robot, "right_back_wheel_joint", 0.0, max_force=1.0)
    with pytest.raises(InvalidArgumentError, match="driven by a bound velocity command"):
        sim.position_command(robot, [7, 13], 0.0, max_force=1.0)
    sim.set_joint_velocity(robot, [13], 0.1, max_force=1.0)  # the other joints are free
    sim.set_joint_torque(robot, WHEELS, 0.5)  # a torque adds to the motor, as in PyBullet
    sim.reset_joint_state(robot, WHEELS, 0.0)
    sim.step()
    cmd.release()
    cmd.release()  # twice is fine
    assert not cmd.bound
    with pytest.raises(StaleCommandError, match="it was released"):
        cmd.targets[:] = 1.0
    sim.set_joint_velocity(robot, WHEELS, 1.0, max_force=1.0)
    sim.position_command(robot, WHEELS, 0.0, max_force=1.0)


@pytest.mark.parametrize("change", ["load_urdf", "remove", "reset", "close"])
def test_a_world_change_ends_every_bound_command(make_sim, change):
    sim, robot = _r2d2(make_sim)
    cmd = sim.velocity_command(robot, WHEELS, [-5.0, -5.0, 5.0, 5.0], max_force=20.0)
    held = cmd.targets
    sim.step(5)
    if change == "load_urdf":
        sim.load_urdf("pendulum.urdf", base_position=(3, 0, 1), fixed_base=True)
    elif change == "remove":
        sim.remove(robot)
    elif change == "reset":
        sim.reset()
    else:
        sim.close()
    assert not cmd.bound
    with pytest.raises(StaleCommandError, match=f"{change} changed the world|was closed"):
        cmd.targets[:] = 1.0
    with pytest.raises(StaleCommandError):
        cmd.send()
    with pytest.raises(ValueError, match="read-only"):
        held[:] = 1.0  # an array kept from before: no silent write that nothing reads
    cmd.release()  # harmless after the end
    if change == "load_urdf":  # the joints keep the command last sent, and take new ones
        v = sim.joint_states(robot, WHEELS).velocities
        sim.step(60)
        assert np.sign(sim.joint_states(robot, WHEELS).velocities).tolist() == [-1, -1, 1, 1]
        assert v is not None
        sim.set_joint_velocity(robot, WHEELS, 0.0, max_force=20.0)
        sim.velocity_command(robot, WHEELS, 0.0, max_force=20.0)


def test_a_step_of_n_runs_on_the_values_read_when_it_starts(make_sim):
    results = []
    for split in (False, True):
        sim, robot = _r2d2(make_sim)
        cmd = sim.velocity_command(robot, WHEELS, TURN, max_force=50.0)
        if split:
            for _ in range(30):
                sim.step()
        else:
            sim.step(30)
        assert cmd.bound
        results.append(_state(sim, robot))
    assert results[0] == results[1]
