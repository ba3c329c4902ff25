"""``p.loadURDF``'s options, on every backend: scaling, self-collision, the inertia source and
merged fixed links.

:class:`LoadOptions` is what :meth:`simbridge.Sim.load_urdf` hands a backend with the model.
Scaling and merging change the model itself and are done here, once, as PyBullet 3.2.7 does
them (bullet3 ``Importers/ImportURDFDemo/UrdfParser.cpp``: ``m_urdfScaling``,
``mergeFixedLinks``); an engine that builds its model from :class:`~simbridge.model.urdf.UrdfModel`
gets the result, an engine that reads the file itself (PyBullet) passes the options on as its
own flags. Self-collision and the inertia source each backend honours itself.

* ``global_scaling`` (``globalScaling``): every length the file gives is multiplied: origins
  (joints, inertial frames, shapes), box sizes, radii and lengths, mesh scales, and the limits
  of prismatic joints (the default range 0..-1 included); masses, the file's inertia tensors,
  a plane's normal and the 1 mm collision margins are not;
* ``self_collision``: ``"off"`` (PyBullet's default: links of one body never collide);
  ``"exclude_parent"`` (``URDF_USE_SELF_COLLISION``, also with ``..._EXCLUDE_PARENT``, which
  PyBullet 3.2.7 does not read: every pair of links collides but a link and its parent);
  ``"exclude_all_parents"`` (``..._EXCLUDE_ALL_PARENTS``: nor a link and any ancestor);
  ``"include_parent"`` (``..._INCLUDE_PARENT``: every pair). In every mode two links welded to a
  fixed base through fixed joints alone do not collide (both static);
* ``inertia_source``: the profile entry of that name for this body: ``"collision_aabb"`` or
  ``"file"`` (``URDF_USE_INERTIA_FROM_FILE``);
* ``merge_fixed_links`` (``URDF_MERGE_FIXED_LINKS``): every link hanging from its parent by a
  fixed joint is merged into it, as Bullet does it (see :func:`merge_fixed_links`).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

from simbridge.exceptions import InvalidArgumentError, UrdfStructureError
from simbridge.model.inertia import jacobi_principal
from simbridge.model.urdf_model import Geometry, Inertial, Joint, Link, UrdfModel, Vec3
from simbridge.profiles import Profile
from simbridge.transforms import IDENTITY_QUAT, rpy_from_quat, transform_multiply
from simbridge.types import Quat

__all__ = [
    "LoadOptions",
    "SELF_COLLISION_MODES",
    "INERTIA_SOURCES",
    "load_options",
    "apply_load_options",
    "scaled",
    "merge_fixed_links",
    "self_collision_exclusions",
]

SELF_COLLISION_MODES = ("off", "exclude_parent", "exclude_all_parents", "include_parent")
INERTIA_SOURCES = ("collision_aabb", "file")


@dataclass(frozen=True)
class LoadOptions:
    """One body's load options (see the module docstring); every field checked."""

    global_scaling: float = 1.0
    self_collision: str = "off"
    inertia_source: str = "collision_aabb"
    merge_fixed_links: bool = False

    def as_dict(self) -> dict[str, Any]:
        """The options, JSON-able.

        Returns:
            Each field by name.
        """
        return asdict(self)


def load_options(
    profile: Profile,
    *,
    global_scaling: Any = 1.0,
    self_collision: Any = None,
    inertia_source: Any = None,
    merge_fixed_links: Any = False,
) -> LoadOptions:
    """Check :meth:`Sim.load_urdf`'s options and fill the profile's entries in for the ones left
    None.

    Args:
        profile: The profile whose ``self_collision`` and ``inertia_source`` fill in.
        global_scaling: A finite number > 0.
        self_collision: One of :data:`SELF_COLLISION_MODES`, True (``"exclude_parent"``),
            False (``"off"``), or None (the profile's).
        inertia_source: One of :data:`INERTIA_SOURCES`, or None (the profile's).
        merge_fixed_links: True or False.

    Returns:
        The checked options.

    Raises:
        InvalidArgumentError: naming the argument and the valid values.
    """
    if isinstance(global_scaling, bool) or not isinstance(global_scaling, (int, float, np.number)):
        raise InvalidArgumentError(
            "global_scaling", f"must be a finite number > 0, got {global_scaling!r}"
        )
    try:
        scale = float(global_scaling)
    except OverflowError:  # an int past float's range
        scale = math.inf
    if not math.isfinite(scale) or scale <= 0:
        raise InvalidArgumentError(
            "global_scaling", f"must be a finite number > 0, got {global_scaling!r}"
        )
    if self_collision is None:
        self_collision = profile.self_collision
    if isinstance(self_collision, (bool, np.bool_)):
        self_collision = "exclude_parent" if self_collision else "off"
    if self_collision not in SELF_COLLISION_MODES:
        raise InvalidArgumentError(
            "self_collision",
            f"must be True, False or one of {list(SELF_COLLISION_MODES)}, got {self_collision!r}",
        )
    if inertia_source is None:
        inertia_source = profile.inertia_source
    if inertia_source not in INERTIA_SOURCES:
        raise InvalidArgumentError(
            "inertia_source", f"must be one of {list(INERTIA_SOURCES)}, got {inertia_source!r}"
        )
    if not isinstance(merge_fixed_links, (bool, np.bool_)):
        raise InvalidArgumentError(
            "merge_fixed_links", f"must be True or False, got {merge_fixed_links!r}"
        )
    return LoadOptions(scale, str(self_collision), str(inertia_source), bool(merge_fixed_links))


def apply_load_options(model: UrdfModel, options: LoadOptions, fixed_base: bool) -> UrdfModel:
    """The model PyBullet builds with these options: scaled, then merged.

    Args:
        model: The parsed robot, left as it was.
        options: The checked options.
        fixed_base: Whether ``load`` was asked for a fixed base (merging keeps a welded root's
            mass).

    Returns:
        The model to build (``model`` itself when neither option changes it).

    Raises:
        UrdfStructureError: as :func:`merge_fixed_links`.
    """
    if options.global_scaling != 1.0:
        model = scaled(model, options.global_scaling)
    if options.merge_fixed_links:
        model = merge_fixed_links(model, fixed_base)
    return model


# ---------------------------------------------------------------- scaling


def _times(v: tuple[float, ...], s: float) -> tuple[float, ...]:
    return tuple(x * s for x in v)


def _xyz(v: Vec3, s: float) -> Vec3:
    return (v[0] * s, v[1] * s, v[2] * s)


def _scaled_shape(g: Geometry, s: float) -> Geometry:
    size = g.size if g.kind == "plane" else _times(g.size, s)
    return replace(g, origin_xyz=_xyz(g.origin_xyz, s), size=size)


def scaled(model: UrdfModel, s: float) -> UrdfModel:
    """``model`` with PyBullet's ``globalScaling`` (see the module docstring).

    Args:
        model: The parsed robot, left as it was.
        s: The factor on every length (> 0).

    Returns:
        The scaled copy.
    """
    links = []
    for link in model.links:
        ine = link.inertial
        links.append(
            replace(
                link,
                inertial=replace(ine, origin_xyz=_xyz(ine.origin_xyz, s)),
                visuals=[_scaled_shape(g, s) for g in link.visuals],
                collisions=[_scaled_shape(g, s) for g in link.collisions],
            )
        )
    joints = []
    for joint in model.joints:
        changes: dict[str, Any] = {"origin_xyz": _xyz(joint.origin_xyz, s)}
        if joint.type == "prismatic":
            changes |= {"lower": joint.lower * s, "upper": joint.upper * s}
        joints.append(replace(joint, **changes))
    return UrdfModel(model.name, model.source, links, joints, model.assumed)


# ---------------------------------------------------------------- merging fixed links


@dataclass
class _Node:
    """A link while links are merged: Bullet's UrdfLink with its UrdfInertia."""

    link: Link
    children: list[tuple[Joint, _Node]]
    mass: float
    frame: tuple[Vec3, Quat]  # inertial frame in the link frame
    tensor: np.ndarray  # (3, 3) as Bullet holds it
    has_frame: bool = False  # Bullet's m_hasLinkLocalFrame: set only by a merge
    merged: bool = False  # received a merge


def _bullet_inertia(link: Link, root_forced: bool) -> tuple[float, np.ndarray]:
    """The mass and tensor Bullet's parser holds for ``link`` (no <inertial>: mass 1 and unit
    moments, 0 for a link named world; a root of a ``fixed_base`` load: zeros)."""
    if root_forced:
        return 0.0, np.zeros((3, 3))
    ine = link.inertial
    if not ine.from_file:
        v = 0.0 if link.name == "world" else 1.0
        return v, np.diag([v, v, v])
    ixx, ixy, ixz, iyy, iyz, izz = ine.inertia
    return float(ine.mass), np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]], float)


def _moved(g: Geometry, frame: tuple[Vec3, Quat]) -> Geometry:
    pos, orn = transform_multiply(frame, (g.origin_xyz, g.origin_quat))
    return replace(g, origin_xyz=pos, origin_quat=orn, origin_rpy=rpy_from_quat(orn))


def merge_fixed_links(model: UrdfModel, fixed_base: bool) -> UrdfModel:
    """``model`` with ``URDF_MERGE_FIXED_LINKS``, as Bullet's ``UrdfParser::mergeFixedLinks``
    does it, quirks included (measured against raw PyBullet in ``tests/test_load_options.py``):

    * a link's children are visited in file order; a child on a fixed joint is merged: its
      shapes move into the parent (in the parent's link frame), its children are re-hung on the
      parent (joint origins composed) and appended to the parent's children, and it takes the
      parent's *last* child's place in the list (Bullet removes by swapping with the last);
      PyBullet's link order is then depth-first over these lists;
    * masses add up; the inertial origin becomes the two centres of mass weighted by mass, each
      taken at its link frame's origin unless it came from an earlier merge (Bullet sets the
      inertial frame it started from to identity); the tensors add without rotation, plus each
      mass's point term about the new centre; the sum is diagonalised (threshold 1e-5, 20
      rotations) and the inertial frame keeps no rotation;
    * a root welded to the world (``fixed_base`` or mass 0) takes the shapes but keeps its mass;
      its inertial frame still becomes the link frame.

    Args:
        model: The parsed robot, left as it was.
        fixed_base: Whether ``load`` was asked for a fixed base.

    Returns:
        The merged copy, links in PyBullet's order.

    Raises:
        UrdfStructureError: where Bullet would divide by a total mass of 0 (a centre of mass of
            NaN).
    """
    file = model.source.display_name
    nodes: dict[str, _Node] = {}
    for link in model.links:
        mass, tensor = _bullet_inertia(link, fixed_base and link.index == -1)
        ine = link.inertial
        frame = (ine.origin_xyz, ine.origin_quat) if ine.from_file else _IDENTITY
        nodes[link.name] = _Node(link, [], mass, frame, tensor)
    for joint in model.joints:  # PyBullet order keeps each parent's children in file order
        nodes[joint.parent].children.append((joint, nodes[joint.child]))
    root = nodes[model.base.name]

    def merge(node: _Node) -> None:
        i = 0
        while i < len(node.children):
            joint, child = node.children[i]
            if joint.type != "fixed":
                merge(child)
                i += 1
                continue
            at = (joint.origin_xyz, joint.origin_quat)
            node.link = replace(
                node.link,
                collisions=[*node.link.collisions, *(_moved(g, at) for g in child.link.collisions)],
                visuals=[*node.link.visuals, *(_moved(g, at) for g in child.link.visuals)],
            )
            if not node.has_frame:
                node.frame = _IDENTITY
            is_root = node is root
            if not ((fixed_base or node.mass == 0.0) and is_root):
                _add_mass(node, child, at, file, joint)
            node.merged = True
            node.children[i] = node.children[-1]
            node.children.pop()
            for grand_joint, grand_child in child.children:
                pos, orn = transform_multiply(at, (grand_joint.origin_xyz, grand_joint.origin_quat))
                moved = replace(
                    grand_joint,
                    parent=node.link.name,
                    origin_xyz=pos,
                    origin_quat=orn,
                    origin_rpy=rpy_from_quat(orn),
                )
                node.children.append((moved, grand_child))

    merge(root)
    links: list[Link] = []
    joints: list[Joint] = []

    def emit(node: _Node, index: int) -> None:
        link = replace(node.link, index=index)
        if node.merged:
            ine = link.inertial
            if node.has_frame:
                ixx, iyy, izz = (float(node.tensor[k, k]) for k in range(3))
                ine = Inertial(
                    node.frame[0],
                    (0.0, 0.0, 0.0),
                    node.mass,
                    (ixx, 0.0, 0.0, iyy, 0.0, izz),
                    True,
                    origin_quat=IDENTITY_QUAT,
                    line=ine.line,
                )
            else:  # a welded root: its own mass, its inertial frame the link frame
                ine = replace(
                    ine,
                    origin_xyz=(0.0, 0.0, 0.0),
                    origin_rpy=(0.0, 0.0, 0.0),
                    origin_quat=IDENTITY_QUAT,
                )
            link = replace(link, inertial=ine)
        links.append(link)
        for joint, child in node.children:
            joints.append(replace(joint, index=len(joints)))
            emit(child, len(joints) - 1)

    emit(root, -1)
    return UrdfModel(model.name, model.source, links, joints, model.assumed)


_IDENTITY: tuple[Vec3, Quat] = ((0.0, 0.0, 0.0), IDENTITY_QUAT)


def _add_mass(node: _Node, child: _Node, at: tuple[Vec3, Quat], file: str, joint: Joint) -> None:
    """Bullet's CalculatePrincipalAxisTransform of the node and the merged child (whose
    inertial frame Bullet takes at its link frame: the joint frame ``at``)."""
    masses = (node.mass, child.mass)
    total = masses[0] + masses[1]
    if total == 0.0:
        raise UrdfStructureError(
            file,
            f"joint {joint.name!r}",
            f"merge_fixed_links: links {node.link.name!r} and {child.link.name!r} both have mass "
            "0; PyBullet's merge divides by their total mass (a centre of mass of NaN)",
            joint.line or None,
        )
    origins = (np.asarray(node.frame[0], float), np.asarray(at[0], float))
    center = (origins[0] * masses[0] + origins[1] * masses[1]) / total
    tensor = np.zeros((3, 3))
    for k, inertia in enumerate((node.tensor, child.tensor)):
        # Bullet turns each tensor with basis * (basis^T * I): the tensor itself
        tensor += inertia
        o = origins[k] - center
        tensor += masses[k] * (float(o @ o) * np.eye(3) - np.outer(o, o))
    diagonal, _ = jacobi_principal(tensor, threshold=1e-5, max_steps=20)
    node.tensor = np.diag(diagonal)
    node.frame = ((float(center[0]), float(center[1]), float(center[2])), IDENTITY_QUAT)
    node.has_frame = True
    node.mass = total


# ---------------------------------------------------------------- self-collision


def self_collision_exclusions(model: UrdfModel, mode: str) -> set[tuple[int, int]] | None:
    """The link pairs of one body that do not collide under ``mode``. The static rule (links
    welded to a fixed base) is the backend's.

    Args:
        model: The robot.
        mode: One of :data:`SELF_COLLISION_MODES`.

    Returns:
        ``(i, j)`` pairs, i < j, -1 = base; None for ``"off"`` (no pair collides).
    """
    if mode == "off":
        return None
    parent = {j.index: model.parent_index(j) for j in model.joints}
    out: set[tuple[int, int]] = set()
    if mode == "include_parent":
        return out
    for link in parent:
        if mode == "exclude_parent":
            out.add((min(link, parent[link]), max(link, parent[link])))
            continue
        up = parent[link]
        while True:  # every ancestor, the base included
            out.add((min(link, up), max(link, up)))
            if up == -1:
                break
            up = parent[up]
    return out
