"""Transitional: the names that lived here, re-exported from their new modules
(:mod:`simbridge.transforms`, :mod:`simbridge.meshes`, :mod:`simbridge.inertia`,
:mod:`simbridge.joint_table`) until the backends import those; then this module goes."""

from __future__ import annotations

from .inertia import (
    URDF_COLLISION_MARGIN,
    LinkInertial,
    collision_aabb_inertia,
    inertia_scalings,
    is_fixed_base,
    link_inertial,
    model_inertials,
)
from .joint_table import JOINT_TYPES, joint_table
from .meshes import mesh_vertices
from .transforms import (
    IDENTITY_QUAT,
    quat_conjugate,
    quat_from_matrix,
    quat_from_rpy,
    quat_multiply,
    quat_rotate,
    quat_to_matrix,
    rpy_from_quat,
    transform_inverse,
    transform_multiply,
    wxyz_to_xyzw,
    xyzw_to_wxyz,
)
from .types import Quat, Vec3

__all__ = [
    "IDENTITY_QUAT",
    "quat_from_rpy",
    "rpy_from_quat",
    "quat_multiply",
    "quat_conjugate",
    "quat_rotate",
    "quat_to_matrix",
    "quat_from_matrix",
    "transform_multiply",
    "transform_inverse",
    "xyzw_to_wxyz",
    "wxyz_to_xyzw",
    "LinkInertial",
    "link_inertial",
    "collision_aabb_inertia",
    "joint_table",
    "is_fixed_base",
    "inertia_scalings",
    "model_inertials",
    "mesh_vertices",
    "JOINT_TYPES",
    "URDF_COLLISION_MARGIN",
    "Quat",
    "Vec3",
]
