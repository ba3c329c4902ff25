"""MJCF as PyBullet 3.2.7's ``loadMJCF`` reads it: one :class:`~simbridge.model.scene.SceneBody`
per body it creates, with its links, joints, numbering and names.

Read in bullet3's ``Importers/ImportMJCFDemo/BulletMJCFImporter.cpp`` and
``ImportURDFDemo/URDF2Bullet.cpp`` and measured on pybullet 3.2.7 (every MJCF file of
pybullet_data: ``tests/conformance/test_mjcf_sdf.py``). PyBullet's importer is not MuJoCo's:

* **bodies**: every ``<worldbody>`` child ``<body>`` is one PyBullet body, and so is every
  ``<worldbody>`` child ``<geom>`` (a static body of one link named after the geom, or
  ``anonymous``); a top-level body with a ``free`` joint (or none) is a free base placed at
  the body's ``pos``/``quat``, its centre of mass there (not its frame: PyBullet places an
  MJCF base's inertial frame at the body frame);
* **links and joints**: each MJCF body is one link named after it (``link<body>_<k>`` when
  unnamed). A body hangs from its parent by a fixed joint ``jointfix_<n>_<parent link>``;
  each of its joints adds a massless link ``link<body>_<k>`` between them, so a body with two
  hinges is three links. A top-level body whose first joint is not ``free`` hangs from a
  massless root link at the world origin (a fixed base). PyBullet numbers the ``<n>`` of those
  names with a counter that lives as long as the process (a second load of a file in the same
  process gets other numbers); simbridge numbers them as a first load in a fresh process does;
* **joints**: ``hinge`` (revolute when ``limited="true"``, else continuous), ``slide``
  (prismatic), ``fixed``; ``ball`` and nested ``free`` joints are not read by PyBullet (it
  drops the body's subtree from its tree): refused here with
  :class:`~simbridge.exceptions.UnsupportedJointError`. ``limited`` comes from the joint or the
  top-level ``<default><joint>``, never from a class; an unlimited joint reports the range
  1..0 (none); hinge ranges are degrees unless ``<compiler angle="radian">``, converted in
  float32 arithmetic. A joint's ``pos`` moves its frame; a second joint of one body is placed
  relative to the first joint's frame, as PyBullet does;
* **numbers**: vectors are read as float32 (``0.1`` is 0.10000000149011612); masses and sphere
  radii as double;
* **mass**: an ``<inertial mass>``, else 1000 kg/m³ times the volume of the body's geoms
  (``density`` is not read); the inertial frame is the ``<inertial>``'s, else the middle of the
  last geom's ``fromto`` (or the body origin when the last geom has none); the moments are
  PyBullet's box around the shapes (:func:`bullet_moments`), never ``diaginertia`` or MuJoCo's;
* **contacts**: each link takes its last geom's ``friction[0]`` as lateral friction (the
  spinning and rolling values of ``<default><geom friction>`` when ``condim`` > 3 and > 4), and
  its last geom's ``contype``/``conaffinity`` as its collision group and mask (PyBullet pairs two
  links when ``group_a & mask_b or group_b & mask_a``);
* **not read by PyBullet** (listed per body in :attr:`SceneBody.ignored` and in the manifest):
  ``<option>`` (time step, integrator, gravity), joint ``damping``, ``armature``,
  ``stiffness``, ``frictionloss``, ``margin``, geom ``density``, ``margin``, ``solref``,
  ``solimp``, ``euler``/``axisangle`` on bodies, ``<actuator>``, ``<tendon>``, ``<contact>``,
  ``<equality>``, ``<sensor>``, ``<keyframe>``; ``<include>`` (the included file is not
  loaded; one warning on the ``simbridge.model.mjcf`` logger names the file and the lines).
"""

from __future__ import annotations

import numpy as np

from simbridge.exceptions import UrdfStructureError
from simbridge.model.mjcf_reader import (
    IGNORED_JOINT_ATTRIBUTES,
    Pose,
    _Joint,
    _Link,
    _Model,
    _Reader,
    _Shape,
    _shortest_arc,
)
from simbridge.model.scene import SceneBody, check_names, line_of
from simbridge.model.urdf_model import Contact, Geometry, Inertial, Joint, Link, Vec3
from simbridge.model.urdf_source import UrdfSource
from simbridge.transforms import (
    IDENTITY_QUAT,
    quat_to_matrix,
    rpy_from_quat,
    transform_inverse,
    transform_multiply,
)

__all__ = ["parse_mjcf", "bullet_moments", "IGNORED_JOINT_ATTRIBUTES"]

CONVEX_MARGIN = 0.04  # m: Bullet's default margin of a convex shape (a fromto capsule's here)
MESH_MARGIN = 0.001  # m: the MJCF importer's collision margin of a mesh hull


# ---------------------------------------------------------------- moments


def _box_moments(mass: float, lengths: np.ndarray) -> Vec3:
    lx, ly, lz = (float(v) for v in lengths)
    k = mass / 12.0
    return (k * (ly * ly + lz * lz), k * (lx * lx + lz * lz), k * (lx * lx + ly * ly))


def _local_box(s: _Shape) -> tuple[np.ndarray, np.ndarray]:
    """(centre, half extents) of a shape's box in its geom frame, margins included as Bullet's
    ``getAabb`` counts them."""
    if s.kind == "sphere":
        return np.zeros(3), np.full(3, s.radius)
    if s.kind in ("box", "plane"):
        if s.kind == "plane":
            return np.zeros(3), np.full(3, 1e30)
        return np.zeros(3), np.asarray(s.half, dtype=float)
    if s.kind == "mesh":
        from simbridge.model.meshes import mesh_vertices

        assert s.mesh is not None
        v = mesh_vertices(s.mesh)
        v = v[np.isfinite(v).all(axis=1)]
        # an .stl: a hull whose box is cached while its margin is still Bullet's default 4 cm,
        # then read with the importer's 1 mm; an .obj: a compound (1 mm) of hulls (1 mm, twice)
        grow = CONVEX_MARGIN + MESH_MARGIN if s.mesh.suffix.lower() == ".stl" else 3 * MESH_MARGIN
        if len(v) == 0:
            return np.zeros(3), np.full(3, grow)
        lo, hi = v.min(axis=0), v.max(axis=0)
        return 0.5 * (lo + hi), 0.5 * (hi - lo) + grow
    r = s.radius
    if s.fromto is None:
        if s.kind == "capsule":
            return np.zeros(3), np.array([r, r, r + 0.5 * s.height])
        return np.zeros(3), np.array([r, r, 0.5 * s.height])
    a, b = np.asarray(s.fromto[0]), np.asarray(s.fromto[1])
    if s.kind == "capsule":  # a btMultiSphereShape: its cached box, then its margin once more
        lo, hi = np.minimum(a, b) - r, np.maximum(a, b) + r
        return 0.5 * (lo + hi), 0.5 * (hi - lo) + CONVEX_MARGIN
    # a cylinder along fromto: a compound (margin 0) of one btCylinderShapeZ, turned
    mid = 0.5 * (a + b)
    diff = b - a
    arc = IDENTITY_QUAT
    if float(diff @ diff) > np.finfo(float).eps:
        arc = _shortest_arc(diff / np.linalg.norm(diff))
    half = np.abs(quat_to_matrix(arc)) @ np.array([r, r, 0.5 * s.height])
    return mid, half


def _alone_moments(s: _Shape, mass: float) -> Vec3:
    """``calculateLocalInertia`` of the shape itself (it is its link's only shape, in the
    inertial frame)."""
    if s.kind == "plane":
        return (0.0, 0.0, 0.0)
    if s.kind == "sphere":
        v = 0.4 * mass * s.radius * s.radius
        return (v, v, v)
    if s.kind == "cylinder" and s.fromto is None:  # btCylinderShapeZ's solid cylinder
        r2 = s.radius * s.radius
        h2 = s.height * s.height
        t1 = mass / 12.0 * h2 + mass / 4.0 * r2
        return (t1, t1, mass / 2.0 * r2)
    if s.kind == "capsule" and s.fromto is not None:  # the multi-sphere's cached box
        a, b = np.asarray(s.fromto[0]), np.asarray(s.fromto[1])
        lo, hi = np.minimum(a, b) - s.radius, np.maximum(a, b) + s.radius
        return _box_moments(mass, hi - lo)
    half = _local_box(s)[1]
    if s.kind == "mesh" and s.mesh is not None and s.mesh.suffix.lower() == ".stl":
        half = half + MESH_MARGIN  # a hull's own inertia counts its margin once more
    return _box_moments(mass, 2.0 * half)


def bullet_moments(shapes: list[_Shape], mass: float, inertial: Pose) -> Vec3:
    """PyBullet's principal moments of an MJCF link (``calculateLocalInertia`` of the link's
    compound shape, whose margin is 0).

    One shape in that very frame gives its own rule (a solid sphere or cylinder, a box for the
    rest); otherwise the box inertia of the box around every shape's box turned into the
    inertial frame (a ``fromto`` capsule's box grown by 4 cm a side, Bullet's default margin of
    its multi-sphere shape).

    Args:
        shapes: The link's collision shapes, each with its frame in the link frame.
        mass: The link's mass (kg); 0 gives zero moments.
        inertial: The inertial frame (position in m, quaternion x, y, z, w) in the link frame.

    Returns:
        The moments in the inertial frame (kg·m²).
    """
    if mass == 0 or not shapes:
        return (0.0, 0.0, 0.0)
    inv = transform_inverse(inertial)
    placed = [(s, transform_multiply(inv, s.frame)) for s in shapes]
    if len(placed) == 1:
        s, (pos, quat) = placed[0]
        if tuple(pos) == (0.0, 0.0, 0.0) and tuple(quat) == IDENTITY_QUAT:
            return _alone_moments(s, mass)
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for s, (pos, quat) in placed:
        centre, half = _local_box(s)
        rot = quat_to_matrix(quat)
        c = rot @ centre + np.asarray(pos)
        h = half if s.kind in ("sphere", "plane") else np.abs(rot) @ half
        lo = np.minimum(lo, c - h)
        hi = np.maximum(hi, c + h)
    return _box_moments(mass, hi - lo)


# ---------------------------------------------------------------- core model


def _geometry(s: _Shape) -> Geometry:
    """The shape as the core's (and MuJoCo's) geometry: a ``fromto`` capsule or cylinder is
    one along the segment, in the geom's frame."""
    pos, quat = s.frame
    size: tuple[float, ...]
    if s.kind == "sphere":
        kind, size = "sphere", (s.radius,)
    elif s.kind == "box":
        kind, size = "box", tuple(2.0 * v for v in s.half)
    elif s.kind == "plane":
        kind, size = "plane", (0.0, 0.0, 1.0)
    elif s.kind == "mesh":
        kind, size = "mesh", (1.0, 1.0, 1.0)
    else:
        kind, size = s.kind, (s.radius, s.height)
        if s.fromto is not None:
            a, b = np.asarray(s.fromto[0]), np.asarray(s.fromto[1])
            diff = b - a
            arc = IDENTITY_QUAT
            if float(diff @ diff) > np.finfo(float).eps:
                arc = _shortest_arc(diff / np.linalg.norm(diff))
            m = 0.5 * (a + b)
            pos, quat = transform_multiply(
                (pos, quat), ((float(m[0]), float(m[1]), float(m[2])), arc)
            )
    return Geometry(
        kind,
        (pos[0], pos[1], pos[2]),
        rpy_from_quat(quat),
        size,
        mesh_path=s.mesh,
        mesh_uri=s.mesh_uri,
        rgba=s.rgba,
        name=s.name,
        origin_quat=(quat[0], quat[1], quat[2], quat[3]),
        line=s.line,
    )


def _order(model: _Model, file: str) -> tuple[list[_Link], list[_Joint]]:
    """PyBullet's order: the root (the first link without a parent), then depth first, each
    link's children in the order their joints were made."""
    child_of = {j.child: j for j in model.joints}
    roots = [link for link in model.links if link.name not in child_of]
    if len(roots) != 1:  # pragma: no cover - refused joint types make the only orphans
        raise UrdfStructureError(file, "<body>", f"{len(roots)} roots in one body", model.line)
    by_name = {link.name: link for link in model.links}
    children: dict[str, list[_Joint]] = {link.name: [] for link in model.links}
    for j in model.joints:
        children[j.parent].append(j)
    links = [roots[0]]
    joints: list[_Joint] = []
    stack = list(reversed(children[roots[0].name]))
    while stack:
        j = stack.pop()
        joints.append(j)
        links.append(by_name[j.child])
        stack.extend(reversed(children[j.child]))
    return links, joints


def _scene_body(
    reader: _Reader, model: _Model, index: int, model_name: str, src: UrdfSource
) -> SceneBody:
    file = reader.file
    check_names(file, "body", [(link.name, link.line) for link in model.links])
    check_names(file, "joint", [(j.name, j.line) for j in model.joints])
    ordered_links, ordered_joints = _order(model, file)
    links: list[Link] = []
    filters: dict[str, tuple[int | None, int | None]] = {}
    for k, bl in enumerate(ordered_links):
        pos, quat = bl.inertial
        moments = bullet_moments(bl.shapes, bl.mass, bl.inertial)
        diag = bl.file_diag if not reader.inertia_from_geom else (0.0, 0.0, 0.0)
        inertial = Inertial(
            pos,
            rpy_from_quat(quat),
            bl.mass,
            (diag[0], 0.0, 0.0, diag[1], 0.0, diag[2]),
            True,
            origin_quat=quat,
            line=bl.line,
            moments=moments,
        )
        shapes = [_geometry(s) for s in bl.shapes]
        contact = Contact(
            lateral_friction=bl.lateral,
            rolling_friction=bl.rolling,
            spinning_friction=bl.spinning,
        )
        links.append(Link(bl.name, inertial, list(shapes), shapes, contact, k - 1, bl.line))
        if bl.filter is not None:
            filters[bl.name] = bl.filter
    joints: list[Joint] = []
    for k, bj in enumerate(ordered_joints):
        (xyz, quat) = bj.origin
        joints.append(
            Joint(
                name=bj.name,
                type=bj.type,
                parent=bj.parent,
                child=bj.child,
                origin_xyz=xyz,
                origin_rpy=rpy_from_quat(quat),
                axis=bj.axis,
                lower=bj.lower,
                upper=bj.upper,
                effort=0.0,
                velocity=0.0,
                damping=0.0,
                friction=0.0,
                has_limit=bj.type in ("revolute", "prismatic") and bj.lower <= bj.upper,
                index=k,
                origin_quat=quat,
                line=bj.line,
            )
        )
    root = ordered_links[0]
    # PyBullet puts an MJCF base's inertial frame where the root's frame is
    base = transform_multiply(root.transform, transform_inverse(root.inertial))
    return SceneBody(
        model_name,
        src,
        links,
        joints,
        [],
        file_format="mjcf",
        body_index=index,
        base_position=base[0],
        base_orientation=base[1],
        collision_filters=filters,
        ignored=reader.file_ignored + model.ignored,
    )


def parse_mjcf(src: UrdfSource) -> list[SceneBody]:
    """The bodies ``p.loadMJCF`` creates from the file (see the module docstring), in its order.

    Args:
        src: The file, as :func:`~simbridge.model.scene.resolve_scene_source` gives it.

    Returns:
        One body per top-level ``<body>`` or ``<geom>`` of ``<worldbody>``.

    Raises:
        UrdfParseError, UrdfStructureError, MeshNotFoundError, UnsupportedJointError: naming
            the file, the line and the element.
    """
    reader = _Reader(src)
    models = reader.read()
    root = reader.root
    model_name = root.get("model", "")
    if not models:
        raise UrdfStructureError(
            reader.file,
            "<mujoco>",
            "has no <body> or <geom> in <worldbody>: PyBullet creates no body from it",
            line_of(root),
        )
    return [_scene_body(reader, m, k, model_name, src) for k, m in enumerate(models)]
