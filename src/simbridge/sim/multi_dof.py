"""The `Sim`'s multi-DoF joints (spherical): their states, teleports, motors and torques.
Functions of the Sim's :class:`~simbridge.sim.shared.Shared` state; the argument shapes and the
motor law are :mod:`simbridge.spherical`."""

from __future__ import annotations

from typing import Any

import numpy as np

from simbridge.exceptions import InvalidArgumentError
from simbridge.sim.arguments import JointsArg, checked_state, per_axis, quaternions
from simbridge.sim.lookups import joint_indices
from simbridge.sim.shared import Shared
from simbridge.spherical import Q_SIZE, U_SIZE
from simbridge.types import JointStateMultiDof, JointType, MotorMode

__all__ = [
    "joint_states_multi_dof",
    "motor",
    "refuse_multi_dof",
    "reset_joint_state_multi_dof",
    "spherical_only",
    "torque",
]


def joint_states_multi_dof(
    s: Shared, body: int, joints: JointsArg | None
) -> tuple[JointStateMultiDof, ...]:
    """Every coordinate of ``joints`` (:meth:`simbridge.Sim.joint_states_multi_dof`).

    Args:
        s: the Sim's shared state.
        body: a body id.
        joints: as :func:`~simbridge.sim.lookups.joint_indices` (None: every joint).

    Returns:
        One :class:`~simbridge.types.JointStateMultiDof` per joint, in the order given.

    Raises:
        UnknownBodyError, UnknownJointError, InvalidArgumentError: a bad body or joints.
    """
    return tuple(s.backend.joint_states_multi_dof(body, joint_indices(s, body, joints, False)))


def reset_joint_state_multi_dof(
    s: Shared, body: int, joints: JointsArg, positions: Any, velocities: Any
) -> None:
    """Teleport joints with all their coordinates
    (:meth:`simbridge.Sim.reset_joint_state_multi_dof`).

    Args:
        s: the Sim's shared state.
        body, joints, positions, velocities: as
            :meth:`simbridge.Sim.reset_joint_state_multi_dof`'s.

    Raises:
        InvalidArgumentError: a fixed joint, a wrong number of coordinates, a value that is not
            finite, a quaternion of norm 0.
    """
    idx = joint_indices(s, body, joints, True)
    b = s.bodies[int(body)]
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
            q = checked_state(given_q[k], Q_SIZE[jtype], name)
        vel = None if given_v is None else given_v[k]
        vname = f"velocities of joint {b.joint_names[j]!r}"
        v = [0.0] * U_SIZE[jtype] if vel is None else checked_state(vel, U_SIZE[jtype], vname)
        if len(v) != U_SIZE[jtype]:
            raise InvalidArgumentError(vname, f"expected {U_SIZE[jtype]} numbers, got {vel!r}")
        qs.append(q)
        vs.append(v)
    s.backend.reset_joint_state_multi_dof(body, idx, qs, vs)


def spherical_only(s: Shared, body: int, idx: np.ndarray) -> None:
    """Refuse a multi-DoF command that names other joints than spherical ones.

    Args:
        s: the Sim's shared state.
        body: a loaded body's id.
        idx: ``(n,)`` joint indices.

    Raises:
        InvalidArgumentError: a joint of ``idx`` is not spherical (the message names them).
    """
    b = s.bodies[int(body)]
    other = [j for j in idx.tolist() if b.joint_types[j] != JointType.SPHERICAL]
    if other:
        raise InvalidArgumentError(
            "joints",
            f"joints {[b.joint_names[j] for j in other]} of body {b.name!r} are not "
            "spherical: command spherical joints apart from the others (their targets "
            "and forces have 3 or 4 values per joint)",
        )


def refuse_multi_dof(s: Shared, body: int, idx: np.ndarray, what: str) -> None:
    """Refuse a one-coordinate call (``what``) on spherical joints.

    Args:
        s: the Sim's shared state.
        body: a loaded body's id.
        idx: ``(n,)`` joint indices.
        what: the call, for the message (``"reset_joint_state"``, ``"a bound command"``).

    Raises:
        InvalidArgumentError: a joint of ``idx`` is spherical (the message names the calls
            that take it).
    """
    b = s.bodies[int(body)]
    multi = [b.joint_names[j] for j in idx.tolist() if b.joint_types[j] == JointType.SPHERICAL]
    if multi:
        raise InvalidArgumentError(
            "joints",
            f"spherical joints {multi} of body {b.name!r} take no {what}: use "
            "reset_joint_state_multi_dof for a teleport, set_joint_position / "
            "set_joint_velocity / set_joint_torque for commands",
        )


def motor(
    s: Shared,
    body: int,
    idx: np.ndarray,
    mode: MotorMode,
    target: Any,
    max_force: Any,
    kp: Any,
    kd: Any,
) -> None:
    """A velocity or position command on spherical joints (see :mod:`simbridge.spherical`).

    Args:
        s: the Sim's shared state.
        body: a loaded body's id.
        idx: ``(n,)`` indices of spherical joints.
        mode: VELOCITY (``target`` 0 alone: a brake) or POSITION (``target`` quaternions
            x, y, z, w: shape (4,) or (n, 4)).
        target, max_force, kp, kd: as :meth:`simbridge.Sim.set_joint_position`'s for a
            spherical joint (per axis of the child's frame: a number, (3,), (n, 1) or (n, 3)).

    Raises:
        InvalidArgumentError: a joint that is not spherical or is held by a bound command, a
            velocity target other than 0, a value of the wrong shape or out of range.
    """
    spherical_only(s, body, idx)
    if s.held:
        s.refuse_held(body, idx)
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
    s.backend.set_joint_motor_multi_dof(
        body,
        idx,
        mode,
        targets,
        per_axis(max_force, n, 3, "max_force", nonneg=True),
        per_axis(kp, n, 3, "kp", nonneg=True),
        per_axis(kd, n, 3, "kd", nonneg=True),
    )


def torque(s: Shared, body: int, idx: np.ndarray, value: Any) -> None:
    """Torques on spherical joints for the next step (:meth:`simbridge.Sim.set_joint_torque`).

    Args:
        s: the Sim's shared state.
        body: a loaded body's id.
        idx: ``(n,)`` indices of spherical joints.
        value: 3 torques (N·m) per joint about its child's (inertial) frame axes: shape (3,)
            or (n, 3).

    Raises:
        InvalidArgumentError: a joint that is not spherical, a value of the wrong shape or not
            finite.
    """
    spherical_only(s, body, idx)
    n = len(idx)
    s.backend.set_joint_torque_multi_dof(body, idx, per_axis(value, n, 3, "torque", scalar=False))
