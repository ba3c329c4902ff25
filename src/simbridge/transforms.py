"""Quaternion, roll-pitch-yaw and rigid-transform maths on plain tuples and numpy arrays.

Quaternions are (x, y, z, w) unless a name says ``wxyz``; rotations are active (a quaternion
turns a vector of the frame it describes into its parent frame); a pose is
(position (3,) in metres, quaternion (4,)). Pure functions, no engine and no other simbridge
module but :mod:`simbridge.types`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from simbridge.types import Quat, Vec3

__all__ = [
    "IDENTITY_QUAT",
    "quat_from_rpy",
    "rpy_from_quat",
    "quat_multiply",
    "quat_conjugate",
    "quat_rotate",
    "quat_to_matrix",
    "quat_from_matrix",
    "quat_from_matrix_bullet",
    "matrix_from_quat_bullet",
    "transform_multiply",
    "transform_inverse",
    "xyzw_to_wxyz",
    "wxyz_to_xyzw",
]

IDENTITY_QUAT: Quat = (0.0, 0.0, 0.0, 1.0)


def quat_from_rpy(rpy: Sequence[float]) -> Quat:
    """URDF roll-pitch-yaw to a unit quaternion, as ``p.getQuaternionFromEuler``.

    Args:
        rpy: (3,) roll, pitch, yaw in radians, about fixed axes X, then Y, then Z:
            R = Rz(yaw) Ry(pitch) Rx(roll).

    Returns:
        The unit quaternion (x, y, z, w).
    """
    r, p, y = (0.5 * float(a) for a in rpy)
    cr, sr, cp, sp, cy, sy = (
        math.cos(r),
        math.sin(r),
        math.cos(p),
        math.sin(p),
        math.cos(y),
        math.sin(y),
    )
    return (
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )


def rpy_from_quat(q: Sequence[float]) -> Vec3:
    """Inverse of :func:`quat_from_rpy` (``p.getEulerFromQuaternion``).

    Args:
        q: (4,) unit quaternion (x, y, z, w).

    Returns:
        Roll, pitch, yaw in radians, pitch in [-pi/2, pi/2].
    """
    x, y, z, w = (float(c) for c in q)
    sinp = max(-1.0, min(1.0, 2.0 * (w * y - z * x)))
    return (
        math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y)),
        math.asin(sinp),
        math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)),
    )


def quat_multiply(a: Sequence[float], b: Sequence[float]) -> Quat:
    """Hamilton product ``a * b``: rotation b, then a.

    Args:
        a: (4,) quaternion (x, y, z, w).
        b: (4,) quaternion (x, y, z, w).

    Returns:
        The product (x, y, z, w).
    """
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def quat_conjugate(q: Sequence[float]) -> Quat:
    """The inverse rotation of a unit quaternion.

    Args:
        q: (4,) unit quaternion (x, y, z, w).

    Returns:
        Its conjugate (x, y, z, w).
    """
    return (-q[0], -q[1], -q[2], q[3])


def quat_rotate(q: Sequence[float], v: Sequence[float]) -> Vec3:
    """Rotate a vector by a unit quaternion.

    Args:
        q: (4,) unit quaternion (x, y, z, w).
        v: (3,) vector in the frame ``q`` describes.

    Returns:
        ``v`` in ``q``'s parent frame.
    """
    x, y, z, w = q
    vx, vy, vz = v
    # t = 2 q_vec x v ; v' = v + w t + q_vec x t
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (
        vx + w * tx + y * tz - z * ty,
        vy + w * ty + z * tx - x * tz,
        vz + w * tz + x * ty - y * tx,
    )


def quat_to_matrix(q: Sequence[float]) -> np.ndarray:
    """The rotation matrix of a unit quaternion.

    Args:
        q: (4,) unit quaternion (x, y, z, w).

    Returns:
        A (3, 3) float64 rotation matrix.
    """
    x, y, z, w = (float(c) for c in q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def quat_from_matrix(m: np.ndarray) -> Quat:
    """The unit quaternion of a rotation matrix.

    Args:
        m: (3, 3) rotation matrix.

    Returns:
        The quaternion (x, y, z, w), normalised, with w >= 0.
    """
    m = np.asarray(m, dtype=float)
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0:
        s = 2.0 * math.sqrt(tr + 1.0)
        q = ((m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s)
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = (0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s)
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = ((m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = ((m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s, (m[1, 0] - m[0, 1]) / s)
    n = math.sqrt(sum(c * c for c in q))
    sign = -1.0 if q[3] < 0 else 1.0
    return (sign * q[0] / n, sign * q[1] / n, sign * q[2] / n, sign * q[3] / n)


def matrix_from_quat_bullet(q: Sequence[float]) -> list[list[float]]:
    """The rotation matrix Bullet's ``btMatrix3x3::setRotation`` makes of a quaternion.

    Operation for operation (double precision, no SIMD: PyBullet's build); with
    :func:`quat_from_matrix_bullet` it repeats Bullet's own round-off where that decides a sign
    (a turn of 120 degrees has trace 0).

    Args:
        q: (4,) quaternion (x, y, z, w).

    Returns:
        The (3, 3) matrix as nested lists of floats, row by row.
    """
    x, y, z, w = (float(c) for c in q)
    s = 2.0 / (x * x + y * y + z * z + w * w)
    xs, ys, zs = x * s, y * s, z * s
    wx, wy, wz = w * xs, w * ys, w * zs
    xx, xy, xz = x * xs, x * ys, x * zs
    yy, yz, zz = y * ys, y * zs, z * zs
    return [
        [1.0 - (yy + zz), xy - wz, xz + wy],
        [xy + wz, 1.0 - (xx + zz), yz - wx],
        [xz - wy, yz + wx, 1.0 - (xx + yy)],
    ]


def quat_from_matrix_bullet(m: Sequence[Sequence[float]] | np.ndarray) -> Quat:
    """The quaternion Bullet's ``btMatrix3x3::getRotation`` gives for a rotation matrix, its sign
    included.

    Bullet turns every rotation it composes into a quaternion this way, so this sign, not
    :func:`quat_from_matrix`'s w >= 0, is the one PyBullet reports (``getJointInfo``).

    Args:
        m: (3, 3) rotation matrix (nested sequences or an array).

    Returns:
        The quaternion (x, y, z, w) as plain floats: w > 0 where the trace is positive, else the
        component of the largest diagonal entry positive (the first of equal ones, in Bullet's
        order of tests).
    """
    # Python floats, not numpy scalars: the same double arithmetic, and the quaternion it
    # returns holds plain floats (the joint table reports it as PyBullet does)
    m = np.asarray(m, dtype=float).tolist()
    trace = m[0][0] + m[1][1] + m[2][2]  # Bullet's order: (m00 + m11) + m22
    q = [0.0, 0.0, 0.0, 0.0]
    if trace > 0.0:
        s = math.sqrt(trace + 1.0)
        q[3] = s * 0.5
        s = 0.5 / s
        q[0] = (m[2][1] - m[1][2]) * s
        q[1] = (m[0][2] - m[2][0]) * s
        q[2] = (m[1][0] - m[0][1]) * s
    else:
        big = m[1][1] if m[0][0] < m[1][1] else m[0][0]
        i = 2 if big < m[2][2] else (1 if m[0][0] < m[1][1] else 0)
        j, k = (i + 1) % 3, (i + 2) % 3
        s = math.sqrt(m[i][i] - m[j][j] - m[k][k] + 1.0)
        q[i] = s * 0.5
        s = 0.5 / s
        q[3] = (m[k][j] - m[j][k]) * s
        q[j] = (m[j][i] + m[i][j]) * s
        q[k] = (m[k][i] + m[i][k]) * s
    return (q[0], q[1], q[2], q[3])


def transform_multiply(
    a: tuple[Sequence[float], Sequence[float]], b: tuple[Sequence[float], Sequence[float]]
) -> tuple[Vec3, Quat]:
    """Compose poses ``a * b``.

    Args:
        a: (position (3,), quaternion (x, y, z, w)) of a frame in its parent frame.
        b: (position, quaternion) expressed in the frame ``a`` describes.

    Returns:
        ``b`` in ``a``'s parent frame, as (position, quaternion).
    """
    pa, qa = a
    pb, qb = b
    r = quat_rotate(qa, pb)
    return (pa[0] + r[0], pa[1] + r[1], pa[2] + r[2]), quat_multiply(qa, qb)


def transform_inverse(t: tuple[Sequence[float], Sequence[float]]) -> tuple[Vec3, Quat]:
    """Inverse of a pose.

    Args:
        t: (position (3,), quaternion (x, y, z, w)) of a frame in its parent frame.

    Returns:
        The parent frame in that frame, as (position, quaternion).
    """
    p, q = t
    qi = quat_conjugate(q)
    r = quat_rotate(qi, p)
    return (-r[0], -r[1], -r[2]), qi


def xyzw_to_wxyz(q: Sequence[float]) -> tuple[float, float, float, float]:
    """(x, y, z, w) to MuJoCo's (w, x, y, z) order.

    Args:
        q: (4,) quaternion (x, y, z, w).

    Returns:
        The same quaternion as (w, x, y, z).
    """
    return (q[3], q[0], q[1], q[2])


def wxyz_to_xyzw(q: Sequence[float]) -> Quat:
    """MuJoCo's (w, x, y, z) order to (x, y, z, w).

    Args:
        q: (4,) quaternion (w, x, y, z).

    Returns:
        The same quaternion as (x, y, z, w).
    """
    return (q[1], q[2], q[3], q[0])
