"""A :class:`~simbridge.urdf.UrdfModel` built into PhysX through SAPIEN's components.

Not SAPIEN's URDF loader (which orders joints depth-first, needs a render device for visuals and
loads a mass-0 link as a dynamic body): every link is made here, one
``PhysxArticulationLinkComponent`` per URDF link, in PyBullet's order, so that link ``i`` of the
articulation is PyBullet's link ``i - 1`` (the base first):

* the entity frame of a link is its URDF link frame; its centre of mass and principal axes are
  :func:`simbridge.inertia.model_inertials`' (PyBullet's numbers for the profile), mass and
  inertia bounded below for moving links (PhysX refuses zero);
* a revolute or prismatic joint turns or slides along the x axis of its joint frame in PhysX:
  the joint frame is the URDF joint origin turned so that its x axis is the URDF axis
  (normalised), in the parent (``pose_in_parent``) and in the child (``pose_in_child``), so the
  joint coordinate is PyBullet's; a revolute joint without limits (continuous, or lower > upper,
  PyBullet's rule) is ``revolute_unwrapped`` (its angle is not wrapped to (-pi, pi]);
* collision shapes as PyBullet makes them from a URDF: boxes, spheres, capsules (PhysX's along x,
  turned onto z), cylinders as PyBullet's 32-gon prism hull, meshes as the convex hull of their
  vertices, a ``<plane>`` as PhysX's half-space; the material of a link carries its friction and
  restitution (``<contact>`` or the profile's);
* a robot welded to the world with no moving link (``plane.urdf``) is one static actor.

Every link gets PhysX's speed caps raised (50 rad/s and 10 m/s by default), joint friction 0,
and PyBullet's one-step depenetration (see :data:`MAX_DEPENETRATION`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sapien
from sapien import physx

from simbridge.inertia import LinkInertial, is_fixed_base, model_inertials
from simbridge.meshes import read_mesh
from simbridge.profiles import Profile
from simbridge.transforms import quat_multiply, transform_multiply, xyzw_to_wxyz
from simbridge.types import Quat, Vec3
from simbridge.urdf import Geometry, Link, UrdfModel

from .combine import set_product_combine

__all__ = ["BuiltRobot", "build_robot", "contact_values", "pose", "MIN_MASS", "MIN_INERTIA"]

MIN_MASS = 1e-6  # kg, for a moving link of mass 0 (PhysX refuses zero)
MIN_INERTIA = 1e-10  # kg m^2, likewise
MIN_SIZE = 1e-6  # m, for a collision shape of size 0
# PhysX caps every link's speed at 50 rad/s and 10 m/s by default; PyBullet caps none (its
# joint speed clamp is applied to joint coordinates, see backend.py): raised out of reach.
LINK_SPEED_CAP = 1e6
# PhysX lets a penetrating body leave at any speed (1e32); PyBullet's split impulse pushes a
# penetration out at a bounded speed. PhysX's own default for new bodies is taken as it is
# measured to behave closest: see DEPARTURES["depenetration"] in backend.py.
MAX_DEPENETRATION = 1e32
CYLINDER_SIDES = 32  # PyBullet's cylinder hull from a URDF (URDF2Bullet.cpp)
# PhysX's own cylinder instead of PyBullet's hull: no steadier on r2d2's wheels (measured)
TRUE_CYLINDER = False
# PyBullet's shapes from a URDF carry a 1 mm collision margin and rest that far apart: two
# shapes here rest the sum of their rest offsets apart (r2d2 on plane.urdf: base at z 0.47100,
# PyBullet 0.47099; at PhysX's rest offset 0, 0.47000)
REST_OFFSET = 0.0005
CONTACT_OFFSET = 0.01  # PhysX's default: contacts are made within 1 cm


def pose(xyz: Vec3, quat: Quat) -> sapien.Pose:
    """A SAPIEN pose from a position and an (x, y, z, w) quaternion."""
    return sapien.Pose(
        np.asarray(xyz, dtype=np.float32), np.asarray(xyzw_to_wxyz(quat), np.float32)
    )


def contact_values(link: Link, profile: Profile) -> tuple[float, float, float, float]:
    """(lateral, rolling, spinning friction, restitution) of a link: its ``<contact>`` where the
    profile reads it, else the profile's."""
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


def _x_to(axis: tuple[float, ...]) -> Quat:
    """The shortest turn (x, y, z, w) of the x axis onto ``axis`` (not zero)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    w = 1.0 + a[0]
    if w < 1e-12:  # axis = -x: half a turn about z
        return (0.0, 0.0, 1.0, 0.0)
    q = np.array([0.0, -a[2], a[1], w])
    q /= np.linalg.norm(q)
    return (float(q[0]), float(q[1]), float(q[2]), float(q[3]))


# x onto z: a quarter turn about -y (capsules and cylinders lie along x in PhysX)
_X_TO_Z: Quat = (0.0, -math.sqrt(0.5), 0.0, math.sqrt(0.5))


@dataclass
class BuiltRobot:
    """What :func:`build_robot` made of one body."""

    inertials: list[LinkInertial]
    static: bool  # one static actor (no articulation)
    entities: list[Any]  # sapien.Entity, base first
    links: list[Any]  # PhysxArticulationLinkComponent per link (empty for a static actor)
    actor: Any = None  # PhysxRigidStaticComponent of a static body
    articulation: Any = None
    shape_links: dict[int, int] = field(default_factory=dict)  # id(shape component) -> link
    bounded_links: list[str] = field(default_factory=list)
    skipped_shapes: list[str] = field(default_factory=list)
    obj_compounds: list[str] = field(default_factory=list)  # .obj meshes of several objects


def _cylinder_hull(radius: float, length: float) -> np.ndarray:
    """PyBullet's cylinder from a URDF: the hull of two 32-gons (URDF2Bullet.cpp)."""
    k = np.arange(CYLINDER_SIDES)
    ang = 2.0 * np.pi * k / CYLINDER_SIDES
    ring = np.stack([radius * np.sin(ang), radius * np.cos(ang)], axis=1)
    top = np.column_stack([ring, np.full(CYLINDER_SIDES, 0.5 * length)])
    bottom = np.column_stack([ring, np.full(CYLINDER_SIDES, -0.5 * length)])
    return np.concatenate([top, bottom])


def _shapes(g: Geometry, material: Any, where: str, skipped: list[str]) -> list[Any]:
    """PhysX shapes of one collision element, placed in the link frame."""
    local: tuple[Vec3, Quat] = (g.origin_xyz, g.origin_quat)
    one = np.ones(3, dtype=np.float32)
    size = [max(float(v), MIN_SIZE) for v in g.size] if g.kind != "mesh" else list(g.size)
    if g.kind == "box":
        shape = physx.PhysxCollisionShapeBox(
            half_size=np.asarray([0.5 * v for v in size], np.float32), material=material
        )
    elif g.kind == "sphere":
        shape = physx.PhysxCollisionShapeSphere(radius=size[0], material=material)
    elif g.kind == "capsule":
        shape = physx.PhysxCollisionShapeCapsule(
            radius=size[0], half_length=0.5 * size[1], material=material
        )
        local = transform_multiply(local, ((0.0, 0.0, 0.0), _X_TO_Z))
    elif g.kind == "cylinder" and TRUE_CYLINDER:
        shape = physx.PhysxCollisionShapeCylinder(
            radius=size[0], half_length=0.5 * size[1], material=material
        )
        local = transform_multiply(local, ((0.0, 0.0, 0.0), _X_TO_Z))
    elif g.kind == "cylinder":
        verts = _cylinder_hull(size[0], size[1]).astype(np.float32)
        shape = physx.PhysxCollisionShapeConvexMesh(vertices=verts, scale=one, material=material)
    elif g.kind == "plane":
        shape = physx.PhysxCollisionShapePlane(material=material)
        normal = np.asarray(g.size, dtype=float)
        local = transform_multiply(local, ((0.0, 0.0, 0.0), _x_to(tuple(normal))))
    else:
        assert g.mesh_path is not None
        try:
            verts, _faces = read_mesh(g.mesh_path)
        except (OSError, ValueError, IndexError):
            skipped.append(where)
            return []
        v = np.asarray(verts, dtype=float) * np.asarray(g.size, dtype=float)
        v = v[np.isfinite(v).all(axis=1)]
        if len(v) < 4:
            skipped.append(where)
            return []
        try:
            shape = physx.PhysxCollisionShapeConvexMesh(
                vertices=v.astype(np.float32), scale=one, material=material
            )
        except RuntimeError:  # PhysX cannot cook a hull of these points (flat, degenerate)
            skipped.append(where)
            return []
    shape.local_pose = pose(*local)
    shape.rest_offset = REST_OFFSET
    shape.contact_offset = CONTACT_OFFSET
    return [shape]


def build_robot(
    scene: Any,
    model: UrdfModel,
    base_position: Vec3,
    base_orientation: Quat,
    fixed_base: bool,
    profile: Profile,
    group: int,
    self_collision_skip: set[tuple[int, int]] | None,
) -> BuiltRobot:
    """Add ``model`` to ``scene``; ``group`` tags its shapes for the contact filter (a robot's
    links do not collide with each other unless ``self_collision_skip`` is given, which lists
    the link pairs left out)."""
    fixed = is_fixed_base(model, fixed_base)
    inertials = model_inertials(model, fixed_base, profile.inertia_source)
    moving = any(j.type != "fixed" for j in model.joints)
    static_body = fixed and not moving
    skipped: list[str] = []
    bounded: list[str] = []
    materials: dict[tuple[float, float], Any] = {}

    def material_of(link: Link) -> Any:
        lateral, _rolling, _spinning, restitution = contact_values(link, profile)
        key = (lateral, restitution)
        if key not in materials:
            mat = physx.PhysxMaterial(lateral, lateral, restitution)
            set_product_combine(mat)  # PyBullet's product rule (combine.py), where reachable
            materials[key] = mat
        return materials[key]

    def link_shapes(link: Link) -> list[Any]:
        mat = material_of(link)
        out = []
        for k, g in enumerate(link.collisions):
            out += _shapes(g, mat, f"link {link.name!r} <collision> #{k}", skipped)
        return out

    root_pose = pose(base_position, base_orientation)
    if static_body:
        entity = sapien.Entity()
        actor = physx.PhysxRigidStaticComponent()
        shape_links = {}
        for link in model.links:
            frame = _link_frame_in_base(model, link.index)
            for shape in link_shapes(link):
                shape.local_pose = pose(*frame) * shape.local_pose
                _filter(shape, group, -1, None)
                actor.attach(shape)
                shape_links[id(shape)] = -1 if link.index == -1 else link.index
        entity.add_component(actor)
        entity.name = model.name
        entity.pose = root_pose
        scene.add_entity(entity)
        return BuiltRobot(
            inertials,
            True,
            [entity],
            [],
            actor=actor,
            shape_links=shape_links,
            skipped_shapes=skipped,
        )

    entities: list[Any] = []
    links: list[Any] = []
    shape_links = {}
    for link in model.links:
        i = link.index
        parent = None if i == -1 else links[model.parent_index(model.joints[i]) + 1]
        comp = physx.PhysxArticulationLinkComponent(parent)
        for shape in link_shapes(link):
            _filter(shape, group, i, self_collision_skip)
            comp.attach(shape)
            shape_links[id(shape)] = i
        ine = inertials[i + 1]
        mass, diag = ine.mass, list(ine.diagonal)
        if not (mass >= MIN_MASS and min(diag) >= MIN_INERTIA):  # NaN too
            if not (i == -1 and fixed):
                bounded.append(link.name)
            mass = max(mass, MIN_MASS) if math.isfinite(mass) else MIN_MASS
            diag = [v if v >= MIN_INERTIA else MIN_INERTIA for v in diag]
        comp.mass = mass
        comp.cmass_local_pose = pose(ine.position, ine.orientation)
        comp.inertia = np.asarray(diag, dtype=np.float32)
        comp.name = link.name
        comp.max_linear_velocity = LINK_SPEED_CAP
        comp.max_angular_velocity = LINK_SPEED_CAP
        comp.max_depenetration_velocity = MAX_DEPENETRATION
        comp.linear_damping = 0.0
        comp.angular_damping = 0.0
        joint = comp.joint
        if i == -1:
            joint.type = "fixed" if fixed else "undefined"
        else:
            uj = model.joints[i]
            joint.name = uj.name
            if uj.type in ("revolute", "continuous", "prismatic"):
                turn = _x_to(uj.axis) if any(uj.axis) else (0.0, 0.0, 0.0, 1.0)
                limited = uj.type != "continuous" and uj.has_limit and uj.lower <= uj.upper
                if uj.type == "prismatic":
                    joint.type = "prismatic"
                else:
                    joint.type = "revolute" if limited else "revolute_unwrapped"
                joint.pose_in_parent = pose(uj.origin_xyz, quat_multiply(uj.origin_quat, turn))
                joint.pose_in_child = pose((0.0, 0.0, 0.0), turn)
                if limited:
                    joint.limit = np.array([[uj.lower, uj.upper]], dtype=np.float32)
                else:
                    joint.limit = np.array([[-np.inf, np.inf]], dtype=np.float32)
                joint.friction = 0.0
                joint.armature = np.zeros(1, dtype=np.float32)
            else:
                joint.type = "fixed"
                joint.pose_in_parent = pose(uj.origin_xyz, uj.origin_quat)
                joint.pose_in_child = pose((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
        entity = sapien.Entity()
        entity.add_component(comp)
        entity.name = link.name
        links.append(comp)
        entities.append(entity)
    entities[0].pose = root_pose
    for entity in entities:
        scene.add_entity(entity)
    art = links[0].articulation
    art.solver_position_iterations = profile.solver_iterations
    art.solver_velocity_iterations = 1
    return BuiltRobot(
        inertials,
        False,
        entities,
        links,
        articulation=art,
        shape_links=shape_links,
        bounded_links=bounded,
        skipped_shapes=skipped,
    )


def _link_frame_in_base(model: UrdfModel, index: int) -> tuple[Vec3, Quat]:
    """Link ``index``'s frame in the base's, every joint at 0."""
    frame: tuple[Vec3, Quat] = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    chain = []
    while index != -1:
        joint = model.joints[index]
        chain.append(joint)
        index = model.parent_index(joint)
    for joint in reversed(chain):
        frame = transform_multiply(frame, (joint.origin_xyz, joint.origin_quat))
    return frame


def _filter(shape: Any, group: int, link: int, skip: set[tuple[int, int]] | None) -> None:
    """PhysX's shape filter (SAPIEN: groups[0] & other[1] or groups[1] & other[0] -> no
    contact; groups[2] == other[2] and groups[3] bits shared -> no contact). Word 2 is the body
    (``group``): the links of one body never touch each other (PyBullet's default) unless
    self-collision is asked for, when word 2 is 0 and nothing is filtered here (the pairs left
    out are removed in the contact callback's stead: see DEPARTURES)."""
    del link, skip
    shape.set_collision_groups([1, 1, group if True else 0, 0])
