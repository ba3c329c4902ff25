"""Joint commands: PyBullet's velocity, position and torque control on the motor table.

A command that changes the motor set (a joint's mode, gains or force limit crossing 0) rewrites
the commanded joints' columns of the motor table and pushes the whole table into the model
(``Compiled.refresh_motors``). A command that only moves targets and force limits on motors
whose rows stay as they are takes a hot path (one per mode, cached per joints array while the
rows keep their layout) that writes those entries in place, in C when the compiled loop runs
(``_mjkernel.c``'s command writes): the same arithmetic as the refresh, so the table, the model
and the rows are exactly what the refresh would leave, whichever path a command took. Torques
add up until the next step, as in PyBullet.

Bound commands (``Sim.velocity_command``, ``Sim.position_command``) are handed to the compiled
loop, which reads their arrays at every step and writes a change with the same command writes;
a change the writes cannot take (a force of 0, a bad value, rows rebound by another command) is
sent through :meth:`set_joint_velocity` / :meth:`set_joint_position`, which check it.

The commands in force, read and set for ``get_state``/``set_state``:

* ``joint_commands``: the motor table's columns of a body (motor_rows.py) in PyBullet's terms: a
  motor with kp 0 and kd 1 is a VELOCITY motor towards ``target_velocity``, any other a
  POSITION motor towards ``target_position`` (a position command sets ``target_velocity`` to
  0); the torques pending for the next step.
* ``set_joint_commands``: writes those columns back (a position target clamped to the
  joint's limits, as ``set_joint_position`` does) and the pending torques; spherical joints
  apart: ``spherical_states``/``set_spherical_states`` read and write their three slots, target
  quaternion, coordinates and torques.
"""

from __future__ import annotations

import threading
import weakref
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from simbridge.profiles import Profile
from simbridge.types import JointCommands, JointType, MotorMode, SphericalJointState

from ..locking import exclusive, wait_for_lock
from .robots import Compiled, Robot

if TYPE_CHECKING:
    from simbridge.bound import BoundCommand

__all__ = ["MotorCommands", "PositionPath", "VelocityPath"]


class VelocityPath(NamedTuple):
    """``set_joint_velocity``'s hot path for one joints array (``Compiled.fast``).

    The motors are velocity motors with kd 1 and all their rows are present; the entry is dropped
    when the rows move or another command rewrites one of these motors
    (``Compiled.refresh_motors``).

    Attributes:
        joints: The (n,) ``np.intp`` joints array the entry is for (compared by identity).
        body: The body's id.
        slots: (n,) the joints' motor slots in the motor table.
        rows: (n,) their rows in the motor table's row arrays (``offset_rows``,
            ``force_rows_slack``).
        dofs: (n,) their dofs in ``qvel``.
        slot_set: ``slots`` as a set, to see whether another command touches them.
        target: The target velocities in force (rad/s or m/s).
        max_force: The force limits in force (N·m or N).
        packed: (3, n) ``intp``: slots, rows, dofs (the compiled loop's index).
    """

    joints: np.ndarray
    body: int
    slots: np.ndarray
    rows: np.ndarray
    dofs: np.ndarray
    slot_set: frozenset[int]
    target: list[float]  # the command in force
    max_force: list[float]
    packed: np.ndarray  # intp 3 x n: slots, rows, dofs (the compiled loop's index)


class PositionPath(NamedTuple):
    """``set_joint_position``'s hot path for one joints array (``Compiled.fast_position``).

    Position motors with all their rows present, taken while the command keeps ``kp`` and ``kd``;
    dropped as a :class:`VelocityPath` is.

    Attributes:
        joints: The (n,) ``np.intp`` joints array the entry is for (compared by identity).
        body: The body's id.
        slot_set: The joints' motor slots, as a set.
        kp: The position gains in force.
        kd: The velocity gains in force.
        packed: (4, n) ``intp``: motor slots, friction rows, dofs, rows in the position arrays.
        limits: (2, n) float64: lower, upper limit (rad or m; -inf, inf: no limit).
        lower: The lower limits, as a list.
        upper: The upper limits, as a list.
    """

    joints: np.ndarray
    body: int
    slot_set: frozenset[int]
    kp: list[float]
    kd: list[float]
    packed: np.ndarray  # intp 4 x n: motor slots, friction rows, dofs, rows in the position arrays
    limits: np.ndarray  # float64 2 x n: lower, upper (-inf, inf: no limit)
    lower: list[float]
    upper: list[float]


class MotorCommands:
    """The ``Backend`` command methods (a part of :class:`MujocoBackend`)."""

    if TYPE_CHECKING:  # provided by MujocoBackend
        profile: Profile
        _robots: dict[int, Robot]
        _c: Compiled | None

        @property
        def _w(self) -> Compiled: ...

        def _joint_cache(self, robot: Robot, joints: np.ndarray) -> tuple[Any, ...]: ...

        def _py_mark(self) -> None: ...

        def _check_idle(self) -> None: ...

        _stepping: threading.RLock

    # ---------------------------------------------------------------- control

    def _motor_slots(self, body: int, joints: np.ndarray) -> np.ndarray:
        return self._joint_cache(self._robots[body], joints)[4]

    def set_joint_velocity(
        self, body: int, joints: np.ndarray, target: list[float], max_force: list[float]
    ) -> None:
        """See Backend.set_joint_velocity.

        MuJoCo: a velocity motor as a friction row (its ``frictionloss`` the force limit) with a
        reference acceleration; a repeated command on the same joints array takes a hot path.
        """
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            c = self._w
            if c.kernel is None:
                self._py_mark()  # SimBusyError from a MuJoCo callback inside the Python loop's step
            t = c.motors
            fast = c.fast.get(id(joints))
            if fast is not None and fast.joints is joints and fast.body == body:
                # Hot path: the same joints, still velocity motors with kd 1, all rows present.
                if target == fast.target and max_force == fast.max_force:
                    return  # the command in force already
                if min(max_force) > 0.0:
                    kernel = c.kernel
                    if kernel is not None:  # the same writes in C (_mjkernel.c write_velocity)
                        kernel.set_velocity(fast.packed, target, max_force)
                    else:  # MotorTable.refresh's arithmetic: kd v / dt with kd 1
                        rows, dt = fast.rows, c.dt
                        t.target_velocity[fast.slots] = target
                        t.max_force[fast.slots] = max_force
                        c.m.dof_frictionloss[fast.dofs] = max_force
                        t.offset_rows[rows] = [v / dt for v in target]
                        t.force_rows_slack[rows] = [f * (1.0 - 1e-9) for f in max_force]
                    t.has_offset = True
                    c.fast[id(joints)] = fast._replace(target=target, max_force=max_force)
                    return
            idx = self._motor_slots(body, joints)
            t.target_velocity[idx] = target
            t.max_force[idx] = max_force
            t.kp[idx] = 0.0
            t.kd[idx] = 1.0
            c.refresh_motors(idx)
            rows = t.row_of[idx]
            if not self.profile.enforce_effort_limit and (rows >= 0).all():
                dofs = t.dof[idx]
                c.fast[id(joints)] = VelocityPath(
                    joints,
                    body,
                    idx,
                    rows,
                    dofs,
                    frozenset(idx.tolist()),
                    list(target),
                    list(max_force),
                    np.ascontiguousarray(np.stack([idx, rows, dofs]), dtype=np.intp),
                )
        finally:
            lock.release()

    def set_joint_position(
        self,
        body: int,
        joints: np.ndarray,
        target: list[float],
        max_force: list[float],
        kp: list[float],
        kd: list[float],
    ) -> None:
        """See Backend.set_joint_position.

        MuJoCo: PyBullet's law written into the motor's friction row; a target is clamped into the
        joint's limits; a repeated command with the same gains takes a hot path.
        """
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            c = self._w
            if c.kernel is None:
                self._py_mark()  # as set_joint_velocity
            t = c.motors
            fast = c.fast_position.get(id(joints))
            if (
                fast is not None
                and fast.joints is joints
                and fast.body == body
                and kp == fast.kp
                and kd == fast.kd
                and min(max_force) > 0.0
            ):  # Hot path: position motors with the same gains, all rows present and staying.
                kernel = c.kernel
                if kernel is not None:  # _mjkernel.c write_position: the same arithmetic
                    kernel.set_position(fast.packed, fast.limits, target, max_force)
                else:
                    self._write_position(c, fast, target, max_force)
                return
            idx = self._motor_slots(body, joints)
            lower, upper = self._limits(body, joints)
            target = [  # PyBullet clamps a position target to the joint's limits (measured)
                min(max(q, lo), hi) for q, lo, hi in zip(target, lower, upper, strict=True)
            ]
            t.target_velocity[idx] = 0.0
            t.target_position[idx] = target
            t.max_force[idx] = max_force
            t.kp[idx] = kp
            t.kd[idx] = kd
            c.refresh_motors(idx)
            path = self._position_path(c, body, joints, idx, kp, kd)
            if path is not None:
                c.fast_position[id(joints)] = path
        finally:
            lock.release()

    def _limits(self, body: int, joints: np.ndarray) -> tuple[list[float], list[float]]:
        """Each joint's position limits, (-inf, inf) where it has none."""
        model = self._robots[body].model
        js = [model.joints[j] for j in joints.tolist()]
        return (
            [j.lower if j.has_limit else -np.inf for j in js],
            [j.upper if j.has_limit else np.inf for j in js],
        )

    def _position_path(
        self, c: Compiled, body: int, joints: np.ndarray, idx: np.ndarray, kp: Any, kd: Any
    ) -> PositionPath | None:
        """The hot path of position commands on ``joints`` after a refresh, or None when
        the rows cannot be written in place (a force of 0, kp 0, an effort limit)."""
        t = c.motors
        rows = t.row_of[idx]
        if not len(idx) or self.profile.enforce_effort_limit or not (rows >= 0).all():
            return None  # (no joints: nothing to write, and the path's min(max_force) fails)
        prows = np.searchsorted(t.position_rows, rows)
        if (prows >= len(t.position_rows)).any() or (t.position_rows[prows] != rows).any():
            return None  # kp 0 somewhere: a velocity row, not a position row
        lower, upper = self._limits(body, joints)
        return PositionPath(
            joints,
            body,
            frozenset(idx.tolist()),
            list(kp),
            list(kd),
            np.ascontiguousarray(np.stack([idx, rows, t.dof[idx], prows]), dtype=np.intp),
            np.array([lower, upper], dtype=np.float64),
            lower,
            upper,
        )

    @staticmethod
    def _write_position(
        c: Compiled, path: PositionPath, target: list[float], max_force: list[float]
    ) -> None:
        """The Python loop's hot path of a position command (_mjkernel.c write_position):
        MotorTable.refresh's arithmetic on the commanded entries alone."""
        t = c.motors
        slots, rows, dofs, prows = path.packed
        q = [min(max(x, lo), hi) for x, lo, hi in zip(target, path.lower, path.upper, strict=True)]
        t.target_position[slots] = q
        t.max_force[slots] = max_force
        c.m.dof_frictionloss[dofs] = max_force
        t.position_target[prows] = q
        gains = t.position_gain[prows].tolist()
        t.offset_rows[rows] = [0.0 + g * x for g, x in zip(gains, q, strict=True)]
        t.force_rows_slack[rows] = [f * (1.0 - 1e-9) for f in max_force]
        t.has_offset = True

    def set_joint_torque(self, body: int, joints: np.ndarray, torque: list[float]) -> None:
        """See Backend.set_joint_torque.

        MuJoCo: clipped to the effort limit where the profile says so.
        """
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            self._add_torque(self._motor_slots(body, joints), torque)
        finally:
            lock.release()

    # ---------------------------------------------------------------- spherical joints

    def _ball_slots(self, body: int, joints: np.ndarray) -> tuple[np.ndarray, list[int]]:
        """The three motor slots of each spherical joint of ``joints`` (n x 3, flattened) and
        each one's ball index in the table."""
        robot = self._robots[body]
        first = dict(zip(robot.movable, robot.motor_index.tolist(), strict=True))
        starts = [first[j] for j in joints.tolist()]
        slots = np.array([s + i for s in starts for i in range(3)], dtype=np.intp)
        return slots, self._w.motors.ball_of[starts].tolist()

    @exclusive
    def set_joint_motor_multi_dof(
        self,
        body: int,
        joints: np.ndarray,
        mode: MotorMode,
        targets: list[list[float]],
        max_force: list[list[float]],
        kp: list[list[float]],
        kd: list[list[float]],
    ) -> None:
        """See Backend.set_joint_motor_multi_dof.

        MuJoCo: a ball joint's three motor rows, its target error taken as a rotation vector.
        """
        c = self._w
        if c.kernel is None:
            self._py_mark()  # as set_joint_velocity
        t = c.motors
        slots, balls = self._ball_slots(body, joints)
        t.target_velocity[slots] = 0.0
        t.target_position[slots] = 0.0
        t.kp[slots] = [x for row in kp for x in row] if mode == MotorMode.POSITION else 0.0
        t.kd[slots] = [x for row in kd for x in row] if mode == MotorMode.POSITION else 1.0
        t.max_force[slots] = [x for row in max_force for x in row]
        t.ball_target[balls] = targets
        c.refresh_motors(slots)

    @exclusive
    def set_joint_torque_multi_dof(
        self, body: int, joints: np.ndarray, torques: list[list[float]]
    ) -> None:
        """See Backend.set_joint_torque_multi_dof.

        MuJoCo: on the ball's three motor slots, as set_joint_torque.
        """
        slots, _ = self._ball_slots(body, joints)
        self._add_torque(slots, [x for row in torques for x in row])

    def _add_torque(self, idx: np.ndarray, torque: list[float]) -> None:
        """Torques on motor slots, for the next step (under the Sim's lock): commands before
        one step add up, as in PyBullet (the effort limit, where the profile enforces it,
        clips each command)."""
        c = self._w
        if c.kernel is None:
            self._py_mark()  # as set_joint_velocity
        t = c.motors
        if self.profile.enforce_effort_limit:
            c.torque[idx] += np.clip(torque, -t.effort[idx], t.effort[idx])  # each command
        elif c.kernel is not None:
            c.kernel.add_torque(idx, torque)  # torque[idx] += torque, in C
        else:
            c.torque[idx] += torque  # commands before one step add up, as in PyBullet
        c.pending_torque = True

    # ---------------------------------------------------------------- bound commands

    @exclusive
    def bind_command(self, command: BoundCommand) -> bool:
        """See Backend.bind_command.

        MuJoCo: True with the compiled loop, which reads the arrays at every step; False with the
        Python loop (the Sim sends the command before every step).
        """
        c = self._w
        kernel = c.kernel
        if kernel is None:
            return False

        # The kernel holds resend, so resend holds no strong reference back to what holds the
        # kernel (the backend, the compiled world, the command and its Sim): the kernel is
        # not seen by Python's cycle collector, and such a cycle would never be freed.
        weak_self, weak_c, weak_command = weakref.ref(self), weakref.ref(c), weakref.ref(command)

        def resend() -> None:  # what the compiled loop's writes cannot take
            backend, world, cmd = weak_self(), weak_c(), weak_command()
            if backend is None or world is None or cmd is None:
                return
            # a bad value is refused even where the table holds the command already: +inf
            # clamped to an upper limit of 0 would compare equal to a target of 0 in force
            bad = not (np.isfinite(cmd.targets).all() and np.isfinite(cmd.max_force).all())
            if bad or not backend._in_force(world, cmd):
                world.fast.pop(id(cmd.joints), None)  # the full path: the table is rewritten
                world.fast_position.pop(id(cmd.joints), None)
                cmd.send()  # checks the values (raises on a bad one), then set_joint_*
            backend._arm(world, cmd, handle)

        handle = kernel.add_command(
            command.mode == "position", command.targets, command.max_force, resend
        )
        command.backend_handle = (c, handle)
        self._arm(c, command, handle)
        return True

    def _in_force(self, c: Compiled, command: BoundCommand) -> bool:
        """Whether the motor table holds ``command``'s arrays as they are (by value, as a
        repeated plain command is recognised): after another command rebound the motor rows,
        the compiled loop needs only the new rows, not a new command."""
        t = c.motors
        idx = self._motor_slots(command.body, command.joints)
        kp, kd = t.kp[idx].tolist(), t.kd[idx].tolist()
        if t.max_force[idx].tolist() != command.max_force.tolist():
            return False
        if command.mode == "velocity":
            n = len(idx)
            return (
                t.target_velocity[idx].tolist() == command.targets.tolist()
                and kp == [0.0] * n
                and kd == [1.0] * n
            )
        lower, upper = self._limits(command.body, command.joints)
        q = [
            min(max(x, lo), hi)
            for x, lo, hi in zip(command.targets.tolist(), lower, upper, strict=True)
        ]
        return (
            t.target_position[idx].tolist() == q
            and not t.target_velocity[idx].any()
            and kp == command.kp
            and kd == command.kd
        )

    def _arm(self, c: Compiled, command: BoundCommand, handle: int) -> None:
        """Tell the compiled loop where the command's next changes go (or that they go
        through Python: rows absent, an effort limit)."""
        kernel = c.kernel
        if kernel is None:
            return
        idx = self._motor_slots(command.body, command.joints)
        if command.mode == "position":
            path = self._position_path(c, command.body, command.joints, idx, command.kp, command.kd)
            if path is None:
                kernel.arm_command(handle, None, None)
            else:
                kernel.arm_command(handle, path.packed, path.limits)
            return
        t = c.motors
        rows = t.row_of[idx]
        if self.profile.enforce_effort_limit or not (rows >= 0).all():
            kernel.arm_command(handle, None, None)
            return
        index = np.ascontiguousarray(np.stack([idx, rows, t.dof[idx]]), dtype=np.intp)
        kernel.arm_command(handle, index, None)

    @exclusive
    def unbind_command(self, command: BoundCommand) -> None:
        """See Backend.unbind_command. MuJoCo: removes the command from the compiled loop."""
        bound = command.backend_handle
        command.backend_handle = None
        if bound is None:
            return
        c, handle = bound
        kernel = c.kernel
        if c is self._c and kernel is not None:
            kernel.remove_command(handle)

    # ---------------------------------------------------------------- commands in force

    @exclusive
    def joint_commands(self, body: int) -> JointCommands:
        """See Backend.joint_commands. MuJoCo: read back from the motor table."""
        robot = self._robots[body]
        c = self._w
        t = c.motors
        n = len(robot.table)
        mv = np.asarray(robot.movable, dtype=np.intp)
        slots = robot.motor_index
        kp = t.kp[slots]
        kd = t.kd[slots]
        position = (kp != 0.0) | (kd != 1.0)
        mode = np.full(n, MotorMode.NONE, dtype=np.int8)
        mode[mv] = np.where(position, MotorMode.POSITION, MotorMode.VELOCITY)
        out = [np.zeros(n) for _ in range(5)]
        out[0][mv] = np.where(position, t.target_position[slots], t.target_velocity[slots])
        out[1][mv] = t.max_force[slots]
        out[2][mv] = kp
        out[3][mv] = kd
        out[4][mv] = c.torque[slots]
        return JointCommands(mode, *out)

    @exclusive
    def set_joint_commands(self, body: int, commands: JointCommands) -> None:
        """See Backend.set_joint_commands.

        MuJoCo: written into the motor table (spherical joints left to ``set_spherical_states``).
        """
        self._check_idle()
        robot = self._robots[body]
        c = self._w
        t = c.motors
        keep = [k for k, j in enumerate(robot.movable) if j not in robot.balls]  # not spherical
        mv = np.asarray(robot.movable, dtype=np.intp)[keep]
        slots = robot.motor_index[keep]
        position = commands.mode[mv] == MotorMode.POSITION
        target = commands.target[mv]
        joints = robot.model.joints
        for k in np.flatnonzero(position).tolist():  # as set_joint_position: within the limits
            j = joints[int(mv[k])]
            if j.has_limit:
                target[k] = min(max(target[k], j.lower), j.upper)
        t.target_velocity[slots] = np.where(position, 0.0, target)
        t.target_position[slots] = np.where(position, target, t.target_position[slots])
        t.kp[slots] = np.where(position, commands.kp[mv], 0.0)
        t.kd[slots] = np.where(position, commands.kd[mv], 1.0)
        t.max_force[slots] = commands.max_force[mv]
        c.refresh_motors()
        c.torque[slots] = commands.pending_torque[mv]  # in place: the step loops hold it
        c.pending_torque = bool(c.torque.any())

    @exclusive
    def spherical_states(self, body: int) -> list[SphericalJointState]:
        """See Backend.spherical_states.

        MuJoCo: the ball's ``qpos`` (w, x, y, z) given as (x, y, z, w).
        """
        robot = self._robots[body]
        c = self._w
        t = c.motors
        d = c.d
        first = dict(zip(robot.movable, robot.motor_index.tolist(), strict=True))
        out = []
        for j in robot.balls:
            s = first[j]
            axes = slice(s, s + 3)
            kp, kd = tuple(t.kp[axes].tolist()), tuple(t.kd[axes].tolist())
            position = any(kp) or kd != (1.0, 1.0, 1.0)
            a, v = int(robot.qadr[j]), int(robot.dofadr[j])  # a: x's address, after w
            q = d.qpos[a - 1 : a + 3].tolist()
            out.append(
                SphericalJointState(
                    j,
                    (q[1], q[2], q[3], q[0]),
                    tuple(d.qvel[v : v + 3].tolist()),
                    int(MotorMode.POSITION if position else MotorMode.VELOCITY),
                    tuple(t.ball_target[t.ball_of[s]].tolist()),
                    tuple(t.max_force[axes].tolist()),
                    kp,
                    kd,
                    tuple(c.torque[axes].tolist()),
                )
            )
        return out

    @exclusive
    def set_spherical_states(
        self, body: int, states: list[SphericalJointState], positions: bool
    ) -> None:
        """See Backend.set_spherical_states. MuJoCo: written into the ball's three motor slots."""
        self._check_idle()
        robot = self._robots[body]
        c = self._w
        t = c.motors
        first = dict(zip(robot.movable, robot.motor_index.tolist(), strict=True))
        for e in states:
            assert robot.table[e.joint].type == JointType.SPHERICAL
            s = first[e.joint]
            axes = slice(s, s + 3)
            t.target_velocity[axes] = 0.0
            t.target_position[axes] = 0.0
            t.kp[axes] = e.motor_kp
            t.kd[axes] = e.motor_kd
            t.max_force[axes] = e.motor_max_force
            t.ball_target[t.ball_of[s]] = e.motor_target
            c.torque[axes] = e.pending_torque  # in place: the step loops hold it
            if positions:
                a, v = int(robot.qadr[e.joint]), int(robot.dofadr[e.joint])
                x, y, z, w = e.position
                c.d.qpos[a - 1 : a + 3] = (w, x, y, z)
                c.d.qvel[v : v + 3] = e.velocity
        c.refresh_motors()
        c.pending_torque = bool(c.torque.any())
        if positions:
            c.stale = True
            c.motor_force_valid = False
