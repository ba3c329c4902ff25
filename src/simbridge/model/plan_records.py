"""The records of a :class:`BuildPlan`, what :func:`simbridge.model.build_plan.build_plan` gives.

A link (:class:`LinkPlan`) with the joint that moves it (:class:`JointPlan`), its shapes
(:class:`ShapePlan`, :class:`MeshPlan`, :class:`GroundPlan`), its contact values
(:class:`ContactValues`, :class:`PairContact` for a pair) and its collision filter
(:class:`CollisionFilter`, :func:`links_collide`). The rules that fill them, and the module's
story, are :mod:`simbridge.model.build_plan`'s. Units: metres, kilograms, seconds, radians;
quaternions (x, y, z, w).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from simbridge.model.inertia import LinkInertial
from simbridge.types import DynamicsInfo, Quat, Vec3

__all__ = [
    "BuildPlan",
    "LinkPlan",
    "JointPlan",
    "ShapePlan",
    "MeshPlan",
    "GroundPlan",
    "ContactValues",
    "CollisionFilter",
    "PairContact",
    "links_collide",
]


@dataclass(frozen=True)
class ContactValues:
    """One link's contact values as PyBullet applies them: the file's ``<contact>`` values where
    the profile reads them (``read_urdf_contact``) and the file gives them, else the profile's.

    ``stiffness`` and ``damping`` (N/m, N·s/m): the file's ``<contact><stiffness>`` and
    ``<damping>`` when it gives both (Bullet uses them only as a pair), else None: the
    profile's ``contact_model`` (each engine's rigid contact)."""

    lateral_friction: float  # dimensionless (Coulomb coefficient)
    rolling_friction: float  # m (Bullet's rolling resistance, scaled by the normal force)
    spinning_friction: float  # m (torsional, about the contact normal)
    restitution: float  # dimensionless, 0..1
    stiffness: float | None = None
    damping: float | None = None


@dataclass(frozen=True)
class PairContact:
    """The contact values of a pair of links, combined as PyBullet does
    (:func:`combine_contact`)."""

    lateral_friction: float
    rolling_friction: float
    spinning_friction: float
    restitution: float


@dataclass(frozen=True)
class CollisionFilter:
    """A link's broadphase filter, Bullet's rule: links a and b may touch when
    ``a.group & b.mask or b.group & a.mask`` (PyBullet's OR rule). A URDF link is group 1, mask
    -1 (all); a fixed base is group 2, mask ``-1 ^ 2``; an MJCF or SDF link may say otherwise
    (``SceneBody.collision_filters``)."""

    group: int = 1
    mask: int = -1

    def passes(self, other: CollisionFilter) -> bool:
        """Whether the broadphase lets this link and ``other`` touch (PyBullet's OR rule).

        Args:
            other: The other link's filter.

        Returns:
            True when ``self.group & other.mask or other.group & self.mask``.
        """
        return bool(self.group & other.mask or other.group & self.mask)


@dataclass(frozen=True, eq=False)
class MeshPlan:
    """A mesh file, read once (:func:`simbridge.model.meshes.read_mesh`).

    ``file_vertices`` (n, 3) float64: the positions as the file holds them (its units and
    frame, unscaled); ``vertices`` (n, 3) float64: the same times ``scale``, in the shape's
    frame (m); ``faces`` (m, 3) int64: triangles, indices into either. All three read-only (the
    file arrays are shared with the mesh cache)."""

    path: Path  # resolved absolute path
    uri: str  # the file name as written in the robot file
    scale: Vec3  # per axis, as written (times global_scaling)
    file_vertices: np.ndarray
    vertices: np.ndarray
    faces: np.ndarray


@dataclass(frozen=True)
class GroundPlan:
    """A ground-like shape: an infinite plane (a ``<plane>``), or the top face of a huge box
    welded to the world (both horizontal sides at least
    :data:`~simbridge.model.build_plan.GROUND_MIN_SIDE`, unrotated, on a body whose z axis is the
    world's), which an engine may build as a plane.

    ``position`` (m) is a point on the plane and ``orientation`` the plane's frame, whose +z
    is the outward normal, both in the link frame; ``half_extents`` (m): the box's top face
    half sizes in x and y, None for a ``<plane>`` (unbounded)."""

    position: Vec3
    orientation: Quat
    half_extents: tuple[float, float] | None


@dataclass(frozen=True, eq=False)
class ShapePlan:
    """One collision or visual shape of a link.

    ``position`` (m) and ``orientation`` place the shape's frame in the link frame. ``size`` as
    :class:`~simbridge.model.urdf_model.Geometry` holds it: box ``(x, y, z)`` full sizes; sphere
    ``(radius,)``; cylinder and capsule ``(radius, length)`` along the shape's z axis (a
    capsule's length without its caps); plane its normal ``(x, y, z)`` in the shape's frame, as
    written; mesh its scale. ``element``: the shape's place among its link's ``<collision>``
    (or ``<visual>``) elements as written, counting the ones left out. (PyBullet itself makes
    a URDF cylinder a 32-gon convex hull, reported as a mesh by its collision shape data; the
    plan keeps the cylinder.)"""

    element: int
    kind: str  # "box" | "sphere" | "cylinder" | "capsule" | "plane" | "mesh"
    position: Vec3
    orientation: Quat
    size: tuple[float, ...]
    mesh: MeshPlan | None = None  # for kind "mesh"
    degenerate: bool = False  # a primitive with a size <= 0 (PyBullet keeps it, point-like)
    ground: GroundPlan | None = None  # collision shapes only
    rgba: tuple[float, float, float, float] | None = None  # visual shapes; None: not given
    name: str = ""  # the element's name attribute
    line: int = 0  # its source line (0: unknown)


@dataclass(frozen=True)
class JointPlan:
    """The joint that moves link ``index`` (PyBullet's joint ``index``).

    ``position`` (m) and ``orientation``: the child link frame in the parent link frame (the
    joint frame is the child link frame). ``axis``: for revolute, continuous and prismatic
    joints the unit axis in the joint frame (the written axis normalised); for fixed and
    spherical joints as written. Limits in rad (revolute) or m (prismatic); ``limited`` is
    PyBullet's rule (a revolute or prismatic joint whose ``<limit>`` has lower <= upper; lower
    == upper locks it). ``effort`` (N·m or N), ``velocity`` (rad/s or m/s), ``damping``
    (N·m·s/rad or N·s/m) and ``friction`` (N·m or N) as written; which of them an engine
    applies is the profile's (``apply_joint_damping``, ``joint_brake``,
    ``enforce_effort_limit``...). ``spherical_limit``: (swing about x, swing about y, twist about
    z) in rad where PyBullet limits a spherical joint (:func:`spherical_limited`), else None."""

    index: int
    name: str
    type: str  # "revolute" | "continuous" | "prismatic" | "spherical" | "fixed"
    parent: int  # the parent link's index (-1 = base)
    position: Vec3
    orientation: Quat
    axis: Vec3
    limited: bool
    lower: float
    upper: float
    effort: float
    velocity: float
    damping: float
    friction: float
    spherical_limit: tuple[float, float, float] | None = None


@dataclass(frozen=True, eq=False)
class LinkPlan:
    """One link, PyBullet's link ``index`` (-1 = base).

    ``inertial``: mass (kg), principal moments (kg·m²) and the principal (inertial) frame in
    the link frame, as PyBullet simulates them for the plan's inertia source (a base loaded
    with ``fixed_base`` has mass 0). ``static``: welded to the world (a fixed base, or a link
    hanging from a static link by a fixed joint). ``collisions`` and ``visuals`` in the file's
    order, without the shapes left out (``BuildPlan.dropped_shapes``); a visual ``<plane>`` is
    not drawn (as in PyBullet) and not listed."""

    index: int
    name: str
    parent: int | None  # None for the base
    joint: JointPlan | None  # None for the base
    inertial: LinkInertial
    static: bool
    collisions: tuple[ShapePlan, ...]
    visuals: tuple[ShapePlan, ...]
    contact: ContactValues
    filter: CollisionFilter


@dataclass(frozen=True, eq=False)
class BuildPlan:
    """Everything an engine builder needs to make one robot (see the module docstring).

    ``fixed_base``: PyBullet welds the root to the world (asked, or a root of mass 0).
    ``base_position`` (m) and ``base_orientation``: the base link frame in the world.
    ``upright``: the base's z axis is the world's (a ground box stays horizontal).
    ``self_collision``: the body's mode
    (:data:`~simbridge.model.load_options.SELF_COLLISION_MODES`);
    ``excluded_pairs``: the link pairs (i < j, -1 = base) that mode leaves out (parent and
    child, or every ancestor; empty for ``"off"``, where no pair collides, and for
    ``"include_parent"``). ``dropped_shapes``: the shapes left out, one line each
    (``"link 'name' <collision> #k"``), visuals before collisions, link by link."""

    name: str
    file: str  # the model's display name, for messages
    fixed_base: bool
    base_position: Vec3
    base_orientation: Quat
    upright: bool
    inertia_source: str
    links: tuple[LinkPlan, ...]
    self_collision: str
    excluded_pairs: frozenset[tuple[int, int]] = field(default_factory=frozenset)
    dropped_shapes: tuple[str, ...] = ()

    def link(self, index: int) -> LinkPlan:
        """The link by PyBullet index.

        Args:
            index: The link's index (-1 = base).

        Returns:
            Its plan.
        """
        return self.links[index + 1]

    def dynamics_info(self, index: int) -> DynamicsInfo:
        """``Backend.dynamics_info`` of a link, as every engine built from this plan simulates it.

        Args:
            index: The link's PyBullet index (-1 = base).

        Returns:
            Its inertial (kg, kg·m², inertial frame in the link frame) and contact values.
        """
        link = self.links[index + 1]
        ine, ct = link.inertial, link.contact
        return DynamicsInfo(
            ine.mass,
            ct.lateral_friction,
            ine.diagonal,
            ine.position,
            ine.orientation,
            ct.restitution,
            ct.rolling_friction,
            ct.spinning_friction,
        )

    @property
    def joints(self) -> tuple[JointPlan, ...]:
        """Joint i moves link i, in PyBullet's order."""
        return tuple(link.joint for link in self.links[1:] if link.joint is not None)

    def self_collides(self, a: int, b: int) -> bool:
        """Whether two links of this body may touch each other, by PyBullet's rules.

        The mode is not ``"off"``, they are two links, not a pair the mode excludes, not both
        static, and the broadphase filter lets them. PyBullet's collision detection still pairs two
        static links the filter lets through (``getContactPoints`` lists them) but they carry no
        force (measured: r2d2 on a fixed base), so they are left out here.

        Args:
            a: One link's PyBullet index (-1 = base).
            b: The other's.

        Returns:
            True when they may touch.
        """
        if self.self_collision == "off" or a == b:
            return False
        if (min(a, b), max(a, b)) in self.excluded_pairs:
            return False
        return links_collide(self.link(a), self.link(b))

    def self_pairs(self) -> tuple[tuple[int, int], ...]:
        """Every pair of links of this body, both with collision shapes, that may touch
        (:meth:`self_collides`).

        Returns:
            ``(i, j)`` pairs of PyBullet indices, i < j, in order.
        """
        ids = [link.index for link in self.links if link.collisions]
        return tuple(
            (a, b) for k, a in enumerate(ids) for b in ids[k + 1 :] if self.self_collides(a, b)
        )


def links_collide(a: LinkPlan, b: LinkPlan) -> bool:
    """Whether two links may touch, by PyBullet's rules: not both welded to the world, and the
    broadphase filter lets them. (Two links of one body: also :meth:`BuildPlan.self_collides`.)

    Args:
        a: One link's plan.
        b: The other's.

    Returns:
        True when they may touch.
    """
    if a.static and b.static:
        return False
    return a.filter.passes(b.filter)
