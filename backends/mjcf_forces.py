"""MuJoCo's joint forces that an engine without them gets from simbridge, each step, under
``load_mjcf(source, semantics="mujoco")`` (no engine is imported here): MuJoCo's soft joint
limits (hinge, slide and ball) and the velocity change a free body's engine state gives (the
damping and armature are solved in ``MjcfOnEngine.with_armature``). Used by
``backends/mjcf_engine.py``; every array is in MuJoCo's generalized coordinates (nv,), ``mass``
the joint-space inertia (nv, nv).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

__all__ = [
    "ball_angle",
    "cross3",
    "free_velocity_change",
    "LimitTable",
    "limit_table",
    "soft_limit_force",
    "violation",
]

_BALL = 1  # mujoco.mjtJoint.mjJNT_BALL (no engine is imported here)


def cross3(a: Any, b: Any) -> np.ndarray:
    """The cross product of two 3-vectors, the same floats as ``np.cross`` (each term
    ``a1 b2 - a2 b1``, as it computes them) without its axis handling, which made ``np.cross``
    the largest cost of a PyBullet step under MuJoCo's reading (cProfile of the ant's gait,
    400 steps: 2.4 of 5.9 s in ``np.cross``, 21 calls a step).

    Args:
        a: (3,) the first vector.
        b: (3,) the second.

    Returns:
        (3,) ``a x b``.
    """
    a0, a1, a2 = float(a[0]), float(a[1]), float(a[2])
    b0, b1, b2 = float(b[0]), float(b[1]), float(b[2])
    return np.array((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0))


def ball_angle(quat: np.ndarray) -> tuple[float, np.ndarray]:
    """A ball joint's rotation angle and axis, as MuJoCo's limit reads them (``mju_quat2Vel``:
    ``2 atan2(|v|, w)`` wrapped into [-pi, pi] along ``v / |v|``, then the vector's norm).

    Args:
        quat: (4,) the joint's ``qpos``, w, x, y, z.

    Returns:
        The angle (rad, >= 0) and the unit axis (3,) in the child body's frame (any unit
        vector at angle 0).
    """
    q = np.asarray(quat, dtype=float)
    s = float(np.linalg.norm(q[1:4]))
    if s == 0.0:
        return 0.0, np.array((1.0, 0.0, 0.0))
    angle = 2.0 * math.atan2(s, float(q[0]))
    if angle > math.pi:
        angle -= 2.0 * math.pi
    axis = q[1:4] / s
    return (angle, axis) if angle >= 0.0 else (-angle, -axis)


def violation(m: Any, j: int, q: float | np.ndarray) -> tuple[float, float]:
    """A limited joint's MuJoCo violation at the nearer end of its range.

    Args:
        m: the compiled ``MjModel``.
        j: the joint's id (a limited hinge, slide or ball).
        q: its ``qpos`` (a ball joint: its quaternion (4,), w, x, y, z).

    Returns:
        ``r`` (dist - margin; < 0: violated) and that end's sign (+1 the lower, -1 the upper;
        a ball joint: -1, its rotation angle against ``max(range)``, MuJoCo's cone).
    """
    if int(m.jnt_type[j]) == _BALL:
        angle, _ = ball_angle(np.asarray(q, dtype=float))
        return float(max(m.jnt_range[j])) - angle - float(m.jnt_margin[j]), -1.0
    x = float(q)
    lo, hi = m.jnt_range[j]
    margin = float(m.jnt_margin[j])
    return (x - lo - margin, 1.0) if x - lo < hi - x else (hi - x - margin, -1.0)


def soft_limit_force(
    m: Any,
    joints: Sequence[int],
    qpos: np.ndarray,
    qvel: np.ndarray,
    mass: np.ndarray,
    free: np.ndarray,
    dt: float,
    table: LimitTable | None = None,
) -> tuple[np.ndarray, set[int]]:
    """MuJoCo's soft joint limits as forces, one row at a time.

    MuJoCo's limit row of violation ``r = dist - margin < 0`` asks for the reference
    acceleration ``a = -b v - k r`` (``b = 2 / (dmax tc)``, ``k = d / (dmax² tc² dr²)``,
    ``(tc, dr)`` the joint's ``solref`` (``tc`` at least 2 dt, as MuJoCo floors it), ``dmax``
    its ``solimp[1]``, ``d`` the impedance, linear from ``solimp[0]`` to ``dmax`` over
    ``solimp[2]``) and gets ``(1 - d) a0 + d a``, ``a0`` the joint's acceleration without the
    limit: the force is ``d m_eff (a - a0)``, ``m_eff = 1 / (M^-1)_ii``, never pulling
    (MuJoCo's limit force is >= 0: a joint pushed back coasts through the end of its range at
    the speed the push gave it, 9.6 rad/s for the ant's ankles).

    A ball joint's row is MuJoCo's cone: ``r = max(range) - angle - margin`` with ``angle``
    the quaternion's rotation angle (:func:`ball_angle`) and the row's Jacobian ``J = -n`` on
    its three velocities (``n`` the rotation axis, child body frame); its force is MuJoCo's
    single-row solution ``(a - a0) / (A + R)``, ``A = J M^-1 J'``, ``R = (1 - d) / d`` times
    MuJoCo's diagonal estimate ``dof_invweight0`` (a hinge's: ``d m_eff (a - a0)``, the estimate
    taken as ``A``).

    Args:
        m: the compiled ``MjModel``.
        joints: the limited hinge, slide and ball joints to consider.
        qpos: (nq,) the positions.
        qvel: (nv,) the velocities.
        mass: (nv, nv) the joint-space inertia, armature included.
        free: (nv,) the acceleration without the limits.
        dt: the time step (s).
        table: ``limit_table(m, joints)``, kept by a caller that calls every step; None:
            read here.

    Returns:
        (nv,) the force, and the joints of ``joints`` inside their range.
    """
    out = np.zeros(m.nv)
    if table is None:
        table = limit_table(m, joints)
    inside, joints = _hinges_inside(table, qpos)
    inv = None
    for j in joints:
        qa, va = int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j])
        ball = int(m.jnt_type[j]) == _BALL
        r, sign = violation(m, j, qpos[qa : qa + 4] if ball else float(qpos[qa]))
        if r >= 0.0:
            inside.add(j)
            continue
        if inv is None:
            inv = np.linalg.inv(mass)
        tc, dr = (float(x) for x in m.jnt_solref[j][:2])
        dmin, dmax, width = (float(x) for x in m.jnt_solimp[j][:3])
        imp = dmin + (dmax - dmin) * min(-r / width, 1.0) if width > 0 else dmax
        tc = max(tc, 2.0 * dt)
        b, k = 2.0 / (dmax * tc), imp / (dmax**2 * tc**2 * dr**2)
        if ball:  # the row's Jacobian: -axis on the joint's three velocities
            jac = -ball_angle(qpos[qa : qa + 4])[1]
            dofs = slice(va, va + 3)
            a = -b * float(jac @ qvel[dofs]) - k * r
            # MuJoCo's row: (a - a0) / (A + R), R = (1 - d) / d times its diagonal estimate,
            # the joint's dof_invweight0 (a ball's mean over its three dofs, far above A where
            # one axis spins a thin body: the cone is then softer than d m_eff (a - a0) says)
            big_a = float(jac @ inv[dofs, dofs] @ jac)
            soft = (1.0 - imp) / imp * float(m.dof_invweight0[va])
            scalar = (a - float(jac @ free[dofs])) / (big_a + soft)
            out[dofs] = jac * max(0.0, scalar)
            continue
        a = -b * (sign * float(qvel[va])) - k * r  # in the violation's coordinate
        out[va] = sign * max(0.0, imp * (a - sign * free[va])) / inv[va, va]
    return out, inside


class LimitTable(NamedTuple):
    """The limited joints' range data, read from the model once (``MjModel``'s attributes
    cost a lookup each): :func:`soft_limit_force` finds the hinges and slides inside their
    range with it at once."""

    joints: np.ndarray
    """(k,) the joints' ids."""
    qposadr: np.ndarray
    """(k,) their ``jnt_qposadr``."""
    lo: np.ndarray
    """(k,) the lower ends of their ranges."""
    hi: np.ndarray
    """(k,) the upper ends."""
    margin: np.ndarray
    """(k,) their ``jnt_margin``."""
    ball: np.ndarray
    """(k,) True for a ball joint (read one at a time)."""


def limit_table(m: Any, joints: Sequence[int]) -> LimitTable:
    """The :class:`LimitTable` of ``joints``.

    Args:
        m: the compiled ``MjModel``.
        joints: limited hinge, slide and ball joints.

    Returns:
        Their ids, ``qpos`` addresses, ranges, margins and which are ball joints.
    """
    ids = np.asarray(joints, dtype=int)
    return LimitTable(
        ids,
        np.array(m.jnt_qposadr[ids]),
        np.array(m.jnt_range[ids, 0]),
        np.array(m.jnt_range[ids, 1]),
        np.array(m.jnt_margin[ids]),
        np.array(m.jnt_type[ids] == _BALL),
    )


def _hinges_inside(table: LimitTable, qpos: np.ndarray) -> tuple[set[int], list[int]]:
    """The hinge and slide joints of ``table`` inside their range, read at once (the same
    ``r`` as :func:`violation`'s), and the joints left to read one at a time.

    Args:
        table: the joints.
        qpos: (nq,) the positions.

    Returns:
        The joints found inside, and the others (violated hinges and slides, balls).
    """
    x = qpos[table.qposadr]
    lo, hi, margin = table.lo, table.hi, table.margin
    r = np.where(x - lo < hi - x, x - lo - margin, hi - x - margin)
    ok = (r >= 0.0) & ~table.ball
    return set(table.joints[ok].tolist()), table.joints[~ok].tolist()


def _mat(w: np.ndarray) -> np.ndarray:
    """The rotation matrix of a unit quaternion w, x, y, z."""
    a, b, c, d = (float(x) for x in w)
    return np.array(
        [
            [a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)],
            [2 * (b * c + a * d), a * a - b * b + c * c - d * d, 2 * (c * d - a * b)],
            [2 * (b * d - a * c), 2 * (c * d + a * b), a * a - b * b - c * c + d * d],
        ]
    ) / (a * a + b * b + c * c + d * d)


def free_velocity_change(
    q0: np.ndarray, v0: np.ndarray, q1: np.ndarray, v1: np.ndarray, com: np.ndarray, dt: float
) -> np.ndarray:
    """A free joint's change of velocity over a step of an engine that steps the centre of
    mass's velocity and the world angular velocity from their accelerations at the start
    (PyBullet), as MuJoCo's ``qacc * dt`` at the start: ``R0^T (w1 - w0)`` and
    ``(u1 - u0) - (w1 - w0) x r0 - dt w0 x (w0 x r0)`` (``u`` the centre of mass's velocity,
    ``w`` the world angular velocity, ``r0`` the centre of mass from the body frame's origin,
    world, at the start). ``v1 - v0`` in MuJoCo's coordinates differs from it by terms of the
    body's rotation over the step (measured on dm_control's humanoid spun at 1, 3, 10 rad/s:
    2e-4, 5e-3, 0.21 N·m taken for constraint forces by
    :meth:`~.mjcf_engine.MjcfOnEngine.with_armature`).

    Args:
        q0: (7,) the free joint's start (position, quaternion w, x, y, z).
        v0: (6,) its start velocity (origin's, world; angular, body frame).
        q1: (7,) its end.
        v1: (6,) its end velocity.
        com: (3,) the centre of mass in the body frame (m).
        dt: the step (s).

    Returns:
        (6,) ``qacc * dt``.
    """
    r0, r1 = _mat(q0[3:7]), _mat(q1[3:7])
    w0, w1 = r0 @ v0[3:6], r1 @ v1[3:6]
    off0, off1 = r0 @ com, r1 @ com
    u0, u1 = v0[:3] + cross3(w0, off0), v1[:3] + cross3(w1, off1)
    out = np.empty(6)
    out[:3] = (u1 - u0) - cross3(w1 - w0, off0) - dt * cross3(w0, cross3(w0, off0))
    out[3:6] = r0.T @ (w1 - w0)
    return out
