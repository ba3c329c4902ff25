"""Checking a :class:`~simbridge.types.WorldState` against a world before ``Sim.set_state``
sets anything (engine-free): the same robots in the same load order, and every value of the
right shape, finite, and a motor mode for every movable joint.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np

from simbridge.exceptions import InvalidArgumentError
from simbridge.types import (
    BodyState,
    JointCommands,
    JointType,
    MotorMode,
    SphericalJointState,
    WorldState,
)

__all__ = ["CheckedBody", "check_state"]

_MODES = {int(m) for m in MotorMode}


class CheckedBody(NamedTuple):
    """One body of a checked state, as the backend calls take it.

    Attributes:
        body: The body's id in the Sim being set.
        base: The base's position (m), orientation (x, y, z, w), linear (m/s) and angular
            (rad/s) velocity, world frame.
        positions: (n,) every joint's position (rad or m).
        velocities: (n,) every joint's velocity.
        commands: The joint commands in force.
        spherical: Every spherical joint's state, checked, in joint order.
    """

    body: int
    base: tuple[tuple[float, ...], ...]
    positions: np.ndarray
    velocities: np.ndarray
    commands: JointCommands
    spherical: list[SphericalJointState]


def _vector(value: Any, n: int, where: str) -> tuple[float, ...]:
    try:
        out = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        raise InvalidArgumentError(
            "state", f"{where}: expected {n} numbers, got {value!r}"
        ) from None
    if len(out) != n or not all(math.isfinite(v) for v in out):
        raise InvalidArgumentError("state", f"{where}: expected {n} finite numbers, got {value!r}")
    return out


def _array(value: Any, n: int, where: str, nonneg: bool = False) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidArgumentError(
            "state", f"{where}: expected {n} numbers, got {value!r}"
        ) from None
    if arr.shape != (n,):
        raise InvalidArgumentError("state", f"{where}: expected shape ({n},), got {arr.shape}")
    if not np.isfinite(arr).all():
        raise InvalidArgumentError("state", f"{where}: values must be finite, got {arr.tolist()}")
    if nonneg and (arr < 0).any():
        raise InvalidArgumentError("state", f"{where}: values must be >= 0, got {arr.tolist()}")
    return arr


def _check_body(bs: BodyState, body: int, types: list[JointType]) -> CheckedBody:
    n = len(types)
    where = f"body {bs.body} ({bs.name!r})"
    pos = _vector(bs.base_position, 3, f"{where} base_position")
    orn = _vector(bs.base_orientation, 4, f"{where} base_orientation")
    norm = math.sqrt(sum(c * c for c in orn))
    if abs(norm - 1.0) > 1e-6:
        raise InvalidArgumentError(
            "state", f"{where} base_orientation: not a unit quaternion (x, y, z, w): norm {norm!r}"
        )
    lin = _vector(bs.base_linear_velocity, 3, f"{where} base_linear_velocity")
    ang = _vector(bs.base_angular_velocity, 3, f"{where} base_angular_velocity")
    q = _array(bs.joint_positions, n, f"{where} joint_positions")
    v = _array(bs.joint_velocities, n, f"{where} joint_velocities")
    try:
        mode = np.asarray(bs.motor_mode)
        ok = mode.shape == (n,) and all(int(x) == x and int(x) in _MODES for x in mode.tolist())
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise InvalidArgumentError(
            "state",
            f"{where} motor_mode: expected ({n},) MotorMode values {sorted(_MODES)}, "
            f"got {bs.motor_mode!r}",
        )
    mode = mode.astype(np.int8)
    for j, t in enumerate(types):
        if (t == JointType.FIXED) != (mode[j] == MotorMode.NONE):
            raise InvalidArgumentError(
                "state",
                f"{where} motor_mode: joint {j} ({bs.joint_names[j]!r}) is "
                f"{'fixed and takes' if t == JointType.FIXED else 'movable and needs'} "
                f"{'mode NONE' if t == JointType.FIXED else 'a motor mode'}, got {int(mode[j])}",
            )
    velocity = mode == MotorMode.VELOCITY
    kp = _array(bs.motor_kp, n, f"{where} motor_kp", nonneg=True)
    kd = _array(bs.motor_kd, n, f"{where} motor_kd", nonneg=True)
    if (kp[velocity] != 0.0).any() or (kd[velocity] != 1.0).any():
        raise InvalidArgumentError(
            "state",
            f"{where}: a VELOCITY motor has kp 0 and kd 1 (PyBullet's velocity command); "
            f"got kp {kp[velocity].tolist()}, kd {kd[velocity].tolist()}: use POSITION for "
            "other gains",
        )
    commands = JointCommands(
        mode,
        _array(bs.motor_target, n, f"{where} motor_target"),
        _array(bs.motor_max_force, n, f"{where} motor_max_force", nonneg=True),
        kp,
        kd,
        _array(bs.pending_torque, n, f"{where} pending_torque"),
    )
    return CheckedBody(body, (pos, orn, lin, ang), q, v, commands, _spherical(bs, types, where))


def _spherical(bs: BodyState, types: list[JointType], where: str) -> list[SphericalJointState]:
    """The spherical joints' part of ``bs``: one entry per spherical joint, in joint order, each
    with unit quaternions (to 1e-6), finite values, forces and gains >= 0."""
    want = [j for j, t in enumerate(types) if t == JointType.SPHERICAL]
    given = getattr(bs, "spherical", ())
    try:
        joints = [int(e[0]) for e in given]
    except (TypeError, ValueError, IndexError):
        joints = None
    if joints != want:
        raise InvalidArgumentError(
            "state",
            f"{where} spherical: expected one SphericalJointState per spherical joint {want}, "
            f"got {given!r}",
        )
    out = []
    for e in given:
        at = f"{where} spherical joint {int(e[0])}"
        if len(e) != len(SphericalJointState._fields):
            raise InvalidArgumentError("state", f"{at}: expected a SphericalJointState, got {e!r}")
        quats = [_vector(e[i], 4, f"{at} {SphericalJointState._fields[i]}") for i in (1, 4)]
        for name, q in zip(("position", "motor_target"), quats, strict=True):
            norm = math.sqrt(sum(c * c for c in q))
            if abs(norm - 1.0) > 1e-6:
                raise InvalidArgumentError(
                    "state", f"{at} {name}: not a unit quaternion (x, y, z, w): norm {norm!r}"
                )
        mode = e[3]
        if mode not in (MotorMode.VELOCITY, MotorMode.POSITION):
            raise InvalidArgumentError(
                "state", f"{at} motor_mode: expected VELOCITY or POSITION, got {mode!r}"
            )
        vec = {
            i: _vector(e[i], 3, f"{at} {SphericalJointState._fields[i]}") for i in (2, 5, 6, 7, 8)
        }
        for i in (5, 6, 7):
            if min(vec[i]) < 0:
                raise InvalidArgumentError(
                    "state", f"{at} {SphericalJointState._fields[i]}: values must be >= 0"
                )
        velocity_mode = int(mode) == MotorMode.VELOCITY
        if velocity_mode and (vec[6] != (0.0, 0.0, 0.0) or vec[7] != (1.0, 1.0, 1.0)):
            raise InvalidArgumentError(
                "state", f"{at}: a VELOCITY motor (a brake) has kp 0 and kd 1; use POSITION"
            )
        out.append(
            SphericalJointState(
                int(e[0]),
                quats[0],  # type: ignore[arg-type]
                vec[2],  # type: ignore[arg-type]
                int(mode),
                quats[1],  # type: ignore[arg-type]
                vec[5],  # type: ignore[arg-type]
                vec[6],  # type: ignore[arg-type]
                vec[7],  # type: ignore[arg-type]
                vec[8],  # type: ignore[arg-type]
            )
        )
    return out


def check_state(state: Any, bodies: Mapping[int, Any]) -> list[CheckedBody]:
    """The bodies of ``state`` paired with this world's ``bodies`` (id -> an object with
    ``name``, ``joint_names`` and ``joint_types``, in load order), each checked.

    Args:
        state: what ``set_state`` was given.
        bodies: body id -> its table (:class:`~simbridge.sim.shared.BodyTable`), in load
            order.

    Returns:
        One :class:`CheckedBody` per body, in load order.

    Raises:
        InvalidArgumentError: ``state`` is no WorldState, holds other robots (by load order,
            ``<robot name>`` and joint names) or a bad value; the message says which.
    """
    if not isinstance(state, WorldState):
        raise InvalidArgumentError(
            "state", f"expected a WorldState from Sim.get_state(), got {type(state).__name__}"
        )
    theirs = [(b.name, tuple(b.joint_names)) for b in state.bodies]
    ours = [(b.name, tuple(b.joint_names)) for b in bodies.values()]
    if theirs != ours:
        for k, (t, o) in enumerate(zip(theirs, ours, strict=False)):
            if t[0] != o[0]:
                detail = f"load order #{k}: {t[0]!r} in the state, {o[0]!r} here"
                break
            if t != o:
                detail = (
                    f"robot {t[0]!r} (load order #{k}) has joints {list(t[1])} in the state, "
                    f"{list(o[1])} here"
                )
                break
        else:
            detail = f"{len(theirs)} bodies in the state, {len(ours)} here"
        raise InvalidArgumentError(
            "state",
            f"it was taken from another world ({detail}): set_state needs the same robots "
            f"loaded in the same order; that state holds {[t[0] for t in theirs]}, this Sim "
            f"holds {[o[0] for o in ours]}",
        )
    if not (isinstance(state.time, (int, float)) and math.isfinite(state.time)):
        raise InvalidArgumentError("state", f"time must be a finite number, got {state.time!r}")
    if state.time < 0:
        raise InvalidArgumentError("state", f"time must be >= 0, got {state.time!r}")
    return [
        _check_body(bs, body, list(info.joint_types))
        for bs, (body, info) in zip(state.bodies, bodies.items(), strict=True)
    ]
