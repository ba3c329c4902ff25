"""Reading an MJCF file as PyBullet 3.2.7's ``loadMJCF`` does (``_Reader``): bodies, links,
joints, shapes, defaults and what the importer leaves unread, as the model :mod:`.mjcf` turns
into scene bodies. The rules are listed in :mod:`.mjcf`'s docstring.

A little over 600 lines because ``_Reader`` is one class following the importer's one pass
over the file; its methods share the file's defaults and the model being built."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from xml.etree.ElementTree import Element

import numpy as np

from simbridge.exceptions import MeshNotFoundError, UnsupportedJointError, UrdfStructureError
from simbridge.model.scene import f32, find_mesh, line_of, number, numbers, read_scene_xml
from simbridge.model.urdf_model import Vec3
from simbridge.model.urdf_source import UrdfSource, not_a_regular_file
from simbridge.transforms import (
    IDENTITY_QUAT,
    transform_inverse,
    transform_multiply,
)
from simbridge.types import Quat

Pose = tuple[Vec3, Quat]
IDENTITY: Pose = ((0.0, 0.0, 0.0), IDENTITY_QUAT)
DENSITY = 1000.0  # kg/m^3: PyBullet's, whatever the file's density
_PI32 = np.float32(6.283185307179586232) * np.float32(0.5)  # Bullet3's B3_PI, float

# what PyBullet's MJCF importer leaves unread, by element (reported per body in .ignored)
IGNORED_JOINT_ATTRIBUTES = (
    "damping",
    "armature",
    "stiffness",
    "frictionloss",
    "margin",
    "springref",
    "ref",
    "solreflimit",
    "solimplimit",
)
_IGNORED_GEOM_ATTRIBUTES = ("density", "margin", "solref", "solimp", "euler", "xyaxes", "zaxis")
_IGNORED_TOP = ("option", "actuator", "tendon", "contact", "equality", "sensor", "keyframe")
# what PyBullet reads of <default>'s <joint> and <geom>
_DEFAULTS_READ = {
    "joint": ("limited",),
    "geom": ("contype", "conaffinity", "rgba", "condim", "friction"),
}
_IGNORED_BODY_ATTRIBUTES = ("euler", "axisangle", "xyaxes", "zaxis")
LOGGER = logging.getLogger("simbridge.model.mjcf")


@dataclass
class _Defaults:
    """PyBullet's ``MyMJCFDefaults``."""

    group: int = 1
    mask: int = 1
    limited: str = ""
    rgba: str = ""
    condim: int = 3
    lateral: float = 0.5
    spinning: float = 0.0
    rolling: float = 0.0


@dataclass
class _Shape:
    """One geom as Bullet builds it (in its link frame ``frame``) and as the core shape."""

    kind: str  # sphere, box, capsule, cylinder, mesh, plane
    frame: Pose
    radius: float = 0.0
    half: Vec3 = (0.0, 0.0, 0.0)  # box half extents
    height: float = 0.0  # capsule/cylinder: the full length of the axis part
    fromto: tuple[Vec3, Vec3] | None = None
    mesh: Path | None = None
    mesh_uri: str = ""
    rgba: tuple[float, float, float, float] | None = None
    name: str = ""
    line: int = 0


@dataclass(eq=False)
class _Link:
    name: str
    line: int
    index: int = 0  # creation order in its body (PyBullet's link index before reordering)
    mass: float = 0.0
    inertial: Pose = IDENTITY
    shapes: list[_Shape] = field(default_factory=list)
    transform: Pose = IDENTITY  # m_linkTransformInWorld: the frame in its parent's
    lateral: float = 0.5
    spinning: float | None = None
    rolling: float | None = None
    filter: tuple[int, int] | None = None
    file_diag: Vec3 = (0.0, 0.0, 0.0)


@dataclass
class _Joint:
    name: str
    type: str  # revolute, continuous, prismatic, fixed
    parent: str
    child: str
    origin: Pose
    axis: Vec3
    lower: float
    upper: float
    line: int


@dataclass
class _Model:
    links: list[_Link] = field(default_factory=list)
    joints: list[_Joint] = field(default_factory=list)
    ignored: list[str] = field(default_factory=list)
    line: int = 0


def _unit(q: Quat) -> Quat:
    n = math.sqrt(sum(v * v for v in q))
    if not n > 0 or not math.isfinite(n):
        return IDENTITY_QUAT
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


def _shortest_arc(v: np.ndarray) -> Quat:
    """Bullet's ``shortestArcQuat(z, v)`` for a unit vector ``v``."""
    d = float(v[2])
    if d < -1.0 + np.finfo(float).eps:  # btPlaneSpace1(z): half a turn about -y
        return (0.0, -1.0, 0.0, 0.0)
    c = np.cross((0.0, 0.0, 1.0), v)
    s = math.sqrt((1.0 + d) * 2.0)
    return (float(c[0] / s), float(c[1] / s), float(c[2] / s), s * 0.5)


class _Reader:
    """One MJCF file read as BulletMJCFImporter reads it."""

    def __init__(self, src: UrdfSource) -> None:
        self.src = src
        self.file = src.display_name
        self.uid = 0  # PyBullet's gUid, as in a fresh process
        self.models: list[_Model] = []
        self.assets: dict[str, str] = {}
        self.mesh_dir = ""
        self.angle = "degree"
        self.inertia_from_geom = True
        self.defaults = _Defaults()
        self.classes: dict[str, _Defaults] = {}
        self.file_ignored: list[str] = []
        self.root: Element

    # ------------------------------------------------------------ errors and values

    def error(self, elem: Element, where: str, detail: str) -> UrdfStructureError:
        return UrdfStructureError(self.file, where, detail, getattr(elem, "line", None))

    def vec3(self, text: str | None, default: Vec3) -> Vec3:
        """``parseVector3`` (float): the first 3 numbers; fewer leave zero."""
        if text is None:
            return default
        v = numbers(text)
        if len(v) < 3:
            return (0.0, 0.0, 0.0)
        return (f32(v[0]), f32(v[1]), f32(v[2]))

    def quat(self, text: str | None) -> Quat | None:
        """``quat="w x y z"`` (``parseVector4``: exactly 4 numbers, float), as (x, y, z, w)."""
        if text is None:
            return None
        v = numbers(text)
        if len(v) != 4:
            return None
        w, x, y, z = (f32(a) for a in v)
        return _unit((x, y, z, w))

    def finite(self, elem: Element, where: str, values: tuple[float, ...]) -> None:
        if not all(math.isfinite(v) for v in values):
            raise self.error(elem, where, f"numbers must be finite, got {values}")

    @staticmethod
    def pos(elem: Element) -> Vec3:
        """``pos``: its first three numbers as float32, PyBullet's reading; none: the origin."""
        v = numbers(elem.get("pos")) if elem.get("pos") is not None else []
        return (f32(v[0]), f32(v[1]), f32(v[2])) if len(v) >= 3 else (0.0, 0.0, 0.0)

    def pose(self, elem: Element, where: str) -> Pose:
        """A body's ``parseTransform``: ``pos`` and ``quat`` only."""
        pos = self.pos(elem)
        quat = self.quat(elem.get("quat")) or IDENTITY_QUAT
        self.finite(elem, where, (*pos, *quat))
        return pos, quat

    # ------------------------------------------------------------ top level

    def read(self) -> list[_Model]:
        root = self.root = read_scene_xml(self.src, "mjcf")
        for elem in root.findall("default"):
            self.parse_defaults(self.defaults, elem)
        for elem in root.findall("compiler"):
            self.angle = elem.get("angle") or "degree"
            inertia = elem.get("inertiafromgeom")
            if inertia and inertia[0] == "f":
                self.inertia_from_geom = False
            if elem.get("meshdir") is not None:
                self.mesh_dir = elem.get("meshdir", "")
        for elem in root.findall("asset"):
            self.parse_assets(elem)
        for tag in _IGNORED_TOP:
            for elem in root.findall(tag):
                self.file_ignored.append(f"line {line_of(elem)}: <{tag}>")
        for elem in root.findall("include"):
            self.file_ignored.append(f"line {line_of(elem)}: <include> file={elem.get('file')!r}")
        included = [f"line {line_of(e)} file={e.get('file')!r}" for e in root.iter("include")]
        if included:
            LOGGER.warning(
                "%s: <include> not read (PyBullet's MJCF importer does not read it; the "
                "included file's elements are not loaded): %s",
                self.file,
                "; ".join(included),
            )
        for elem in root.findall("body"):  # PyBullet reads a top-level <body>'s children too
            self.parse_root_level(elem)
        for elem in root.findall("worldbody"):
            self.parse_root_level(elem)
        return self.models

    def parse_defaults(self, defaults: _Defaults, elem: Element) -> None:
        for child in elem:
            tag = child.tag
            if "default" in tag:
                name = child.get("class")
                if name:
                    self.parse_defaults(self.classes.setdefault(name, _Defaults()), child)
            if tag == "asset":
                self.parse_assets(child)
            if tag in ("joint", "geom"):
                read = _DEFAULTS_READ[tag]
                for attr, value in child.attrib.items():
                    if attr not in read:
                        self.file_ignored.append(
                            f"line {line_of(child)}: <default><{tag}> {attr}={value!r}"
                        )
            if tag == "joint" and child.get("limited") is not None:
                defaults.limited = child.get("limited", "")
            if tag == "geom":
                if child.get("contype") is not None:
                    defaults.group = int(number(child.get("contype")))
                if child.get("conaffinity") is not None:
                    defaults.mask = int(number(child.get("conaffinity")))
                if child.get("rgba") is not None:
                    defaults.rgba = child.get("rgba", "")
                if child.get("condim") is not None:
                    defaults.condim = int(number(child.get("condim")))
                if child.get("friction") is not None:
                    f = [f32(v) for v in numbers(child.get("friction"))]
                    if len(f) > 0:
                        defaults.lateral = f[0]
                    if len(f) > 1:
                        defaults.spinning = f[1]
                    if len(f) > 2:
                        defaults.rolling = f[2]

    def parse_assets(self, elem: Element) -> None:
        for child in elem:
            if child.tag == "mesh" and child.get("name") and child.get("file"):
                self.assets[child.get("name", "")] = self.mesh_dir + child.get("file", "")
                for attr, value in child.attrib.items():
                    if attr not in ("name", "file"):  # PyBullet: "todo: parse mesh scale"
                        self.file_ignored.append(
                            f"line {line_of(child)}: <asset><mesh> {attr}={value!r}"
                        )

    def parse_root_level(self, elem: Element) -> None:
        for child in elem:
            if child.tag == "body":
                model = _Model(line=line_of(child))
                self.models.append(model)
                self.parse_body(self.defaults, child, model, None)
            elif child.tag == "geom":
                model = _Model(line=line_of(child))
                self.models.append(model)
                link = _Link(child.get("name") or "anonymous", line_of(child))
                model.links.append(link)
                self.parse_geom(self.defaults, child, model, link)
            elif child.tag not in ("site", "light", "camera"):
                self.file_ignored.append(f"line {line_of(child)}: <{child.tag}> in <worldbody>")

    # ------------------------------------------------------------ bodies

    def create_link(self, model: _Model, name: str | None, line: int) -> _Link:
        k = len(model.links)
        link = _Link(name or f"link{len(self.models) - 1}_{k}", line, k)
        model.links.append(link)
        return link

    def parse_body(
        self, defaults: _Defaults, elem: Element, model: _Model, parent: _Link | None
    ) -> None:
        cur = replace(defaults)
        cls = elem.get("childclass")
        if cls and cls in self.classes:
            cur = replace(self.classes[cls])
        name = elem.get("name")
        link = self.create_link(model, name, line_of(elem))
        where = f"<body {name!r}>" if name else "<body>"
        if not name:
            self.uid += 1  # "anon%d"
        for attr in _IGNORED_BODY_ATTRIBUTES:
            if elem.get(attr) is not None:
                model.ignored.append(f"line {line_of(elem)}: {where} {attr}")
        inertial_pos: Vec3 = (0.0, 0.0, 0.0)
        inertial_quat: Quat = IDENTITY_QUAT
        link_transform = self.pose(elem, where)
        mass_defined = False
        mass = 0.0
        has_joint = False
        joint_trans: Pose = IDENTITY
        new_parent = parent
        for child in elem:
            tag = child.tag
            if tag == "inertial":
                v = numbers(child.get("pos")) if child.get("pos") is not None else []
                if len(v) >= 3:
                    inertial_pos = (f32(v[0]), f32(v[1]), f32(v[2]))
                q = self.quat(child.get("quat"))
                if q is not None:
                    inertial_quat = q
                if child.get("mass") is not None:
                    mass = number(child.get("mass"))
                if child.get("diaginertia") is not None:
                    link.file_diag = self.vec3(child.get("diaginertia"), (0.0, 0.0, 0.0))
                mass_defined = True
                self.finite(child, f"{where} <inertial>", (*inertial_pos, *inertial_quat, mass))
                if mass < 0:
                    raise self.error(child, f"{where} <inertial>", f"mass must be >= 0, got {mass}")
            elif tag == "joint":
                if not has_joint:
                    jtype = child.get("type") or ""
                    if new_parent is not None or jtype != "free":
                        if new_parent is None:
                            new_parent = self.create_link(model, None, line_of(child))
                        dummy = self.create_link(model, None, line_of(child))
                        joint_trans = self.parse_joint(
                            child,
                            model,
                            new_parent,
                            dummy,
                            link_transform,
                        )
                        link_transform = transform_inverse(joint_trans)
                        new_parent = dummy
                        has_joint = True
                    else:  # the root's free joint: PyBullet's free base
                        self.note_joint_attributes(model, child)
                else:
                    assert new_parent is not None  # set by the first joint
                    dummy = self.create_link(model, None, line_of(child))
                    self.parse_joint(
                        child,
                        model,
                        new_parent,
                        dummy,
                        transform_inverse(joint_trans),
                    )
                    new_parent = dummy
            elif tag == "geom":
                shift = self.parse_geom(cur, child, model, link)
                if not mass_defined:
                    inertial_pos = shift
            elif tag == "body":
                self.parse_body(cur, child, model, link)
            elif tag not in ("light", "site", "camera"):
                model.ignored.append(f"line {line_of(child)}: {where} <{tag}>")
        link.transform = link_transform
        if new_parent is not None:
            model.joints.append(
                _Joint(
                    f"jointfix_{self.uid}_{new_parent.index}",
                    "fixed",
                    new_parent.name,
                    link.name,
                    link_transform,
                    (1.0, 0.0, 0.0),
                    0.0,
                    -1.0,
                    line_of(elem),
                )
            )
            self.uid += 1
        if not mass_defined:
            mass = DENSITY * _volume(link.shapes)
        link.inertial = (inertial_pos, inertial_quat)
        link.mass = mass

    def note_joint_attributes(self, model: _Model, elem: Element) -> None:
        name = elem.get("name")
        shown = f"<joint {name!r}>" if name else "<joint>"
        for attr in IGNORED_JOINT_ATTRIBUTES:
            if elem.get(attr) is not None:
                model.ignored.append(f"line {line_of(elem)}: {shown} {attr}={elem.get(attr)!r}")

    def parse_joint(
        self, elem: Element, model: _Model, parent: _Link, child: _Link, parent_to_link: Pose
    ) -> Pose:
        """Add the joint from ``parent`` to ``child``; return its own ``pos``/``quat``."""
        name = elem.get("name")
        jtype = elem.get("type")
        shown = f"<joint {name!r}>" if name else "<joint>"
        self.note_joint_attributes(model, elem)
        pos: Vec3 = (0.0, 0.0, 0.0)
        if elem.get("pos") is not None:
            v = numbers(elem.get("pos"))
            if len(v) >= 3:
                pos = (f32(v[0]), f32(v[1]), f32(v[2]))
        quat: Quat = IDENTITY_QUAT
        q = numbers(elem.get("quat")) if elem.get("quat") is not None else []
        if len(q) == 4:  # PyBullet reads a joint's quat in another order than a body's
            quat = _unit((f32(q[3]), f32(q[0]), f32(q[1]), f32(q[2])))
        joint_trans: Pose = (pos, quat)
        axis = self.vec3(elem.get("axis"), (1.0, 0.0, 0.0))
        limited = elem.get("limited")
        is_limited = (limited if limited is not None else self.defaults.limited) == "true"
        kinds = {"fixed": "fixed", "slide": "prismatic", "hinge": "revolute"}
        if jtype not in kinds:
            detail = "has no type attribute" if jtype is None else f"joint type {jtype!r}"
            if jtype in ("ball", "free"):
                raise UnsupportedJointError(
                    self.file,
                    name or "<unnamed>",
                    jtype,
                    ["hinge", "slide", "fixed", "free (on a top-level body)"],
                    line_of(elem),
                )
            raise self.error(
                elem,
                shown,
                f"{detail}: PyBullet does not read it and drops the body's subtree; valid: "
                "hinge, slide, fixed (free on a top-level body)",
            )
        kind = kinds[jtype]
        if kind == "revolute" and not is_limited:
            kind = "continuous"
        lower, upper = 1.0, 0.0
        if is_limited:
            if elem.get("range") is None:
                raise self.error(
                    elem,
                    shown,
                    "limited but has no range attribute (PyBullet's importer crashes on it)",
                )
            r = numbers(elem.get("range"))
            if len(r) == 2:
                lo, hi = np.float32(r[0]), np.float32(r[1])
                if self.angle == "degree" and kind == "revolute":
                    lo = lo * _PI32 / np.float32(180)
                    hi = hi * _PI32 / np.float32(180)
                lower, upper = float(lo), float(hi)
            else:
                model.ignored.append(
                    f"line {line_of(elem)}: {shown} range={elem.get('range')!r} (not 2 numbers)"
                )
        self.finite(elem, shown, (*pos, *quat, *axis, lower, upper))
        if kind != "fixed" and max(abs(a) for a in axis) < 1e-12:
            raise self.error(elem, f"{shown} axis", f"axis must not be zero, got {axis}")
        if name is None:
            name = f"joint{self.uid}_{child.index}_{len(model.joints)}"
            self.uid += 1
        model.joints.append(
            _Joint(
                name,
                kind,
                parent.name,
                child.name,
                transform_multiply(parent_to_link, joint_trans),
                axis,
                lower,
                upper,
                line_of(elem),
            )
        )
        return joint_trans

    # ------------------------------------------------------------ geoms

    def parse_geom(self, d: _Defaults, elem: Element, model: _Model, link: _Link) -> Vec3:
        """Add a geom to ``link``; return its inertial shift (a ``fromto``'s middle, else 0)."""
        name = elem.get("name", "")
        where = f"<geom {name!r}>" if name else "<geom>"
        for attr in _IGNORED_GEOM_ATTRIBUTES:
            if elem.get(attr) is not None:
                model.ignored.append(f"line {line_of(elem)}: {where} {attr}={elem.get(attr)!r}")
        condim = int(number(elem.get("condim"))) if elem.get("condim") is not None else d.condim
        lateral = d.lateral
        if elem.get("friction") is not None:
            f = [f32(v) for v in numbers(elem.get("friction"))]
            if len(f) > 0:
                lateral = f[0]
        link.lateral = lateral
        # PyBullet keeps the defaults' spinning and rolling friction (a geom's own friction[1:]
        # is read, then overwritten) and applies them once a geom of the link has condim > 3 (> 4)
        if condim > 3 or link.spinning is not None:
            link.spinning = d.spinning
        if condim > 4 or link.rolling is not None:
            link.rolling = d.rolling
        pos = self.pos(elem)
        quat = self.quat(elem.get("quat")) or IDENTITY_QUAT
        aa = numbers(elem.get("axisangle")) if elem.get("axisangle") is not None else []
        if len(aa) == 4:  # axis and angle (radians, whatever <compiler angle>)
            axis = np.array([f32(aa[0]), f32(aa[1]), f32(aa[2])])
            norm = float(np.linalg.norm(axis))
            if not norm > 0:
                raise self.error(elem, f"{where} axisangle", "the axis must not be zero")
            s = math.sin(0.5 * f32(aa[3])) / norm
            quat = (axis[0] * s, axis[1] * s, axis[2] * s, math.cos(0.5 * f32(aa[3])))
            quat = _unit((float(quat[0]), float(quat[1]), float(quat[2]), float(quat[3])))
        frame: Pose = (pos, quat)
        rgba_text = elem.get("rgba") if elem.get("rgba") is not None else d.rgba
        rgba_v = numbers(rgba_text) if rgba_text else []
        rgba = (rgba_v[0], rgba_v[1], rgba_v[2], rgba_v[3]) if len(rgba_v) == 4 else None
        size_text = elem.get("size")
        gtype = elem.get("type")
        shift: Vec3 = (0.0, 0.0, 0.0)
        shape: _Shape | None = None
        if gtype is None:  # PyBullet: "geom requires type" (MuJoCo's default is a sphere)
            model.ignored.append(f"line {line_of(elem)}: {where} without type (no shape)")
            return shift
        if gtype in ("plane", "box"):
            size = self.vec3(size_text, (1.0, 1.0, 1.0))
            shape = _Shape(gtype, frame, half=size)
        elif gtype == "sphere":
            radius = 1.0 if size_text is None else number(size_text)  # 1: PyBullet's default
            shape = _Shape("sphere", frame, radius=radius)
        elif gtype in ("capsule", "cylinder"):
            sizes = [f32(v) for v in numbers(size_text)]
            radius, height = 2.0, 2.0  # PyBullet's "make it visible if something is wrong"
            if sizes:
                radius = sizes[0]
                if len(sizes) > 1:
                    height = 2.0 * sizes[1]
            if elem.get("fromto") is not None:
                v = numbers(elem.get("fromto"))
                if len(v) >= 6:
                    a = (f32(v[0]), f32(v[1]), f32(v[2]))
                    b = (f32(v[3]), f32(v[4]), f32(v[5]))
                else:
                    a = b = (0.0, 0.0, 0.0)
                shift = (0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2]))
                length = math.dist(a, b)
                shape = _Shape(
                    gtype,
                    frame,
                    radius=radius,
                    height=length,
                    fromto=(a, b),
                )
            elif len(sizes) >= 2:
                shape = _Shape(gtype, frame, radius=radius, height=height)
            else:
                model.ignored.append(
                    f"line {line_of(elem)}: {where} {gtype} without fromto needs 2 sizes (no shape)"
                )
        elif gtype == "mesh":
            asset = self.assets.get(elem.get("mesh", ""))
            if asset is not None:
                path, tried = find_mesh(asset, self.src.mesh_from)
                if not path.is_file():
                    odd = not_a_regular_file(tried)
                    if odd is not None:
                        raise self.error(elem, where, f"mesh file {asset!r}: {odd}")
                    raise MeshNotFoundError(self.file, where, asset, tried, line_of(elem))
                if path.suffix.lower() not in (".obj", ".stl"):
                    raise self.error(
                        elem,
                        where,
                        f"mesh {asset!r}: PyBullet's MJCF importer reads .obj and .stl only",
                    )
                shape = _Shape("mesh", frame, mesh=path, mesh_uri=asset)
            else:
                model.ignored.append(
                    f"line {line_of(elem)}: {where} mesh asset not found (no shape)"
                )
        else:
            model.ignored.append(f"line {line_of(elem)}: {where} type {gtype!r} (no shape)")
        if shape is not None:
            shape.rgba, shape.name, shape.line = rgba, name, line_of(elem)
            self.finite(
                elem,
                where,
                (*shape.frame[0], *shape.frame[1], shape.radius, *shape.half, shape.height),
            )
            if min(shape.radius, *shape.half, shape.height) < 0:
                raise self.error(elem, f"{where} size", "sizes must be >= 0")
            link.shapes.append(shape)
            group = d.group
            mask = d.mask
            if elem.get("contype") is not None:
                group = int(number(elem.get("contype")))
            if elem.get("conaffinity") is not None:
                mask = int(number(elem.get("conaffinity")))
            link.filter = (group, mask)
        return shift


def _volume(shapes: list[_Shape]) -> float:
    """PyBullet's ``computeVolume``: spheres, boxes, cylinders and capsules (meshes and planes
    count nothing)."""
    total = 0.0
    for s in shapes:
        if s.kind == "sphere":
            total += 4.0 / 3.0 * math.pi * s.radius**3
        elif s.kind == "box":
            total += (2 * s.half[0]) * (2 * s.half[1]) * (2 * s.half[2])
        elif s.kind in ("capsule", "cylinder"):
            r = s.radius
            if s.kind == "capsule":
                total += 4.0 / 3.0 * math.pi * r * r * r
            total += math.pi * r * r * s.height
    return total
