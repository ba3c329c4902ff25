"""Multi-DoF joints at the ``Sim`` boundary: the argument rules of spherical joints' states and
commands (engine-free; :class:`simbridge.Sim` calls these, the backends receive checked lists).

PyBullet's spherical joint (its URDF ``type="spherical"``) has 4 position coordinates, the
quaternion (x, y, z, w) that turns the child link's inertial frame from its zero pose, and 3
velocity coordinates, the child's angular velocity relative to its parent in that frame (rad/s).
Its motor is ``btMultiBodySphericalJointMotor``: three rows, one per axis of that frame, each
boxed by its own force limit, asking for

    v_new = v_free - kd v_free - 0.2 kp e / dt

with e Bullet's ``matrixToEulerXYZ`` of the turn from the joint's quaternion to the target
(0.2: the solver's non-contact erp). What that means for the commands (measured on PyBullet
3.2.7, tests/conformance/test_spherical.py):

* position (``Sim.set_joint_position``): a target quaternion; ``kp`` PyBullet's
  ``positionGain``, ``kd`` PyBullet's ``damping`` (``setJointMotorControlMultiDof``'s
  ``velocityGain`` and ``targetVelocity`` are read by nothing on a spherical joint);
* velocity (``Sim.set_joint_velocity``): PyBullet refuses ``VELOCITY_CONTROL`` on a spherical
  joint ("Illegal control mode") and its motor cannot drive one towards a velocity other than
  0: a target of 0 is the brake (kp 0, kd 1) with ``max_force`` per axis, and ``max_force=0``
  releases the joint; any other target is refused;
* torque (``Sim.set_joint_torque``): three torques about the child's frame axes (N·m), for the
  next step, adding up, as ``TORQUE_CONTROL``.

Every spherical joint starts with PyBullet's motor holding it at the identity (kp 0.2, 1000
N·m·s of impulse per step per axis: about 240,000 N·m at 240 Hz) under the "pybullet" profile;
under ``joint_brake="urdf_friction"`` with the file's friction on each axis, as a brake.

Shapes follow numpy's broadcasting against (n, 3) (or (n, 4) for targets): a number is every
axis of every joint, (3,) the axes of every joint, (n, 1) one value per joint, (n, 3) all.
"""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np

from .exceptions import InvalidArgumentError
from .keywords import Missing

__all__ = ["motor_error", "per_axis", "quaternions", "Q_SIZE", "U_SIZE"]

Q_SIZE = {0: 1, 1: 1, 2: 4, 3: 3, 4: 0}
"""Position coordinates per joint type (JointType's values), as PyBullet's q layout."""
U_SIZE = {0: 1, 1: 1, 2: 3, 3: 3, 4: 0}
"""Velocity coordinates per joint type."""


def per_axis(
    value: Any, n: int, width: int, argument: str, *, nonneg: bool = False, scalar: bool = True
) -> list[list[float]]:
    """``value`` broadcast to (n, width) float64, finite (and >= 0): a list of n lists.
    ``scalar``: whether one number may stand for all (not for a torque, whose axes matter)."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        if type(value) is Missing:  # a required argument not given
            raise value.error() from None
        raise InvalidArgumentError(
            argument, f"expected numbers of shape ({width},) or ({n}, {width}), got {value!r}"
        ) from None
    if arr.ndim == 0 and not scalar:
        raise InvalidArgumentError(
            argument,
            f"a spherical joint takes {width} values (one per axis of the child's frame), "
            f"shape ({width},) or ({n}, {width}); got the single number {value!r}",
        )
    try:
        arr = np.broadcast_to(arr, (n, width))
    except ValueError:
        raise InvalidArgumentError(
            argument,
            f"expected a number, shape ({width},) (per axis), ({n}, 1) (per joint) or "
            f"({n}, {width}) for {n} spherical joint(s), got shape {arr.shape}",
        ) from None
    if not np.isfinite(arr).all():
        raise InvalidArgumentError(argument, f"values must be finite, got {value!r}")
    if nonneg and (arr < 0).any():
        raise InvalidArgumentError(argument, f"values must be >= 0, got {value!r}")
    return arr.tolist()


def quaternions(value: Any, n: int, argument: str) -> list[list[float]]:
    """``value`` as n unit quaternions (x, y, z, w): shape (4,) for one joint or (n, 4). A
    quaternion is divided by its norm, as PyBullet takes it (its motor and its reset normalise
    it); one whose norm is off 1 by more than 1e-3 is normalised with a warning on the
    ``simbridge.sim`` logger; a zero one is refused."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        if type(value) is Missing:  # a required argument not given
            raise value.error() from None
        raise InvalidArgumentError(
            argument, f"expected quaternions (x, y, z, w), got {value!r}"
        ) from None
    if arr.shape == (4,) and n == 1:
        arr = arr.reshape(1, 4)
    if arr.shape != (n, 4):
        raise InvalidArgumentError(
            argument,
            f"expected a quaternion (x, y, z, w) per spherical joint: shape "
            f"{'(4,) or ' if n == 1 else ''}({n}, 4), got shape {arr.shape}",
        )
    if not np.isfinite(arr).all():
        raise InvalidArgumentError(argument, f"values must be finite, got {value!r}")
    out = []
    for q in arr.tolist():
        norm = math.sqrt(sum(c * c for c in q))
        if not norm > 0.0:
            raise InvalidArgumentError(argument, f"a quaternion of norm 0: {q!r}")
        if abs(norm - 1.0) > 1e-3:
            logging.getLogger("simbridge.sim").warning(
                "%s %r has norm %.6g: normalised, as PyBullet does", argument, q, norm
            )
        out.append([c / norm for c in q])
    return out


def motor_error(
    qx: float, qy: float, qz: float, qw: float, tx: float, ty: float, tz: float, tw: float
) -> tuple[float, float, float]:
    """The spherical motor's error e: Bullet's ``matrixToEulerXYZ`` of the rotation
    ``conj(q) * t`` from the joint quaternion q to the target t (both x, y, z, w), with Bullet's
    quaternion product and matrix (the matrix divides by the squared norm), in Bullet's order of
    operations (the MuJoCo backend's compiled loop, _mjkernel.c ``spherical_error``, does the
    same arithmetic in the same order; math's atan2 and asin are the C library's)."""
    cx, cy, cz, cw = -qx, -qy, -qz, qw
    rx = cw * tx + cx * tw + cy * tz - cz * ty
    ry = cw * ty + cy * tw + cz * tx - cx * tz
    rz = cw * tz + cz * tw + cx * ty - cy * tx
    rw = cw * tw - cx * tx - cy * ty - cz * tz
    s = 2.0 / (rx * rx + ry * ry + rz * rz + rw * rw)
    xs, ys, zs = rx * s, ry * s, rz * s
    wx, wy, wz = rw * xs, rw * ys, rw * zs
    xx, xy, xz = rx * xs, rx * ys, rx * zs
    yy, yz, zz = ry * ys, ry * zs, rz * zs
    m20 = xz - wy
    if m20 < 1.0:
        if m20 > -1.0:
            return (
                math.atan2(-(yz + wx), 1.0 - (xx + yy)),
                math.asin(m20),
                math.atan2(-(xy + wz), 1.0 - (yy + zz)),
            )
        return (-math.atan2(xy - wz, 1.0 - (xx + zz)), -0.5 * math.pi, 0.0)
    return (math.atan2(xy - wz, 1.0 - (xx + zz)), 0.5 * math.pi, 0.0)
