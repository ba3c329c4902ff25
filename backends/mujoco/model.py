"""URDF to MjSpec: one MuJoCo body per URDF link, built from the :class:`UrdfModel`.

MuJoCo's own URDF importer welds the root to the world, merges fixed-joint links, drops
visuals, reads neither .dae nor ``package://`` and turns ``<limit effort>`` into a force clamp,
so the bodies, joints, geoms and inertias are added here one by one:

* body ``<prefix><link name>`` per link, in PyBullet's order, its frame the URDF link frame;
  a free joint on the root unless the base is fixed (``fixed_base`` or a root of mass 0);
* hinge/slide joints at the body origin, axis normalised (MuJoCo requires it), range only for
  revolute/prismatic joints with lower <= upper (PyBullet's rule; lower == upper locks the joint,
  a range one ulp wide here); no damping, friction or
  force range in the model: the backend applies them per step with PyBullet's laws;
* a ball joint for a spherical joint, at the body origin (the joint origin). Bullet's joint
  quaternion turns the child's *inertial* frame and its velocity is in that frame, MuJoCo's
  ball turns the body frame: where a spherical joint's child has a rotated inertial frame, its
  body frame is the link frame turned by that rotation (``RobotSpec.link_offsets``), so that
  the ball's quaternion and velocity are PyBullet's as they are;
* explicit inertia from :func:`simbridge.inertia.model_inertials` (PyBullet's numbers for
  the profile), mass and inertia bounded below for moving bodies (MuJoCo refuses zero);
* visual geoms (``contype = conaffinity = 0``, group 1) and collision geoms (group 3), also
  ``contype = conaffinity = 0``: every contact comes from an explicit ``<pair>`` (see
  :func:`add_pairs`), which carries PyBullet's product friction;
* a huge static box (both horizontal sides >= 100 m, as pybullet_data's ``plane.urdf``,
  200 x 200 x 10 m) becomes an infinite plane at its top face.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field, replace

import mujoco
import numpy as np

from simbridge.exceptions import UrdfStructureError
from simbridge.inertia import LinkInertial, is_fixed_base, model_inertials
from simbridge.meshes import read_mesh
from simbridge.profiles import Profile
from simbridge.transforms import (
    quat_rotate,
    transform_inverse,
    transform_multiply,
    xyzw_to_wxyz,
)
from simbridge.types import Quat, Vec3
from simbridge.urdf import Geometry, Joint, Link, UrdfModel

from .motors import LIMIT_ERP, LIMIT_MARGIN, MOTOR_DMAX

__all__ = ["RobotSpec", "GeomContact", "add_robot", "add_pairs", "new_world_spec"]

VISUAL_GROUP = 1
COLLISION_GROUP = 3
PLANE_MIN_SIDE = 100.0  # m: a static box at least this wide in x and y is a ground plane
MIN_MASS = 1e-6  # kg, for a moving body whose URDF mass is 0 (MuJoCo refuses zero)
MIN_INERTIA = 1e-10  # kg m^2, likewise
MIN_SIZE = 1e-6  # m, for a collision shape of size 0
# Friction rows of the joint motors: as close to a hard constraint as MuJoCo allows, so the
# motor reaches the velocity it asks for within a step (see motors.py).
MOTOR_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)
DEFAULT_RGBA = (1.0, 1.0, 1.0, 1.0)


@dataclass(frozen=True)
class GeomContact:
    """A collision geom and the contact values of its link (PyBullet's meaning)."""

    name: str
    link: int  # PyBullet link index, -1 = base
    static: bool  # welded to the world
    lateral: float
    rolling: float
    spinning: float
    restitution: float
    is_plane: bool = False
    # Bullet's broadphase filter: two geoms collide when group_a & mask_b or group_b & mask_a
    # (PyBullet's default rule). A URDF link is group 1, mask -1 (all); a fixed base is group 2,
    # mask -1 ^ 2; an MJCF or SDF link may say otherwise (SceneBody.collision_filters)
    group: int = 1
    mask: int = -1


@dataclass
class RobotSpec:
    """What :func:`add_robot` put into the spec, by name (ids change on every compile)."""

    prefix: str
    root: mujoco.MjsBody
    body_names: list[str]  # index link + 1 (base first)
    joint_names: list[str | None]  # per URDF joint; None for fixed joints
    free_joint: str | None
    geoms: list[GeomContact]
    inertials: list[LinkInertial]
    bounded_links: list[str] = field(default_factory=list)  # mass/inertia raised for MuJoCo
    planes: list[str] = field(default_factory=list)
    pair_names: list[str] = field(default_factory=list)
    skipped_shapes: list[str] = field(default_factory=list)  # meshes without finite vertices
    # A free base's body frame is its centre-of-mass frame (PyBullet integrates the base there;
    # a free joint at the link frame moves the centre of mass with a first-order error when the
    # base spins): the URDF base link frame in that body's frame, None when they coincide.
    base_offset: tuple[Vec3, Quat] | None = None
    # link index -> the URDF link frame in its body's frame, for the children of spherical
    # joints whose inertial frame is rotated (their body frame is turned by it; see add_robot)
    link_offsets: dict[int, tuple[Vec3, Quat]] = field(default_factory=dict)
    # spherical joints whose PyBullet limit (swing x, swing y, twist) is not enforced here
    unlimited_spherical: list[str] = field(default_factory=list)


def new_world_spec(profile: Profile) -> mujoco.MjSpec:
    """An empty world with the profile's options."""
    spec = mujoco.MjSpec()
    spec.modelname = "simbridge"
    spec.compiler.fusestatic = False
    spec.compiler.discardvisual = False
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.compiler.autolimits = False
    spec.compiler.degree = False  # joint ranges in radians
    opt = spec.option
    opt.timestep = profile.timestep
    opt.gravity = list(profile.gravity)
    opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    opt.solver = mujoco.mjtSolver.mjSOL_NEWTON
    opt.iterations = profile.solver_iterations
    opt.cone = mujoco.mjtCone.mjCONE_PYRAMIDAL
    # islands copy efc_R/efc_D before the backend hardens the motor rows (motors.py)
    opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_ISLAND
    spec.visual.global_.offwidth = 640
    return spec


def _wxyz(q: Quat) -> list[float]:
    return list(xyzw_to_wxyz(q))


def _contact_values(link: Link, profile: Profile) -> tuple[float, float, float, float]:
    ct = link.contact
    read = profile.read_urdf_contact

    def pick(value: float | None, default: float) -> float:
        return float(value) if read and value is not None else default

    return (
        pick(ct.lateral_friction, profile.lateral_friction),
        pick(ct.rolling_friction, profile.rolling_friction),
        pick(ct.spinning_friction, profile.spinning_friction),
        pick(ct.restitution, profile.restitution),
    )


class MeshLibrary:
    """Mesh assets of one world spec, one per (file version, scale); .dae converted with
    trimesh. A file rewritten since (another modification time or size) is a new asset."""

    def __init__(self, spec: mujoco.MjSpec) -> None:
        self.spec = spec
        self.names: dict[tuple[str, int, int, tuple[float, ...]], str] = {}

    def usable(self, g: Geometry) -> bool:
        """False for a mesh PyBullet gets nothing from: no finite vertex (pybullet_data's
        random_urdfs/168 is all NaN) or an .obj without a readable triangle (PyBullet warns
        "cannot extract anything useful from mesh" and loads the link without it). Such a
        shape is left out here too (MuJoCo cannot compile it) and listed in the manifest."""
        assert g.mesh_path is not None
        try:
            verts, faces = read_mesh(g.mesh_path)
        except (OSError, ValueError, IndexError):
            return False
        if g.mesh_path.suffix.lower() == ".obj" and len(faces) == 0:
            return False
        return len(verts) > 0 and bool(np.isfinite(verts).all())

    def mark(self) -> int:
        """A point to roll back to (the number of meshes so far)."""
        return len(self.names)

    def rollback(self, mark: int) -> None:
        """Delete the meshes added since ``mark`` (a load that failed leaves none behind: a
        mesh MuJoCo cannot compile would break every later compile of the world)."""
        for key, name in list(self.names.items())[mark:]:
            mesh = self.spec.mesh(name)
            if mesh is not None:
                self.spec.delete(mesh)
            del self.names[key]

    def get(self, g: Geometry, file: str, where: str) -> str:
        assert g.mesh_path is not None
        stat = os.stat(g.mesh_path)
        key = (str(g.mesh_path), stat.st_mtime_ns, stat.st_size, tuple(g.size))
        name = self.names.get(key)
        if name is not None:
            return name
        name = f"mesh{len(self.names)}"
        mesh = self.spec.add_mesh(name=name)
        self.names[key] = name  # before any error: rollback() finds it
        mesh.scale = list(g.size)
        mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL  # robust to flat meshes
        suffix = g.mesh_path.suffix.lower()
        if suffix == ".stl":
            mesh.file = str(g.mesh_path)
        else:
            # MuJoCo's OBJ decoder refuses files PyBullet reads (e.g. table_square's face normal
            # indices): .obj is read by simbridge.meshes (positions and faces only), other
            # formats (.dae) through trimesh there
            verts, faces = read_mesh(g.mesh_path)
            if len(verts) < 4 or len(faces) == 0:
                raise UrdfStructureError(file, where, f"mesh {g.mesh_uri!r} has no triangles")
            mesh.uservert = verts.astype(np.float32).ravel().tolist()
            mesh.userface = faces.astype(np.int32).ravel().tolist()
        return name


def _is_ground_box(g: Geometry) -> bool:
    return (
        g.kind == "box"
        and g.size[0] >= PLANE_MIN_SIDE
        and g.size[1] >= PLANE_MIN_SIDE
        and not any(g.origin_rpy)
    )


def add_robot(
    spec: mujoco.MjSpec,
    meshes: MeshLibrary,
    model: UrdfModel,
    prefix: str,
    base_position: Vec3,
    base_orientation: Quat,
    fixed_base: bool,
    profile: Profile,
) -> RobotSpec:
    """Add ``model`` to ``spec`` as bodies named ``prefix + link name``."""
    file = model.source.display_name
    fixed = is_fixed_base(model, fixed_base)
    inertials = model_inertials(model, fixed_base, profile.inertia_source)
    body_names = [prefix + link.name for link in model.links]
    bodies: list[mujoco.MjsBody] = []
    static = [False] * len(model.links)
    joint_names: list[str | None] = []
    bounded: list[str] = []
    geoms: list[GeomContact] = []
    planes: list[str] = []
    free_joint = None
    skipped: list[str] = []
    # A base whose z axis is the world's keeps a huge box's top face horizontal.
    base_z = quat_rotate(base_orientation, (0.0, 0.0, 1.0))
    upright = base_z[2] > 1.0 - 1e-9

    # the link frame of a free base in its body (centre-of-mass) frame
    offset: tuple[Vec3, Quat] | None = None
    if not fixed:
        ine0 = inertials[0]
        if any(ine0.position) or tuple(ine0.orientation) != (0.0, 0.0, 0.0, 1.0):
            offset = transform_inverse((ine0.position, ine0.orientation))

    # the link frame of a spherical joint's child in its body frame, where they differ
    link_offsets: dict[int, tuple[Vec3, Quat]] = {}
    for joint in model.joints:
        orn = inertials[joint.index + 1].orientation
        if joint.type == "spherical" and tuple(orn) != (0.0, 0.0, 0.0, 1.0):
            link_offsets[joint.index] = transform_inverse(((0.0, 0.0, 0.0), orn))
    unlimited: list[str] = []

    def placed(xyz: Vec3, quat: Quat, on_base: bool) -> tuple[list[float], list[float]]:
        """A pose given in a link frame, as MuJoCo position and wxyz quaternion in the body"""
        if on_base and offset is not None:
            xyz, quat = transform_multiply(offset, (xyz, quat))
        return list(xyz), _wxyz(quat)

    def placed_in(link: int, xyz: Vec3, quat: Quat) -> tuple[list[float], list[float]]:
        """A pose given in link ``link``'s frame, in its body's frame"""
        if link == -1:
            return placed(xyz, quat, True)
        own = link_offsets.get(link)
        if own is not None:
            xyz, quat = transform_multiply(own, (xyz, quat))
        return list(xyz), _wxyz(quat)

    for link in model.links:
        i = link.index
        if i == -1:
            body = spec.worldbody.add_body(name=body_names[0])
            frame: tuple[Vec3, Quat] = (base_position, base_orientation)
            if offset is not None:  # the body frame is the base's centre-of-mass frame
                frame = transform_multiply(frame, transform_inverse(offset))
            body.pos = list(frame[0])
            body.quat = _wxyz(frame[1])
            if not fixed:
                free_joint = prefix + "$free"
                body.add_freejoint(name=free_joint)
            static[0] = fixed
        else:
            joint = model.joints[i]
            parent = model.parent_index(joint)
            body = bodies[parent + 1].add_body(name=body_names[i + 1])
            frame = (joint.origin_xyz, joint.origin_quat)  # the link frame in the parent's
            if i in link_offsets:  # the body frame: the link frame turned (see link_offsets)
                frame = transform_multiply(frame, transform_inverse(link_offsets[i]))
            body.pos, body.quat = placed_in(parent, frame[0], frame[1])
            static[i + 1] = static[parent + 1] and joint.type == "fixed"
            if joint.type == "fixed":
                joint_names.append(None)
            elif joint.type == "spherical":
                name = prefix + joint.name
                jnt = body.add_joint(name=name)
                jnt.type = mujoco.mjtJoint.mjJNT_BALL
                jnt.frictionloss = 0.0
                jnt.armature = 0.0
                jnt.actfrclimited = mujoco.mjtLimited.mjLIMITED_FALSE
                jnt.solimp_friction = list(MOTOR_SOLIMP)
                jnt.limited = mujoco.mjtLimited.mjLIMITED_FALSE
                if spherical_limited(joint):
                    unlimited.append(joint.name)
                joint_names.append(name)
            else:
                axis = np.asarray(joint.axis, dtype=float)
                name = prefix + joint.name
                jnt = body.add_joint(name=name)
                jnt.type = (
                    mujoco.mjtJoint.mjJNT_SLIDE
                    if joint.type == "prismatic"
                    else mujoco.mjtJoint.mjJNT_HINGE
                )
                jnt.axis = (axis / np.linalg.norm(axis)).tolist()
                jnt.frictionloss = 0.0
                jnt.armature = 0.0
                jnt.actfrclimited = mujoco.mjtLimited.mjLIMITED_FALSE
                jnt.solimp_friction = list(MOTOR_SOLIMP)
                if joint.has_limit:
                    jnt.limited = mujoco.mjtLimited.mjLIMITED_TRUE
                    # lower == upper locks the joint in PyBullet; MuJoCo wants a range of
                    # positive width: one ulp of it
                    upper = joint.upper
                    if upper == joint.lower:
                        upper = float(np.nextafter(upper, np.inf))
                    jnt.range = [joint.lower, upper]
                    # PyBullet's limit row (motors.py): aref = -v/dt - erp pos/dt^2
                    dt = profile.timestep
                    jnt.solref_limit = [-LIMIT_ERP / dt / dt * MOTOR_DMAX, -MOTOR_DMAX / dt]
                    jnt.solimp_limit = list(MOTOR_SOLIMP)
                    jnt.margin = LIMIT_MARGIN
                else:
                    jnt.limited = mujoco.mjtLimited.mjLIMITED_FALSE
                joint_names.append(name)
        bodies.append(body)

        ine = inertials[i + 1]
        mass, diag = ine.mass, list(ine.diagonal)
        moving = not static[i + 1]
        if moving and not (mass >= MIN_MASS and min(diag) >= MIN_INERTIA):  # NaN too
            bounded.append(link.name)
            mass = max(mass, MIN_MASS)
            diag = [v if v >= MIN_INERTIA else MIN_INERTIA for v in diag]
        body.explicitinertial = True
        body.mass = mass
        body.inertia = diag
        if i == -1 and offset is not None:  # the body frame is the inertial frame itself
            body.ipos = [0.0, 0.0, 0.0]
            body.iquat = [1.0, 0.0, 0.0, 0.0]
        else:
            body.ipos, body.iquat = placed_in(i, ine.position, ine.orientation)

        where = f"link {link.name!r}"
        for k, g in enumerate(link.visuals):
            if g.kind == "plane":
                continue  # PyBullet draws no <plane> either ("No default visual")
            if _degenerate(g) or (g.kind == "mesh" and not meshes.usable(g)):
                skipped.append(f"{where} <visual> #{k}")
                continue  # nothing to draw (e.g. laikago_toes' radius-0 spheres)
            vg = body.add_geom(name=f"{body_names[i + 1]}$v{k}")
            _set_shape(vg, g, meshes, file, f"{where} <visual> #{k}")
            vg.pos, vg.quat = placed_in(i, g.origin_xyz, g.origin_quat)
            vg.contype = vg.conaffinity = 0
            vg.group = VISUAL_GROUP
            vg.rgba = list(g.rgba or DEFAULT_RGBA)
            vg.mass = 0.0
        lateral, rolling, spinning, restitution = _contact_values(link, profile)
        group, mask = _collision_filter(model, link, fixed)
        for k, g in enumerate(link.collisions):
            if g.kind == "mesh" and not meshes.usable(g):
                skipped.append(f"{where} <collision> #{k}")
                continue
            name = f"{body_names[i + 1]}$c{k}"
            cg = body.add_geom(name=name)
            is_plane = g.kind == "plane" or (static[i + 1] and upright and _is_ground_box(g))
            if g.kind == "plane":  # Bullet's infinite plane through the shape's origin
                if not static[i + 1]:
                    raise UrdfStructureError(
                        file,
                        f"{where} <collision> #{k} <plane>",
                        "MuJoCo takes a plane only on a body welded to the world; this link "
                        "moves (PyBullet moves the plane with it)",
                        g.line or None,
                    )
                cg.type = mujoco.mjtGeom.mjGEOM_PLANE
                cg.size = [0.0, 0.0, 1.0]
                turn = transform_multiply(
                    (g.origin_xyz, g.origin_quat), ((0.0, 0.0, 0.0), _z_to(g.size))
                )
                cg.pos, cg.quat = placed_in(i, turn[0], turn[1])
                planes.append(name)
            elif is_plane:
                cg.type = mujoco.mjtGeom.mjGEOM_PLANE
                cg.size = [0.5 * g.size[0], 0.5 * g.size[1], 1.0]
                cg.pos = [g.origin_xyz[0], g.origin_xyz[1], g.origin_xyz[2] + 0.5 * g.size[2]]
                planes.append(name)
            else:
                if _degenerate(g):  # MuJoCo refuses size 0: a point-like shape instead
                    g = replace(g, size=tuple(max(v, MIN_SIZE) for v in g.size))
                _set_shape(cg, g, meshes, file, f"{where} <collision> #{k}")
                cg.pos, cg.quat = placed_in(i, g.origin_xyz, g.origin_quat)
            cg.contype = cg.conaffinity = 0
            cg.group = COLLISION_GROUP
            cg.rgba = [0.5, 0.5, 0.5, 0.5]
            cg.mass = 0.0
            geoms.append(
                GeomContact(
                    name,
                    i,
                    static[i + 1],
                    lateral,
                    rolling,
                    spinning,
                    restitution,
                    is_plane,
                    group,
                    mask,
                )
            )
    return RobotSpec(
        prefix,
        bodies[0],
        body_names,
        joint_names,
        free_joint,
        geoms,
        inertials,
        bounded,
        planes,
        skipped_shapes=skipped,
        base_offset=offset,
        link_offsets=link_offsets,
        unlimited_spherical=unlimited,
    )


def spherical_limited(joint: Joint) -> bool:
    """Whether PyBullet limits this spherical joint: its importer adds a
    btMultiBodySphericalJointLimit (swing about x within ``lower``, about y within ``upper``,
    twist about z within ``twist``) when all four of lower, upper, twist and effort are > 0."""
    return joint.lower > 0 and joint.upper > 0 and joint.twist > 0 and joint.effort > 0


def _collision_filter(model: UrdfModel, link: Link, fixed: bool) -> tuple[int, int]:
    """A link's collision group and mask as PyBullet gives them (see GeomContact)."""
    static_base = link.index == -1 and fixed
    group, mask = (2, -1 ^ 2) if static_base else (1, -1)
    own = getattr(model, "collision_filters", {}).get(link.name)
    if own is not None:
        group = own[0] if own[0] is not None else group
        mask = own[1] if own[1] is not None else mask
    return group, mask


def _set_shape(geom: mujoco.MjsGeom, g: Geometry, meshes: MeshLibrary, file: str, where: str):
    geom.pos = list(g.origin_xyz)
    geom.quat = _wxyz(g.origin_quat)
    if g.kind == "box":
        geom.type = mujoco.mjtGeom.mjGEOM_BOX
        geom.size = [0.5 * v for v in g.size]
    elif g.kind == "sphere":
        geom.type = mujoco.mjtGeom.mjGEOM_SPHERE
        geom.size = [g.size[0], 0.0, 0.0]
    elif g.kind == "cylinder":
        geom.type = mujoco.mjtGeom.mjGEOM_CYLINDER
        geom.size = [g.size[0], 0.5 * g.size[1], 0.0]
    elif g.kind == "capsule":
        geom.type = mujoco.mjtGeom.mjGEOM_CAPSULE
        geom.size = [g.size[0], 0.5 * g.size[1], 0.0]
    else:
        geom.type = mujoco.mjtGeom.mjGEOM_MESH
        geom.meshname = meshes.get(g, file, where)


def _z_to(normal: tuple[float, ...]) -> Quat:
    """The shortest turn (x, y, z, w) of the z axis onto ``normal`` (not zero)."""
    n = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    w = 1.0 + n[2]
    if w < 1e-12:  # normal = -z: half a turn about x
        return (1.0, 0.0, 0.0, 0.0)
    q = np.array([-n[1], n[0], 0.0, w])
    q /= np.linalg.norm(q)
    return (float(q[0]), float(q[1]), float(q[2]), float(q[3]))


def _degenerate(g: Geometry) -> bool:
    return g.kind != "mesh" and min(g.size) <= 0.0


def pair_friction(a: GeomContact, b: GeomContact) -> tuple[list[float], int]:
    """Bullet's combination rules: sliding = product; rolling and spinning
    ``x_a mu_b + x_b mu_a`` clamped to 10. Returns MuJoCo's 5 friction values and condim."""
    mu = a.lateral * b.lateral
    roll = min(10.0, a.rolling * b.lateral + b.rolling * a.lateral)
    spin = min(10.0, a.spinning * b.lateral + b.spinning * a.lateral)
    condim = 6 if roll > 0 else (4 if spin > 0 else 3)
    return [mu, mu, spin, roll, roll], condim


def add_pairs(
    spec: mujoco.MjSpec,
    new: RobotSpec,
    others: list[RobotSpec],
    profile: Profile,
    margin: float,
    self_collision_skip: set[tuple[int, int]] | None,
) -> None:
    """Explicit contact pairs between ``new`` and every robot in ``others`` (and inside
    ``new`` when ``self_collision_skip`` is given: the link pairs it holds are left out)."""
    solref = [2.0 * profile.timestep, 1.0]

    def add(a: GeomContact, b: GeomContact) -> None:
        if a.static and b.static:
            return
        if not (a.group & b.mask or b.group & a.mask):  # Bullet's filter (PyBullet's OR rule)
            return
        friction, condim = pair_friction(a, b)
        name = f"{a.name}|{b.name}"
        pair = spec.add_pair(name=name, geomname1=a.name, geomname2=b.name)
        pair.friction = friction
        pair.condim = condim
        pair.solref = solref
        pair.margin = margin
        new.pair_names.append(name)

    for other in others:
        for a in new.geoms:
            for b in other.geoms:
                if a.is_plane and b.is_plane:
                    continue
                # MuJoCo's plane collisions need the plane first
                add(b, a) if a.is_plane is False and b.is_plane else add(a, b)
    if self_collision_skip is not None:
        for k, a in enumerate(new.geoms):
            for b in new.geoms[k + 1 :]:
                if a.link == b.link or (min(a.link, b.link), max(a.link, b.link)) in (
                    self_collision_skip
                ):
                    continue
                add(a, b)


def mass_bound_note(robot: RobotSpec) -> str:
    return (
        f"links {robot.bounded_links} move but have zero mass or inertia: raised to "
        f"{MIN_MASS} kg / {MIN_INERTIA} kg m^2 (MuJoCo refuses zero)"
    )
