"""The joint table: the 17 fields of ``p.getJointInfo`` for every joint of a
:class:`~simbridge.urdf.UrdfModel`, computed without PyBullet (the MuJoCo backend reports it as
PyBullet would; ``tests/test_joint_table_and_inertia.py`` pins it against PyBullet itself).

Frames are PyBullet's: the joint frame in the parent link's inertial (centre-of-mass) frame,
the axis in the child link's inertial frame; quaternions (x, y, z, w); lengths in metres,
angles in radians.
"""

from __future__ import annotations

from collections.abc import Sequence

from .inertia import LinkInertial
from .transforms import (
    quat_conjugate,
    quat_multiply,
    quat_rotate,
    transform_inverse,
    transform_multiply,
)
from .types import JointInfo, JointType, Vec3
from .urdf import UrdfModel

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

    ``inertials[i + 1]`` is link i's inertial frame (``inertials[0]`` the base), as
    :func:`~simbridge.inertia.link_inertial` gives them for the profile's inertia source. Fields:

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
      (measured: this, not the joint frame's orientation, is what ``getJointInfo`` reports).
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
        fpos, jorn = transform_multiply(inv_parent, (joint.origin_xyz, joint.origin_quat))
        # Bullet's rotParentToThis: child inertial frame relative to the joint frame seen
        # from the parent's inertial frame, inverted (what getJointInfo reports).
        forn = quat_conjugate(quat_multiply(jorn, cin.orientation))
        if abs(forn[3]) < 1e-6 and max(forn[:3], key=abs) < 0:
            # w ~ 0: Bullet's sign is round-off; measured (kuka_iiwa, minitaur): its largest
            # component comes out positive
            forn = (-forn[0], -forn[1], -forn[2], -forn[3])
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
