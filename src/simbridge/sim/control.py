"""The `Sim`'s commands: teleports, velocity, position and torque commands, and bound
commands (a part of :class:`simbridge.Sim`; the commands themselves are
:mod:`simbridge.bound`). ``set_joint_velocity`` and ``set_joint_position`` are the hot path of
every control loop: one joints lookup, one check per argument, one backend call."""

from __future__ import annotations

from collections.abc import Sequence
from math import inf as _INF
from math import isfinite
from typing import TYPE_CHECKING, Any

import numpy as np

from simbridge.bound import BoundCommand
from simbridge.exceptions import InvalidArgumentError
from simbridge.sim.arguments import _F64, JointsArg, quat, state_vec
from simbridge.sim.keywords import Missing, keyword_error
from simbridge.sim.lookups import _Body, _Closed
from simbridge.types import MotorMode

if TYPE_CHECKING:
    from simbridge.backend import Backend

__all__ = ["Control"]

# required arguments' defaults: a PyBullet keyword given in their place is named, not missed
_RESET_POSITIONS = Missing("reset_joint_state", "positions")
_VELOCITY_TARGET = Missing("set_joint_velocity", "target")
_VELOCITY_MAX_FORCE = Missing("set_joint_velocity", "max_force", keyword_only=True)
_POSITION_TARGET = Missing("set_joint_position", "target")
_POSITION_MAX_FORCE = Missing("set_joint_position", "max_force", keyword_only=True)
_TORQUE = Missing("set_joint_torque", "torque")


class Control:
    """Teleports, motor commands and bound commands (a part of :class:`Sim`)."""

    if TYPE_CHECKING:  # provided by simbridge.sim.Sim and its other parts
        _b: Backend
        _bodies: dict[int, _Body]
        _commands: list[BoundCommand]
        _presend: list[BoundCommand]
        _held: dict[int, dict[int, BoundCommand]]
        _multi_idx: dict[int, np.ndarray]

        def _body(self, body: int, argument: str = "body") -> _Body: ...

        def _joints(self, body: int, joints: JointsArg | None, movable: bool) -> np.ndarray: ...

        @staticmethod
        def _values(value: Any, n: int, argument: str, nonneg: bool = False) -> list[float]: ...

        @staticmethod
        def _checked_state(value: Any, n: int, argument: str) -> list[float]: ...

        def _spherical_only(self, body: int, idx: np.ndarray) -> None: ...

        def _refuse_multi_dof(self, body: int, idx: np.ndarray, what: str) -> None: ...

        def _multi_dof_motor(
            self,
            body: int,
            idx: np.ndarray,
            mode: MotorMode,
            target: Any,
            max_force: Any,
            kp: Any,
            kd: Any,
        ) -> None: ...

    def reset_joint_state(
        self,
        body: int,
        joints: JointsArg,
        positions: Any = _RESET_POSITIONS,
        velocities: Any = 0.0,
        **pybullet: Any,
    ) -> None:
        """Teleport movable joints to ``positions`` with ``velocities`` (``resetJointState``).
        A spherical joint takes :meth:`reset_joint_state_multi_dof` (PyBullet's
        ``resetJointState`` leaves one as it is: measured). PyBullet's keywords
        (``targetValue``...) raise PyBulletKeywordError naming simbridge's."""
        if pybullet:
            raise keyword_error(self.reset_joint_state, pybullet)
        idx = self._joints(body, joints, True)
        if self._multi_idx and id(idx) in self._multi_idx:
            self._refuse_multi_dof(body, idx, "reset_joint_state")
        n = len(idx)
        self._b.reset_joint_state(
            body,
            idx,
            self._checked_state(positions, n, "positions"),
            self._checked_state(velocities, n, "velocities"),
        )

    def reset_base_state(
        self,
        body: int,
        position: Sequence[float] | None = None,
        orientation: Sequence[float] | None = None,
        linear_velocity: Sequence[float] | None = None,
        angular_velocity: Sequence[float] | None = None,
    ) -> None:
        """Teleport the base (centre-of-mass frame, as ``resetBasePositionAndOrientation``).
        An argument left None keeps its current value: a pose alone keeps the base's velocity
        (``p.resetBasePositionAndOrientation`` zeroes it; pass zeros for that)."""
        self._body(body)
        self._b.reset_base_state(
            body,
            None if position is None else state_vec(position, "position"),  # type: ignore[arg-type]
            None if orientation is None else quat(orientation, "orientation"),
            None if linear_velocity is None else state_vec(linear_velocity, "linear_velocity"),  # type: ignore[arg-type]
            None if angular_velocity is None else state_vec(angular_velocity, "angular_velocity"),  # type: ignore[arg-type]
        )

    # ---------------------------------------------------------------- control

    def set_joint_velocity(
        self,
        body: int,
        joints: JointsArg,
        target: Any = _VELOCITY_TARGET,
        *,
        max_force: Any = _VELOCITY_MAX_FORCE,
        **pybullet: Any,
    ) -> None:
        """VELOCITY_CONTROL: drive ``joints`` towards ``target`` (rad/s or m/s) with at most
        ``max_force`` (N·m or N). Persists until replaced; ``max_force=0`` releases the joint
        (and removes the default brake).

        A spherical joint takes only the target 0 (PyBullet's spherical motor brakes; it drives
        no other velocity), and ``max_force`` per axis of the child's frame: a number, shape
        (3,), (n, 1) or (n, 3) (see :mod:`simbridge.spherical`); spherical joints are commanded
        apart from other joints. PyBullet's keywords (``force``...) raise PyBulletKeywordError
        naming simbridge's."""
        if pybullet:
            raise keyword_error(self.set_joint_velocity, pybullet)
        # the hot path inline (a control loop's every step): joints already resolved, a float64
        # array of targets and one force; anything else, or a value to refuse, takes the checks
        # of every command (_joints, _values), which give the same results and errors
        b = self._bodies.get(body) if type(body) is int else None
        idx = None
        if b is not None:
            if type(joints) is np.ndarray:
                idx = b.movable_cache.get((joints.dtype.char, joints.tobytes()))
            elif type(joints) is list:
                try:
                    idx = b.movable_cache.get(tuple(joints))
                except TypeError:  # an unhashable item: _joints says what is wrong
                    pass
        if idx is None:
            idx = self._joints(body, joints, True)
        if self._multi_idx and id(idx) in self._multi_idx:
            return self._multi_dof_motor(body, idx, MotorMode.VELOCITY, target, max_force, 0, 1)
        if self._held:
            self._refuse_held(body, idx)
        n = len(idx)
        if (
            type(target) is np.ndarray
            and target.dtype is _F64
            and target.ndim == 1
            and len(target) == n
        ):
            targets = target.tolist()
            if not isfinite(sum(targets)):  # an inf or a NaN (or an overflowing sum)
                targets = self._values(target, n, "target")
        else:
            targets = self._values(target, n, "target")
        if type(max_force) is float and 0.0 <= max_force < _INF:
            forces = [max_force] * n
        else:
            forces = self._values(max_force, n, "max_force", nonneg=True)
        self._b.set_joint_velocity(body, idx, targets, forces)

    def set_joint_position(
        self,
        body: int,
        joints: JointsArg,
        target: Any = _POSITION_TARGET,
        *,
        max_force: Any = _POSITION_MAX_FORCE,
        kp: Any = 0.1,
        kd: Any = 1.0,
        **pybullet: Any,
    ) -> None:
        """POSITION_CONTROL with PyBullet's law: each step the motor asks for the velocity
        change ``kp * (target - q) / dt - kd * v`` (so it depends on dt), its force clamped to
        ``max_force``. Persists until replaced.

        A spherical joint takes a target quaternion (x, y, z, w; shape (4,) or (n, 4)) and
        PyBullet's spherical motor law: each axis of the child's frame asks for the velocity
        ``-kd v + 0.2 kp e / dt`` (e: the turn to the target as Bullet's XYZ Euler angles; kd is
        what PyBullet's ``setJointMotorControlMultiDof`` calls ``damping``), ``max_force``,
        ``kp`` and ``kd`` per axis (a number, (3,), (n, 1) or (n, 3)); see
        :mod:`simbridge.spherical`. PyBullet's keywords (``positionGain``...) raise
        PyBulletKeywordError naming simbridge's."""
        if pybullet:
            raise keyword_error(self.set_joint_position, pybullet)
        # the hot path inline, as set_joint_velocity's (one float each for the force and gains)
        b = self._bodies.get(body) if type(body) is int else None
        idx = None
        if b is not None:
            if type(joints) is np.ndarray:
                idx = b.movable_cache.get((joints.dtype.char, joints.tobytes()))
            elif type(joints) is list:
                try:
                    idx = b.movable_cache.get(tuple(joints))
                except TypeError:  # an unhashable item: _joints says what is wrong
                    pass
        if idx is None:
            idx = self._joints(body, joints, True)
        if self._multi_idx and id(idx) in self._multi_idx:
            return self._multi_dof_motor(body, idx, MotorMode.POSITION, target, max_force, kp, kd)
        if self._held:
            self._refuse_held(body, idx)
        n = len(idx)
        if (
            type(target) is np.ndarray
            and target.dtype is _F64
            and target.ndim == 1
            and len(target) == n
        ):
            targets = target.tolist()
            if not isfinite(sum(targets)):  # an inf or a NaN (or an overflowing sum)
                targets = self._values(target, n, "target")
        else:
            targets = self._values(target, n, "target")
        if type(max_force) is float and 0.0 <= max_force < _INF:
            forces = [max_force] * n
        else:
            forces = self._values(max_force, n, "max_force", nonneg=True)
        if type(kp) is float and 0.0 <= kp < _INF:
            kps = [kp] * n
        else:
            kps = self._values(kp, n, "kp", nonneg=True)
        if type(kd) is float and 0.0 <= kd < _INF:
            kds = [kd] * n
        else:
            kds = self._values(kd, n, "kd", nonneg=True)
        self._b.set_joint_position(body, idx, targets, forces, kps, kds)

    # ---------------------------------------------------------------- bound commands

    def velocity_command(
        self, body: int, joints: JointsArg, target: Any, *, max_force: Any
    ) -> BoundCommand:
        """A velocity command bound to ``joints``, for a tight control loop: sent now, then
        at every :meth:`step` from its own arrays, which are written in place::

            cmd = sim.velocity_command(robot, [2, 3, 6, 7], 0.0, max_force=50)
            for k in range(1000):
                cmd.targets[:] = policy(observation)   # rad/s or m/s, shape (4,)
                sim.step()

        Each step gives the results of ``set_joint_velocity(body, joints, cmd.targets,
        max_force=cmd.max_force)`` called just before it, bit for bit, without its per-call
        checks: the joints (known, movable, not driven by another bound command) and the
        arguments' shapes are checked here, once; the values are checked when a step reads
        them (a non-finite target or a negative or non-finite force raises
        InvalidArgumentError from ``step`` before any step). While bound, plain velocity and
        position commands on these joints are refused; :meth:`BoundCommand.release` frees
        them. ``load_urdf``, ``remove``, ``reset`` and ``close`` end every bound command
        (StaleCommandError on its next use). See :mod:`simbridge.bound`.

        Returns:
            a :class:`~simbridge.bound.BoundCommand`: ``targets`` and ``max_force`` are
            float64 arrays of shape (n,), n the number of joints, in the order given.
        """
        return self._bound("velocity", body, joints, target, max_force, None, None)

    def position_command(
        self,
        body: int,
        joints: JointsArg,
        target: Any,
        *,
        max_force: Any,
        kp: Any = 0.1,
        kd: Any = 1.0,
    ) -> BoundCommand:
        """A position command bound to ``joints`` (rad or m; PyBullet's law with gains ``kp``
        and ``kd``, fixed here): sent now, then at every :meth:`step` from its own arrays, as
        :meth:`set_joint_position` called just before each step would, bit for bit. Checks,
        ownership and the end of the binding as for :meth:`velocity_command`."""
        return self._bound("position", body, joints, target, max_force, kp, kd)

    def _bound(
        self,
        mode: str,
        body: int,
        joints: JointsArg,
        target: Any,
        max_force: Any,
        kp: Any | None,
        kd: Any | None,
    ) -> BoundCommand:
        """A checked :class:`BoundCommand`, bound (kp, kd None: a velocity command's 0 and 1)."""
        idx = self._joints(body, joints, True)
        self._refuse_multi_dof(body, idx, "a bound command")
        self._refuse_held(body, idx)
        n = len(idx)
        command = BoundCommand(
            self,
            mode,
            body,
            idx,
            self._values(target, n, "target"),
            self._values(max_force, n, "max_force", nonneg=True),
            [0.0] * n if kp is None else self._values(kp, n, "kp", nonneg=True),
            [1.0] * n if kd is None else self._values(kd, n, "kd", nonneg=True),
        )
        return self._bind(command)

    def _bind(self, command: BoundCommand) -> BoundCommand:
        command.send()  # the first command, through the plain path
        held = self._held.setdefault(command.body, {})
        for j in command.joints.tolist():
            held[j] = command
        self._commands.append(command)
        try:
            stepped = self._b.bind_command(command)
        except BaseException:
            self._release_command(command)
            raise
        if not stepped:
            self._presend.append(command)
        return command

    def _refuse_held(self, body: int, idx: np.ndarray) -> None:
        held = self._held.get(body)
        if not held:
            return
        for j in idx.tolist():
            command = held.get(j)
            if command is not None:
                b = self._bodies[body]
                raise InvalidArgumentError(
                    "joints",
                    f"joint {b.joint_names[j]!r} (index {j}) of body {b.name!r} is driven by a "
                    f"bound {command.mode} command: write its targets, or release() it first",
                )

    def _release_command(self, command: BoundCommand) -> None:
        """Unbind one command (BoundCommand.release). The backend unbinds first: a refusal
        (SimBusyError while another thread steps) leaves the command bound, here and there."""
        if not isinstance(self._b, _Closed):
            self._b.unbind_command(command)
        if command in self._commands:
            self._commands.remove(command)
        if command in self._presend:
            self._presend.remove(command)
        held = self._held.get(command.body, {})
        for j in command.joints.tolist():
            if held.get(j) is command:
                del held[j]
        if not held:
            self._held.pop(command.body, None)

    def _end_commands(self, why: str) -> None:
        """A world change ends every bound command (unbound before the change)."""
        if not self._commands:
            return
        commands = self._commands
        for command in list(commands):
            self._release_command(command)
            command._end(why)

    def set_joint_torque(
        self,
        body: int,
        joints: JointsArg,
        torque: Any = _TORQUE,
        **pybullet: Any,
    ) -> None:
        """TORQUE_CONTROL: add ``torque`` (N·m or N) during the next step only (commands before
        one step add up, as in PyBullet). The joint's motor stays; release the default brake
        first with ``set_joint_velocity(..., max_force=0)``.

        A spherical joint takes 3 torques about the axes of its child's (inertial) frame:
        shape (3,) or (n, 3); spherical joints are commanded apart from other joints.
        PyBullet's keywords (``force``...) raise PyBulletKeywordError naming simbridge's."""
        if pybullet:
            raise keyword_error(self.set_joint_torque, pybullet)
        # the hot path inline, as set_joint_velocity's
        b = self._bodies.get(body) if type(body) is int else None
        idx = None
        if b is not None:
            if type(joints) is np.ndarray:
                idx = b.movable_cache.get((joints.dtype.char, joints.tobytes()))
            elif type(joints) is list:
                try:
                    idx = b.movable_cache.get(tuple(joints))
                except TypeError:  # an unhashable item: _joints says what is wrong
                    pass
        if idx is None:
            idx = self._joints(body, joints, True)
        if self._multi_idx and id(idx) in self._multi_idx:
            self._spherical_only(body, idx)
            from simbridge.sim.arguments import per_axis

            n = len(idx)
            self._b.set_joint_torque_multi_dof(
                body, idx, per_axis(torque, n, 3, "torque", scalar=False)
            )
            return
        n = len(idx)
        if (
            type(torque) is np.ndarray
            and torque.dtype is _F64
            and torque.ndim == 1
            and len(torque) == n
        ):
            torques = torque.tolist()
            if not isfinite(sum(torques)):  # an inf or a NaN (or an overflowing sum)
                torques = self._values(torque, n, "torque")
        else:
            torques = self._values(torque, n, "torque")
        self._b.set_joint_torque(body, idx, torques)
