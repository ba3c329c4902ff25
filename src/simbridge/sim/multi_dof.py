"""The `Sim`'s multi-DoF joints (spherical): their states, teleports and motors (a part of
:class:`simbridge.Sim`; the argument shapes and the motor law are :mod:`simbridge.spherical`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from simbridge.exceptions import InvalidArgumentError
from simbridge.sim.arguments import JointsArg
from simbridge.types import JointStateMultiDof, JointType, MotorMode

if TYPE_CHECKING:
    from simbridge.backend import Backend
    from simbridge.sim.lookups import _Body

__all__ = ["MultiDof"]


class MultiDof:
    """Spherical joints' states, teleports and motors (a part of :class:`Sim`)."""

    if TYPE_CHECKING:  # provided by simbridge.sim.Sim and its other parts
        _b: Backend
        _bodies: dict[int, _Body]
        _held: dict[int, dict[int, Any]]

        def _joints(self, body: int, joints: JointsArg | None, movable: bool) -> np.ndarray: ...

        @staticmethod
        def _checked_state(value: Any, n: int, argument: str) -> list[float]: ...

        def _refuse_held(self, body: int, idx: np.ndarray) -> None: ...

    def joint_states_multi_dof(
        self, body: int, joints: JointsArg | None = None
    ) -> tuple[JointStateMultiDof, ...]:
        """Every coordinate of ``joints`` (default all), one
        :class:`~simbridge.types.JointStateMultiDof` per joint (``p.getJointStatesMultiDof``
        without the reaction forces): a spherical joint's quaternion (x, y, z, w), angular
        velocity and motor torques (3, about the child's inertial frame axes); a revolute or
        prismatic joint's 1-tuples; a fixed joint's empty tuples."""
        return tuple(self._b.joint_states_multi_dof(body, self._joints(body, joints, False)))

    def reset_joint_state_multi_dof(
        self, body: int, joints: JointsArg, positions: Any, velocities: Any = None
    ) -> None:
        """Teleport joints with all their coordinates (``p.resetJointStateMultiDof``; commands
        are kept). One joint: ``positions`` its coordinates (a spherical joint's quaternion
        x, y, z, w, normalised as PyBullet does; a revolute or prismatic joint's one number)
        and ``velocities`` likewise (3 for a spherical joint, in its child's frame; None:
        zeros). Several joints: a sequence of such per joint, in the order given.

        Raises:
            InvalidArgumentError: a fixed joint, a wrong number of coordinates, a value that
                is not finite, a quaternion of norm 0.
        """
        from simbridge.sim.arguments import quaternions
        from simbridge.spherical import Q_SIZE, U_SIZE

        idx = self._joints(body, joints, True)
        b = self._bodies[int(body)]
        one = isinstance(joints, (int, str, np.integer))
        given_q = [positions] if one else positions
        given_v = [velocities] if one else velocities
        try:
            if len(given_q) != len(idx) or (given_v is not None and len(given_v) != len(idx)):
                raise TypeError
        except TypeError:
            raise InvalidArgumentError(
                "positions/velocities", f"expected one entry per joint ({len(idx)}) of {joints!r}"
            ) from None
        qs: list[list[float]] = []
        vs: list[list[float]] = []
        for k, j in enumerate(idx.tolist()):
            jtype = int(b.joint_types[j])
            name = f"positions of joint {b.joint_names[j]!r}"
            if jtype == JointType.SPHERICAL:
                q = quaternions(given_q[k], 1, name)[0]
            else:
                q = self._checked_state(given_q[k], Q_SIZE[jtype], name)
            vel = None if given_v is None else given_v[k]
            vname = f"velocities of joint {b.joint_names[j]!r}"
            v = (
                [0.0] * U_SIZE[jtype]
                if vel is None
                else self._checked_state(vel, U_SIZE[jtype], vname)
            )
            if len(v) != U_SIZE[jtype]:
                raise InvalidArgumentError(vname, f"expected {U_SIZE[jtype]} numbers, got {vel!r}")
            qs.append(q)
            vs.append(v)
        self._b.reset_joint_state_multi_dof(body, idx, qs, vs)

    def _spherical_only(self, body: int, idx: np.ndarray) -> None:
        """A multi-DoF command names spherical joints only."""
        b = self._bodies[int(body)]
        other = [j for j in idx.tolist() if b.joint_types[j] != JointType.SPHERICAL]
        if other:
            raise InvalidArgumentError(
                "joints",
                f"joints {[b.joint_names[j] for j in other]} of body {b.name!r} are not "
                "spherical: command spherical joints apart from the others (their targets "
                "and forces have 3 or 4 values per joint)",
            )

    def _refuse_multi_dof(self, body: int, idx: np.ndarray, what: str) -> None:
        b = self._bodies[int(body)]
        multi = [b.joint_names[j] for j in idx.tolist() if b.joint_types[j] == JointType.SPHERICAL]
        if multi:
            raise InvalidArgumentError(
                "joints",
                f"spherical joints {multi} of body {b.name!r} take no {what}: use "
                "reset_joint_state_multi_dof for a teleport, set_joint_position / "
                "set_joint_velocity / set_joint_torque for commands",
            )

    def _multi_dof_motor(
        self,
        body: int,
        idx: np.ndarray,
        mode: MotorMode,
        target: Any,
        max_force: Any,
        kp: Any,
        kd: Any,
    ) -> None:
        """A velocity or position command on spherical joints (see :mod:`simbridge.spherical`)."""
        from simbridge.sim.arguments import per_axis, quaternions

        self._spherical_only(body, idx)
        if self._held:
            self._refuse_held(body, idx)
        n = len(idx)
        if mode == MotorMode.VELOCITY:
            v = per_axis(target, n, 3, "target")
            if any(x != 0.0 for row in v for x in row):
                raise InvalidArgumentError(
                    "target",
                    f"a spherical joint takes a velocity target of 0 alone (a brake; "
                    f"max_force=0 releases it), got {target!r}: PyBullet's spherical motor "
                    "drives no other velocity (setJointMotorControlMultiDof refuses "
                    "VELOCITY_CONTROL and its POSITION_CONTROL reads no targetVelocity); use "
                    "set_joint_torque or a position target",
                )
            targets = [[0.0, 0.0, 0.0, 1.0]] * n
        else:
            targets = quaternions(target, n, "target")
        self._b.set_joint_motor_multi_dof(
            body,
            idx,
            mode,
            targets,
            per_axis(max_force, n, 3, "max_force", nonneg=True),
            per_axis(kp, n, 3, "kp", nonneg=True),
            per_axis(kd, n, 3, "kd", nonneg=True),
        )
