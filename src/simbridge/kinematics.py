"""Engine-free kinematics any backend can reuse.

* Quaternion (x, y, z, w) and roll-pitch-yaw math on plain tuples and numpy arrays.
* PyBullet's view of a :class:`~simbridge.urdf.UrdfModel`: the inertial frame and inertia of each
  link (:func:`link_inertial`, both inertia sources), and the joint table :func:`joint_table`
  exactly as ``p.getJointInfo`` reports it (indices, frames in the parent's centre-of-mass frame,
  the axis in the child's centre-of-mass frame).

The rules below were measured on pybullet 3.2.7 and read in bullet3's
``Importers/ImportURDFDemo`` (``URDF2Bullet.cpp``, ``BulletUrdfImporter.cpp``); each is pinned
by ``tests/test_kinematics.py`` against PyBullet itself.

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
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from .types import JointInfo, JointType, Quat, Vec3

if TYPE_CHECKING:
    from .urdf import Geometry, Link, UrdfModel

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
]

IDENTITY_QUAT: Quat = (0.0, 0.0, 0.0, 1.0)
URDF_COLLISION_MARGIN = 0.001  # PyBullet's collision margin of shapes loaded from a URDF (m)
_CYLINDER_HULL_SEGMENTS = 32  # PyBullet turns a URDF cylinder into a 32-gon prism hull

JOINT_TYPES: dict[str, JointType] = {
    "revolute": JointType.REVOLUTE,
    "continuous": JointType.REVOLUTE,
    "prismatic": JointType.PRISMATIC,
    "fixed": JointType.FIXED,
}


# ---------------------------------------------------------------- quaternions (x, y, z, w)


def quat_from_rpy(rpy: Sequence[float]) -> Quat:
    """URDF roll-pitch-yaw (fixed axes X, then Y, then Z: R = Rz(yaw) Ry(pitch) Rx(roll)) to a
    unit quaternion (x, y, z, w), as ``p.getQuaternionFromEuler``."""
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
    """Inverse of :func:`quat_from_rpy` (``p.getEulerFromQuaternion``); pitch in [-pi/2, pi/2]."""
    x, y, z, w = (float(c) for c in q)
    sinp = max(-1.0, min(1.0, 2.0 * (w * y - z * x)))
    return (
        math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y)),
        math.asin(sinp),
        math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)),
    )


def quat_multiply(a: Sequence[float], b: Sequence[float]) -> Quat:
    """Hamilton product ``a * b`` (rotation b, then a), both (x, y, z, w)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def quat_conjugate(q: Sequence[float]) -> Quat:
    """The inverse rotation of a unit quaternion."""
    return (-q[0], -q[1], -q[2], q[3])


def quat_rotate(q: Sequence[float], v: Sequence[float]) -> Vec3:
    """Rotate vector ``v`` by unit quaternion ``q`` (x, y, z, w)."""
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
    """3x3 rotation matrix of a unit quaternion (x, y, z, w)."""
    x, y, z, w = (float(c) for c in q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def quat_from_matrix(m: np.ndarray) -> Quat:
    """Unit quaternion (x, y, z, w, with w >= 0) of a 3x3 rotation matrix."""
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


def transform_multiply(
    a: tuple[Sequence[float], Sequence[float]], b: tuple[Sequence[float], Sequence[float]]
) -> tuple[Vec3, Quat]:
    """Compose poses ``a * b`` given as (position, quaternion x, y, z, w)."""
    pa, qa = a
    pb, qb = b
    r = quat_rotate(qa, pb)
    return (pa[0] + r[0], pa[1] + r[1], pa[2] + r[2]), quat_multiply(qa, qb)


def transform_inverse(t: tuple[Sequence[float], Sequence[float]]) -> tuple[Vec3, Quat]:
    """Inverse of a pose (position, quaternion x, y, z, w)."""
    p, q = t
    qi = quat_conjugate(q)
    r = quat_rotate(qi, p)
    return (-r[0], -r[1], -r[2]), qi


def xyzw_to_wxyz(q: Sequence[float]) -> tuple[float, float, float, float]:
    return (q[3], q[0], q[1], q[2])


def wxyz_to_xyzw(q: Sequence[float]) -> Quat:
    return (q[1], q[2], q[3], q[0])


# ---------------------------------------------------------------- meshes


@lru_cache(maxsize=256)
def _mesh_vertices_cached(path: str) -> np.ndarray:
    suffix = Path(path).suffix.lower()
    if suffix == ".obj":
        rows = []
        with open(path, encoding="utf-8", errors="replace") as f:
            for line in f:
                if line.startswith("v "):
                    parts = line.split()
                    rows.append((float(parts[1]), float(parts[2]), float(parts[3])))
        verts = np.array(rows, dtype=float).reshape(-1, 3)
    elif suffix == ".stl":
        verts = _stl_vertices(path)
    else:  # .dae and anything else trimesh reads (imported only here: ~1 s)
        import trimesh

        loaded = trimesh.load(path, force="mesh", process=False)
        verts = np.asarray(loaded.vertices, dtype=float).reshape(-1, 3)
    verts.setflags(write=False)
    return verts


def _stl_vertices(path: str) -> np.ndarray:
    data = Path(path).read_bytes()
    if len(data) >= 84:
        n = int(np.frombuffer(data, dtype="<u4", count=1, offset=80)[0])
        if 84 + 50 * n == len(data):
            rec = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
            tri = np.frombuffer(data, dtype=rec, count=n, offset=84)
            return tri["v"].reshape(-1, 3).astype(float)
    rows = []
    for line in data.decode("utf-8", errors="replace").splitlines():
        parts = line.split()
        if len(parts) == 4 and parts[0] == "vertex":
            rows.append((float(parts[1]), float(parts[2]), float(parts[3])))
    return np.array(rows, dtype=float).reshape(-1, 3)


def mesh_vertices(path: str | Path) -> np.ndarray:
    """Vertices (n, 3) of a mesh file, unscaled (.obj and .stl read directly; other formats
    through trimesh). Cached per path; the array is read-only."""
    return _mesh_vertices_cached(str(path))


# ---------------------------------------------------------------- inertia


class LinkInertial(NamedTuple):
    """A link's mass properties as PyBullet simulates them."""

    mass: float
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
    lo, hi = v.min(axis=0), v.max(axis=0)
    return 0.5 * (lo + hi), 0.5 * (hi - lo) + grow


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
    """PyBullet's default inertia of ``link`` with ``mass``, in the inertial ``frame``
    (position, quaternion x, y, z, w, in the link frame). See the module docstring."""
    if mass <= 0:
        return (0.0, 0.0, 0.0)
    inv = transform_inverse(frame)
    shapes = []
    for g in link.collisions:
        pos, orn = transform_multiply(inv, (g.origin_xyz, quat_from_rpy(g.origin_rpy)))
        shapes.append((g, pos, orn))
    if len(shapes) == 1:
        g, pos, orn = shapes[0]
        # Bullet tests the shape's frame in the inertial frame for exact identity, after
        # floating-point composition: in practice only when both frames are unrotated and
        # share their origin (equal non-zero rotations leave round-off, measured on r2d2).
        same_frame = (
            tuple(g.origin_xyz) == tuple(frame[0])
            and not any(g.origin_rpy)
            and tuple(frame[1]) == IDENTITY_QUAT
        )
        if same_frame:
            if g.kind == "sphere":
                v = 0.4 * mass * g.size[0] ** 2
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
        h = half if g.kind == "sphere" else np.abs(rot) @ half
        lo = c - h if k == 0 else np.minimum(lo, c - h)
        hi = c + h if k == 0 else np.maximum(hi, c + h)
    return _box_inertia(mass, hi - lo + 2.0 * URDF_COLLISION_MARGIN)


def _jacobi_principal(tensor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments and axes (columns) of a symmetric 3x3 matrix by cyclic Jacobi
    rotations, in the order Bullet's ``btMatrix3x3::diagonalize`` visits them (largest
    off-diagonal first, threshold 1e-6, at most 30 sweeps), so the principal frame's
    orientation (axis order and signs) is the one PyBullet reports."""
    a = np.array(tensor, dtype=float)
    rot = np.eye(3)
    eps = np.finfo(float).eps
    steps = 30
    while steps > 0:
        p, q, r = 0, 1, 2
        biggest = abs(a[0, 1])
        if abs(a[0, 2]) > biggest:
            q, r, biggest = 2, 1, abs(a[0, 2])
        if abs(a[1, 2]) > biggest:
            p, q, r, biggest = 1, 2, 0, abs(a[1, 2])
        limit = 1e-6 * (abs(a[0, 0]) + abs(a[1, 1]) + abs(a[2, 2]))
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


def is_fixed_base(model: UrdfModel, fixed_base: bool) -> bool:
    """PyBullet welds the root to the world when asked, or when the root's mass is 0 (a root
    named ``world`` without ``<inertial>`` has mass 0)."""
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

    ``inertia_source`` is the profile entry: ``"collision_aabb"`` (PyBullet's default) or
    ``"file"`` (``URDF_USE_INERTIA_FROM_FILE``: the tensor, diagonalised as Bullet does, its
    principal axes turning the inertial frame; a tensor that breaks the triangle inequality
    or is negative becomes zero, as in PyBullet). ``is_fixed_root``: the base of a body loaded
    with ``fixed_base`` (mass and inertia 0). ``inertia_scaling``: Bullet's
    ``<contact><inertia_scaling>`` factor on the moments (see :func:`inertia_scalings`).

    A link without ``<inertial>`` has mass 1 (inertia 1, 1, 1 from the file), except one named
    ``world``, which has mass 0 (Bullet's URDF parser).
    """
    ine = link.inertial
    pos: Vec3 = tuple(float(v) for v in ine.origin_xyz)  # type: ignore[assignment]
    orn = quat_from_rpy(ine.origin_rpy)
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
            ixx, ixy, ixz, iyy, iyz, izz = ine.inertia
            if ixy == 0.0 and ixz == 0.0 and iyz == 0.0:
                file_diag = np.array([ixx, iyy, izz], dtype=float)
            else:
                tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]], dtype=float)
                file_diag, axes = _jacobi_principal(tensor)
                orn = quat_from_matrix(quat_to_matrix(orn) @ axes)
            x, y, z = file_diag
            if min(x, y, z) < 0 or x > y + z or y > x + z or z > x + y:
                file_diag = np.zeros(3)
                orn = quat_from_rpy(ine.origin_rpy)
        diag = tuple(float(v) for v in file_diag)
    else:
        diag = collision_aabb_inertia(link, mass, (pos, orn), vertices)
    if mass and inertia_scaling != 1.0:
        diag = tuple(v * inertia_scaling for v in diag)
    return LinkInertial(mass, diag, pos, orn)  # type: ignore[arg-type]


def inertia_scalings(model: UrdfModel) -> dict[str, float]:
    """Bullet's ``<contact><inertia_scaling value=..>`` per link name (links without one are
    left out). Read from the URDF text, since :class:`~simbridge.urdf.Contact` has no field for
    it."""
    import xml.etree.ElementTree as ET

    if "inertia_scaling" not in model.source.text:
        return {}
    out: dict[str, float] = {}
    for link in ET.fromstring(model.source.text).findall("link"):
        elem = link.find("contact/inertia_scaling")
        if elem is not None and elem.get("value") is not None:
            try:
                out[link.get("name", "")] = float(elem.get("value", "1"))
            except ValueError:
                continue
    return out


def model_inertials(
    model: UrdfModel,
    fixed_base: bool,
    inertia_source: str,
    vertices: Callable[[Path], np.ndarray] = mesh_vertices,
) -> list[LinkInertial]:
    """:func:`link_inertial` of every link, in PyBullet order (base first)."""
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


# ---------------------------------------------------------------- joint table


def joint_table(
    model: UrdfModel,
    fixed_base: bool,
    inertials: Sequence[LinkInertial],
) -> list[JointInfo]:
    """The rows of ``p.getJointInfo`` for every joint of ``model``.

    ``inertials[i + 1]`` is link i's inertial frame (``inertials[0]`` the base), as
    :func:`link_inertial` gives them for the profile's inertia source. Fields:

    * ``q_index``/``u_index``: PyBullet's state layout, after 7 position and 6 velocity
      base coordinates (PyBullet counts them for a fixed base too); -1 for fixed joints;
    * ``flags``: 1 for revolute and prismatic joints (they carry the default motor), else 0;
    * ``axis``: the URDF axis, as written (not normalised), turned into the child's inertial
      frame; (0, 0, 0) for fixed joints;
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
        fpos, jorn = transform_multiply(
            inv_parent, (joint.origin_xyz, quat_from_rpy(joint.origin_rpy))
        )
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
