"""URDF parsing and validation, shared by every backend.

The core reads a URDF once into a :class:`UrdfModel`: links, joints, geometry, inertia and
contact values, and PyBullet's link order (joint i moves link i, the root is -1). Every backend
builds its engine model from, or checks its engine's model against, this one object, so a bad
file gets the same error on every backend before any engine sees it.

The values are the ones PyBullet 3.2.7 reads from the same file (bullet3
``Importers/ImportURDFDemo/UrdfParser.cpp``), leniency included (:mod:`simbridge.model.urdf_xml`:
numbers read with C's ``atof``, vectors split at spaces, their first three numbers used, a NUL
byte a line break...); whatever a strict reading would not have read so is logged as one
warning naming the file and the lines. What PyBullet refuses is refused here too, with an error
naming the file, the line and the element; a few things PyBullet loads are refused on purpose
(no engine simulates them faithfully): a non-finite number, a negative mass, size, joint
damping or friction, a zero joint axis, several root links (PyBullet crashes), and the joint
types outside :data:`SUPPORTED_JOINT_TYPES`.

Sources (files, names on the search path, URDF text) are :mod:`simbridge.model.urdf_source`'s part;
attribute values read as PyBullet reads them, :mod:`simbridge.model.urdf_values`'s; a link's
elements (geometry and meshes, inertial, contact, colours), :mod:`simbridge.model.urdf_elements`'s.
This module reads the joints and the robot (:func:`parse_urdf`) and puts them in PyBullet's order.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

from simbridge.exceptions import UnsupportedJointError, UrdfStructureError
from simbridge.model.inertia import file_principal
from simbridge.model.urdf_elements import (  # noqa: F401 - MESH_FORMATS re-exported
    MESH_FORMATS,
    _contact,
    _geometry,
    _inertial,
    _material_color,
    _visual_color,
    _without_unread_stl,
)
from simbridge.model.urdf_model import (
    Contact,
    Geometry,
    Inertial,
    Joint,
    Link,
    UrdfModel,
)
from simbridge.model.urdf_source import (  # noqa: F401 - re-exported: simbridge.model.urdf is the public module
    UrdfSource,
    _robots_dir,
    not_a_regular_file,
    resolve_mesh,
    resolve_source,
    search_path,
)
from simbridge.model.urdf_values import _fmt, _Reader
from simbridge.model.urdf_xml import (
    LOGGER,
    Leniency,
    XmlElement,
    pybullet_numbers,
    read_urdf_xml,
)

__all__ = [
    "UrdfSource",
    "UrdfModel",
    "Link",
    "Joint",
    "Geometry",
    "Inertial",
    "Contact",
    "resolve_source",
    "resolve_mesh",
    "parse_urdf",
    "search_path",
    "check_file_inertia",
    "warn_missing_inertials",
    "SUPPORTED_JOINT_TYPES",
    "MESH_FORMATS",
]

SUPPORTED_JOINT_TYPES = ("revolute", "continuous", "prismatic", "spherical", "fixed", "floating")
_KNOWN_UNSUPPORTED = ("planar",)
# PyBullet 3.2.7 builds a planar joint (btMultibody setupPlanar) but broken, measured: the
# child's centre of mass is put at the joint origin, its state reads back 2 of its 3
# coordinates, and resetJointStateMultiDof leaves it where it is. No engine can be held to that.
_PLANAR_REFUSED = (
    "PyBullet's planar joint is broken (measured on 3.2.7: the child's centre of mass is put at "
    "the joint origin, getJointStateMultiDof reads 2 of its 3 coordinates, resetJointStateMultiDof "
    "is ignored)"
)

# ---------------------------------------------------------------- parse


def warn_missing_inertials(model: UrdfModel) -> None:
    """Say once per link, on every backend, that a link without ``<inertial>`` gets mass 1.

    PyBullet's parser gives a link without ``<inertial>`` (but one named ``world``) mass 1 at
    the link's own frame, and says so ("No inertial data for link, using mass=1, ..."): every
    backend simulates that link so, and this logs it on the ``simbridge.model.urdf`` logger,
    naming the file, the line and the link.

    Args:
        model: The parsed robot.
    """
    file = model.source.display_name
    for link in model.links:
        if link.inertial.from_file or link.name == "world":
            continue
        at = f"{file}:{link.line}" if link.line else file
        LOGGER.warning(
            "%s: link %r has no <inertial>: simulated with mass 1 kg, its centre of mass at the "
            "link frame, as PyBullet does ('No inertial data for link, using mass=1')",
            at,
            link.name,
        )


def check_file_inertia(model: UrdfModel) -> None:
    """Check the file's ``<inertia>`` under a profile that simulates it (inertia_source "file").

    A negative moment of inertia is an error (PyBullet zeroes it, MuJoCo cannot take it); under
    the "pybullet" profile the file's inertia is not used and such a file loads, as in PyBullet.
    A tensor whose principal moments PyBullet zeroes (negative, or breaking the triangle
    inequality) is simulated so on every backend, with one warning per link on the
    ``simbridge.model.urdf`` logger naming the file, the line, the link and why.

    Args:
        model: The parsed robot.

    Raises:
        UrdfStructureError: a negative ixx, iyy or izz.
    """
    file = model.source.display_name
    for link in model.links:
        i = link.inertial.inertia
        if min(i[0], i[3], i[5]) < 0:
            raise UrdfStructureError(
                file,
                f"link {link.name!r} <inertia>",
                f"ixx, iyy and izz must be >= 0 to be simulated, got {i[0]}, {i[3]}, {i[5]}",
                link.inertial.line or None,
            )
    for link in model.links:
        if not link.inertial.from_file:
            continue
        reason = file_principal(link.inertial)[2]
        if reason is not None:
            at = f"{file}:{link.inertial.line}" if link.inertial.line else file
            LOGGER.warning(
                "%s: link %r <inertia>: %s; simulated with zero inertia, as PyBullet does "
                "('Bad inertia tensor properties, setting inertia to zero')",
                at,
                link.name,
                reason,
            )


def _joint(r: _Reader, elem: XmlElement, name: str, links: dict[str, Link]) -> Joint:
    where = f"joint {name!r}"
    jtype = elem.get("type")
    if jtype is None:
        raise r.error(elem, where, "has no type attribute (PyBullet refuses it too)")
    if jtype not in SUPPORTED_JOINT_TYPES:
        if jtype in _KNOWN_UNSUPPORTED:
            raise UnsupportedJointError(
                r.file, name, jtype, SUPPORTED_JOINT_TYPES, elem.line, _PLANAR_REFUSED
            )
        raise r.error(
            elem, where, f"unknown joint type {jtype!r}; valid: {list(SUPPORTED_JOINT_TYPES)}"
        )
    parent_elem, child_elem = elem.find("parent"), elem.find("child")
    if parent_elem is None or child_elem is None:
        raise r.error(elem, where, "needs both <parent link> and <child link>")
    parent, child = parent_elem.get("link", ""), child_elem.get("link", "")
    for role, link_name in (("parent", parent), ("child", child)):
        if link_name not in links:
            raise r.error(elem, where, f"{role} link {link_name!r} is not a <link> of this robot")
    if parent == child:
        raise r.error(elem, where, f"link {child!r} is its own parent (a cycle)")
    xyz, rpy = r.origin(elem, where)
    if jtype == "floating":  # PyBullet: "joint unsupported, creating a fixed joint instead"
        r.lenient.add(
            elem.line, f"{where} type 'floating' read as 'fixed' (PyBullet welds it the same)"
        )
        jtype = "fixed"
    axis: tuple[float, ...] = (1.0, 0.0, 0.0)  # PyBullet's axis without an <axis> element
    axis_elem: XmlElement | None = elem.find("axis")  # type: ignore[assignment]
    if jtype in ("fixed", "spherical"):
        if axis_elem is not None:  # not read by PyBullet; kept when it reads as 3 numbers
            values, clean = pybullet_numbers(axis_elem.get("xyz", ""))
            if clean and len(values) == 3 and all(math.isfinite(v) for v in values):
                axis = tuple(values)
    elif axis_elem is not None:
        if axis_elem.get("xyz") is None:
            axis = (0.0, 0.0, 0.0)  # PyBullet: an <axis> without xyz is the zero axis
        else:
            read = r.vector(axis_elem, "xyz", 3, f"{where} <axis>")
            if read is None:
                raise r.error(
                    axis_elem,
                    f"{where} <axis>",
                    f"expected 3 numbers, got {axis_elem.get('xyz')!r} (PyBullet refuses it too)",
                )
            axis = read
    # The axis is kept as written (PyBullet reports it unnormalised); engines normalise it.
    if jtype not in ("fixed", "spherical") and max(abs(a) for a in axis) < 1e-12:
        raise r.error(
            axis_elem if axis_elem is not None else elem,
            f"{where} <axis>",
            f"axis must not be zero, got {_fmt(axis)}",
        )
    if jtype not in ("fixed", "spherical") and not math.isfinite(sum(a * a for a in axis)):
        raise r.error(
            axis_elem if axis_elem is not None else elem,
            f"{where} <axis>",
            f"axis {_fmt(axis)} is too long to normalise: its squared length overflows a "
            "double, and PyBullet then turns the joint about a zero axis, so that it never "
            "moves (measured); write it shorter, a unit axis",
        )
    limit: XmlElement | None = elem.find("limit")  # type: ignore[assignment]
    dynamics: XmlElement | None = elem.find("dynamics")  # type: ignore[assignment]
    if jtype in ("revolute", "prismatic") and limit is None:
        raise r.error(elem, where, f"a {jtype} joint needs a <limit> element (effort, velocity)")
    if (
        dynamics is not None
        and dynamics.get("damping") is None
        and dynamics.get("friction") is None
    ):
        raise r.error(
            dynamics,
            f"{where} <dynamics>",
            "has neither damping nor friction (PyBullet refuses it too)",
        )
    has_range = limit is not None and (
        limit.get("lower") is not None or limit.get("upper") is not None
    )
    # PyBullet's defaults: lower 0, upper -1 ("no range"); attributes override. Fixed joints
    # report their <limit> too (PyBullet 3.2.7, e.g. microtaur.urdf's plate joints).
    lower = r.number(limit, "lower", 0.0, f"{where} <limit>")
    upper = r.number(limit, "upper", -1.0, f"{where} <limit>")
    damping = r.number(dynamics, "damping", 0.0, f"{where} <dynamics>")
    friction = r.number(dynamics, "friction", 0.0, f"{where} <dynamics>")
    for what, value in (("damping", damping), ("friction", friction)):
        if value < 0:
            raise r.error(dynamics, f"{where} <dynamics>", f"{what} must be >= 0, got {value}")
    return Joint(
        name=name,
        type=jtype,
        parent=parent,
        child=child,
        origin_xyz=xyz,
        origin_rpy=rpy,
        axis=axis,  # type: ignore[arg-type]
        lower=lower,
        upper=upper,
        effort=r.number(limit, "effort", 0.0, f"{where} <limit>"),
        velocity=r.number(limit, "velocity", 0.0, f"{where} <limit>"),
        damping=damping,
        friction=friction,
        has_limit=jtype in ("revolute", "prismatic") and has_range and lower <= upper,
        line=elem.line,
        twist=r.number(limit, "twist", -1.0, f"{where} <limit>"),
    )


def parse_urdf(src: UrdfSource) -> UrdfModel:
    """Parse and validate a URDF as PyBullet reads it (see the module docstring).

    What was read leniently is logged as one warning on the ``simbridge.model.urdf`` logger and
    kept in ``model.assumed``.

    Args:
        src: The source, as :func:`~simbridge.model.urdf_source.resolve_source` gives it.

    Returns:
        The model: links and joints in PyBullet's order, each with its index.

    Raises:
        UrdfError: a subclass naming the file, the line and the element on anything a backend
            could not load faithfully (UrdfParseError, UrdfStructureError, MeshNotFoundError,
            UnsupportedJointError).
    """
    file = src.display_name
    lenient = Leniency(file)
    xml = read_urdf_xml(src.text, file, lenient)
    root = xml.root
    r = _Reader(file, lenient)
    if root.tag != "robot":
        raise r.error(root, f"<{root.tag}>", "the root element must be <robot>")
    robot_name = root.get("name")
    if robot_name is None:  # PyBullet: "Expected a name for robot"
        raise r.error(root, "<robot>", "has no name attribute")

    materials: dict[str, tuple[float, float, float, float] | None] = {}
    for elem in root.findall("material"):
        name = elem.get("name")
        if name is not None and name not in materials:  # the first of a name counts
            materials[name] = _material_color(r, elem, f"<material {name!r}>")  # type: ignore[arg-type]

    links: dict[str, Link] = {}
    for elem in root.findall("link"):
        name = elem.get("name")
        if name is None:
            raise r.error(elem, "<link>", "a link has no name attribute")  # type: ignore[arg-type]
        where = f"link {name!r}"
        if name in links:
            raise r.error(elem, where, "link name is used twice")  # type: ignore[arg-type]
        contact = _contact(r, elem.find("contact"), where)  # type: ignore[arg-type]
        inertial = _inertial(r, elem.find("inertial"), where)  # type: ignore[arg-type]
        visuals = []
        for i, v in enumerate(elem.findall("visual")):
            vwhere = f"{where} <visual> #{i}"
            rgba = _visual_color(r, v, vwhere, materials)  # type: ignore[arg-type]
            visuals.append(_geometry(r, v, vwhere, src, rgba))  # type: ignore[arg-type]
        collisions = [
            _geometry(r, c, f"{where} <collision> #{i}", src, None)  # type: ignore[arg-type]
            for i, c in enumerate(elem.findall("collision"))
        ]
        visuals = _without_unread_stl(r.file, visuals, f"{where} <visual>")
        collisions = _without_unread_stl(r.file, collisions, f"{where} <collision>")
        links[name] = Link(
            name,
            inertial,
            visuals,
            collisions,
            contact,
            line=elem.line,  # type: ignore[attr-defined]
        )
    if not links:
        raise r.error(root, f"robot {robot_name!r}", "has no <link>")

    joints: list[Joint] = []
    child_of: dict[str, Joint] = {}
    names: set[str] = set()
    for elem in root.findall("joint"):
        name = elem.get("name")
        if not name:
            raise r.error(elem, "<joint>", "a joint has no name attribute")  # type: ignore[arg-type]
        if name in names:
            raise r.error(elem, f"joint {name!r}", "joint name is used twice")  # type: ignore[arg-type]
        names.add(name)
        joint = _joint(r, elem, name, links)  # type: ignore[arg-type]
        if joint.child in child_of:
            raise r.error(
                elem,  # type: ignore[arg-type]
                f"joint {name!r}",
                f"link {joint.child!r} already has parent joint {child_of[joint.child].name!r}; "
                "a URDF is a tree (each link has at most one parent)",
            )
        joints.append(joint)
        child_of[joint.child] = joint

    roots = [name for name in links if name not in child_of]
    if len(roots) != 1:
        if not roots:
            detail = "every link has a parent: the joints form a cycle"
        else:
            detail = (
                f"{len(roots)} root links {roots}; a URDF needs exactly one root "
                "(PyBullet crashes on several)"
            )
        raise r.error(root, f"robot {robot_name!r}", detail)

    ordered_links, ordered_joints = pybullet_order(links, joints, roots[0])
    if len(ordered_links) != len(links):
        unreached = sorted(set(links) - {link.name for link in ordered_links})
        raise r.error(
            root, f"robot {robot_name!r}", f"links {unreached} form a cycle detached from the root"
        )
    lenient.log()
    return UrdfModel(
        robot_name, replace(src, text=xml.text), ordered_links, ordered_joints, lenient.notes
    )


def pybullet_order(
    links: dict[str, Link], joints: Sequence[Joint], root: str
) -> tuple[list[Link], list[Joint]]:
    """PyBullet's order: depth-first, pre-order, children in the order their joints appear.

    Sets each link's and joint's index (the root's -1).

    Args:
        links: Every link by name.
        joints: Every joint, in the file's order.
        root: The root link's name.

    Returns:
        The links reached from the root (root first) and their joints, in that order.
    """
    children: dict[str, list[Joint]] = {name: [] for name in links}
    for joint in joints:
        children[joint.parent].append(joint)
    ordered_links = [links[root]]
    ordered_joints: list[Joint] = []
    stack = list(reversed(children[root]))
    while stack:
        joint = stack.pop()
        joint.index = len(ordered_joints)
        ordered_joints.append(joint)
        link = links[joint.child]
        link.index = joint.index
        ordered_links.append(link)
        stack.extend(reversed(children[link.name]))
    ordered_links[0].index = -1
    return ordered_links, ordered_joints
