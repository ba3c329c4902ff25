"""Build plans of an MJCF model as MuJoCo compiled it, for the engines that are not MuJoCo
(``load_mjcf(source, semantics="mujoco")`` on PyBullet and PhysX).

The compiled ``MjModel`` (:mod:`simbridge.model.mjcf_native`) is the truth; this module turns
each of its top-level bodies into a :class:`~simbridge.model.plan_records.BuildPlan`, the
records every engine builder already reads, and the world body's geoms (the ground) into one
more, static. The links are the joint-table rows of :func:`~simbridge.model.mjcf_native.
native_bodies` (link -1 the base, link i the row i), so the backends' joint indices are
MuJoCo's joint order:

* **frames**: a row's link frame is its MuJoCo body's frame moved to the joint's anchor
  (``jnt_pos``), at ``qpos0``; a free or fixed base's link frame is the body frame; a massless
  root's is the body frame at ``qpos0``. ``JointPlan.position``/``orientation`` place the
  child link frame in the parent's; the axis is ``jnt_axis`` (body frame, unit); a ball joint
  is a ``spherical`` joint about the anchor, never limited in the plan (MuJoCo's cone is the
  backend's force: ``backends/mjcf_forces.py``);
* **inertia**: MuJoCo's ``body_mass``, ``body_inertia`` in the ``body_iquat`` frame at
  ``body_ipos``. A body without a joint moves with its nearest ancestor's row (or the base);
  its mass is merged into that link (the composite's mass, centre of mass and principal
  inertia, exact for a welded body). A body with several joints gives the body's mass to its
  last row; the rows before it are massless links;
* **geoms**: ``plane``, ``sphere``, ``capsule``, ``cylinder``, ``box`` and ``mesh`` (MuJoCo's
  compiled vertices, in the geom frame) are the plan's shapes, placed from MuJoCo's geom
  frames at ``qpos0``; an ``ellipsoid`` becomes the convex hull of
  :data:`ELLIPSOID_POINTS` points on its surface (a named departure); a height field is refused;
* **contacts**: a geom with ``contype`` and ``conaffinity`` 0 is no collision shape, nor is
  any geom where ``<option><flag contact="disable"/>`` turns MuJoCo's contacts off; a link's
  friction is its first colliding geom's: sliding always, torsional
  when its ``condim`` >= 4, rolling when 6 (:class:`~simbridge.model.plan_records.
  ContactValues`, restitution 0); its filter is that geom's ``contype`` (group) and
  ``conaffinity`` (mask), MuJoCo's rule being the plan's OR rule; the parent-child pairs
  MuJoCo filters (``filterparent``) and every ``<contact><exclude>`` within one body are
  ``excluded_pairs``; one between two top-level bodies is :func:`cross_excludes`';
* **visuals** (only when asked: a window draws them, nothing simulates them): every geom
  MuJoCo's viewer shows by default (``geom_group`` 0-2, alpha above 0), visual-only geoms
  included, in its colour (its material's ``rgba`` where it has one, else the geom's); a plane
  is a box 2 mm thick under it, as wide as the plane (100 m where MuJoCo's is infinite); an
  ellipsoid is not drawn;
* **refused** (:func:`refuse_unsimulated`): what no engine but MuJoCo simulates: tendons,
  equality constraints, flex (composite) bodies, explicit ``<contact><pair>``, actuators that
  are not on a joint or that carry activation dynamics, height fields, and a body that hangs
  from a free joint below the top (a nested free joint).

Every departure the build makes is named in :func:`plan_departures`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from simbridge.exceptions import MjcfFeatureUnsupportedError
from simbridge.model.inertia import LinkInertial
from simbridge.model.mjcf_native import NativeBody, NativeMjcf
from simbridge.model.plan_records import (
    BuildPlan,
    CollisionFilter,
    ContactValues,
    GroundPlan,
    JointPlan,
    LinkPlan,
    MeshPlan,
    ShapePlan,
)
from simbridge.transforms import quat_rotate
from simbridge.types import JointType, Quat, Vec3

__all__ = [
    "ELLIPSOID_POINTS",
    "cross_excludes",
    "ground_plan",
    "mixed_links",
    "native_plans",
    "plan_departures",
    "refuse_unsimulated",
]

ELLIPSOID_POINTS = 162
"""Points on an ellipsoid's surface whose convex hull stands for it (an icosphere of two
subdivisions; the hull's volume is 0.96 of the ellipsoid's)."""

_G = mujoco.mjtGeom
_KIND = {
    int(_G.mjGEOM_PLANE): "plane",
    int(_G.mjGEOM_SPHERE): "sphere",
    int(_G.mjGEOM_CAPSULE): "capsule",
    int(_G.mjGEOM_CYLINDER): "cylinder",
    int(_G.mjGEOM_BOX): "box",
    int(_G.mjGEOM_MESH): "mesh",
    int(_G.mjGEOM_ELLIPSOID): "ellipsoid",
}
_JOINT_KIND = {
    JointType.REVOLUTE: "continuous",
    JointType.PRISMATIC: "prismatic",
    JointType.SPHERICAL: "spherical",
}


def _xyzw(q: np.ndarray) -> Quat:
    return (float(q[1]), float(q[2]), float(q[3]), float(q[0]))


def _v(a: np.ndarray) -> Vec3:
    return (float(a[0]), float(a[1]), float(a[2]))


def _mat(q: np.ndarray) -> np.ndarray:
    out = np.empty(9)
    mujoco.mju_quat2Mat(out, np.asarray(q, dtype=float))
    return out.reshape(3, 3)


def _quat(r: np.ndarray) -> np.ndarray:
    out = np.empty(4)
    mujoco.mju_mat2Quat(out, np.ascontiguousarray(r, dtype=float).reshape(9))
    return out


def refuse_unsimulated(native: NativeMjcf, backend: str) -> None:
    """Refuse a model with a feature the engine ``backend`` cannot simulate (item 6).

    Args:
        native: The compiled model.
        backend: The engine's backend name (for the message).

    Raises:
        MjcfFeatureUnsupportedError: The first such feature, naming it and its element.
    """
    m = native.model

    def no(feature: str, kind: Any, i: int, why: str) -> MjcfFeatureUnsupportedError:
        name = mujoco.mj_id2name(m, kind, i) or f"#{i}"
        return MjcfFeatureUnsupportedError(native.display_name, backend, feature, name, why)

    o = mujoco.mjtObj
    if m.ntendon:
        raise no("<tendon>", o.mjOBJ_TENDON, 0, "a tendon couples joints through its length")
    if m.neq:
        raise no("<equality>", o.mjOBJ_EQUALITY, 0, "equality constraints are MuJoCo's rows")
    if m.nflex:
        raise no("<flex>/<composite>", o.mjOBJ_FLEX, 0, "deformable bodies are MuJoCo's")
    if m.npair:
        raise no("<contact><pair>", o.mjOBJ_PAIR, 0, "explicit contact pairs are MuJoCo's")
    for i in range(m.nu):
        if int(m.actuator_trntype[i]) != int(mujoco.mjtTrn.mjTRN_JOINT):
            raise no("<actuator> not on a joint", o.mjOBJ_ACTUATOR, i, "only joint actuators")
        if int(m.actuator_dyntype[i]) != int(mujoco.mjtDyn.mjDYN_NONE) or m.actuator_actadr[i] >= 0:
            raise no("<actuator> with activation dynamics", o.mjOBJ_ACTUATOR, i, "no act state")
        j = int(m.actuator_trnid[i][0])
        if int(m.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_BALL), int(mujoco.mjtJoint.mjJNT_FREE)):
            raise no("<actuator> on a ball or free joint", o.mjOBJ_ACTUATOR, i, "hinge/slide only")
    for g in range(m.ngeom):
        if int(m.geom_type[g]) not in _KIND:
            raise no("<geom type='hfield'>", o.mjOBJ_GEOM, g, "height fields are MuJoCo's")
    for j in range(m.njnt):
        if int(m.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_FREE):
            b = int(m.jnt_bodyid[j])
            if m.body_parentid[b] != 0 or m.body_jntadr[b] != j:
                raise no("a nested <freejoint>", o.mjOBJ_JOINT, j, "free joints at the top only")


class _Frames:
    """World frames of the compiled model at ``qpos0`` (``mj_kinematics``)."""

    def __init__(self, m: Any) -> None:
        d = mujoco.MjData(m)
        mujoco.mj_kinematics(m, d)
        self.m, self.d = m, d

    def body(self, b: int) -> tuple[np.ndarray, np.ndarray]:
        """Body frame (position, 3x3 rotation) in the world."""
        return self.d.xpos[b].copy(), self.d.xmat[b].reshape(3, 3).copy()

    def link(self, nb: NativeBody, row: int) -> tuple[np.ndarray, np.ndarray]:
        """Row ``row``'s link frame (the body frame at the joint's anchor); -1: the base."""
        if row < 0:
            return self.body(nb.body_id)
        j = nb.joint_ids[row]
        pos, rot = self.body(nb.link_bodies[row])
        return pos + rot @ self.m.jnt_pos[j], rot


def _owner(m: Any, nb: NativeBody) -> dict[int, int]:
    """MuJoCo body -> the row whose link carries it (-1: the base), for the body's subtree."""
    last: dict[int, int] = {}
    for row, b in enumerate(nb.link_bodies):
        last[b] = row
    out: dict[int, int] = {}
    for b in range(nb.body_id, m.nbody):
        if m.body_rootid[b] != nb.body_id:
            continue
        a = b
        while a != nb.body_id and a not in last:
            a = int(m.body_parentid[a])
        out[b] = last.get(a, -1)
    return out


def _composite(
    m: Any, fr: _Frames, bodies: list[int], frame: tuple[np.ndarray, np.ndarray]
) -> LinkInertial:
    """The welded bodies' mass, centre of mass and principal inertia in a link frame."""
    fp, fr_rot = frame
    mass = sum(float(m.body_mass[b]) for b in bodies)
    if mass <= 0.0:
        return LinkInertial(0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    coms, tensors = [], []
    for b in bodies:
        com = fr_rot.T @ (fr.d.xipos[b] - fp)
        rot = fr_rot.T @ fr.d.ximat[b].reshape(3, 3)
        coms.append(com)
        tensors.append(rot @ np.diag(m.body_inertia[b]) @ rot.T)
    masses = np.array([float(m.body_mass[b]) for b in bodies])
    c = (masses[:, None] * np.array(coms)).sum(axis=0) / mass
    total = np.zeros((3, 3))
    for mb, com, t in zip(masses, coms, tensors, strict=True):
        r = com - c
        total += t + mb * (float(r @ r) * np.eye(3) - np.outer(r, r))
    if len(bodies) == 1:  # MuJoCo's own principal frame, unchanged
        b = bodies[0]
        rot = fr_rot.T @ fr.d.ximat[b].reshape(3, 3)
        return LinkInertial(mass, _v(m.body_inertia[b]), _v(c), _xyzw(_quat(rot)))
    w, vecs = np.linalg.eigh(0.5 * (total + total.T))
    if np.linalg.det(vecs) < 0:
        vecs[:, 2] *= -1.0
    return LinkInertial(mass, _v(w), _v(c), _xyzw(_quat(vecs)))


def _ellipsoid_points(radii: np.ndarray) -> np.ndarray:
    """ELLIPSOID_POINTS points on an ellipsoid (an icosphere of two subdivisions, scaled)."""
    t = (1.0 + 5.0**0.5) / 2.0
    verts = [
        (-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
        (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1),
    ]  # fmt: skip
    faces = [
        (0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
        (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
        (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1),
    ]  # fmt: skip
    pts = [np.array(v, dtype=float) / np.linalg.norm(v) for v in verts]
    for _ in range(2):
        cache: dict[tuple[int, int], int] = {}
        new_faces = []
        for a, b, c in faces:
            mids = []
            for i, j in ((a, b), (b, c), (c, a)):
                key = (min(i, j), max(i, j))
                if key not in cache:
                    mid = pts[i] + pts[j]
                    pts.append(mid / np.linalg.norm(mid))
                    cache[key] = len(pts) - 1
                mids.append(cache[key])
            ab, bc, ca = mids
            new_faces += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new_faces
    return np.array(pts) * radii


def _shape(
    native: NativeMjcf, fr: _Frames, g: int, frame: tuple[np.ndarray, np.ndarray], k: int
) -> ShapePlan:
    """Geom ``g`` as a plan shape in a link frame."""
    m = native.model
    name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}"
    kind = _KIND[int(m.geom_type[g])]
    fp, frot = frame
    pos = frot.T @ (fr.d.geom_xpos[g] - fp)
    rot = frot.T @ fr.d.geom_xmat[g].reshape(3, 3)
    size = m.geom_size[g]
    mesh, ground = None, None
    out_size: tuple[float, ...] = ()
    if kind == "plane":  # MuJoCo's planes are infinite for collisions
        out_size = (0.0, 0.0, 1.0)
        ground = GroundPlan(_v(pos), _xyzw(_quat(rot)), None)
    elif kind == "sphere":
        out_size = (float(size[0]),)
    elif kind in ("capsule", "cylinder"):
        out_size = (float(size[0]), 2.0 * float(size[1]))
    elif kind == "box":
        out_size = tuple(2.0 * float(v) for v in size[:3])
    else:  # mesh, or an ellipsoid as a hull
        if kind == "mesh":
            mid = int(m.geom_dataid[g])
            a, n = int(m.mesh_vertadr[mid]), int(m.mesh_vertnum[mid])
            verts = np.array(m.mesh_vert[a : a + n], dtype=float)
            fa, fn = int(m.mesh_faceadr[mid]), int(m.mesh_facenum[mid])
            faces = np.array(m.mesh_face[fa : fa + fn], dtype=np.int64)
            uri = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_MESH, mid) or f"mesh{mid}"
        else:
            verts = _ellipsoid_points(np.asarray(size[:3], dtype=float))
            faces = np.zeros((0, 3), dtype=np.int64)
            uri = f"ellipsoid {name!r}"
        kind = "mesh"
        out_size = (1.0, 1.0, 1.0)
        mesh = MeshPlan(Path(native.display_name), uri, (1.0, 1.0, 1.0), verts, verts, faces)
    return ShapePlan(k, kind, _v(pos), _xyzw(_quat(rot)), out_size, mesh, False, ground, None, name)


# <option><flag contact="disable"/> (or constraint="disable"): MuJoCo makes no contact at all
_NO_CONTACT = int(mujoco.mjtDisableBit.mjDSBL_CONTACT) | int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)


def _colliding(m: Any, bodies: list[int]) -> list[int]:
    """The bodies' geoms that can touch anything (``contype`` or ``conaffinity`` not 0): a
    geom with both 0 is MuJoCo's visual-only geom and is no collision shape here; none where
    the file's ``<option><flag contact="disable"/>`` (or ``constraint="disable"``) turns
    MuJoCo's contacts off."""
    if m.opt.disableflags & _NO_CONTACT:
        return []
    return [
        g
        for b in bodies
        for g in range(int(m.body_geomadr[b]), int(m.body_geomadr[b] + m.body_geomnum[b]))
        if m.geom_contype[g] or m.geom_conaffinity[g]
    ]


VISIBLE_GROUPS = 3  # MuJoCo's viewer shows geom groups 0, 1 and 2 by default
PLANE_THICKNESS = 0.002  # m: a drawn plane's box
INFINITE_PLANE = 50.0  # m: the half size drawn for a plane MuJoCo makes infinite (size 0)


def _visible(m: Any, bodies: list[int]) -> list[int]:
    """The bodies' geoms MuJoCo's viewer draws by default (groups 0-2, alpha above 0), but
    ellipsoids (no drawn shape here)."""
    return [
        g
        for b in bodies
        for g in range(int(m.body_geomadr[b]), int(m.body_geomadr[b] + m.body_geomnum[b]))
        if int(m.geom_group[g]) < VISIBLE_GROUPS
        and _rgba(m, g)[3] > 0.0
        and int(m.geom_type[g]) != int(mujoco.mjtGeom.mjGEOM_ELLIPSOID)
    ]


def _rgba(m: Any, g: int) -> tuple[float, float, float, float]:
    """Geom ``g``'s colour as MuJoCo's viewer takes it: its material's, else its own."""
    mat = int(m.geom_matid[g])
    c = m.mat_rgba[mat] if mat >= 0 else m.geom_rgba[g]
    return (float(c[0]), float(c[1]), float(c[2]), float(c[3]))


def _visual(
    native: NativeMjcf, fr: _Frames, g: int, frame: tuple[np.ndarray, np.ndarray], k: int
) -> ShapePlan:
    """Geom ``g`` as a visual shape in a link frame (a plane: a thin box under it)."""
    m = native.model
    s = _shape(native, fr, g, frame, k)
    if s.kind == "plane":
        half = [float(v) if v > 0 else INFINITE_PLANE for v in m.geom_size[g][:2]]
        down = quat_rotate(s.orientation, (0.0, 0.0, -0.5 * PLANE_THICKNESS))
        position = (s.position[0] + down[0], s.position[1] + down[1], s.position[2] + down[2])
        s = replace(
            s, kind="box", position=position, size=(2 * half[0], 2 * half[1], PLANE_THICKNESS)
        )
    return replace(s, ground=None, rgba=_rgba(m, g))


def _key(m: Any, g: int) -> tuple[Any, ...]:
    """What a link takes of one geom: friction, condim, contype, conaffinity."""
    return (tuple(m.geom_friction[g]), int(m.geom_condim[g]), int(m.geom_contype[g]),
            int(m.geom_conaffinity[g]))  # fmt: skip


def mixed_links(native: NativeMjcf) -> tuple[str, ...]:
    """The links whose colliding geoms differ in friction, ``condim``, ``contype`` or
    ``conaffinity``: the link takes its first geom's (the departure ``link_contact_values``).

    Args:
        native: The compiled model.

    Returns:
        The links' names (a row's link, or a top-level body for its base).
    """
    m = native.model
    out = []
    for nb in native.bodies:
        owner = _owner(m, nb)
        for row in range(-1, len(nb.table)):
            keys = {_key(m, g) for g in _colliding(m, [b for b, r in owner.items() if r == row])}
            if len(keys) > 1:
                out.append(nb.name if row < 0 else nb.table[row].link_name)
    return tuple(out)


def _contact(m: Any, geoms: list[int]) -> tuple[ContactValues, CollisionFilter]:
    """A link's friction and filter: its first colliding geom's (MuJoCo's condim rule)."""
    if not geoms:
        return ContactValues(1.0, 0.0, 0.0, 0.0), CollisionFilter(0, 0)
    g = geoms[0]
    fr, condim = m.geom_friction[g], int(m.geom_condim[g])
    values = ContactValues(
        float(fr[0]),
        float(fr[2]) if condim >= 6 else 0.0,
        float(fr[1]) if condim >= 4 else 0.0,
        0.0,
    )
    return values, CollisionFilter(int(m.geom_contype[g]), int(m.geom_conaffinity[g]))


def _joint_plan(m: Any, nb: NativeBody, row: int, fr: _Frames, limits: bool) -> JointPlan:
    """Row ``row``'s joint: the child link frame in the parent's, MuJoCo's axis and range
    (none when ``limits`` is False)."""
    info = nb.table[row]
    j = nb.joint_ids[row]
    pp, prot = fr.link(nb, info.parent_index)
    cp, crot = fr.link(nb, row)
    kind = _JOINT_KIND[info.type]
    limited = limits and bool(m.jnt_limited[j]) and kind != "spherical"
    if kind == "continuous" and limited:
        kind = "revolute"
    return JointPlan(
        row,
        info.name,
        kind,
        info.parent_index,
        _v(prot.T @ (cp - pp)),
        _xyzw(_quat(prot.T @ crot)),
        _v(m.jnt_axis[j]) if kind != "spherical" else (0.0, 0.0, 0.0),
        limited,
        info.lower_limit if limited else 0.0,
        info.upper_limit if limited else -1.0,
        0.0,
        0.0,
        0.0,  # damping, friction and armature: applied by the backend (plan_departures)
        0.0,
    )


def _excluded(m: Any, nb: NativeBody, owner: dict[int, int]) -> frozenset[tuple[int, int]]:
    """Link pairs MuJoCo never lets touch: parent and child bodies (``filterparent``; not where
    either is welded to the world, as MuJoCo's rule has it: a fixed-base root touches its
    children) and the file's ``<contact><exclude>`` pairs, as rows (-1 = the base)."""
    pairs: set[tuple[int, int]] = set()
    parent_filter = not (m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT))
    for b, row in owner.items():
        if b == nb.body_id or not parent_filter:
            continue
        p = int(m.body_weldid[m.body_parentid[b]])
        if p == 0 or int(m.body_weldid[b]) == 0:  # the world's weld: MuJoCo does not filter
            continue
        prow = owner.get(p, -1)
        if prow != row:
            pairs.add((min(row, prow), max(row, prow)))
    for k in range(m.nexclude):
        sig = int(m.exclude_signature[k])
        b1, b2 = sig >> 16, sig & 0xFFFF
        if b1 in owner and b2 in owner and owner[b1] != owner[b2]:
            r1, r2 = owner[b1], owner[b2]
            pairs.add((min(r1, r2), max(r1, r2)))
    return frozenset(pairs)


def cross_excludes(native: NativeMjcf) -> tuple[tuple[int, int, int, int, str], ...]:
    """The ``<contact><exclude>`` pairs between two top-level bodies (or one and the world
    body), which no single plan holds.

    Args:
        native: The compiled model.

    Returns:
        ``(plan a, link a, plan b, link b, "body1/body2")`` per pair: plans by index in
        :func:`native_plans` (-1: the world body's :func:`ground_plan`, link -1), links by row
        (-1 = the base).
    """
    m = native.model
    where: dict[int, tuple[int, int]] = {0: (-1, -1)}
    for k, nb in enumerate(native.bodies):
        for b, row in _owner(m, nb).items():
            where[b] = (k, row)
    out = []
    for i in range(m.nexclude):
        sig = int(m.exclude_signature[i])
        b1, b2 = sig >> 16, sig & 0xFFFF
        (k1, r1), (k2, r2) = where.get(b1, (-1, -1)), where.get(b2, (-1, -1))
        if k1 != k2:
            names = [
                mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}" for b in (b1, b2)
            ]
            out.append((k1, r1, k2, r2, "/".join(names)))
    return tuple(out)


def native_plans(
    native: NativeMjcf, limits: bool = True, visuals: bool = False
) -> tuple[BuildPlan, ...]:
    """One build plan per top-level body of the compiled model (the module docstring).

    Args:
        native: The compiled model.
        limits: Whether the joints carry MuJoCo's ranges as the engine's own limits (False:
            no joint is limited in the plan; the backend applies MuJoCo's soft limit itself).
        visuals: Whether the links carry visual shapes (for a window; none otherwise).

    Returns:
        The plans, in MuJoCo's order of the top-level bodies; link i of plan k is row i of
        ``native.bodies[k].table``.
    """
    m = native.model
    fr = _Frames(m)
    out = []
    for nb in native.bodies:
        owner = _owner(m, nb)
        links = []
        for row in range(-1, len(nb.table)):
            frame = fr.link(nb, row)
            carried = [b for b, r in owner.items() if r == row]
            geoms = _colliding(m, carried)
            contact, filt = _contact(m, geoms)
            shapes = tuple(_shape(native, fr, g, frame, k) for k, g in enumerate(geoms))
            fixed = row < 0 and nb.free_joint < 0
            inertial = _composite(m, fr, carried, frame)
            if fixed:
                inertial = inertial._replace(mass=0.0)
            links.append(
                LinkPlan(
                    row,
                    nb.name if row < 0 else nb.table[row].link_name,
                    None if row < 0 else nb.table[row].parent_index,
                    None if row < 0 else _joint_plan(m, nb, row, fr, limits),
                    inertial,
                    fixed,
                    tuple(s for s in shapes if s.kind != "plane" or row < 0),
                    _visuals(native, fr, carried, frame) if visuals else (),
                    contact,
                    filt,
                )
            )
        pos, rot = fr.body(nb.body_id)
        out.append(
            BuildPlan(
                nb.name,
                native.display_name,
                nb.free_joint < 0,
                _v(pos),
                _xyzw(_quat(rot)),
                bool(np.allclose(rot[:, 2], (0.0, 0.0, 1.0))),
                "file",
                tuple(links),
                "exclude_parent",
                _excluded(m, nb, owner),
            )
        )
    return tuple(out)


def _visuals(
    native: NativeMjcf, fr: _Frames, bodies: list[int], frame: tuple[np.ndarray, np.ndarray]
) -> tuple[ShapePlan, ...]:
    """The visual shapes of the geoms of ``bodies`` drawn in the link ``frame``."""
    return tuple(
        _visual(native, fr, g, frame, k) for k, g in enumerate(_visible(native.model, bodies))
    )


def ground_plan(native: NativeMjcf, visuals: bool = False) -> BuildPlan | None:
    """The world body's geoms (the ground and any fixed scenery) as one static plan.

    Args:
        native: The compiled model.
        visuals: Whether the link carries visual shapes (for a window; none otherwise).

    Returns:
        A fixed-base plan of one link at the world origin, or None when the world body has
        no colliding geom (and, with ``visuals``, none drawn).
    """
    m = native.model
    geoms = _colliding(m, [0])
    if not geoms and not (visuals and _visible(m, [0])):
        return None
    fr = _Frames(m)
    frame = (np.zeros(3), np.eye(3))
    contact, filt = _contact(m, geoms)
    shapes = tuple(_shape(native, fr, g, frame, k) for k, g in enumerate(geoms))
    drawn = _visuals(native, fr, [0], frame) if visuals else ()
    zero = LinkInertial(0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    link = LinkPlan(-1, "world", None, None, zero, True, shapes, drawn, contact, filt)
    return BuildPlan(
        "world", native.display_name, True, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0), True,
        "file", (link,), "off",
    )  # fmt: skip


def plan_departures(native: NativeMjcf, engine: str, texts: Mapping[str, str]) -> dict[str, str]:
    """The MuJoCo features of this model an engine does not reproduce, each named with what is
    done instead (the manifest's ``departures``; docs/mjcf_mujoco_reading.md measures them).

    Args:
        native: The compiled model.
        engine: The engine's name, as the texts say it.
        texts: What the engine does instead of MuJoCo's ``"armature"``, ``"joint_damping"``,
            ``"frictionloss"`` and ``"ball_joints"`` (its backend's own words: each engine
            simulates them its own way); each used where the model exercises it.

    Returns:
        Departure name -> what is done instead; only those this model exercises.
    """
    m = native.model
    out: dict[str, str] = {
        "mujoco_soft_contacts": "MuJoCo's soft contacts (solref/solimp, margin, gap) are "
        f"{engine}'s own rigid contacts",
        "integrator": f"MuJoCo's {mujoco.mjtIntegrator(int(m.opt.integrator)).name} is "
        f"{engine}'s own time stepping",
        "friction_combination": "a pair's friction is the engine's combination, not MuJoCo's "
        "element-wise max; one friction per link (its first colliding geom's)",
    }
    if m.jnt_limited.any():
        out["joint_limits"] = (
            "a joint's range is MuJoCo's soft limit computed here, a force each step: "
            "d m_eff (a_ref - a0) from solref/solimp, one row at a time, never pulling; the "
            "engine's own limits are off"
        )
    if m.dof_armature.any():
        out["armature"] = texts["armature"]
    if m.dof_damping.any():
        out["joint_damping"] = texts["joint_damping"]
    if m.dof_frictionloss.any():
        out["frictionloss"] = texts["frictionloss"]
    touching = [
        f"{plan.link(lk.parent).name}/{lk.name}"
        for plan in native_plans(native)
        for lk in plan.links[1:]
        if lk.parent is not None
        and (min(lk.parent, lk.index), max(lk.parent, lk.index)) not in plan.excluded_pairs
        and lk.collisions
        and plan.link(lk.parent).collisions
    ]
    if touching:
        out["parent_child_contacts"] = (
            "a joint's parent and child links never touch in the engine, where MuJoCo lets a "
            f"body welded to the world touch its child: {touching}"
        )
    mixed = mixed_links(native)
    if mixed:
        out["link_contact_values"] = (
            "one friction, condim and contype/conaffinity per link, its first colliding geom's; "
            f"these links' geoms differ: {list(mixed)}"
        )
    if (m.geom_type == int(_G.mjGEOM_ELLIPSOID)).any():
        out["ellipsoid"] = f"an ellipsoid is the convex hull of {ELLIPSOID_POINTS} points on it"
    if (m.jnt_type == int(mujoco.mjtJoint.mjJNT_BALL)).any():
        out["ball_joints"] = texts["ball_joints"]
    if m.nu:
        out["actuators"] = (
            "actuator forces are MuJoCo's formulas (gain, bias, gear, ctrlrange, forcerange) "
            "evaluated at the start of each step and held through it"
        )
    return out
