"""URDF sources, parsing and validation, shared by every backend.

The core reads a URDF once, with the standard library, into a :class:`UrdfModel`: links, joints,
geometry, inertia and contact values, and PyBullet's link order (joint i moves link i, the root
is -1). Every backend builds its engine model from, or checks its engine's model against, this
one object, so a bad file gets the same error on every backend before any engine sees it.
"""

from __future__ import annotations

import importlib.util
import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from .exceptions import (
    MeshNotFoundError,
    UnsupportedJointError,
    UrdfNotFoundError,
    UrdfParseError,
    UrdfStructureError,
)
from .meshes import mesh_vertices

__all__ = [
    "UrdfSource",
    "UrdfModel",
    "Link",
    "Joint",
    "Geometry",
    "Inertial",
    "Contact",
    "resolve_source",
    "parse_urdf",
    "search_path",
    "SUPPORTED_JOINT_TYPES",
]

SUPPORTED_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed")
_KNOWN_UNSUPPORTED = ("floating", "planar", "spherical")


# ---------------------------------------------------------------- sources


@dataclass(frozen=True)
class UrdfSource:
    """Where a URDF came from: its text, its file (None for text) and the folder that relative
    mesh paths resolve against."""

    text: str
    path: Path | None
    base_dir: Path
    display_name: str


def _robots_dir() -> Path:
    spec = importlib.util.find_spec("simbridge.robots")
    if spec is None or not spec.submodule_search_locations:  # pragma: no cover - broken install
        raise RuntimeError("simbridge.robots package data is missing from this installation")
    return Path(next(iter(spec.submodule_search_locations)))


def search_path() -> list[Path]:
    """Folders searched for a URDF given by name: the package's robots, then pybullet_data.

    ``SIMBRIDGE_URDF_PATH`` (os.pathsep-separated) is searched first when set.
    """
    paths = [Path(p) for p in os.environ.get("SIMBRIDGE_URDF_PATH", "").split(os.pathsep) if p]
    paths.append(_robots_dir())
    spec = importlib.util.find_spec("pybullet_data")
    if spec is not None and spec.submodule_search_locations:
        paths.append(Path(next(iter(spec.submodule_search_locations))))
    return paths


def _is_file(path: Path) -> bool:
    """Path.is_file, False for names no file system takes (too long, a NUL byte)."""
    try:
        return path.is_file()
    except (OSError, ValueError):
        return False


def resolve_source(source: str | os.PathLike[str]) -> UrdfSource:
    """Turn a path, a name on the search path, or URDF XML text into a :class:`UrdfSource`."""
    if isinstance(source, str) and source.lstrip("\ufeff \t\r\n").startswith("<"):
        return UrdfSource(source.lstrip("\ufeff"), None, Path.cwd(), "<urdf text>")
    if not isinstance(source, (str, os.PathLike)):
        raise UrdfNotFoundError(repr(source), ["a path, a name or URDF text was expected"])
    shown = (
        str(source)
        if len(str(source)) <= 120
        else f"{str(source)[:100]}... ({len(str(source))} characters)"
    )
    try:
        candidate = Path(source).expanduser()
    except (RuntimeError, ValueError):  # "~nosuchuser/..."
        candidate = Path(source)
    tried: list[str] = []
    if _is_file(candidate):
        found: Path | None = candidate
    else:
        tried.append(shown if len(str(candidate)) > 120 else str(candidate.absolute()))
        found = None
        if not candidate.is_absolute() and len(str(candidate)) <= 255 and "\0" not in str(source):
            for folder in search_path():
                for name in (candidate, Path(f"{candidate}.urdf")):
                    path = folder / name
                    if _is_file(path):
                        found = path
                        break
                    tried.append(str(path))
                if found:
                    break
    if found is None:
        raise UrdfNotFoundError(shown, tried)
    found = found.resolve()
    try:
        text = found.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise UrdfParseError(str(found), f"cannot read the file: {exc}") from exc
    return UrdfSource(text, found, found.parent, str(found))


# ---------------------------------------------------------------- model


@dataclass(frozen=True)
class Geometry:
    """One ``<visual>`` or ``<collision>`` element. ``origin`` is (xyz, rpy) in the link frame."""

    kind: str  # "box" | "cylinder" | "sphere" | "capsule" | "mesh"
    origin_xyz: tuple[float, float, float]
    origin_rpy: tuple[float, float, float]
    size: tuple[float, ...] = ()  # box: (x, y, z) full sizes; cylinder/capsule: (radius, length);
    # sphere: (radius,); mesh: scale (sx, sy, sz)
    mesh_path: Path | None = None  # resolved absolute mesh path
    mesh_uri: str = ""  # filename as written in the URDF
    rgba: tuple[float, float, float, float] | None = None
    name: str = ""


@dataclass(frozen=True)
class Inertial:
    origin_xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    origin_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    mass: float = 1.0
    inertia: tuple[float, float, float, float, float, float] = (1.0, 0.0, 0.0, 1.0, 0.0, 1.0)
    # ixx, ixy, ixz, iyy, iyz, izz in the inertial frame
    from_file: bool = False  # False when the link had no <inertial> (PyBullet: mass 1)


@dataclass(frozen=True)
class Contact:
    """Bullet's ``<contact>`` extension; None where the file says nothing."""

    lateral_friction: float | None = None
    rolling_friction: float | None = None
    spinning_friction: float | None = None
    restitution: float | None = None
    stiffness: float | None = None
    damping: float | None = None


@dataclass
class Link:
    name: str
    inertial: Inertial
    visuals: list[Geometry] = field(default_factory=list)
    collisions: list[Geometry] = field(default_factory=list)
    contact: Contact = field(default_factory=Contact)
    index: int = -1  # PyBullet link index; -1 = base


@dataclass
class Joint:
    name: str
    type: str  # URDF type: revolute, continuous, prismatic, fixed
    parent: str
    child: str
    origin_xyz: tuple[float, float, float]
    origin_rpy: tuple[float, float, float]
    axis: tuple[float, float, float]
    lower: float
    upper: float
    effort: float
    velocity: float
    damping: float
    friction: float
    has_limit: bool
    index: int = -1  # PyBullet joint index (= child link index)


@dataclass
class UrdfModel:
    """A parsed, validated URDF in PyBullet's order.

    ``links[0]`` is the root (PyBullet link -1); ``links[i + 1]`` is link i; ``joints[i]`` is
    joint i, whose child is link i.
    """

    name: str
    source: UrdfSource
    links: list[Link]
    joints: list[Joint]

    @property
    def base(self) -> Link:
        return self.links[0]

    def link(self, index: int) -> Link:
        """Link by PyBullet index (-1 = base)."""
        return self.links[index + 1]

    def parent_index(self, joint: Joint) -> int:
        return self._link_index[joint.parent]

    def __post_init__(self) -> None:
        self._link_index = {link.name: link.index for link in self.links}


# ---------------------------------------------------------------- parsing helpers


def _floats(
    text: str | None, n: int, default: tuple[float, ...], where: str, file: str
) -> tuple[float, ...]:
    if text is None:
        return default
    try:
        values = tuple(float(v) for v in text.split())
    except ValueError:
        raise UrdfStructureError(file, where, f"expected {n} numbers, got {text!r}") from None
    if len(values) != n:
        raise UrdfStructureError(file, where, f"expected {n} numbers, got {text!r}")
    if not all(math.isfinite(v) for v in values):
        raise UrdfStructureError(file, where, f"numbers must be finite, got {text!r}")
    return values


def _float(elem: ET.Element | None, attr: str, default: float, where: str, file: str) -> float:
    if elem is None or elem.get(attr) is None:
        return default
    return _floats(elem.get(attr), 1, (default,), f"{where} attribute {attr!r}", file)[0]


def _nonneg(elem: ET.Element | None, attr: str, where: str, file: str) -> float:
    value = _float(elem, attr, 0.0, where, file)
    if value < 0:
        raise UrdfStructureError(file, where, f"{attr} must be >= 0, got {value}")
    return value


def _origin(
    elem: ET.Element, where: str, file: str
) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    origin = elem.find("origin")
    if origin is None:
        return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    xyz = _floats(origin.get("xyz"), 3, (0.0, 0.0, 0.0), f"{where} <origin xyz>", file)
    rpy = _floats(origin.get("rpy"), 3, (0.0, 0.0, 0.0), f"{where} <origin rpy>", file)
    return xyz, rpy  # type: ignore[return-value]


def resolve_mesh(uri: str, base_dir: Path) -> tuple[Path, list[Path]]:
    """Resolve a mesh filename against the URDF's own tree.

    ``package://NAME/rest`` is looked up in every ancestor of ``base_dir`` (a folder that is, or
    contains, NAME), then as ``rest`` and ``NAME/rest`` relative to ``base_dir``;
    ``file://`` and plain paths resolve relative to ``base_dir``. Returns the first existing
    candidate (or the first candidate) and every candidate tried.
    """
    candidates: list[Path] = []
    if uri.startswith("package://"):
        rest = uri[len("package://") :]
        package, _, sub = rest.partition("/")
        for ancestor in [base_dir, *base_dir.parents]:
            if ancestor.name == package:
                candidates.append(ancestor / sub)
            candidates.append(ancestor / package / sub)
        candidates += [base_dir / sub, base_dir / rest]
    else:
        path = uri[len("file://") :] if uri.startswith("file://") else uri
        candidates.append(Path(path) if os.path.isabs(path) else base_dir / path)
    for candidate in candidates:
        if candidate.is_file():
            return candidate.resolve(), candidates
    return candidates[0], candidates


def _geometry(elem: ET.Element, where: str, src: UrdfSource, is_visual: bool) -> Geometry | None:
    file = src.display_name
    xyz, rpy = _origin(elem, where, file)
    geom = elem.find("geometry")
    if geom is None or len(geom) == 0:
        raise UrdfStructureError(file, where, "has no <geometry>")
    shape = geom[0]
    rgba = None
    if is_visual:
        material = elem.find("material")
        color = material.find("color") if material is not None else None
        if color is not None:
            rgba = _floats(color.get("rgba"), 4, (1.0, 1.0, 1.0, 1.0), f"{where} <color>", file)
    name = elem.get("name", "")
    tag = shape.tag
    if tag == "box":
        if shape.get("size") is None:  # PyBullet: "box requires a size attribute"
            raise UrdfStructureError(file, f"{where} <box>", "has no size attribute")
        size = _floats(shape.get("size"), 3, (1.0, 1.0, 1.0), f"{where} <box size>", file)
        _sizes(size, f"{where} <box size>", file)
        return Geometry("box", xyz, rpy, size, rgba=rgba, name=name)  # type: ignore[arg-type]
    if tag in ("cylinder", "capsule"):
        radius = _float(shape, "radius", 1.0, f"{where} <{tag}>", file)
        length = _float(shape, "length", 1.0, f"{where} <{tag}>", file)
        _sizes((radius, length), f"{where} <{tag} radius, length>", file)
        return Geometry(tag, xyz, rpy, (radius, length), rgba=rgba, name=name)  # type: ignore[arg-type]
    if tag == "sphere":
        radius = _float(shape, "radius", 1.0, f"{where} <sphere>", file)
        _sizes((radius,), f"{where} <sphere radius>", file)
        return Geometry("sphere", xyz, rpy, (radius,), rgba=rgba, name=name)  # type: ignore[arg-type]
    if tag == "mesh":
        uri = shape.get("filename")
        if not uri:
            raise UrdfStructureError(file, f"{where} <mesh>", "has no filename attribute")
        scale = _floats(shape.get("scale"), 3, (1.0, 1.0, 1.0), f"{where} <mesh scale>", file)
        path, tried = resolve_mesh(uri, src.base_dir)
        if not path.is_file():
            raise MeshNotFoundError(file, where, uri, str(tried[0]))
        if path.suffix.lower() not in MESH_FORMATS:
            raise UrdfStructureError(
                file,
                f"{where} <mesh>",
                f"{uri!r}: unsupported mesh format; valid: {', '.join(MESH_FORMATS)}",
            )
        if path.suffix.lower() == ".dae":
            _check_collada(path, uri, f"{where} <mesh>", file)
        return Geometry(
            "mesh",
            xyz,
            rpy,
            scale,
            mesh_path=path,
            mesh_uri=uri,
            rgba=rgba,  # type: ignore[arg-type]
            name=name,
        )
    raise UrdfStructureError(
        file, where, f"unknown geometry <{tag}>; valid: box, cylinder, sphere, capsule, mesh"
    )


MESH_FORMATS = (".obj", ".stl", ".dae")  # what PyBullet's URDF importer reads


def _sizes(values: Sequence[float], where: str, file: str) -> None:
    if any(v < 0 for v in values):
        raise UrdfStructureError(file, where, f"sizes must be >= 0, got {tuple(values)}")


def _check_collada(path: Path, uri: str, where: str, file: str) -> None:
    """Read a .dae before any engine does: PyBullet's COLLADA reader ends the process on some
    malformed files (an empty <scene>), and MuJoCo's backend converts .dae through trimesh."""
    try:
        vertices = mesh_vertices(path)
    except Exception as exc:  # noqa: BLE001 - any reader failure is a bad file
        raise UrdfStructureError(
            file, where, f"{uri!r} cannot be read as COLLADA ({type(exc).__name__}: {exc})"
        ) from None
    if len(vertices) < 3:
        raise UrdfStructureError(file, where, f"{uri!r} holds no geometry (no vertices)")


def _inertial(elem: ET.Element | None, where: str, file: str) -> Inertial:
    if elem is None:
        return Inertial()
    xyz, rpy = _origin(elem, f"{where} <inertial>", file)
    mass = _float(elem.find("mass"), "value", 0.0, f"{where} <mass>", file)
    if mass < 0:
        raise UrdfStructureError(file, f"{where} <mass>", f"mass must be >= 0, got {mass}")
    ie = elem.find("inertia")
    inertia = tuple(
        _float(ie, key, 0.0, f"{where} <inertia>", file)
        for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    )
    return Inertial(xyz, rpy, mass, inertia, True)  # type: ignore[arg-type]


def _contact(elem: ET.Element | None, where: str, file: str) -> Contact:
    if elem is None:
        return Contact()

    def value(tag: str) -> float | None:
        child = elem.find(tag)
        if child is None:
            return None
        return _float(child, "value", 0.0, f"{where} <contact><{tag}>", file)

    return Contact(
        value("lateral_friction"),
        value("rolling_friction"),
        value("spinning_friction"),
        value("restitution"),
        value("stiffness"),
        value("damping"),
    )


# ---------------------------------------------------------------- parse


def check_file_inertia(model: UrdfModel) -> None:
    """Under a profile that simulates the file's <inertia> (inertia_source "file"), a negative
    moment of inertia is an error (PyBullet zeroes it, MuJoCo cannot take it); under the
    "pybullet" profile the file's inertia is not used and such a file loads, as in PyBullet."""
    file = model.source.display_name
    for link in model.links:
        i = link.inertial.inertia
        if min(i[0], i[3], i[5]) < 0:
            raise UrdfStructureError(
                file,
                f"link {link.name!r} <inertia>",
                f"ixx, iyy and izz must be >= 0 to be simulated, got {i[0]}, {i[3]}, {i[5]}",
            )


def parse_urdf(src: UrdfSource) -> UrdfModel:
    """Parse and validate a URDF; raise a :class:`~simbridge.exceptions.UrdfError` subclass
    that names the file and element on anything a backend could not load faithfully."""
    file = src.display_name
    try:
        root = ET.fromstring(src.text)
    except ET.ParseError as exc:
        raise UrdfParseError(file, str(exc)) from None
    if root.tag != "robot":
        raise UrdfStructureError(file, f"<{root.tag}>", "the root element must be <robot>")
    robot_name = root.get("name")
    if robot_name is None:  # PyBullet: "Expected a name for robot"
        raise UrdfStructureError(file, "<robot>", "has no name attribute")

    links: dict[str, Link] = {}
    for elem in root.findall("link"):
        name = elem.get("name")
        if not name:
            raise UrdfStructureError(file, "<link>", "a link has no name attribute")
        where = f"link {name!r}"
        if name in links:
            raise UrdfStructureError(file, where, "link name is used twice")
        link = Link(
            name=name,
            inertial=_inertial(elem.find("inertial"), where, file),
            visuals=[
                g
                for i, v in enumerate(elem.findall("visual"))
                if (g := _geometry(v, f"{where} <visual> #{i}", src, True))
            ],
            collisions=[
                g
                for i, c in enumerate(elem.findall("collision"))
                if (g := _geometry(c, f"{where} <collision> #{i}", src, False))
            ],
            contact=_contact(elem.find("contact"), where, file),
        )
        links[name] = link
    if not links:
        raise UrdfStructureError(file, f"robot {robot_name!r}", "has no <link>")

    joints: list[Joint] = []
    child_of: dict[str, Joint] = {}
    names: set[str] = set()
    for elem in root.findall("joint"):
        name = elem.get("name")
        if not name:
            raise UrdfStructureError(file, "<joint>", "a joint has no name attribute")
        where = f"joint {name!r}"
        if name in names:
            raise UrdfStructureError(file, where, "joint name is used twice")
        names.add(name)
        jtype = elem.get("type", "")
        if jtype not in SUPPORTED_JOINT_TYPES:
            if jtype in _KNOWN_UNSUPPORTED:
                raise UnsupportedJointError(file, name, jtype, SUPPORTED_JOINT_TYPES)
            raise UrdfStructureError(
                file, where, f"unknown joint type {jtype!r}; valid: {list(SUPPORTED_JOINT_TYPES)}"
            )
        parent_elem, child_elem = elem.find("parent"), elem.find("child")
        if parent_elem is None or child_elem is None:
            raise UrdfStructureError(file, where, "needs both <parent link> and <child link>")
        parent, child = parent_elem.get("link", ""), child_elem.get("link", "")
        for role, link_name in (("parent", parent), ("child", child)):
            if link_name not in links:
                raise UrdfStructureError(
                    file, where, f"{role} link {link_name!r} is not a <link> of this robot"
                )
        if parent == child:
            raise UrdfStructureError(file, where, f"link {child!r} is its own parent (a cycle)")
        if child in child_of:
            raise UrdfStructureError(
                file,
                where,
                f"link {child!r} already has parent joint {child_of[child].name!r}; "
                "a URDF is a tree (each link has at most one parent)",
            )
        xyz, rpy = _origin(elem, where, file)
        axis_elem = elem.find("axis")
        axis = _floats(
            axis_elem.get("xyz") if axis_elem is not None else None,
            3,
            (1.0, 0.0, 0.0),
            f"{where} <axis>",
            file,
        )
        # The axis is kept as written (PyBullet reports it unnormalised); engines normalise it.
        if jtype != "fixed" and max(abs(a) for a in axis) < 1e-12:
            raise UrdfStructureError(file, f"{where} <axis>", "axis must not be zero")
        limit = elem.find("limit")
        dynamics = elem.find("dynamics")
        if jtype in ("revolute", "prismatic") and limit is None:
            raise UrdfStructureError(
                file, where, f"a {jtype} joint needs a <limit> element (effort, velocity)"
            )
        has_range = limit is not None and (
            limit.get("lower") is not None or limit.get("upper") is not None
        )
        # PyBullet's defaults: lower 0, upper -1 ("no range"); attributes override. Fixed joints
        # report their <limit> too (PyBullet 3.2.7, e.g. microtaur.urdf's plate joints).
        lower = _float(limit, "lower", 0.0, f"{where} <limit>", file)
        upper = _float(limit, "upper", -1.0, f"{where} <limit>", file)
        joint = Joint(
            name=name,
            type=jtype,
            parent=parent,
            child=child,
            origin_xyz=xyz,
            origin_rpy=rpy,
            axis=axis,  # type: ignore[arg-type]
            lower=lower,
            upper=upper,
            effort=_float(limit, "effort", 0.0, f"{where} <limit>", file),
            velocity=_float(limit, "velocity", 0.0, f"{where} <limit>", file),
            damping=_nonneg(dynamics, "damping", f"{where} <dynamics>", file),
            friction=_nonneg(dynamics, "friction", f"{where} <dynamics>", file),
            has_limit=jtype in ("revolute", "prismatic") and has_range and lower <= upper,
        )
        joints.append(joint)
        child_of[child] = joint

    roots = [name for name in links if name not in child_of]
    if len(roots) != 1:
        if not roots:
            detail = "every link has a parent: the joints form a cycle"
        else:
            detail = f"{len(roots)} root links {roots}; a URDF needs exactly one root"
        raise UrdfStructureError(file, f"robot {robot_name!r}", detail)

    # PyBullet's order: depth-first, pre-order, children in the order their joints appear.
    children: dict[str, list[Joint]] = {name: [] for name in links}
    for joint in joints:
        children[joint.parent].append(joint)
    ordered_links = [links[roots[0]]]
    ordered_joints: list[Joint] = []
    stack = list(reversed(children[roots[0]]))
    while stack:
        joint = stack.pop()
        joint.index = len(ordered_joints)
        ordered_joints.append(joint)
        link = links[joint.child]
        link.index = joint.index
        ordered_links.append(link)
        stack.extend(reversed(children[link.name]))
    if len(ordered_links) != len(links):
        unreached = sorted(set(links) - {link.name for link in ordered_links})
        raise UrdfStructureError(
            file, f"robot {robot_name!r}", f"links {unreached} form a cycle detached from the root"
        )
    ordered_links[0].index = -1
    return UrdfModel(robot_name, src, ordered_links, ordered_joints)
