"""Spherical joints as PyBullet means them, for the `Sim` and every backend: their coordinates
(:data:`Q_SIZE`, :data:`U_SIZE`) and the motor's error (:func:`motor_error`); the `Sim`'s checks
of their arguments are :func:`simbridge.sim.arguments.per_axis` and
:func:`~simbridge.sim.arguments.quaternions`.

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

import math

__all__ = ["motor_error", "Q_SIZE", "U_SIZE"]

Q_SIZE = {0: 1, 1: 1, 2: 4, 3: 3, 4: 0}
"""Position coordinates per joint type (JointType's values), as PyBullet's q layout."""
U_SIZE = {0: 1, 1: 1, 2: 3, 3: 3, 4: 0}
"""Velocity coordinates per joint type."""


def motor_error(
    qx: float, qy: float, qz: float, qw: float, tx: float, ty: float, tz: float, tw: float
) -> tuple[float, float, float]:
    """The spherical motor's error e: Bullet's ``matrixToEulerXYZ`` of the rotation ``conj(q) * t``
    from the joint quaternion q to the target t.

    With Bullet's quaternion product and matrix (the matrix divides by the squared norm), in
    Bullet's order of operations (the MuJoCo backend's compiled loop, _mjkernel.c
    ``spherical_error``, does the same arithmetic in the same order; math's atan2 and asin are
    the C library's).

    Args:
        qx: The joint quaternion's x.
        qy: Its y.
        qz: Its z.
        qw: Its w.
        tx: The target quaternion's x.
        ty: Its y.
        tz: Its z.
        tw: Its w.

    Returns:
        e, Euler angles XYZ (rad) about the axes of the child's inertial frame.
    """
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
