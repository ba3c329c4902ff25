"""What an engine's builder needs to make one robot, resolved once: :func:`build_plan`.

A backend that builds its own model (MuJoCo, PhysX) does not read the :class:`UrdfModel`, the
:class:`Profile` or the :class:`LoadOptions` itself: it asks :func:`build_plan` for a
:class:`BuildPlan` and only translates it into its engine. Every PyBullet rule an engine
builder needs is applied here, once, by the engine-neutral core:

* the links in PyBullet's order (``links[0]`` the base, link -1; ``links[i + 1]`` link i),
  each with its parent and the joint that moves it (:class:`JointPlan`);
* the profile's inertial of each link (:class:`~simbridge.model.inertia.LinkInertial`: PyBullet's
  mass, principal moments and inertial frame for the inertia source of ``options``);
* the collision and visual shapes (:class:`ShapePlan`), meshes read once
  (:class:`MeshPlan`: vertices with the scale applied, triangles), primitives of size 0 marked
  ``degenerate`` (PyBullet keeps them as point-like shapes), meshes PyBullet gets nothing from
  left out and listed (``BuildPlan.dropped_shapes``), ground-like shapes marked
  (:class:`GroundPlan`: a ``<plane>``, or a huge box welded to the world);
* each link's contact values (:class:`ContactValues`: the profile's or the file's friction and
  restitution, as PyBullet applies them) and :func:`combine_contact` for a pair (PyBullet's
  combination rules);
* the contact filter (:class:`CollisionFilter` per link; :meth:`BuildPlan.self_collides` for
  two links of the body under its self-collision mode; :func:`links_collide` for links of two
  bodies).

Engine-specific choices (geom groups, collision bits, the engine's own minimum sizes or masses,
its body frames) stay with each backend. Units: metres, kilograms, seconds, radians;
quaternions (x, y, z, w). Every pose is a frame in the link frame of the link it belongs to,
unless its field says otherwise. Nothing here imports an engine.

The records are :mod:`simbridge.model.plan_records`' (importable from here too); this module
holds the rules that fill them and :func:`build_plan`.
"""

from __future__ import annotations

import numpy as np

from simbridge.model.inertia import is_fixed_base, model_inertials
from simbridge.model.load_options import LoadOptions, self_collision_exclusions
from simbridge.model.meshes import read_mesh
from simbridge.model.plan_records import (
    BuildPlan,
    CollisionFilter,
    ContactValues,
    GroundPlan,
    JointPlan,
    LinkPlan,
    MeshPlan,
    PairContact,
    ShapePlan,
    links_collide,
)
from simbridge.model.urdf_model import Geometry, Joint, Link, UrdfModel
from simbridge.profiles import Profile
from simbridge.transforms import IDENTITY_QUAT, quat_rotate, transform_multiply
from simbridge.types import Quat, Vec3

__all__ = [
    "GROUND_MIN_SIDE",
    "BuildPlan",
    "LinkPlan",
    "JointPlan",
    "ShapePlan",
    "MeshPlan",
    "GroundPlan",
    "ContactValues",
    "CollisionFilter",
    "PairContact",
    "build_plan",
    "combine_contact",
    "contact_values",
    "collision_filter",
    "links_collide",
    "mesh_unusable",
    "spherical_limited",
]

GROUND_MIN_SIDE = 100.0
"""m: a box welded to the world at least this wide in x and y is ground-like (pybullet_data's
``plane.urdf`` is a 200 x 200 x 10 m box)."""

COMBINED_FRICTION_MAX = 10.0
"""Bullet clamps a pair's combined rolling and spinning friction to this."""


# ---------------------------------------------------------------- rules


def contact_values(link: Link, profile: Profile) -> ContactValues:
    """A link's contact values under a profile (see :class:`ContactValues`).

    Args:
        link: The link, with the ``<contact>`` values its file gives.
        profile: The profile (its defaults, and whether it reads the file's values).

    Returns:
        Its friction, restitution and (when the file gives both) contact stiffness and damping.
    """
    ct = link.contact
    read = profile.read_urdf_contact

    def pick(value: float | None, default: float) -> float:
        return float(value) if read and value is not None else default

    both = ct.stiffness is not None and ct.damping is not None
    return ContactValues(
        pick(ct.lateral_friction, profile.lateral_friction),
        pick(ct.rolling_friction, profile.rolling_friction),
        pick(ct.spinning_friction, profile.spinning_friction),
        pick(ct.restitution, profile.restitution),
        float(ct.stiffness) if both else None,  # type: ignore[arg-type]
        float(ct.damping) if both else None,  # type: ignore[arg-type]
    )


def combine_contact(a: ContactValues, b: ContactValues) -> PairContact:
    """Bullet's combination of two links' contact values.

    Args:
        a: One link's values.
        b: The other's.

    Returns:
        Sliding friction and restitution as the products; rolling and spinning friction
        ``x_a mu_b + x_b mu_a`` (mu the sliding friction), clamped to
        :data:`COMBINED_FRICTION_MAX`.
    """
    mu = a.lateral_friction * b.lateral_friction
    roll = min(
        COMBINED_FRICTION_MAX,
        a.rolling_friction * b.lateral_friction + b.rolling_friction * a.lateral_friction,
    )
    spin = min(
        COMBINED_FRICTION_MAX,
        a.spinning_friction * b.lateral_friction + b.spinning_friction * a.lateral_friction,
    )
    return PairContact(mu, roll, spin, a.restitution * b.restitution)


def collision_filter(model: UrdfModel, link: Link, fixed: bool) -> CollisionFilter:
    """A link's broadphase group and mask as PyBullet gives them; see :class:`CollisionFilter`.

    Args:
        model: The robot (an MJCF or SDF body may set its own filters).
        link: One of its links.
        fixed: Whether the body's base is welded to the world.

    Returns:
        The link's filter.
    """
    static_base = link.index == -1 and fixed
    group, mask = (2, -1 ^ 2) if static_base else (1, -1)
    own = getattr(model, "collision_filters", {}).get(link.name)
    if own is not None:
        group = own[0] if own[0] is not None else group
        mask = own[1] if own[1] is not None else mask
    return CollisionFilter(group, mask)


def spherical_limited(joint: Joint) -> bool:
    """Whether PyBullet limits this spherical joint.

    Its importer adds a btMultiBodySphericalJointLimit (swing about x within ``lower``, about y
    within ``upper``, twist about z within ``twist``) when all four of lower, upper, twist and
    effort are > 0.

    Args:
        joint: A spherical joint.

    Returns:
        True when it is limited.
    """
    return joint.lower > 0 and joint.upper > 0 and joint.twist > 0 and joint.effort > 0


def mesh_unusable(g: Geometry) -> bool:
    """Whether PyBullet gets nothing from a mesh.

    Args:
        g: A mesh geometry with its resolved path.

    Returns:
        True for a file that cannot be read, no finite vertex (pybullet_data's random_urdfs/168
        is all NaN) or an .obj without a readable triangle (PyBullet warns "cannot extract
        anything useful from mesh" and loads the link without it).
    """
    assert g.mesh_path is not None
    try:
        verts, faces = read_mesh(g.mesh_path)
    except (OSError, ValueError, IndexError):
        return True
    if g.mesh_path.suffix.lower() == ".obj" and len(faces) == 0:
        return True
    return not (len(verts) > 0 and bool(np.isfinite(verts).all()))


def _degenerate(g: Geometry) -> bool:
    """A primitive with a size <= 0 (a plane's size is its normal, a mesh's its scale)."""
    return g.kind not in ("mesh", "plane") and min(g.size) <= 0.0


def _is_ground_box(g: Geometry) -> bool:
    return (
        g.kind == "box"
        and g.size[0] >= GROUND_MIN_SIDE
        and g.size[1] >= GROUND_MIN_SIDE
        and not any(g.origin_rpy)
    )


def _z_to(normal: tuple[float, ...]) -> Quat:
    """The shortest turn (x, y, z, w) of the z axis onto ``normal`` (not zero)."""
    n = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    w = 1.0 + n[2]
    if w < 1e-12:  # normal = -z: half a turn about x
        return (1.0, 0.0, 0.0, 0.0)
    q = np.array([-n[1], n[0], 0.0, w])
    q /= np.linalg.norm(q)
    return (float(q[0]), float(q[1]), float(q[2]), float(q[3]))


def _mesh_plan(g: Geometry) -> MeshPlan:
    assert g.mesh_path is not None
    verts, faces = read_mesh(g.mesh_path)
    scale = (float(g.size[0]), float(g.size[1]), float(g.size[2]))
    scaled = verts * np.asarray(scale, dtype=float)
    scaled.setflags(write=False)
    return MeshPlan(g.mesh_path, g.mesh_uri, scale, verts, scaled, faces)


def _shape(g: Geometry, k: int, ground: GroundPlan | None = None) -> ShapePlan:
    return ShapePlan(
        k,
        g.kind,
        g.origin_xyz,
        g.origin_quat,
        tuple(g.size),
        _mesh_plan(g) if g.kind == "mesh" else None,
        _degenerate(g),
        ground,
        g.rgba,
        g.name,
        g.line,
    )


def _ground(g: Geometry, static: bool, upright: bool) -> GroundPlan | None:
    if g.kind == "plane":  # Bullet's infinite plane through the shape's origin
        pos, orn = transform_multiply(
            (g.origin_xyz, g.origin_quat), ((0.0, 0.0, 0.0), _z_to(g.size))
        )
        return GroundPlan(pos, orn, None)
    if static and upright and _is_ground_box(g):
        top = (g.origin_xyz[0], g.origin_xyz[1], g.origin_xyz[2] + 0.5 * g.size[2])
        return GroundPlan(top, IDENTITY_QUAT, (0.5 * g.size[0], 0.5 * g.size[1]))
    return None


def _joint(model: UrdfModel, joint: Joint) -> JointPlan:
    axis: Vec3 = joint.axis
    if joint.type in ("revolute", "continuous", "prismatic"):
        a = np.asarray(joint.axis, dtype=float)
        axis = tuple((a / np.linalg.norm(a)).tolist())
    limit = None
    if joint.type == "spherical" and spherical_limited(joint):
        limit = (joint.lower, joint.upper, joint.twist)
    return JointPlan(
        joint.index,
        joint.name,
        joint.type,
        model.parent_index(joint),
        joint.origin_xyz,
        joint.origin_quat,
        axis,
        joint.has_limit,
        joint.lower,
        joint.upper,
        joint.effort,
        joint.velocity,
        joint.damping,
        joint.friction,
        limit,
    )


# ---------------------------------------------------------------- the plan


def build_plan(
    model: UrdfModel,
    profile: Profile,
    options: LoadOptions,
    *,
    fixed_base: bool,
    base_position: Vec3 = (0.0, 0.0, 0.0),
    base_orientation: Quat = IDENTITY_QUAT,
) -> BuildPlan:
    """The :class:`BuildPlan` of ``model`` as ``load`` was asked to place it.

    The inertia source and self-collision mode are ``options``'; contact values the
    ``profile``'s. Meshes are read here (:func:`simbridge.model.meshes.read_mesh`, cached).

    Args:
        model: A :class:`UrdfModel`, or a :class:`~simbridge.model.scene.SceneBody` from an
            MJCF or SDF file, already scaled and merged by
            :func:`~simbridge.model.load_options.apply_load_options`.
        profile: The profile in force.
        options: The load options.
        fixed_base: As asked of ``load`` (a root of mass 0 is fixed too).
        base_position: The base link frame's position in the world (m).
        base_orientation: Its orientation (x, y, z, w).

    Returns:
        The plan: links in PyBullet's order, their inertials, shapes, contact values and
        filters.

    Raises:
        OSError, ValueError: A mesh file that is not one of its format may raise its reader's
            error, as it would at load.
    """
    fixed = is_fixed_base(model, fixed_base)
    inertials = model_inertials(model, fixed_base, options.inertia_source)
    base_z = quat_rotate(base_orientation, (0.0, 0.0, 1.0))
    upright = base_z[2] > 1.0 - 1e-9
    skip = self_collision_exclusions(model, options.self_collision)
    static: dict[int, bool] = {}
    links: list[LinkPlan] = []
    dropped: list[str] = []
    for link in model.links:
        i = link.index
        joint = None
        parent = None
        if i == -1:
            static[i] = fixed
        else:
            j = model.joints[i]
            joint = _joint(model, j)
            parent = joint.parent
            static[i] = static[parent] and j.type == "fixed"
        where = f"link {link.name!r}"
        visuals: list[ShapePlan] = []
        for k, g in enumerate(link.visuals):
            if g.kind == "plane":
                continue  # PyBullet draws no <plane> either ("No default visual")
            if _degenerate(g) or (g.kind == "mesh" and mesh_unusable(g)):
                dropped.append(f"{where} <visual> #{k}")
                continue  # nothing to draw (e.g. laikago_toes' radius-0 spheres)
            visuals.append(_shape(g, k))
        collisions: list[ShapePlan] = []
        for k, g in enumerate(link.collisions):
            if g.kind == "mesh" and mesh_unusable(g):
                dropped.append(f"{where} <collision> #{k}")
                continue
            collisions.append(_shape(g, k, _ground(g, static[i], upright)))
        links.append(
            LinkPlan(
                i,
                link.name,
                parent,
                joint,
                inertials[i + 1],
                static[i],
                tuple(collisions),
                tuple(visuals),
                contact_values(link, profile),
                collision_filter(model, link, fixed),
            )
        )
    return BuildPlan(
        model.name,
        model.source.display_name,
        fixed,
        base_position,
        base_orientation,
        upright,
        options.inertia_source,
        tuple(links),
        options.self_collision,
        frozenset(skip or ()),
        tuple(dropped),
    )
