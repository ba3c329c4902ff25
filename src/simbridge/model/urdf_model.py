"""The parsed robot: :class:`UrdfModel` and its links, joints, geometry, inertia and contact
values, in PyBullet's order (see :func:`simbridge.model.urdf.parse_urdf`). Lengths in metres, angles
in radians, quaternions (x, y, z, w)."""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from pathlib import Path

from simbridge.model.urdf_source import UrdfSource
from simbridge.transforms import quat_from_rpy
from simbridge.types import Quat

__all__ = [
    "CONTACT_TAGS",
    "UrdfModel",
    "Link",
    "Joint",
    "Geometry",
    "Inertial",
    "Contact",
    "Vec3",
]

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class Geometry:
    """One ``<visual>`` or ``<collision>`` element. Its frame in the link frame: ``origin_xyz``
    (m) and ``origin_quat`` (x, y, z, w; ``origin_rpy`` as written, radians)."""

    kind: str  # "box" | "cylinder" | "sphere" | "capsule" | "mesh" | "plane"
    origin_xyz: Vec3
    origin_rpy: Vec3
    size: tuple[float, ...] = ()  # box: (x, y, z) full sizes; cylinder/capsule: (radius, length);
    # sphere: (radius,); mesh: scale (sx, sy, sz); plane: its normal (x, y, z), as written
    mesh_path: Path | None = None  # resolved absolute mesh path
    mesh_uri: str = ""  # filename as written in the URDF
    rgba: tuple[float, float, float, float] | None = None
    name: str = ""
    origin_quat: Quat = None  # type: ignore[assignment]  # None: from origin_rpy
    line: int = 0  # source line of the element (0: unknown)

    def __post_init__(self) -> None:
        if self.origin_quat is None:
            object.__setattr__(self, "origin_quat", quat_from_rpy(self.origin_rpy))


@dataclass(frozen=True)
class Inertial:
    """A link's ``<inertial>``: its frame in the link frame (``origin_xyz`` m, ``origin_quat``
    x, y, z, w), mass (kg) and inertia tensor (kg m², in that frame)."""

    origin_xyz: Vec3 = (0.0, 0.0, 0.0)
    origin_rpy: Vec3 = (0.0, 0.0, 0.0)
    mass: float = 1.0
    inertia: tuple[float, float, float, float, float, float] = (1.0, 0.0, 0.0, 1.0, 0.0, 1.0)
    # ixx, ixy, ixz, iyy, iyz, izz in the inertial frame
    from_file: bool = False  # False when the link had no <inertial> (PyBullet: mass 1)
    origin_quat: Quat = None  # type: ignore[assignment]  # None: from origin_rpy
    line: int = 0
    # principal moments (kg m^2, in this frame) PyBullet computes itself where its shapes follow
    # other rules than a URDF's (an MJCF body: simbridge.model.mjcf); None: from the collision
    # shapes
    moments: Vec3 | None = None

    def __post_init__(self) -> None:
        if self.origin_quat is None:
            object.__setattr__(self, "origin_quat", quat_from_rpy(self.origin_rpy))


@dataclass(frozen=True)
class Contact:
    """Bullet's ``<contact>`` extension; None where the file says nothing."""

    lateral_friction: float | None = None
    rolling_friction: float | None = None
    spinning_friction: float | None = None
    restitution: float | None = None
    stiffness: float | None = None
    damping: float | None = None
    inertia_scaling: float | None = None  # multiplies the link's moments of inertia


CONTACT_TAGS = tuple(f.name for f in fields(Contact))
"""The ``<contact>`` children read (URDF and SDF alike), one per :class:`Contact` field."""


@dataclass
class Link:
    name: str
    inertial: Inertial
    visuals: list[Geometry] = field(default_factory=list)
    collisions: list[Geometry] = field(default_factory=list)
    contact: Contact = field(default_factory=Contact)
    index: int = -1  # PyBullet link index; -1 = base
    line: int = 0  # source line of the <link> element


@dataclass
class Joint:
    """A joint: its frame in the parent link frame (``origin_xyz`` m, ``origin_quat`` x, y, z, w;
    ``origin_rpy`` radians), axis as written (not normalised), limits (rad or m), effort (N·m
    or N), velocity (rad/s or m/s), damping and friction as written."""

    name: str
    type: str  # URDF type: revolute, continuous, prismatic, spherical, fixed
    parent: str
    child: str
    origin_xyz: Vec3
    origin_rpy: Vec3
    axis: Vec3
    lower: float
    upper: float
    effort: float
    velocity: float
    damping: float
    friction: float
    has_limit: bool
    index: int = -1  # PyBullet joint index (= child link index)
    origin_quat: Quat = None  # type: ignore[assignment]  # None: from origin_rpy
    line: int = 0  # source line of the <joint> element
    # a spherical joint's <limit twist> (rad; -1 when absent, PyBullet's default): with lower,
    # upper and effort > 0 PyBullet limits its swing about x and y and its twist about z
    twist: float = -1.0

    def __post_init__(self) -> None:
        if self.origin_quat is None:
            self.origin_quat = quat_from_rpy(self.origin_rpy)


@dataclass
class UrdfModel:
    """A parsed, validated URDF in PyBullet's order.

    ``links[0]`` is the root (PyBullet link -1); ``links[i + 1]`` is link i; ``joints[i]`` is
    joint i, whose child is link i. ``source.text`` is the text PyBullet reads (see
    :mod:`simbridge.model.urdf_xml`); ``assumed`` lists (line, what) where it was read leniently.
    """

    name: str
    source: UrdfSource
    links: list[Link]
    joints: list[Joint]
    assumed: list[tuple[int, str]] = field(default_factory=list)

    @property
    def base(self) -> Link:
        return self.links[0]

    def link(self, index: int) -> Link:
        """A link by PyBullet index.

        Args:
            index: The link's index (-1 = base).

        Returns:
            The link.
        """
        return self.links[index + 1]

    def parent_index(self, joint: Joint) -> int:
        """The PyBullet index of a joint's parent link.

        Args:
            joint: One of the model's joints.

        Returns:
            The parent's index (-1 = base).
        """
        return self._link_index[joint.parent]

    def __post_init__(self) -> None:
        self._link_index = {link.name: link.index for link in self.links}
