"""A robot's :class:`~simbridge.model.build_plan.BuildPlan` translated into MjSpec: one MuJoCo body
per link, its joint, inertia, geoms and contact pairs.

MuJoCo's own URDF importer welds the root to the world, merges fixed-joint links, drops
visuals, reads neither .dae nor ``package://`` and turns ``<limit effort>`` into a force clamp,
so the bodies, joints, geoms and inertias are added here one by one from the plan, which holds
every PyBullet rule (link order, inertials, shapes and meshes, contact values, contact filter,
ground shapes); what is decided here is MuJoCo's alone:

* body ``<prefix><link name>`` per link, in PyBullet's order, its frame the URDF link frame;
  a free joint on the root unless the base is fixed (``fixed_base`` or a root of mass 0);
* hinge/slide joints at the body origin, the plan's unit axis, range only for limited joints
  (PyBullet's rule; lower == upper locks the joint, a range one ulp wide here); no damping,
  friction or force range in the model: the backend applies them per step with PyBullet's laws;
* a ball joint for a spherical joint, at the body origin (the joint origin). Bullet's joint
  quaternion turns the child's *inertial* frame and its velocity is in that frame, MuJoCo's
  ball turns the body frame: where a spherical joint's child has a rotated inertial frame, its
  body frame is the link frame turned by that rotation (``RobotSpec.link_offsets``), so that
  the ball's quaternion and velocity are PyBullet's as they are;
* explicit inertia, the plan's (PyBullet's numbers for the profile), mass and inertia bounded
  below for moving bodies (MuJoCo refuses zero);
* visual geoms (``contype = conaffinity = 0``, group 1) and collision geoms (group 3), also
  ``contype = conaffinity = 0``: every contact comes from an explicit ``<pair>`` (see
  :func:`add_pairs`), which carries PyBullet's product friction; a collision primitive of size
  0 gets a size of :data:`MIN_SIZE` (MuJoCo refuses zero);
* the plan's ground shapes (a ``<plane>``; a huge box welded to the world, as pybullet_data's
  ``plane.urdf``, 200 x 200 x 10 m) become MuJoCo planes (the box's at its top face).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, field

import mujoco
import numpy as np

from simbridge.exceptions import UrdfStructureError
from simbridge.model.build_plan import (
    BuildPlan,
    ContactValues,
    JointPlan,
    LinkPlan,
    ShapePlan,
    combine_contact,
    links_collide,
)
from simbridge.model.inertia import LinkInertial
from simbridge.profiles import Profile
from simbridge.transforms import transform_inverse, transform_multiply, xyzw_to_wxyz
from simbridge.types import Quat, Vec3

from .motor_rows import LIMIT_ERP, LIMIT_HARD_MARGIN, LIMIT_MARGIN, MOTOR_DMAX

__all__ = ["RobotSpec", "GeomContact", "add_robot", "add_pairs", "new_world_spec"]

VISUAL_GROUP = 1
COLLISION_GROUP = 3
MIN_MASS = 1e-6  # kg, for a moving body whose URDF mass is 0 (MuJoCo refuses zero)
MIN_INERTIA = 1e-10  # kg m^2, likewise
MIN_SIZE = 1e-6  # m, for a collision shape of size 0
# Friction rows of the joint motors: as close to a hard constraint as MuJoCo allows, so the
# motor reaches the velocity it asks for within a step (see motor_rows.py).
MOTOR_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)
DEFAULT_RGBA = (1.0, 1.0, 1.0, 1.0)


@dataclass(frozen=True)
class GeomContact:
    """A collision geom, its link and that link's contact values (the plan's)."""

    name: str
    link: int  # PyBullet link index, -1 = base
    contact: ContactValues
    is_plane: bool = False


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
    plan: BuildPlan  # what it was built from (its contact values and contact filter)
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


_CONES = {"pyramidal": mujoco.mjtCone.mjCONE_PYRAMIDAL, "elliptic": mujoco.mjtCone.mjCONE_ELLIPTIC}
_SOLVERS = {
    "Newton": mujoco.mjtSolver.mjSOL_NEWTON,
    "CG": mujoco.mjtSolver.mjSOL_CG,
    "PGS": mujoco.mjtSolver.mjSOL_PGS,
}
# engine settings that are MuJoCo options of the same name
_OPTIONS = (
    "impratio",
    "noslip_iterations",
    "noslip_tolerance",
    "tolerance",
    "ls_iterations",
    "ls_tolerance",
)


def new_world_spec(profile: Profile) -> mujoco.MjSpec:
    """An empty world with the profile's options.

    Args:
        profile: The physics settings (time step in seconds, gravity in m/s², solver iterations) and
            the MuJoCo engine settings it sets.

    Returns:
        A new ``MjSpec`` holding no body.
    """
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
    # islands copy efc_R/efc_D before the backend hardens the motor rows (motor_rows.py)
    opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_ISLAND
    # the engine settings the profile sets (backends/settings_mujoco.py); contacts: add_pairs
    settings = profile.engine("mujoco")
    if "cone" in settings:
        opt.cone = _CONES[settings["cone"]]
    if "solver" in settings:
        opt.solver = _SOLVERS[settings["solver"]]
    for key in _OPTIONS:
        if key in settings:
            setattr(opt, key, settings[key])
    spec.visual.global_.offwidth = 640
    return spec


def _wxyz(q: Quat) -> list[float]:
    return list(xyzw_to_wxyz(q))


class MeshLibrary:
    """Mesh assets of one world spec, one per (file version, scale); .dae converted with trimesh.

    A file rewritten since (another modification time or size) is a new asset.

    Args:
        spec: The world's ``MjSpec`` the assets are added to.
    """

    def __init__(self, spec: mujoco.MjSpec) -> None:
        self.spec = spec
        self.names: dict[tuple[str, int, int, tuple[float, ...]], str] = {}

    def mark(self) -> int:
        """A point to roll back to.

        Returns:
            The number of meshes so far.
        """
        return len(self.names)

    def rollback(self, mark: int) -> None:
        """Delete the meshes added since ``mark``.

        A load that failed leaves none behind: a mesh MuJoCo cannot compile would break every later
        compile of the world.

        Args:
            mark: What :meth:`mark` returned before the load.
        """
        for key, name in list(self.names.items())[mark:]:
            mesh = self.spec.mesh(name)
            if mesh is not None:
                self.spec.delete(mesh)
            del self.names[key]

    def get(self, shape: ShapePlan, file: str, where: str) -> str:
        """The asset of a mesh shape of the plan (its file read there, once).

        Args:
            shape: The plan's mesh shape (its file and scale).
            file: The robot's file, for the error.
            where: Where in it the shape is, for the error.

        Returns:
            The mesh asset's name in the spec.

        Raises:
            UrdfStructureError: An .obj or .dae mesh with fewer than 4 vertices or no face.
        """
        m = shape.mesh
        assert m is not None
        stat = os.stat(m.path)
        key = (str(m.path), stat.st_mtime_ns, stat.st_size, tuple(shape.size))
        name = self.names.get(key)
        if name is not None:
            return name
        name = f"mesh{len(self.names)}"
        mesh = self.spec.add_mesh(name=name)
        self.names[key] = name  # before any error: rollback() finds it
        mesh.scale = list(shape.size)
        mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL  # robust to flat meshes
        suffix = m.path.suffix.lower()
        if suffix == ".stl":
            mesh.file = str(m.path)
        else:
            # MuJoCo's OBJ decoder refuses files PyBullet reads (e.g. table_square's face normal
            # indices): .obj and .dae go in as the plan read them (positions and faces only),
            # unscaled (MuJoCo scales them, as it does a file)
            verts, faces = m.file_vertices, m.faces
            if len(verts) < 4 or len(faces) == 0:
                raise UrdfStructureError(file, where, f"mesh {m.uri!r} has no triangles")
            mesh.uservert = verts.astype(np.float32).ravel().tolist()
            mesh.userface = faces.astype(np.int32).ravel().tolist()
        return name


_Placer = Callable[[int, Vec3, Quat], tuple[list[float], list[float]]]


def _body_offsets(
    plan: BuildPlan,
) -> tuple[tuple[Vec3, Quat] | None, dict[int, tuple[Vec3, Quat]]]:
    """Where a link frame lies in its MuJoCo body's frame, where they differ: a free base's
    (its body frame is its centre-of-mass frame), and each spherical joint's child's (keyed by
    joint index: its body frame is the link frame turned by the child's inertial rotation)."""
    offset: tuple[Vec3, Quat] | None = None
    if not plan.fixed_base:
        ine0 = plan.links[0].inertial
        if any(ine0.position) or tuple(ine0.orientation) != (0.0, 0.0, 0.0, 1.0):
            offset = transform_inverse((ine0.position, ine0.orientation))
    link_offsets: dict[int, tuple[Vec3, Quat]] = {}
    for joint in plan.joints:
        orn = plan.links[joint.index + 1].inertial.orientation
        if joint.type == "spherical" and tuple(orn) != (0.0, 0.0, 0.0, 1.0):
            link_offsets[joint.index] = transform_inverse(((0.0, 0.0, 0.0), orn))
    return offset, link_offsets


def _placer(
    offset: tuple[Vec3, Quat] | None, link_offsets: dict[int, tuple[Vec3, Quat]]
) -> _Placer:
    """``placed_in(link, xyz, quat)``: a pose given in link ``link``'s frame, in its body's
    frame, as MjSpec's ``pos`` and ``quat`` (w first)."""

    def placed_in(link: int, xyz: Vec3, quat: Quat) -> tuple[list[float], list[float]]:
        own = offset if link == -1 else link_offsets.get(link)
        if own is not None:
            xyz, quat = transform_multiply(own, (xyz, quat))
        return list(xyz), _wxyz(quat)

    return placed_in


def _set_inertial(
    body: mujoco.MjsBody, link: LinkPlan, free_offset: bool, placed_in: _Placer, bounded: list[str]
) -> None:
    """The link's explicit inertia, bounded below for a moving link (its name then added to
    ``bounded``); ``free_offset``: the body frame is the base's inertial frame itself."""
    ine = link.inertial
    mass, diag = ine.mass, list(ine.diagonal)
    if not link.static and not (mass >= MIN_MASS and min(diag) >= MIN_INERTIA):  # NaN too
        bounded.append(link.name)
        mass = max(mass, MIN_MASS)
        diag = [v if v >= MIN_INERTIA else MIN_INERTIA for v in diag]
    body.explicitinertial = True
    body.mass = mass
    body.inertia = diag
    if free_offset:
        body.ipos = [0.0, 0.0, 0.0]
        body.iquat = [1.0, 0.0, 0.0, 0.0]
    else:
        body.ipos, body.iquat = placed_in(link.index, ine.position, ine.orientation)


def _add_visuals(
    body: mujoco.MjsBody,
    link: LinkPlan,
    name: str,
    meshes: MeshLibrary,
    file: str,
    placed_in: _Placer,
) -> None:
    """The link's visual geoms (drawn, never colliding), named ``name$v<element>``."""
    i = link.index
    for s in link.visuals:
        vg = body.add_geom(name=f"{name}$v{s.element}")
        _set_shape(vg, s, meshes, file, f"link {link.name!r} <visual> #{s.element}")
        vg.pos, vg.quat = placed_in(i, s.position, s.orientation)
        vg.contype = vg.conaffinity = 0
        vg.group = VISUAL_GROUP
        vg.rgba = list(s.rgba or DEFAULT_RGBA)
        vg.mass = 0.0


def _add_collisions(
    body: mujoco.MjsBody,
    link: LinkPlan,
    name: str,
    meshes: MeshLibrary,
    file: str,
    placed_in: _Placer,
    geoms: list[GeomContact],
    planes: list[str],
) -> None:
    """The link's collision geoms, named ``name$c<element>``, each recorded in ``geoms`` (and
    in ``planes`` where it is a ground plane).

    Raises:
        UrdfStructureError: a ``<plane>`` on a link that moves.
    """
    i = link.index
    where = f"link {link.name!r}"
    for s in link.collisions:
        k = s.element
        geom_name = f"{name}$c{k}"
        cg = body.add_geom(name=geom_name)
        ground = s.ground
        if ground is not None:
            half = ground.half_extents
            if half is None:  # a <plane>: Bullet's infinite plane
                if not link.static:
                    raise UrdfStructureError(
                        file,
                        f"{where} <collision> #{k} <plane>",
                        "MuJoCo takes a plane only on a body welded to the world; this link "
                        "moves (PyBullet moves the plane with it)",
                        s.line or None,
                    )
                cg.size = [0.0, 0.0, 1.0]
            else:  # a huge box welded to the world: its top face
                cg.size = [half[0], half[1], 1.0]
            cg.type = mujoco.mjtGeom.mjGEOM_PLANE
            cg.pos, cg.quat = placed_in(i, ground.position, ground.orientation)
            planes.append(geom_name)
        else:
            _set_shape(cg, s, meshes, file, f"{where} <collision> #{k}")
            cg.pos, cg.quat = placed_in(i, s.position, s.orientation)
        cg.contype = cg.conaffinity = 0
        cg.group = COLLISION_GROUP
        cg.rgba = [0.5, 0.5, 0.5, 0.5]
        cg.mass = 0.0
        geoms.append(GeomContact(geom_name, i, link.contact, ground is not None))


def add_robot(
    spec: mujoco.MjSpec,
    meshes: MeshLibrary,
    plan: BuildPlan,
    prefix: str,
    profile: Profile,
) -> RobotSpec:
    """Add the robot of ``plan`` to ``spec``: the plan translated into MjSpec.

    Args:
        spec: the world's ``MjSpec``.
        meshes: the world's mesh library (each mesh file added once).
        plan: the engine-neutral build plan of the robot.
        prefix: the prefix of every name the robot adds (bodies are ``prefix + link name``).
        profile: the profile, which gives the timestep of the joint-limit rows.

    Returns:
        The :class:`RobotSpec`: what was added, and the frames and bounds decided here.

    Raises:
        UrdfStructureError: a ``<plane>`` on a moving link, or a mesh MuJoCo cannot read.
    """
    file = plan.file
    fixed = plan.fixed_base
    body_names = [prefix + link.name for link in plan.links]
    bodies: list[mujoco.MjsBody] = []
    joint_names: list[str | None] = []
    bounded: list[str] = []
    geoms: list[GeomContact] = []
    planes: list[str] = []
    unlimited: list[str] = []
    free_joint = None
    offset, link_offsets = _body_offsets(plan)
    placed_in = _placer(offset, link_offsets)
    for link in plan.links:
        i = link.index
        if link.joint is None:
            body = spec.worldbody.add_body(name=body_names[0])
            frame: tuple[Vec3, Quat] = (plan.base_position, plan.base_orientation)
            if offset is not None:  # the body frame is the base's centre-of-mass frame
                frame = transform_multiply(frame, transform_inverse(offset))
            body.pos = list(frame[0])
            body.quat = _wxyz(frame[1])
            if not fixed:
                free_joint = prefix + "$free"
                body.add_freejoint(name=free_joint)
        else:
            joint = link.joint
            parent = joint.parent
            body = bodies[parent + 1].add_body(name=body_names[i + 1])
            frame = (joint.position, joint.orientation)  # the link frame in the parent's
            if i in link_offsets:  # the body frame: the link frame turned (see link_offsets)
                frame = transform_multiply(frame, transform_inverse(link_offsets[i]))
            body.pos, body.quat = placed_in(parent, frame[0], frame[1])
            _add_joint(body, prefix, joint, profile, joint_names, unlimited)
        bodies.append(body)
        _set_inertial(body, link, i == -1 and offset is not None, placed_in, bounded)
        _add_visuals(body, link, body_names[i + 1], meshes, file, placed_in)
        _add_collisions(body, link, body_names[i + 1], meshes, file, placed_in, geoms, planes)
    return RobotSpec(
        prefix,
        bodies[0],
        body_names,
        joint_names,
        free_joint,
        geoms,
        [link.inertial for link in plan.links],
        plan,
        bounded,
        planes,
        skipped_shapes=list(plan.dropped_shapes),
        base_offset=offset,
        link_offsets=link_offsets,
        unlimited_spherical=unlimited,
    )


def _add_joint(
    body: mujoco.MjsBody,
    prefix: str,
    joint: JointPlan,
    profile: Profile,
    joint_names: list[str | None],
    unlimited: list[str],
) -> None:
    """The MuJoCo joint of ``joint`` at the body origin (none for a fixed joint)."""
    if joint.type == "fixed":
        joint_names.append(None)
        return
    name = prefix + joint.name
    jnt = body.add_joint(name=name)
    if joint.type == "spherical":
        jnt.type = mujoco.mjtJoint.mjJNT_BALL
    elif joint.type == "prismatic":
        jnt.type = mujoco.mjtJoint.mjJNT_SLIDE
    else:
        jnt.type = mujoco.mjtJoint.mjJNT_HINGE
    if joint.type != "spherical":
        jnt.axis = list(joint.axis)  # a unit vector (MuJoCo requires it)
    jnt.frictionloss = 0.0
    jnt.armature = 0.0
    jnt.actfrclimited = mujoco.mjtLimited.mjLIMITED_FALSE
    jnt.solimp_friction = list(MOTOR_SOLIMP)
    if joint.type == "spherical":
        jnt.limited = mujoco.mjtLimited.mjLIMITED_FALSE
        if joint.spherical_limit is not None:
            unlimited.append(joint.name)
    elif joint.limited:
        jnt.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        # lower == upper locks the joint in PyBullet; MuJoCo wants a range of positive
        # width: one ulp of it
        upper = joint.upper
        if upper == joint.lower:
            upper = float(np.nextafter(upper, np.inf))
        jnt.range = [joint.lower, upper]
        # PyBullet's limit row (motor_rows.py): aref = -v/dt - erp pos/dt^2
        dt = profile.timestep
        jnt.solref_limit = [-LIMIT_ERP / dt / dt * MOTOR_DMAX, -MOTOR_DMAX / dt]
        jnt.solimp_limit = list(MOTOR_SOLIMP)
        hard = profile.engine("mujoco").get("limit_rule") == "hard"
        jnt.margin = LIMIT_HARD_MARGIN if hard else LIMIT_MARGIN
    else:
        jnt.limited = mujoco.mjtLimited.mjLIMITED_FALSE
    joint_names.append(name)


def _set_shape(geom: mujoco.MjsGeom, s: ShapePlan, meshes: MeshLibrary, file: str, where: str):
    size = s.size
    if s.degenerate:  # MuJoCo refuses size 0: a point-like shape instead
        size = tuple(max(v, MIN_SIZE) for v in size)
    if s.kind == "box":
        geom.type = mujoco.mjtGeom.mjGEOM_BOX
        geom.size = [0.5 * v for v in size]
    elif s.kind == "sphere":
        geom.type = mujoco.mjtGeom.mjGEOM_SPHERE
        geom.size = [size[0], 0.0, 0.0]
    elif s.kind == "cylinder":
        geom.type = mujoco.mjtGeom.mjGEOM_CYLINDER
        geom.size = [size[0], 0.5 * size[1], 0.0]
    elif s.kind == "capsule":
        geom.type = mujoco.mjtGeom.mjGEOM_CAPSULE
        geom.size = [size[0], 0.5 * size[1], 0.0]
    else:
        geom.type = mujoco.mjtGeom.mjGEOM_MESH
        geom.meshname = meshes.get(s, file, where)


def pair_friction(a: GeomContact, b: GeomContact) -> tuple[list[float], int]:
    """The pair's contact values combined by PyBullet's rules, as MuJoCo's.

    The rules are :func:`simbridge.model.build_plan.combine_contact`'s.

    Args:
        a: One geom's contact values.
        b: The other's.

    Returns:
        MuJoCo's 5 friction values (sliding twice, spinning, rolling twice) and the condim (3, 4
        with spinning friction, 6 with rolling friction).
    """
    c = combine_contact(a.contact, b.contact)
    mu, roll, spin = c.lateral_friction, c.rolling_friction, c.spinning_friction
    condim = 6 if roll > 0 else (4 if spin > 0 else 3)
    return [mu, mu, spin, roll, roll], condim


_SOLIMP_TAIL = (0.9, 0.95, 0.001, 0.5, 2.0)  # MuJoCo's solimp: a 3-number one keeps its tail


def add_pairs(
    spec: mujoco.MjSpec,
    new: RobotSpec,
    others: list[RobotSpec],
    profile: Profile,
    margin: float,
) -> None:
    """Explicit contact pairs for a new robot.

    Pairs between ``new`` and every robot in ``others``, and inside ``new`` between the links its
    plan lets collide (:meth:`BuildPlan.self_collides`); ``new.pair_names`` records them.

    Args:
        spec: The world's ``MjSpec``.
        new: The robot just built.
        others: The robots already in the world.
        profile: The physics settings (time step for the default solref) and the MuJoCo engine
            settings (solref, solimp, margin, gap) it sets.
        margin: The pairs' margin in metres, unless the engine settings give one.
    """
    settings = profile.engine("mujoco")  # the engine settings the profile sets
    solref = list(settings.get("solref", (2.0 * profile.timestep, 1.0)))
    solimp = settings.get("solimp")
    margin = settings.get("margin", margin)
    gap = settings.get("gap")

    def add(a: GeomContact, b: GeomContact) -> None:
        friction, condim = pair_friction(a, b)
        name = f"{a.name}|{b.name}"
        pair = spec.add_pair(name=name, geomname1=a.name, geomname2=b.name)
        pair.friction = friction
        pair.condim = condim
        pair.solref = solref
        pair.margin = margin
        if solimp is not None:
            pair.solimp = list(solimp) + list(_SOLIMP_TAIL[len(solimp) :])
        if gap is not None:
            pair.gap = gap
        new.pair_names.append(name)

    for other in others:
        for a in new.geoms:
            for b in other.geoms:
                if a.is_plane and b.is_plane:
                    continue
                if not links_collide(new.plan.link(a.link), other.plan.link(b.link)):
                    continue
                # MuJoCo's plane collisions need the plane first
                add(b, a) if a.is_plane is False and b.is_plane else add(a, b)
    plan = new.plan
    for k, a in enumerate(new.geoms):
        for b in new.geoms[k + 1 :]:
            if plan.self_collides(a.link, b.link):
                add(a, b)
