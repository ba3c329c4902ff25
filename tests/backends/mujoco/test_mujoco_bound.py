"""The MuJoCo backend's bound commands and command hot paths, from inside (the conformance
suite, tests/conformance/test_bound_commands.py, holds every backend to the plain drive's
bits through the public interface).

The compiled loop reads a bound command's arrays itself and writes a change in C; a change it
cannot take (a force of 0, a bad value, motor rows rebound by another command) goes through
the command's ``send``. Here: that the writes in C really carry the command (``send`` is not
called for them), that each fallback is taken when it must be, the same bits on the Python
step loop, and that the kernel's new entry points refuse bad input instead of crashing.
"""

from __future__ import annotations

import numpy as np
import pytest

import simbridge
from simbridge.backends.mujoco import inspect
from simbridge.backends.mujoco import kernel as mujoco_kernel
from simbridge.backends.mujoco.inspect import compiled
from simbridge.bound import BoundCommand

requires_kernel = pytest.mark.skipif(
    mujoco_kernel.reason() != "", reason=f"no compiled loop: {mujoco_kernel.reason()}"
)
WHEELS = [2, 3, 6, 7]


def _select_loop(monkeypatch, loop: str) -> None:
    if loop == "python":
        monkeypatch.setenv(mujoco_kernel.ENV, "python")
    else:
        monkeypatch.delenv(mujoco_kernel.ENV, raising=False)


def _count_sends(monkeypatch) -> list[int]:
    calls = [0]
    send = BoundCommand.send

    def counting(self: BoundCommand) -> None:
        calls[0] += 1
        send(self)

    monkeypatch.setattr(BoundCommand, "send", counting)
    return calls


def _states(sim, body) -> bytes:
    js = sim.joint_states(body)
    b = sim.base_state(body)
    return js.positions.tobytes() + js.velocities.tobytes() + np.array(b.position).tobytes()


def _mixed(bound: bool) -> list[bytes]:
    """r2d2 driven by a velocity command and a KUKA by a position command, new targets every
    step; halfway the KUKA's gains change every step (a full refresh each time, which
    rebinds the motor rows under the r2d2's bound command)."""
    out = []
    with simbridge.Sim("mujoco") as sim:
        sim.load_urdf("plane.urdf")
        r2d2 = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
        arm = sim.load_urdf("kuka_iiwa/model.urdf", base_position=(2, 0, 0), fixed_base=True)
        vel = pos = None
        for k in range(80):
            v = [-5.0 - 0.1 * k, -5.0, 5.0, 5.0 + 0.1 * k]
            q = list(0.5 * np.sin(0.1 * k + np.arange(7)))
            kp = 0.1 if k < 40 else 0.1 + 0.001 * k
            if bound:
                if vel is None:
                    vel = sim.velocity_command(r2d2, WHEELS, v, max_force=30.0)
                    pos = sim.position_command(arm, range(7), q, max_force=200.0)
                vel.targets[:] = v
                if k >= 40:  # new gains: a new bound command
                    pos.release()
                    pos = sim.position_command(arm, range(7), q, max_force=200.0, kp=kp)
                pos.targets[:] = q
            else:
                sim.set_joint_velocity(r2d2, WHEELS, v, max_force=30.0)
                sim.set_joint_position(arm, range(7), q, max_force=200.0, kp=kp)
            sim.step()
            out.append(_states(sim, r2d2) + _states(sim, arm))
    return out


@pytest.mark.parametrize("loop", ["kernel", "python"])
def test_two_bound_commands_and_refreshes_give_the_plain_bits(monkeypatch, loop):
    if loop == "kernel" and mujoco_kernel.reason():
        pytest.skip(f"no compiled loop: {mujoco_kernel.reason()}")
    _select_loop(monkeypatch, loop)
    assert _mixed(True) == _mixed(False)


@requires_kernel
def test_the_compiled_loop_writes_a_bound_command_itself(monkeypatch):
    _select_loop(monkeypatch, "kernel")
    sends = _count_sends(monkeypatch)
    with simbridge.Sim("mujoco") as sim:
        robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 1.0))
        arm = sim.load_urdf("kuka_iiwa/model.urdf", base_position=(2, 0, 0), fixed_base=True)
        cmd = sim.velocity_command(robot, WHEELS, 1.0, max_force=10.0)
        pos = sim.position_command(arm, range(7), 0.2, max_force=100.0)
        assert sends[0] == 2  # the first values, through the plain path
        for k in range(50):
            cmd.targets[:] = 1.0 + 0.1 * k
            cmd.max_force[k % 4] = 10.0 + k
            pos.targets[:] = 0.01 * k
            sim.step()
        assert sends[0] == 2  # every change written by the compiled loop
        t = compiled(sim).motors
        r = inspect.robot(sim, robot)
        slots = [int(r.motor_index[r.movable.index(j)]) for j in WHEELS]
        assert t.target_velocity[slots].tolist() == [1.0 + 0.1 * 49] * 4
        assert t.max_force[slots].tolist() == [58.0, 59.0, 56.0, 57.0] == cmd.max_force.tolist()
        cmd.max_force[0] = 0.0  # releasing a joint removes its motor row: Python's path
        sim.step()
        assert sends[0] == 3
        sim.step()  # unchanged: nothing sent
        assert sends[0] == 3
        cmd.max_force[0] = 5.0  # the row comes back: Python's path again
        sim.step()
        assert sends[0] == 4
        cmd.targets[:] = -1.0  # and the next change is the compiled loop's again
        sim.step()
        assert sends[0] == 4


@requires_kernel
def test_after_another_commands_refresh_a_bound_command_is_rearmed_or_sent(monkeypatch):
    """Another command's refresh rebinds the motor rows: the bound command is armed again on
    the new rows, and sent again only when the table no longer holds it (rewritten behind
    its back, as a restored state would)."""
    _select_loop(monkeypatch, "kernel")
    sends = _count_sends(monkeypatch)
    with simbridge.Sim("mujoco") as sim:
        robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 1.0))
        cmd = sim.velocity_command(robot, WHEELS, 1.0, max_force=10.0)
        sim.step()
        assert sends[0] == 1
        sim.set_joint_velocity(robot, [13], 0.5, max_force=0.0)  # a row goes: a refresh
        sim.step()  # armed on the new rows, nothing sent: the table holds the command
        assert sends[0] == 1
        cmd.targets[:] = 2.0
        sim.step()  # written by the compiled loop on the new rows
        assert sends[0] == 1
        c = compiled(sim)
        r = inspect.robot(sim, robot)
        slots = [int(r.motor_index[r.movable.index(j)]) for j in WHEELS]
        assert c.motors.target_velocity[slots].tolist() == [2.0] * 4
        c.motors.target_velocity[slots] = 7.0  # the table rewritten behind its back
        c.refresh_motors()
        sim.step()
        assert sends[0] == 2  # sent again: the arrays are the command
        assert c.motors.target_velocity[slots].tolist() == [2.0] * 4


def test_the_plain_position_hot_path_clamps_and_writes_as_the_refresh(monkeypatch):
    """set_joint_position with new targets takes the hot path; the table it leaves is the one
    a full refresh of the same commands builds (both loops)."""
    for loop in ("kernel", "python"):
        if loop == "kernel" and mujoco_kernel.reason():
            continue
        _select_loop(monkeypatch, loop)
        with simbridge.Sim("mujoco") as sim:
            arm = sim.load_urdf("kuka_iiwa/model.urdf", fixed_base=True)
            joints = np.arange(7)
            sim.set_joint_position(arm, joints, 0.1, max_force=100.0, kp=0.2, kd=0.7)
            q = np.array([0.3, 9.0, -9.0, 0.0, -0.0, 1e-300, 2.0])  # past limits, signed zeros
            sim.set_joint_position(arm, joints, q, max_force=[1, 2, 3, 4, 5, 6, 7], kp=0.2, kd=0.7)
            c = compiled(sim)
            t = c.motors
            hot = [
                a.copy()
                for a in (t.target_position, t.max_force, t.offset_rows, t.force_rows_slack)
            ] + [c.m.dof_frictionloss.copy(), t.position_target.copy()]
            c.refresh_motors()  # the full refresh, from the table the hot path wrote
            full = [
                t.target_position,
                t.max_force,
                t.offset_rows,
                t.force_rows_slack,
                c.m.dof_frictionloss,
                t.position_target,
            ]
            for a, b in zip(hot, full, strict=True):
                assert a.tobytes() == b.tobytes()
            assert t.target_position[1] == 2.09439510239  # clamped to joint 1's upper limit


@requires_kernel
def test_the_kernels_command_entry_points_refuse_bad_input():
    with simbridge.Sim("mujoco") as sim:
        arm = sim.load_urdf("kuka_iiwa/model.urdf", fixed_base=True)
        sim.set_joint_position(arm, range(7), 0.0, max_force=10.0)
        k = compiled(sim).kernel
        two = np.zeros(2)
        with pytest.raises(ValueError, match="max_force: expected 2 elements"):
            k.add_command(False, two, np.zeros(3), lambda: None)
        with pytest.raises(TypeError, match="callable"):
            k.add_command(False, two, two, None)
        with pytest.raises(TypeError, match="float64"):
            k.add_command(False, np.zeros(2, np.int64), two, lambda: None)
        h = k.add_command(True, two, two, lambda: None)
        with pytest.raises(ValueError, match="out of range"):
            k.arm_command(h, np.full(8, 99, np.intp), np.zeros(4))
        with pytest.raises(ValueError, match="expected 8 elements"):
            k.arm_command(h, np.zeros(6, np.intp), np.zeros(4))
        k.remove_command(h)
        with pytest.raises(ValueError, match="no bound command"):
            k.remove_command(h)
        with pytest.raises(ValueError, match="no bound command"):
            k.arm_command(123, None, None)
        index = np.zeros(4, np.intp)  # slot 0, row 0, dof 0, position row 0
        with pytest.raises(ValueError, match="lists of n floats"):
            k.set_position(index, np.array([-1.0, 1.0]), [1.0, 2.0], [1.0])
        with pytest.raises(ValueError, match="out of range"):
            k.set_position(index + 50, np.array([-1.0, 1.0]), [1.0], [1.0])
        with pytest.raises(ValueError, match="limits: expected 2 elements"):
            k.set_position(index, np.zeros(3), [1.0], [1.0])
        with pytest.raises(ValueError, match="slots in range"):
            k.add_torque(np.array([99], np.intp), [1.0])
        with pytest.raises(ValueError, match="slots in range"):
            k.add_torque(np.array([0], np.intp), [1])  # an int, not a float


def test_a_release_refused_mid_step_leaves_the_command_bound() -> None:
    """A release while another thread steps is refused (SimBusyError); the command stays bound
    in the Sim as in the backend (the Sim's lists once dropped it before the backend refused:
    the joints took plain commands while the compiled loop still read the arrays)."""
    import threading

    from simbridge.exceptions import InvalidArgumentError, SimBusyError

    sim = simbridge.Sim("mujoco")
    try:
        robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
        command = sim.velocity_command(robot, WHEELS, [1.0] * 4, max_force=[10.0] * 4)
        b = inspect.backend_of(sim)
        held = threading.Event()
        done = threading.Event()

        def stepper() -> None:  # holds the lock as a step(n) does
            with b._stepping:
                b._in_step = True
                held.set()
                done.wait(10)
                b._in_step = False

        t = threading.Thread(target=stepper)
        t.start()
        try:
            assert held.wait(10)
            with pytest.raises(SimBusyError):
                command.release()
            assert command.bound
            with pytest.raises(InvalidArgumentError, match="bound"):
                sim.set_joint_velocity(robot, WHEELS, [0.0] * 4, max_force=10.0)
        finally:
            done.set()
            t.join(10)
        command.release()
        assert not command.bound
        sim.set_joint_velocity(robot, WHEELS, [0.0] * 4, max_force=10.0)
        sim.step(1)
    finally:
        sim.close()
