"""A robot's :class:`~simbridge.model.build_plan.BuildPlan` built into PhysX through SAPIEN's
components. The plan holds every PyBullet rule (link order, inertials, shapes and meshes,
contact values, contact filter); what is decided here is PhysX's alone.

Not SAPIEN's URDF loader (which orders joints depth-first, needs a render device for visuals and
loads a mass-0 link as a dynamic body): every link is made here, one
``PhysxArticulationLinkComponent`` per URDF link, in PyBullet's order, so that link ``i`` of the
articulation is PyBullet's link ``i - 1`` (the base first):

* the entity frame of a link is its URDF link frame; its centre of mass and principal axes are
  the plan's (PyBullet's numbers for the profile), mass and inertia bounded below for moving
  links (PhysX refuses zero);
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
from collections.abc import Hashable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sapien
from sapien import physx

from simbridge.exceptions import BackendUnsupportedError, InvalidEngineSettingError
from simbridge.model.build_plan import BuildPlan, JointPlan, LinkPlan, ShapePlan
from simbridge.model.inertia import LinkInertial
from simbridge.transforms import quat_multiply, transform_multiply, xyzw_to_wxyz
from simbridge.types import Quat, Vec3

from .combine import set_product_combine

__all__ = [
    "BuiltRobot",
    "bits_needed",
    "build_robot",
    "ignore_bits",
    "needed_pairs",
    "pose",
    "MIN_MASS",
    "MIN_INERTIA",
    "IGNORE_BITS",
]

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
# the most links one PhysX articulation takes here (root included): measured with chains and
# with one-link arms, 255 links step, 256 crash the process at the first step (SAPIEN 3.0.3, CPU)
MAX_ARTICULATION_LINKS = 255
IGNORE_BITS = 32  # SAPIEN's "ignore" bits (a shape's collision group g2, one uint32)
CYLINDER_SIDES = 32  # PyBullet's cylinder hull from a URDF (URDF2Bullet.cpp)
# PhysX's own cylinder instead of PyBullet's hull: no steadier on r2d2's wheels (measured)
TRUE_CYLINDER = False
# PyBullet's shapes from a URDF carry a 1 mm collision margin and rest that far apart: two
# shapes here rest the sum of their rest offsets apart (r2d2 on plane.urdf: base at z 0.47100,
# PyBullet 0.47099; at PhysX's rest offset 0, 0.47000)
REST_OFFSET = 0.0005
CONTACT_OFFSET = 0.01  # PhysX's default: contacts are made within 1 cm


def pose(xyz: Vec3, quat: Quat) -> sapien.Pose:
    """A SAPIEN pose from a position and a quaternion.

    Args:
        xyz: The position (m).
        quat: The orientation, a unit quaternion (x, y, z, w).

    Returns:
        The ``sapien.Pose`` (float32; SAPIEN's quaternion order w, x, y, z).
    """
    return sapien.Pose(
        np.asarray(xyz, dtype=np.float32), np.asarray(xyzw_to_wxyz(quat), np.float32)
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
    plan: BuildPlan | None = None
    filtered_exactly: bool = True  # the self-collision exclusions fit SAPIEN's 32 bits
    ball_links: list[Any] = field(default_factory=list)  # the spherical joints' extra links


def _cylinder_hull(radius: float, length: float) -> np.ndarray:
    """PyBullet's cylinder from a URDF: the hull of two 32-gons (URDF2Bullet.cpp)."""
    k = np.arange(CYLINDER_SIDES)
    ang = 2.0 * np.pi * k / CYLINDER_SIDES
    ring = np.stack([radius * np.sin(ang), radius * np.cos(ang)], axis=1)
    top = np.column_stack([ring, np.full(CYLINDER_SIDES, 0.5 * length)])
    bottom = np.column_stack([ring, np.full(CYLINDER_SIDES, -0.5 * length)])
    return np.concatenate([top, bottom])


def _shapes(
    g: ShapePlan,
    material: Any,
    where: str,
    skipped: list[str],
    offsets: tuple[float, float] = (REST_OFFSET, CONTACT_OFFSET),
) -> list[Any]:
    """PhysX shapes of one collision shape of the plan, placed in the link frame."""
    local: tuple[Vec3, Quat] = (g.position, g.orientation)
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
        local = transform_multiply(local, ((0.0, 0.0, 0.0), _x_to(tuple(g.size))))
    else:
        assert g.mesh is not None
        v = np.asarray(g.mesh.vertices, dtype=float)
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
    shape.rest_offset, shape.contact_offset = offsets
    return [shape]


def _offsets(settings: Mapping[str, Any]) -> tuple[float, float]:
    """The shapes' (rest offset, contact offset) the settings ask for.

    Raises:
        InvalidEngineSettingError: the rest offset is not below the contact offset.
    """
    offsets = (
        float(settings.get("rest_offset", REST_OFFSET)),
        float(settings.get("contact_offset", CONTACT_OFFSET)),
    )
    if offsets[0] >= offsets[1]:
        raise InvalidEngineSettingError(
            "physx",
            "rest_offset",
            f"must be below contact_offset ({offsets[1]:g} m), got {offsets[0]:g}",
        )
    return offsets


def _check_size(plan: BuildPlan) -> None:
    """BackendUnsupportedError when the plan needs more links than one articulation takes."""
    n_links = len(plan.links) + 2 * sum(  # a spherical joint's two extra links (ball.py)
        1 for link in plan.links if link.joint is not None and link.joint.type == "spherical"
    )
    if n_links > MAX_ARTICULATION_LINKS:
        raise BackendUnsupportedError(
            "physx",
            f"a body with {len(plan.links) - 1} joints ({n_links} PhysX links, its base and a "
            "spherical joint's two extra links included)",
            f"one PhysX articulation takes no more than {MAX_ARTICULATION_LINKS} links "
            f"(measured: {MAX_ARTICULATION_LINKS + 1} crash the process at the first step)",
        )


class _LinkShapes:
    """Makes each link's collision shapes, one material per (friction, restitution), and
    records which link each shape belongs to and which shapes were left out."""

    def __init__(
        self,
        plan: BuildPlan,
        body: int,
        offsets: tuple[float, float],
        ignore: Mapping[int, int] | None = None,
    ) -> None:
        self.body = body
        self.offsets = offsets
        self.ignore = _ignore_bits(plan) if ignore is None else dict(ignore)
        self.materials: dict[tuple[float, float], Any] = {}
        self.skipped: list[str] = []
        self.shape_links: dict[int, int] = {}

    def material_of(self, link: LinkPlan) -> Any:
        """The ``PhysxMaterial`` of the link's friction and restitution, made once per pair."""
        key = (link.contact.lateral_friction, link.contact.restitution)
        if key not in self.materials:
            mat = physx.PhysxMaterial(key[0], key[0], key[1])
            set_product_combine(mat)  # PyBullet's product rule (combine.py), where reachable
            self.materials[key] = mat
        return self.materials[key]

    def of(self, link: LinkPlan) -> list[Any]:
        """The link's collision shapes, filtered for the contact filter (none attached yet)."""
        mat = self.material_of(link)
        out = []
        for g in link.collisions:
            where = f"link {link.name!r} <collision> #{g.element}"
            for shape in _shapes(g, mat, where, self.skipped, self.offsets):
                _filter(shape, link, self.ignore, self.body)
                out.append(shape)
        return out


def _static_robot(scene: Any, plan: BuildPlan, shapes: _LinkShapes) -> BuiltRobot:
    """The robot as one static actor (welded to the world, nothing of it moves)."""
    entity = sapien.Entity()
    actor = physx.PhysxRigidStaticComponent()
    for link in plan.links:
        frame = _link_frame_in_base(plan, link.index)
        for shape in shapes.of(link):
            shape.local_pose = pose(*frame) * shape.local_pose
            actor.attach(shape)
            shapes.shape_links[id(shape)] = link.index
    entity.add_component(actor)
    entity.name = plan.name
    entity.pose = pose(plan.base_position, plan.base_orientation)
    scene.add_entity(entity)
    return BuiltRobot(
        [link.inertial for link in plan.links],
        True,
        [entity],
        [],
        actor=actor,
        shape_links=shapes.shape_links,
        skipped_shapes=shapes.skipped,
    )


def _set_inertia(comp: Any, link: LinkPlan, bounded: list[str]) -> None:
    """The link's mass, centre of mass and principal inertia, bounded below for a moving link
    (its name then added to ``bounded``)."""
    ine = link.inertial
    mass, diag = ine.mass, list(ine.diagonal)
    if not (mass >= MIN_MASS and min(diag) >= MIN_INERTIA):  # NaN too
        if not link.static:
            bounded.append(link.name)
        mass = max(mass, MIN_MASS) if math.isfinite(mass) else MIN_MASS
        diag = [v if v >= MIN_INERTIA else MIN_INERTIA for v in diag]
    comp.mass = mass
    comp.cmass_local_pose = pose(ine.position, ine.orientation)
    comp.inertia = np.asarray(diag, dtype=np.float32)


def _articulation(
    scene: Any,
    plan: BuildPlan,
    shapes: _LinkShapes,
    depenetration: float,
    solver_iterations: tuple[int, int],
) -> BuiltRobot:
    """The robot as one articulation, a link per URDF link in PyBullet's order (a spherical
    joint's two extra links before its child); ``solver_iterations``: (position, velocity)."""
    entities: list[Any] = []
    links: list[Any] = []
    extra: list[Any] = []
    bounded: list[str] = []
    for link in plan.links:
        parent = None if link.parent is None else links[link.parent + 1]
        jp = link.joint
        if jp is not None and jp.type == "spherical":  # two massless links, then this one
            parent = _ball_links(parent, jp, link.inertial.orientation, entities, extra)
        comp = physx.PhysxArticulationLinkComponent(parent)
        for shape in shapes.of(link):
            comp.attach(shape)
            shapes.shape_links[id(shape)] = link.index
        _set_inertia(comp, link, bounded)
        comp.name = link.name
        comp.max_linear_velocity = LINK_SPEED_CAP
        comp.max_angular_velocity = LINK_SPEED_CAP
        comp.max_depenetration_velocity = depenetration
        comp.linear_damping = 0.0
        comp.angular_damping = 0.0
        if jp is not None and jp.type == "spherical":
            _ball_joint(comp.joint, jp, link.inertial.orientation, 2)
        else:
            _joint(comp.joint, jp, plan.fixed_base)
        entity = sapien.Entity()
        entity.add_component(comp)
        entity.name = link.name
        links.append(comp)
        entities.append(entity)
    entities[0].pose = pose(plan.base_position, plan.base_orientation)
    for entity in entities:
        scene.add_entity(entity)
    art = links[0].articulation
    art.solver_position_iterations, art.solver_velocity_iterations = solver_iterations
    # PyBullet lets a body sleep only when loaded with URDF_ENABLE_SLEEPING: never here
    art.sleep_threshold = 0.0
    # the links' poses are PhysX's only after a step or a write of the joint positions: one
    # write now, so that a read right after the load sees every link where it is
    art.qpos = art.qpos
    return BuiltRobot(
        [link.inertial for link in plan.links],
        False,
        entities,
        links,
        articulation=art,
        shape_links=shapes.shape_links,
        bounded_links=bounded,
        skipped_shapes=shapes.skipped,
        ball_links=extra,
    )


def build_robot(
    scene: Any,
    plan: BuildPlan,
    solver_iterations: int,
    body: int,
    settings: Mapping[str, Any] | None = None,
    ignore: Mapping[int, int] | None = None,
) -> BuiltRobot:
    """Add the robot of ``plan`` to ``scene``: one static actor when it is welded to the world
    and nothing of it moves, else one articulation.

    Args:
        scene: the ``sapien.Scene`` to add it to.
        plan: the engine-neutral build plan of the robot.
        solver_iterations: the articulation's solver position iterations (the profile's).
        body: the robot's body id, which tags its shapes for the contact filter
            (:func:`_filter`'s g3: bodies given the same id may leave pairs out between them).
        settings: the engine settings a profile sets (backends/settings_physx.py); each one
            not given is at the backend's default.
        ignore: each link's ignore bits (g2), where the caller works them out over several
            bodies tagged with one ``body``; None: the plan's own (:func:`_ignore_bits`).

    Returns:
        The :class:`BuiltRobot`: its SAPIEN entities and components, and what was bounded or
        left out.

    Raises:
        InvalidEngineSettingError: ``rest_offset`` is not below ``contact_offset``.
        BackendUnsupportedError: the body needs more links than one articulation takes.
    """
    settings = settings or {}
    offsets = _offsets(settings)
    depenetration = float(settings.get("max_depenetration_velocity", MAX_DEPENETRATION))
    velocity_iterations = int(settings.get("solver_velocity_iterations", 1))
    moving = any(link.joint is not None and link.joint.type != "fixed" for link in plan.links)
    static_body = plan.fixed_base and not moving
    if not static_body:
        _check_size(plan)
    shapes = _LinkShapes(plan, body, offsets, ignore)
    if static_body:
        built = _static_robot(scene, plan, shapes)
    else:
        built = _articulation(
            scene, plan, shapes, depenetration, (solver_iterations, velocity_iterations)
        )
    built.filtered_exactly = shapes.ignore is not None
    return built


# a spherical joint is three revolute joints about the child's inertial x, y and z axes at the
# joint origin, through two links of this mass and inertia (PhysX has no spherical joint in
# SAPIEN 3.0.3; its reduced coordinates then are XYZ angles of the child's inertial frame)
BALL_LINK_MASS = 1e-6
BALL_LINK_INERTIA = 1e-9
_X_TO: dict[int, Quat] = {
    0: (0.0, 0.0, 0.0, 1.0),
    1: (0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5)),  # x onto y: a quarter turn about z
    2: (0.0, -math.sqrt(0.5), 0.0, math.sqrt(0.5)),  # x onto z: a quarter turn about -y
}


def _ball_joint(joint: Any, jp: JointPlan, inertial: Quat, axis: int) -> None:
    """Revolute ``axis`` (0, 1, 2: x, y, z of the child's inertial frame) of a spherical
    joint; all three turn about the joint origin, the frame F = joint origin * inertial turn."""
    joint.name = f"{jp.name}#{axis}"
    joint.type = "revolute_unwrapped"
    turn = _X_TO[axis]
    if axis == 0:
        joint.pose_in_parent = pose(jp.position, quat_multiply(jp.orientation, inertial))
    else:
        joint.pose_in_parent = pose((0.0, 0.0, 0.0), turn)
    if axis == 2:  # the child's link frame: F turned back by the inertial turn
        joint.pose_in_child = pose((0.0, 0.0, 0.0), quat_multiply(inertial, turn))
    else:
        joint.pose_in_child = pose((0.0, 0.0, 0.0), turn)
    joint.limit = np.array([[-np.inf, np.inf]], dtype=np.float32)
    joint.friction = 0.0
    joint.armature = np.zeros(1, dtype=np.float32)


def _ball_links(
    parent: Any, jp: JointPlan, inertial: Quat, entities: list[Any], extra: list[Any]
) -> Any:
    """The two massless links of a spherical joint; returns the second (the child's parent)."""
    for axis in (0, 1):
        comp = physx.PhysxArticulationLinkComponent(parent)
        comp.mass = BALL_LINK_MASS
        comp.inertia = np.full(3, BALL_LINK_INERTIA, dtype=np.float32)
        comp.name = f"{jp.name}#{axis}"
        comp.max_linear_velocity = LINK_SPEED_CAP
        comp.max_angular_velocity = LINK_SPEED_CAP
        comp.linear_damping = 0.0
        comp.angular_damping = 0.0
        _ball_joint(comp.joint, jp, inertial, axis)
        entity = sapien.Entity()
        entity.add_component(comp)
        entity.name = comp.name
        entities.append(entity)
        extra.append(comp)
        parent = comp
    return parent


def _joint(joint: Any, jp: JointPlan | None, fixed_base: bool) -> None:
    """Set up a link's incoming PhysX joint from the plan's joint (None: the base)."""
    if jp is None:
        joint.type = "fixed" if fixed_base else "undefined"
        return
    joint.name = jp.name
    identity: Quat = (0.0, 0.0, 0.0, 1.0)
    if jp.type in ("revolute", "continuous", "prismatic"):
        turn = _x_to(jp.axis) if any(jp.axis) else identity
        limited = jp.type != "continuous" and jp.limited
        if jp.type == "prismatic":
            joint.type = "prismatic"
        else:
            joint.type = "revolute" if limited else "revolute_unwrapped"
        joint.pose_in_parent = pose(jp.position, quat_multiply(jp.orientation, turn))
        joint.pose_in_child = pose((0.0, 0.0, 0.0), turn)
        bounds = [jp.lower, jp.upper] if limited else [-np.inf, np.inf]
        joint.limit = np.array([bounds], dtype=np.float32)
        joint.friction = 0.0  # PhysX's default 0.05: PyBullet's joints have none
        joint.armature = np.zeros(1, dtype=np.float32)
    else:
        joint.type = "fixed"
        joint.pose_in_parent = pose(jp.position, jp.orientation)
        joint.pose_in_child = pose((0.0, 0.0, 0.0), identity)


def _link_frame_in_base(plan: BuildPlan, index: int) -> tuple[Vec3, Quat]:
    """Link ``index``'s frame in the base's, every joint at 0."""
    frame: tuple[Vec3, Quat] = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    chain = []
    while index != -1:
        jp = plan.link(index).joint
        assert jp is not None
        chain.append(jp)
        index = jp.parent
    for jp in reversed(chain):
        frame = transform_multiply(frame, (jp.position, jp.orientation))
    return frame


def ignore_bits(
    excluded: Iterable[tuple[Hashable, Hashable]],
    needed: Iterable[tuple[Hashable, Hashable]],
    width: int = IGNORE_BITS,
) -> dict[Hashable, int] | None:
    """ "Ignore" bits (SAPIEN's g2) that leave out each ``needed`` pair: a greedy cover of the
    needed pairs by cliques of the ``excluded`` graph, one bit per clique set on its members, so
    that two links share a bit only where their pair is excluded (a parent and its children
    excluded pairwise share one bit, not one per pair).

    Args:
        excluded: Every pair that must not touch (links as any hashable key).
        needed: The pairs that need a bit (a subset of ``excluded``: those PhysX does not
            already leave out, between two links that both have shapes).
        width: How many bits there are (SAPIEN's 32; a larger one counts the bits a cover
            needs, as :func:`bits_needed` does).

    Returns:
        key -> bits for every key of a needed pair (the others: 0), or None where the cover
        needs more than ``width`` bits.
    """
    adj: dict[Hashable, set[Hashable]] = {}
    for a, b in excluded:
        adj.setdefault(a, set()).add(b)
        adj.setdefault(b, set()).add(a)
    left = {frozenset(pair) for pair in needed if pair[0] != pair[1]}
    bits: dict[Hashable, int] = {}
    k = 0
    while left:
        pair = min(left, key=lambda e: sorted(map(repr, e)))
        if k == width:
            return None
        clique = sorted(pair, key=repr)
        # grown by every node excluded with each member (in a fixed order)
        for c in sorted(set.intersection(*(adj[x] for x in clique)), key=repr):
            if all(c in adj[x] for x in clique):
                clique.append(c)
        for x in clique:
            bits[x] = bits.get(x, 0) | (1 << k)
        left -= {frozenset((x, y)) for x in clique for y in clique if x != y}
        k += 1
    return bits


def bits_needed(
    excluded: Iterable[tuple[Hashable, Hashable]], needed: Iterable[tuple[Hashable, Hashable]]
) -> int:
    """How many ignore bits :func:`ignore_bits`' cover of ``needed`` takes, uncapped.

    Args:
        excluded: As :func:`ignore_bits`.
        needed: As :func:`ignore_bits`.

    Returns:
        The number of bits (0: no pair needs one).
    """
    needed = list(needed)
    bits = ignore_bits(excluded, needed, width=len(needed) + 1)
    assert bits is not None  # one bit per pair at most
    return max(bits.values(), default=0).bit_length()


def _ignore_bits(plan: BuildPlan) -> dict[int, int] | None:
    """Each link's "ignore" bits (SAPIEN's g2) that leave out exactly the plan's pairs: all
    links one bit with self-collision off; else :func:`ignore_bits` of the excluded pairs that
    PhysX does not leave out itself (a joint's parent and child never touch in PhysX) and whose
    two links both have shapes. None where that needs more than 32 bits (PhysX's own rule
    then: the body's ``filtered_exactly`` is False)."""
    if plan.self_collision == "off":
        return {link.index: 1 for link in plan.links}
    bits = ignore_bits(plan.excluded_pairs, needed_pairs(plan))
    if bits is None:
        return None
    return {link.index: int(bits.get(link.index, 0)) for link in plan.links}


def needed_pairs(plan: BuildPlan) -> list[tuple[int, int]]:
    """The plan's excluded pairs that need an ignore bit in PhysX: both links have collision
    shapes, and they are not a joint's parent and child in the articulation (PhysX never lets
    those touch; a spherical joint's child is two links below its parent here, ball.py).

    Args:
        plan: The body's plan.

    Returns:
        ``(i, j)`` pairs, i < j, -1 = the base.
    """
    out = []
    for a, b in sorted(plan.excluded_pairs):
        la, lb = plan.link(a), plan.link(b)
        if not (la.collisions and lb.collisions):
            continue
        if any(
            x.parent == y and x.joint is not None and x.joint.type != "spherical"
            for x, y in ((la, b), (lb, a))
        ):
            continue
        out.append((a, b))
    return out


def _filter(shape: Any, link: LinkPlan, bits: dict[int, int] | None, body: int) -> None:
    """PyBullet's contact filter as SAPIEN's four collision groups (two shapes touch when
    ``(A.g0 & B.g1) or (A.g1 & B.g0)``, unless ``A.g2 & B.g2`` and ``A.g3 == B.g3``): g0, g1
    the plan's group and mask (Bullet's OR rule); g3 the body, g2 the link's ignore bits
    (:func:`_ignore_bits`)."""
    own = 0 if bits is None else bits[link.index]
    shape.set_collision_groups(
        [link.filter.group & 0xFFFFFFFF, link.filter.mask & 0xFFFFFFFF, own, body & 0xFFFF]
    )
