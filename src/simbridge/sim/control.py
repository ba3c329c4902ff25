"""The `Sim`'s teleports and bound commands. Functions of the Sim's
:class:`~simbridge.sim.shared.Shared` state; the commands themselves are :mod:`simbridge.bound`.

The plain motor commands (``set_joint_velocity``, ``set_joint_position``,
``set_joint_torque``) are written in :mod:`simbridge.sim.core` itself: they are the hot path of
every control loop, where one more call would cost them 2-4% on MuJoCo.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from simbridge.bound import BoundCommand
from simbridge.sim.arguments import JointsArg, checked_state, command_values, quat, state_vec
from simbridge.sim.lookups import body_table, joint_indices
from simbridge.sim.multi_dof import refuse_multi_dof
from simbridge.sim.shared import Shared

__all__ = ["bound_command", "reset_base_state", "reset_joint_state"]


def reset_joint_state(
    s: Shared, body: int, joints: JointsArg, positions: Any, velocities: Any
) -> None:
    """Teleport movable joints (:meth:`simbridge.Sim.reset_joint_state`).

    Args:
        s: the Sim's shared state.
        body, joints, positions, velocities: as :meth:`simbridge.Sim.reset_joint_state`'s.

    Raises:
        InvalidArgumentError: a spherical or fixed joint, a value of the wrong shape, not
            finite or past :data:`~simbridge.sim.arguments.MAX_STATE_VALUE`.
        UnknownBodyError, UnknownJointError: a bad body or joint.
    """
    idx = joint_indices(s, body, joints, True)
    if s.multi_idx and id(idx) in s.multi_idx:
        refuse_multi_dof(s, body, idx, "reset_joint_state")
    n = len(idx)
    s.backend.reset_joint_state(
        body,
        idx,
        checked_state(positions, n, "positions"),
        checked_state(velocities, n, "velocities"),
    )


def reset_base_state(
    s: Shared,
    body: int,
    position: Sequence[float] | None,
    orientation: Sequence[float] | None,
    linear_velocity: Sequence[float] | None,
    angular_velocity: Sequence[float] | None,
) -> None:
    """Teleport the base (:meth:`simbridge.Sim.reset_base_state`).

    Args:
        s: the Sim's shared state.
        body, position, orientation, linear_velocity, angular_velocity: as
            :meth:`simbridge.Sim.reset_base_state`'s (None: keep the current value).

    Raises:
        InvalidArgumentError: a value of the wrong shape, not finite, out of range, or a
            quaternion of norm 0.
        UnknownBodyError: a bad body.
    """
    body_table(s, body)
    s.backend.reset_base_state(
        body,
        None if position is None else state_vec(position, "position"),  # type: ignore[arg-type]
        None if orientation is None else quat(orientation, "orientation"),
        None if linear_velocity is None else state_vec(linear_velocity, "linear_velocity"),  # type: ignore[arg-type]
        None if angular_velocity is None else state_vec(angular_velocity, "angular_velocity"),  # type: ignore[arg-type]
    )


def bound_command(
    s: Shared,
    mode: str,
    body: int,
    joints: JointsArg,
    target: Any,
    max_force: Any,
    kp: Any | None,
    kd: Any | None,
) -> BoundCommand:
    """A checked :class:`~simbridge.bound.BoundCommand`, bound (:meth:`Shared.bind`).

    Args:
        s: the Sim's shared state.
        mode: ``"velocity"`` or ``"position"``.
        body, joints, target, max_force: as :meth:`simbridge.Sim.velocity_command`'s.
        kp, kd: the position gains; None: a velocity command's 0 and 1.

    Returns:
        The bound command.

    Raises:
        InvalidArgumentError: a spherical or fixed joint, a joint another bound command holds,
            a value of the wrong shape, not finite or negative (a force or gain).
        UnknownBodyError, UnknownJointError: a bad body or joint.
    """
    idx = joint_indices(s, body, joints, True)
    refuse_multi_dof(s, body, idx, "a bound command")
    s.refuse_held(body, idx)
    n = len(idx)
    command = BoundCommand(
        s,
        mode,
        body,
        idx,
        command_values(target, n, "target"),
        command_values(max_force, n, "max_force", nonneg=True),
        [0.0] * n if kp is None else command_values(kp, n, "kp", nonneg=True),
        [1.0] * n if kd is None else command_values(kd, n, "kd", nonneg=True),
    )
    return s.bind(command)
