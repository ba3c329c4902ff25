"""Each link's mass properties as PyBullet simulates them, from a
:class:`~simbridge.model.urdf.UrdfModel`.

:func:`model_inertials` gives every link's mass, principal moments and inertial frame for the
profile's inertia source; :func:`is_fixed_base` says whether PyBullet welds the root. The rules
below were measured on pybullet 3.2.7 and read in bullet3's ``Importers/ImportURDFDemo``
(``URDF2Bullet.cpp``, ``BulletUrdfImporter.cpp``); each is pinned by
``tests/model/test_joint_table_and_inertia.py`` against PyBullet itself.

Collision-box inertia (PyBullet without ``URDF_USE_INERTIA_FROM_FILE``), a link of mass m > 0:

* one collision shape whose frame is the inertial frame (same origin, neither rotated): the
  shape's own rule:
  box ``m/12 (ly² + lz², ...)`` of the box, sphere ``2/5 m r²``, capsule the box
  ``(2r, 2r, 2r + length)``; cylinders and meshes are convex hulls, see next point;
* otherwise: the box inertia of the bounding box, in the inertial frame, of every collision
  shape, grown by 1 mm on every side (the compound's collision margin). Each shape contributes
  its own local box turned into the inertial frame (the box around the turned box; a sphere's
  does not turn): a box its size, a sphere ``2r``, a capsule ``(2r, 2r, 2r + length)``, a
  cylinder (a 32-gon hull) and an .stl/.dae mesh (the hull of its vertices) their vertex
  bounds grown by 2 mm on every side (the hull's margin counted twice), an .obj mesh (a
  compound of one hull per object) by 3 mm; a lone .obj in the inertial frame gets its own
  box (+3 mm a side) without the outer 1 mm;
* no collision shape: the 2 mm box of the margins alone (``m/12 · 2 · 0.002²``);
* no ``<inertial>`` element: mass 1 (and the rules above); mass 0: zero inertia;
* ``<contact><inertia_scaling>`` multiplies the moments (both inertia sources).

A base loaded with ``fixed_base`` reports mass 0 and zero inertia.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from simbridge.model.meshes import mesh_vertices
from simbridge.model.urdf_model import Geometry, Inertial, Link, UrdfModel
from simbridge.transforms import (
    IDENTITY_QUAT,
    quat_from_matrix,
    quat_to_matrix,
    transform_inverse,
    transform_multiply,
)
from simbridge.types import Quat, Vec3

__all__ = [
    "LinkInertial",
    "link_inertial",
    "model_inertials",
    "collision_aabb_inertia",
    "is_fixed_base",
    "inertia_scalings",
    "URDF_COLLISION_MARGIN",
    "jacobi_principal",
    "file_principal",
]

URDF_COLLISION_MARGIN = 0.001  # PyBullet's collision margin of shapes loaded from a URDF (m)
PLANE_HALF_EXTENT = 1e30  # m: a plane's bounding box in Bullet (BT_LARGE_FLOAT, double precision)


class LinkInertial(NamedTuple):
    """A link's mass properties as PyBullet simulates them."""

    mass: float
    """kg (0 for a link welded to the world as a fixed base)."""
    diagonal: Vec3
    """Principal moments in the inertial frame (kg·m²)."""
    position: Vec3
    """Inertial frame (centre of mass) position in the link frame."""
    orientation: Quat
    """Inertial frame orientation in the link frame (x, y, z, w)."""


def _shape_local_box(
    g: Geometry, vertices: Callable[[Path], np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """(centre, half extents) of a collision shape's own bounding box in its frame, with the
    margins PyBullet's AABB carries."""
    twice = 2.0 * URDF_COLLISION_MARGIN
    if g.kind == "box":
        return np.zeros(3), 0.5 * np.asarray(g.size, dtype=float)
    if g.kind == "sphere":
        return np.zeros(3), np.full(3, g.size[0])
    if g.kind == "plane":  # Bullet's plane: the box of its AABB, +-BT_LARGE_FLOAT (double)
        return np.zeros(3), np.full(3, PLANE_HALF_EXTENT)
    if g.kind == "capsule":
        r, length = g.size
        return np.zeros(3), np.array([r, r, r + 0.5 * length])
    if g.kind == "cylinder":
        r, length = g.size
        return np.zeros(3), np.array([r, r, 0.5 * length]) + twice
    assert g.mesh_path is not None
    # An .obj becomes a compound of one hull per object (+1 mm for that compound's margin).
    grow = twice + (URDF_COLLISION_MARGIN if _is_obj(g) else 0.0)
    v = vertices(g.mesh_path) * np.asarray(g.size, dtype=float)
    v = v[np.isfinite(v).all(axis=1)]  # (pybullet_data's random_urdfs/168 is all NaN)
    if len(v) == 0:
        return np.zeros(3), np.full(3, grow)
    if not _is_obj(g):
        v = _bullet_hull_points(v)
    lo, hi = v.min(axis=0), v.max(axis=0)
    return 0.5 * (lo + hi), 0.5 * (hi - lo) + grow


def _bullet_hull_points(v: np.ndarray) -> np.ndarray:
    """The points (n, 3) as Bullet's ``btConvexHullComputer`` returns them: snapped, per axis,
    to a grid of 1/10216 of the points' extent, truncated towards their bounding box's centre
    (``btConvexHullInternal::compute``). An .stl or .dae collision hull's bounding box is taken
    after this (``optimizeConvexHull`` then ``recalcLocalAabb``); an .obj hull's and a
    cylinder's before it. The snap moves an extreme by one grid step when the scaled extent's
    arithmetic rounds below the grid (measured: kuka_iiwa link 4 at global_scaling 1.7)."""
    lo, hi = v.min(axis=0), v.max(axis=0)
    s = (hi - lo) / 10216.0
    inv = np.divide(1.0, s, out=np.zeros(3), where=s != 0)
    center = (lo + hi) * 0.5
    return np.trunc((v - center) * inv) * s + center


def _is_obj(g: Geometry) -> bool:
    return g.kind == "mesh" and g.mesh_path is not None and g.mesh_path.suffix.lower() == ".obj"


def _box_inertia(mass: float, lengths: np.ndarray) -> Vec3:
    lx, ly, lz = (float(v) for v in lengths)
    k = mass / 12.0
    return (k * (ly * ly + lz * lz), k * (lx * lx + lz * lz), k * (lx * lx + ly * ly))


def collision_aabb_inertia(
    link: Link,
    mass: float,
    frame: tuple[Sequence[float], Sequence[float]],
    vertices: Callable[[Path], np.ndarray] = mesh_vertices,
) -> Vec3:
    """PyBullet's default inertia of a link: that of the box around its collision shapes. See the
    module docstring.

    Args:
        link: The link.
        mass: Its mass (kg); <= 0 gives zero moments.
        frame: The inertial frame (position (3,) in m, quaternion (x, y, z, w)) in the link
            frame.
        vertices: Reads a mesh file's vertices ((n, 3) array) by path.

    Returns:
        The principal moments in the inertial frame (kg·m²).
    """
    if mass <= 0:
        return (0.0, 0.0, 0.0)
    inv = transform_inverse(frame)
    shapes = []
    for g in link.collisions:
        pos, orn = transform_multiply(inv, (g.origin_xyz, g.origin_quat))
        shapes.append((g, pos, orn))
    if len(shapes) == 1:
        g, pos, orn = shapes[0]
        # Bullet tests the shape's frame in the inertial frame for exact identity, after
        # floating-point composition: in practice only when both frames are unrotated and
        # share their origin (equal non-zero rotations leave round-off, measured on r2d2).
        same_frame = (
            tuple(g.origin_xyz) == tuple(frame[0])
            and tuple(g.origin_quat) == IDENTITY_QUAT
            and tuple(frame[1]) == IDENTITY_QUAT
        )
        if same_frame:
            if g.kind == "plane":  # btStaticPlaneShape::calculateLocalInertia
                return (0.0, 0.0, 0.0)
            if g.kind == "sphere":
                v = 0.4 * mass * (g.size[0] * g.size[0])  # inf, not OverflowError, past 1e154
                return (v, v, v)
            if g.kind in ("box", "capsule") or _is_obj(g):
                return _box_inertia(mass, 2.0 * _shape_local_box(g, vertices)[1])
            # a cylinder or an .stl/.dae hull alone: its box plus its margin once more, which
            # is the compound rule below
    lo = np.zeros(3)
    hi = np.zeros(3)
    for k, (g, pos, orn) in enumerate(shapes):
        centre, half = _shape_local_box(g, vertices)
        rot = quat_to_matrix(orn)
        c = rot @ centre + np.asarray(pos)
        # a sphere's box does not grow when turned; every other shape's box is the box around
        # its turned local box
        h = half if g.kind in ("sphere", "plane") else np.abs(rot) @ half
        lo = c - h if k == 0 else np.minimum(lo, c - h)
        hi = c + h if k == 0 else np.maximum(hi, c + h)
    return _box_inertia(mass, hi - lo + 2.0 * URDF_COLLISION_MARGIN)


def jacobi_principal(
    tensor: np.ndarray, threshold: float = 1e-6, max_steps: int = 30
) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments and axes of a symmetric 3x3 matrix by cyclic Jacobi rotations, in the
    order Bullet's ``btMatrix3x3::diagonalize`` visits them (largest off-diagonal first), so
    the principal frame's orientation (axis order and signs) is the one PyBullet reports.

    Args:
        tensor: (3, 3) symmetric matrix (an inertia tensor, kg·m²).
        threshold: When to stop, relative to the trace (1e-6 for a link's file inertia).
        max_steps: The most rotations (30 for a link's file inertia).

    Returns:
        The (3,) moments and the (3, 3) matrix whose columns are the principal axes.
    """
    a = np.array(tensor, dtype=float)
    rot = np.eye(3)
    eps = np.finfo(float).eps
    steps = max_steps
    while steps > 0:
        p, q, r = 0, 1, 2
        biggest = abs(a[0, 1])
        if abs(a[0, 2]) > biggest:
            q, r, biggest = 2, 1, abs(a[0, 2])
        if abs(a[1, 2]) > biggest:
            p, q, r, biggest = 1, 2, 0, abs(a[1, 2])
        limit = threshold * (abs(a[0, 0]) + abs(a[1, 1]) + abs(a[2, 2]))
        if biggest <= limit:
            if biggest <= eps * limit:
                break
            steps = 1
        apq = a[p, q]
        theta = (a[q, q] - a[p, p]) / (2.0 * apq)
        theta2 = theta * theta
        if theta2 * theta2 < 10.0 / eps:
            t = (
                1.0 / (theta + math.sqrt(1.0 + theta2))
                if theta >= 0
                else 1.0 / (theta - math.sqrt(1.0 + theta2))
            )
            c = 1.0 / math.sqrt(1.0 + t * t)
        else:
            t = 1.0 / (theta * (2.0 + 0.5 / theta2))
            c = 1.0 - 0.5 * t * t
        s = c * t
        a[p, q] = a[q, p] = 0.0
        a[p, p] -= t * apq
        a[q, q] += t * apq
        arp, arq = a[r, p], a[r, q]
        a[r, p] = a[p, r] = c * arp - s * arq
        a[r, q] = a[q, r] = c * arq + s * arp
        colp, colq = rot[:, p].copy(), rot[:, q].copy()
        rot[:, p] = c * colp - s * colq
        rot[:, q] = c * colq + s * colp
        steps -= 1
    return np.diag(a).copy(), rot


def file_principal(ine: Inertial) -> tuple[np.ndarray, Quat, str | None]:
    """What PyBullet makes of an ``<inertia>`` tensor under ``URDF_USE_INERTIA_FROM_FILE``
    (diagonalised as Bullet does).

    Moments that are negative or break the triangle inequality become zero (and the frame the
    ``<inertial>``'s), as in PyBullet ("Bad inertia tensor properties, setting inertia to
    zero").

    Args:
        ine: The link's ``<inertial>``.

    Returns:
        The (3,) principal moments (kg·m²), the principal frame's orientation in the link frame
        (x, y, z, w), and why the moments were zeroed, or None.
    """
    ixx, ixy, ixz, iyy, iyz, izz = ine.inertia
    orn = ine.origin_quat
    if ixy == 0.0 and ixz == 0.0 and iyz == 0.0:
        diag = np.array([ixx, iyy, izz], dtype=float)
    else:
        tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]], dtype=float)
        diag, axes = jacobi_principal(tensor)
        orn = quat_from_matrix(quat_to_matrix(orn) @ axes)
    x, y, z = (float(v) for v in diag)
    reason = None
    if min(x, y, z) < 0:
        reason = "a principal moment is negative (the tensor is not positive semi-definite)"
    elif x > y + z or y > x + z or z > x + y:
        reason = "they break the triangle inequality (each must be at most the sum of the others)"
    if reason is not None:
        return np.zeros(3), ine.origin_quat, f"principal moments ({x:g}, {y:g}, {z:g}): {reason}"
    return diag, orn, None


def is_fixed_base(model: UrdfModel, fixed_base: bool) -> bool:
    """Whether PyBullet welds the root to the world: when asked, or when the root's mass is 0 (a
    root named ``world`` without ``<inertial>`` has mass 0).

    Args:
        model: The robot.
        fixed_base: Whether ``load`` was asked for a fixed base.

    Returns:
        True when the base is welded.
    """
    if fixed_base:
        return True
    base = model.base
    if not base.inertial.from_file:
        return base.name == "world"
    return base.inertial.mass <= 0.0


def link_inertial(
    link: Link,
    inertia_source: str,
    *,
    is_fixed_root: bool = False,
    inertia_scaling: float = 1.0,
    vertices: Callable[[Path], np.ndarray] = mesh_vertices,
) -> LinkInertial:
    """Mass, principal inertia and inertial frame of ``link`` as PyBullet simulates them.

    A link without ``<inertial>`` has mass 1 (inertia 1, 1, 1 from the file), except one named
    ``world``, which has mass 0 (Bullet's URDF parser).

    Args:
        link: The link.
        inertia_source: The profile entry: ``"collision_aabb"`` (PyBullet's default) or
            ``"file"`` (``URDF_USE_INERTIA_FROM_FILE``: the tensor, diagonalised as Bullet does,
            its principal axes turning the inertial frame; a tensor that breaks the triangle
            inequality or is negative becomes zero, as in PyBullet).
        is_fixed_root: The base of a body loaded with ``fixed_base`` (mass and inertia 0).
        inertia_scaling: Bullet's ``<contact><inertia_scaling>`` factor on the moments (see
            :func:`inertia_scalings`).
        vertices: Reads a mesh file's vertices ((n, 3) array) by path.

    Returns:
        Mass (kg), principal moments (kg·m²), and the inertial frame in the link frame.
    """
    ine = link.inertial
    pos: Vec3 = tuple(float(v) for v in ine.origin_xyz)  # type: ignore[assignment]
    orn = ine.origin_quat
    if not ine.from_file:
        pos, orn = (0.0, 0.0, 0.0), IDENTITY_QUAT
        mass = 0.0 if link.name == "world" else 1.0
        file_diag = np.full(3, mass)
    else:
        mass = float(ine.mass)
        file_diag = np.zeros(3)
    if is_fixed_root:
        return LinkInertial(0.0, (0.0, 0.0, 0.0), pos, orn)
    if inertia_source == "file":
        if ine.from_file:
            file_diag, orn, _ = file_principal(ine)
        diag = tuple(float(v) for v in file_diag)
    elif ine.moments is not None:  # computed by the file's reader (an MJCF body's shapes)
        diag = ine.moments if mass else (0.0, 0.0, 0.0)
    else:
        diag = collision_aabb_inertia(link, mass, (pos, orn), vertices)
    if mass and inertia_scaling != 1.0:
        diag = tuple(v * inertia_scaling for v in diag)
    return LinkInertial(mass, diag, pos, orn)  # type: ignore[arg-type]


def inertia_scalings(model: UrdfModel) -> dict[str, float]:
    """Bullet's ``<contact><inertia_scaling value=..>`` per link.

    Args:
        model: The robot.

    Returns:
        The factor by link name (links without one are left out).
    """
    return {
        link.name: link.contact.inertia_scaling
        for link in model.links
        if link.contact.inertia_scaling is not None
    }


def model_inertials(
    model: UrdfModel,
    fixed_base: bool,
    inertia_source: str,
    vertices: Callable[[Path], np.ndarray] = mesh_vertices,
) -> list[LinkInertial]:
    """:func:`link_inertial` of every link.

    Args:
        model: The robot.
        fixed_base: Whether ``load`` was asked for a fixed base (the base's mass is then 0).
        inertia_source: The profile entry (``"collision_aabb"`` or ``"file"``).
        vertices: Reads a mesh file's vertices ((n, 3) array) by path.

    Returns:
        One per link, in PyBullet order (base first).
    """
    scales = inertia_scalings(model)
    return [
        link_inertial(
            link,
            inertia_source,
            is_fixed_root=fixed_base and link.index == -1,
            inertia_scaling=scales.get(link.name, 1.0),
            vertices=vertices,
        )
        for link in model.links
    ]
