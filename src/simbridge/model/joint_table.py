"""The joint table: the 17 fields of ``p.getJointInfo`` for every joint of a
:class:`~simbridge.model.urdf.UrdfModel`, computed without PyBullet (the MuJoCo backend
reports it as PyBullet would; ``tests/model/test_joint_table_and_inertia.py`` pins it against
PyBullet itself).

Frames are PyBullet's: the joint frame in the parent link's inertial (centre-of-mass) frame,
the axis in the child link's inertial frame; quaternions (x, y, z, w); lengths in metres,
angles in radians.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from simbridge.model.inertia import LinkInertial
from simbridge.model.urdf import UrdfModel
from simbridge.transforms import (
    matrix_from_quat_bullet,
    quat_conjugate,
    quat_from_matrix_bullet,
    quat_multiply,
    quat_rotate,
    transform_inverse,
    transform_multiply,
)
from simbridge.types import JointInfo, JointType, Quat, Vec3

__all__ = ["JOINT_TYPES", "joint_table"]

JOINT_TYPES: dict[str, JointType] = {
    "revolute": JointType.REVOLUTE,
    "continuous": JointType.REVOLUTE,
    "prismatic": JointType.PRISMATIC,
    "spherical": JointType.SPHERICAL,
    "fixed": JointType.FIXED,
}
"""URDF joint type -> PyBullet's joint type (a continuous joint is a revolute one; the reader
turns a floating joint into a fixed one, as PyBullet does)."""


def joint_table(
    model: UrdfModel,
    fixed_base: bool,
    inertials: Sequence[LinkInertial],
) -> list[JointInfo]:
    """The rows of ``p.getJointInfo`` for every joint of ``model``.

    Fields:

    * ``q_index``/``u_index``: PyBullet's state layout, after 7 position and 6 velocity
      base coordinates (PyBullet counts them for a fixed base too); -1 for fixed joints; a
      spherical joint takes 4 positions (its quaternion) and 3 velocities;
    * ``flags``: 1 for revolute and prismatic joints (they carry the default motor), else 0
      (a spherical joint's motor is another kind: 0, measured);
    * ``axis``: the URDF axis, as written (not normalised), turned into the child's inertial
      frame; (0, 0, 0) for fixed and spherical joints;
    * ``parent_frame_position``: the joint origin in the parent's inertial frame;
    * ``parent_frame_orientation``: Bullet's ``rotParentToThis``, the inverse of the child's
      inertial frame orientation seen from the parent's inertial frame at zero joint angle
      (measured: this, not the joint frame's orientation, is what ``getJointInfo`` reports),
      with Bullet's sign (:func:`_rot_parent_to_this`).

    Args:
        model: The robot, links and joints in PyBullet's order.
        fixed_base: Whether the base is fixed; unused (PyBullet counts 7 and 6 base coordinates
            even for a fixed base).
        inertials: ``inertials[i + 1]`` is link i's inertial frame (``inertials[0]`` the base),
            as :func:`~simbridge.model.inertia.link_inertial` gives them for the profile's
            inertia source.

    Returns:
        One row per joint, in index order.
    """
    del fixed_base  # PyBullet counts 7 and 6 base coordinates even for a fixed base
    q, u = 7, 6
    rows: list[JointInfo] = []
    for joint in model.joints:
        jtype = JOINT_TYPES[joint.type]
        parent = model.parent_index(joint)
        pin = inertials[parent + 1]
        cin = inertials[joint.index + 1]
        inv_parent = transform_inverse((pin.position, pin.orientation))
        fpos = transform_multiply(inv_parent, (joint.origin_xyz, joint.origin_quat))[0]
        forn = _rot_parent_to_this(pin.orientation, joint.origin_quat, cin.orientation)
        if jtype == JointType.FIXED:
            axis: Vec3 = (0.0, 0.0, 0.0)
            qi = ui = -1
            flags = 0
        elif jtype == JointType.SPHERICAL:
            axis = (0.0, 0.0, 0.0)
            qi, ui = q, u
            q += 4
            u += 3
            flags = 0
        else:
            axis = quat_rotate(quat_conjugate(cin.orientation), joint.axis)
            qi, ui = q, u
            q += 1
            u += 1
            flags = 1
        rows.append(
            JointInfo(
                joint.index,
                joint.name,
                jtype,
                qi,
                ui,
                flags,
                float(joint.damping),
                float(joint.friction),
                float(joint.lower),
                float(joint.upper),
                float(joint.effort),
                float(joint.velocity),
                joint.child,
                axis,
                fpos,
                forn,
                parent,
            )
        )
    return rows


def _rot_parent_to_this(parent_inertial: Quat, joint_origin: Quat, child_inertial: Quat) -> Quat:
    """Bullet's ``parentRotToThis`` as ``ConvertURDF2BulletInternal`` (URDF2Bullet.cpp) makes
    it, sign included: the frames are rotation matrices there (``btTransform``), and each of
    ``offsetInB = childInertial^-1`` and ``offsetInA^-1 = (parentInertial^-1 * joint)^-1``
    becomes a quaternion through ``btMatrix3x3::getRotation`` before their product. Going
    through the matrices makes the result independent of the input quaternions' signs."""
    # Bullet's URDF parser normalises each <origin>'s quaternion (btQuaternion::normalize:
    # times 1 / its length) before it makes a matrix of it: the same bits here, where a turn of
    # half a revolution leaves the sign to round-off (pybullet_data's microtaur, joint 9)
    parent = matrix_from_quat_bullet(_normalised(parent_inertial))
    joint = matrix_from_quat_bullet(_normalised(joint_origin))
    child = matrix_from_quat_bullet(_normalised(child_inertial))
    # offsetInA's basis parent^T joint, summed in Bullet's order (btMatrix3x3::operator*), and
    # transposed (inverse()); offsetInB's, child^T. Plain floats: no BLAS, the same bits on
    # every processor.
    in_a = [[sum(parent[k][i] * joint[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    in_a_inverse = [[in_a[j][i] for j in range(3)] for i in range(3)]
    in_b = [[child[j][i] for j in range(3)] for i in range(3)]
    return quat_multiply(quat_from_matrix_bullet(in_b), quat_from_matrix_bullet(in_a_inverse))


def _normalised(q: Quat) -> Quat:
    """``btQuaternion::normalize``: each component times 1 / sqrt(x x + y y + z z + w w)."""
    x, y, z, w = q
    inv = 1.0 / math.sqrt(x * x + y * y + z * z + w * w)
    return (x * inv, y * inv, z * inv, w * inv)
