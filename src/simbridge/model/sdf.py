"""SDF as PyBullet 3.2.7's ``loadSDF`` reads it: one :class:`~simbridge.model.scene.SceneBody` per
``<model>``, with PyBullet's links, joints, numbering and names.

Read in bullet3's ``Importers/ImportURDFDemo/UrdfParser.cpp`` (its SDF mode) and
``URDF2Bullet.cpp``, and measured on pybullet 3.2.7 (every SDF file of pybullet_data:
``tests/conformance/test_mjcf_sdf.py``). PyBullet reads SDF with its URDF parser, values from
element text instead of attributes:

* **bodies**: every ``<model>`` of the first ``<world>`` (or of ``<sdf>`` when there is no
  world) is one body; ``<include>`` is not read. ``<static>1</static>`` (``atof`` of the text,
  so ``true`` is not static) welds the root (mass 0);
* **links**: in file order, the root the one link no joint moves (several roots: PyBullet
  crashes; refused here), then depth first, children in the order of their joints, as for a
  URDF. A link's ``<pose>`` is its frame in the model: a joint's frame is its child link's
  frame (the joint's own ``<pose>`` is not read), the joint axis ``<axis><xyz>`` is in that
  frame. The base's link frame is put at the model's ``<pose>``; the root link's own ``<pose>``
  places nothing (it only offsets its children);
* **poses**: ``x y z roll pitch yaw``: the position is the text's first three numbers, the
  rotation its last three (so a pose of three numbers is also read as those three angles);
* **joints**: ``revolute`` and ``prismatic`` need ``<axis><limit>``; ``continuous``,
  ``fixed``; ``<axis><dynamics>`` damping and friction as in a URDF; ``spherical``, ``planar``
  and ``floating`` are refused with :class:`~simbridge.exceptions.UnsupportedJointError`;
* **links' values**: ``<inertial>`` (``<pose>``, ``<mass>``, ``<inertia>``), no inertial: mass
  1 (0 for a link named ``world``); ``<contact>`` with Bullet's children (``lateral_friction``...)
  as in a URDF; a collision's ``group`` and ``mask`` attributes; shapes ``box``, ``sphere``,
  ``cylinder``, ``capsule``, ``mesh`` (``<uri>``, ``<scale>``), ``plane``. The moments are the
  collision-box inertia of a URDF (:mod:`simbridge.model.inertia`).
"""

from __future__ import annotations

import logging
import math
from xml.etree.ElementTree import Element

from simbridge.exceptions import MeshNotFoundError, UnsupportedJointError, UrdfStructureError
from simbridge.model.scene import (
    SceneBody,
    check_names,
    find_mesh,
    line_of,
    number,
    numbers,
    read_scene_xml,
)
from simbridge.model.urdf import MESH_FORMATS, pybullet_order
from simbridge.model.urdf_model import CONTACT_TAGS, Contact, Geometry, Inertial, Joint, Link, Vec3
from simbridge.model.urdf_source import UrdfSource, not_a_regular_file
from simbridge.transforms import (
    IDENTITY_QUAT,
    quat_from_rpy,
    rpy_from_quat,
    transform_inverse,
    transform_multiply,
)
from simbridge.types import Quat

__all__ = ["parse_sdf"]

Pose = tuple[Vec3, Quat]
_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed")
_UNSUPPORTED = ("spherical", "planar", "floating")


class _Reader:
    def __init__(self, src: UrdfSource) -> None:
        self.src = src
        self.file = src.display_name

    def error(self, elem: Element, where: str, detail: str) -> UrdfStructureError:
        return UrdfStructureError(self.file, where, detail, getattr(elem, "line", None))

    def text(self, elem: Element, where: str) -> str:
        """An element's text (PyBullet crashes on an empty element where it wants text)."""
        if elem.text is None or not elem.text.strip():
            raise self.error(
                elem, where, "is empty; a value was expected (PyBullet's importer crashes on it)"
            )
        return elem.text

    def child_text(self, elem: Element, tag: str, where: str) -> str | None:
        child = elem.find(tag)
        return None if child is None else self.text(child, f"{where} <{tag}>")

    def value(self, elem: Element, tag: str, where: str, default: float) -> float:
        text = self.child_text(elem, tag, where)
        if text is None:
            return default
        v = number(text)
        if not math.isfinite(v):
            raise self.error(elem, f"{where} <{tag}>", f"must be finite, got {text!r}")
        return v

    def vec3(self, elem: Element, where: str) -> Vec3 | None:
        v = numbers(self.text(elem, where))
        if len(v) < 3:
            return None
        if not all(math.isfinite(a) for a in v[:3]):
            raise self.error(elem, where, f"numbers must be finite, got {elem.text!r}")
        return (v[0], v[1], v[2])

    def pose(self, parent: Element, where: str) -> Pose:
        """PyBullet's SDF ``parseTransform`` of ``parent``'s ``<pose>``: position the first
        three numbers, roll, pitch, yaw the last three (identity without ``<pose>``)."""
        elem: Element | None = parent.find("pose")
        if elem is None:
            return (0.0, 0.0, 0.0), IDENTITY_QUAT
        v = numbers(self.text(elem, f"{where} <pose>"))
        if not all(math.isfinite(a) for a in v):
            raise self.error(elem, f"{where} <pose>", f"numbers must be finite, got {elem.text!r}")
        if len(v) < 3:
            return (0.0, 0.0, 0.0), IDENTITY_QUAT
        return (v[0], v[1], v[2]), quat_from_rpy(v[-3:])

    # ------------------------------------------------------------ links

    def geometry(self, elem: Element, where: str, frame: Pose, rgba) -> Geometry:  # noqa: ANN001
        geom: Element | None = elem.find("geometry")
        if geom is None or len(geom) == 0:
            raise self.error(elem, where, "has no <geometry> shape (PyBullet refuses it too)")
        shape: Element = geom[0]
        tag = shape.tag
        shown = f"{where} <{tag}>"
        common = {
            "origin_quat": frame[1],
            "rgba": rgba,
            "name": elem.get("name", ""),
            "line": line_of(elem),
        }
        xyz, rpy = frame[0], rpy_from_quat(frame[1])
        if tag == "sphere":
            if shape.find("radius") is None:
                raise self.error(shape, shown, "needs <radius> (PyBullet refuses it too)")
            r = self.value(shape, "radius", shown, 0.0)
            size: tuple[float, ...] = (r,)
        elif tag == "box":
            size_elem: Element | None = shape.find("size")
            if size_elem is None:
                raise self.error(shape, shown, "needs <size> (PyBullet refuses it too)")
            size = self.vec3(size_elem, f"{shown} <size>") or (0.0, 0.0, 0.0)
        elif tag in ("cylinder", "capsule"):
            default = 0.1 if tag == "cylinder" else 1.0  # PyBullet's, without the element
            size = (
                self.value(shape, "radius", shown, default),
                self.value(shape, "length", shown, default),
            )
        elif tag == "mesh":
            uri = self.child_text(shape, "uri", shown)
            if not uri:
                raise self.error(shape, shown, "has no <uri> (PyBullet refuses it too)")
            uri = uri.strip()
            scale: tuple[float, ...] = (1.0, 1.0, 1.0)
            scale_elem: Element | None = shape.find("scale")
            if scale_elem is not None:
                scale = self.vec3(scale_elem, f"{shown} <scale>") or (0.0, 0.0, 0.0)
            path, tried = find_mesh(uri, self.src.mesh_from)
            if not path.is_file():
                odd = not_a_regular_file(tried)
                if odd is not None:
                    raise self.error(shape, shown, f"mesh file {uri!r}: {odd}")
                raise MeshNotFoundError(self.file, shown, uri, tried, line_of(shape))
            if path.suffix.lower() not in MESH_FORMATS:
                raise self.error(
                    shape, shown, f"{uri!r}: unsupported mesh format; valid: {MESH_FORMATS}"
                )
            return Geometry("mesh", xyz, rpy, scale, mesh_path=path, mesh_uri=uri, **common)
        elif tag == "plane":
            normal_elem: Element | None = shape.find("normal")
            if normal_elem is None or shape.find("size") is None:
                raise self.error(
                    shape, shown, "needs <normal> and <size> (PyBullet refuses it too)"
                )
            size = self.vec3(normal_elem, f"{shown} <normal>") or (0.0, 0.0, 0.0)
            if not any(size):
                raise self.error(shape, shown, "the normal must not be zero")
            return Geometry("plane", xyz, rpy, size, **common)
        else:
            raise self.error(
                shape,
                where,
                f"unknown geometry <{tag}>; valid: box, sphere, cylinder, capsule, mesh, plane",
            )
        if any(v < 0 for v in size):
            raise self.error(shape, shown, f"sizes must be >= 0, got {size}")
        return Geometry(tag, xyz, rpy, size, **common)

    def link(self, elem: Element, index: int) -> tuple[Link, Pose, tuple[int | None, int | None]]:
        name = elem.get("name")
        if name is None:
            raise self.error(elem, "<link>", "has no name attribute (PyBullet refuses it too)")
        where = f"link {name!r}"
        frame = self.pose(elem, where)
        contact = self.contact(elem.find("contact"), where)
        inertial = self.inertial(elem.find("inertial"), where)
        visuals = []
        for k, v in enumerate(elem.findall("visual")):
            vwhere = f"{where} <visual> #{k}"
            rgba = None
            diffuse = v.find("material/diffuse")
            if diffuse is not None and diffuse.text:
                values = numbers(diffuse.text)
                rgba = tuple(values) if len(values) == 4 else None
            visuals.append(self.geometry(v, vwhere, self.pose(v, vwhere), rgba))
        collisions = []
        group: int | None = None
        mask: int | None = None
        for k, c in enumerate(elem.findall("collision")):
            cwhere = f"{where} <collision> #{k}"
            collisions.append(self.geometry(c, cwhere, self.pose(c, cwhere), None))
            if c.get("group") is not None:
                group = int(number(c.get("group")))
            if c.get("mask") is not None:
                mask = int(number(c.get("mask")))
        link = Link(name, inertial, visuals, collisions, contact, index, line_of(elem))
        return link, frame, (group, mask)

    def contact(self, elem: Element | None, where: str) -> Contact:
        if elem is None:
            return Contact()
        values = {}
        for tag in CONTACT_TAGS:
            if elem.find(tag) is not None:
                values[tag] = self.value(elem, tag, f"{where} <contact>", 0.0)
        return Contact(**values)

    def inertial(self, elem: Element | None, where: str) -> Inertial:
        if elem is None:
            return Inertial()
        xyz, quat = self.pose(elem, f"{where} <inertial>")
        if elem.find("mass") is None:
            raise self.error(elem, f"{where} <inertial>", "has no <mass> (PyBullet refuses it too)")
        mass = self.value(elem, "mass", f"{where} <inertial>", 0.0)
        if mass < 0:
            raise self.error(elem, f"{where} <mass>", f"mass must be >= 0, got {mass}")
        ie: Element | None = elem.find("inertia")
        if ie is None:
            raise self.error(
                elem, f"{where} <inertial>", "has no <inertia> (PyBullet refuses it too)"
            )
        keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
        present = [ie.find(k) is not None for k in keys]
        if not (present[0] and present[3] and present[5]):
            raise self.error(
                ie,
                f"{where} <inertia>",
                "needs at least ixx, iyy and izz (PyBullet refuses it too)",
            )
        used = keys if all(present) else ("ixx", "iyy", "izz")
        ixx, ixy, ixz, iyy, iyz, izz = (
            self.value(ie, k, f"{where} <inertia>", 0.0) if k in used else 0.0 for k in keys
        )
        inertia = (ixx, ixy, ixz, iyy, iyz, izz)
        return Inertial(
            xyz, rpy_from_quat(quat), mass, inertia, True, origin_quat=quat, line=line_of(ie)
        )

    # ------------------------------------------------------------ joints

    def joint(self, elem: Element, links: dict[str, tuple[Link, Pose]]) -> Joint:
        name = elem.get("name")
        if not name:
            raise self.error(elem, "<joint>", "has no name attribute (PyBullet refuses it too)")
        where = f"joint {name!r}"
        jtype = elem.get("type")
        if jtype is None:
            raise self.error(elem, where, "has no type attribute (PyBullet refuses it too)")
        if jtype in _UNSUPPORTED:
            raise UnsupportedJointError(self.file, name, jtype, _JOINT_TYPES, line_of(elem))
        if jtype not in _JOINT_TYPES:
            raise self.error(
                elem, where, f"unknown joint type {jtype!r}; valid: {list(_JOINT_TYPES)}"
            )
        ends = []
        for role in ("parent", "child"):
            text = self.child_text(elem, role, where)
            if text is None:
                raise self.error(elem, where, f"needs a <{role}> link (PyBullet refuses it too)")
            text = text.strip()
            if text not in links:
                raise self.error(elem, where, f"{role} link {text!r} is not a <link> of this model")
            ends.append(text)
        parent, child = ends
        if parent == child:
            raise self.error(elem, where, f"link {child!r} is its own parent (a cycle)")
        axis: Vec3 = (1.0, 0.0, 0.0)
        lower, upper, effort, velocity, damping, friction = 0.0, -1.0, 0.0, 0.0, 0.0, 0.0
        axis_elem: Element | None = elem.find("axis")
        if jtype != "fixed" and axis_elem is not None:
            xyz: Element | None = axis_elem.find("xyz")
            if xyz is not None:
                read = self.vec3(xyz, f"{where} <axis><xyz>")
                if read is None:
                    raise self.error(
                        xyz, f"{where} <axis><xyz>", "expected 3 numbers (PyBullet refuses it too)"
                    )
                axis = read
            limit: Element | None = axis_elem.find("limit")
            if limit is not None:
                if jtype != "continuous":
                    lw = f"{where} <limit>"
                    lower = self.value(limit, "lower", lw, 0.0)
                    upper = self.value(limit, "upper", lw, -1.0)
                    effort = self.value(limit, "effort", lw, 0.0)
                    velocity = self.value(limit, "velocity", lw, 0.0)
            elif jtype in ("revolute", "prismatic"):
                raise self.error(
                    axis_elem,
                    where,
                    f"a {jtype} joint needs <axis><limit> (PyBullet refuses it too)",
                )
            dyn: Element | None = axis_elem.find("dynamics")
            if dyn is not None:
                if dyn.find("damping") is None and dyn.find("friction") is None:
                    raise self.error(
                        dyn,
                        f"{where} <dynamics>",
                        "has neither damping nor friction (PyBullet refuses it too)",
                    )
                damping = self.value(dyn, "damping", f"{where} <dynamics>", 0.0)
                friction = self.value(dyn, "friction", f"{where} <dynamics>", 0.0)
                for what, value in (("damping", damping), ("friction", friction)):
                    if value < 0:
                        raise self.error(dyn, f"{where} <dynamics>", f"{what} must be >= 0")
        elif jtype in ("revolute", "prismatic"):
            raise self.error(
                elem, where, f"a {jtype} joint needs <axis><limit> (PyBullet refuses it too)"
            )
        if jtype != "fixed" and max(abs(a) for a in axis) < 1e-12:
            raise self.error(elem, f"{where} <axis>", f"axis must not be zero, got {axis}")
        # the joint frame is the child link's frame, in the parent link's
        origin = transform_multiply(transform_inverse(links[parent][1]), links[child][1])
        return Joint(
            name=name,
            type=jtype,
            parent=parent,
            child=child,
            origin_xyz=origin[0],
            origin_rpy=rpy_from_quat(origin[1]),
            axis=axis,
            lower=lower,
            upper=upper,
            effort=effort,
            velocity=velocity,
            damping=damping,
            friction=friction,
            has_limit=jtype in ("revolute", "prismatic") and lower <= upper,
            origin_quat=origin[1],
            line=line_of(elem),
        )

    # ------------------------------------------------------------ models

    def model(self, elem: Element, index: int) -> SceneBody:
        name = elem.get("name")
        if name is None:
            raise self.error(elem, "<model>", "has no name attribute (PyBullet refuses it too)")
        where = f"model {name!r}"
        static = elem.find("static")
        is_static = (
            static is not None and int(number(static.text or "")) == 1  # PyBullet: atof, then int
        )
        base = self.pose(elem, where)
        links: dict[str, tuple[Link, Pose]] = {}
        filters: dict[str, tuple[int | None, int | None]] = {}
        for k, le in enumerate(elem.findall("link")):
            link, frame, flt = self.link(le, k)
            if link.name in links:
                raise self.error(
                    le,
                    f"link {link.name!r}",
                    "link name is used twice in one model (PyBullet refuses it too)",
                )
            links[link.name] = (link, frame)
            if flt != (None, None):
                filters[link.name] = flt
        if not links:
            raise self.error(elem, where, "has no <link> (PyBullet refuses it too)")
        joints = [self.joint(je, links) for je in elem.findall("joint")]
        check_names(self.file, "joint", [(j.name, j.line) for j in joints])
        children = {j.child for j in joints}
        roots = [n for n in links if n not in children]
        seen: dict[str, str] = {}
        for j in joints:
            if j.child in seen:
                raise self.error(
                    elem,
                    where,
                    f"link {j.child!r} has two parent joints ({seen[j.child]!r}, {j.name!r})",
                )
            seen[j.child] = j.name
        if len(roots) != 1:
            detail = (
                "every link has a parent: the joints form a cycle"
                if not roots
                else f"{len(roots)} root links {roots}; PyBullet crashes on a model with several"
            )
            raise self.error(elem, where, detail)
        ordered_links, ordered_joints = pybullet_order(
            {n: link for n, (link, _) in links.items()}, joints, roots[0]
        )
        if len(ordered_links) != len(links):
            raise self.error(elem, where, "some links form a cycle detached from the root")
        root = ordered_links[0]
        if is_static:  # PyBullet: the root's mass is 0 (its inertial frame stays)
            ine = root.inertial
            root.inertial = Inertial(
                ine.origin_xyz if ine.from_file else (0.0, 0.0, 0.0),
                ine.origin_rpy if ine.from_file else (0.0, 0.0, 0.0),
                0.0,
                ine.inertia,
                True,
                origin_quat=ine.origin_quat if ine.from_file else IDENTITY_QUAT,
                line=ine.line,
            )
        ignored = [
            f"line {line_of(e)}: <{e.tag}> in <model>"
            for e in elem
            if e.tag in ("include", "plugin")
        ]
        return SceneBody(
            name,
            self.src,
            ordered_links,
            ordered_joints,
            [],
            file_format="sdf",
            body_index=index,
            base_position=base[0],
            base_orientation=base[1],
            collision_filters=filters,
            ignored=ignored,
        )


def parse_sdf(src: UrdfSource) -> list[SceneBody]:
    """The bodies ``p.loadSDF`` creates from the file (see the module docstring), in its order.

    An ``<include>``, which PyBullet does not read, is one warning on the
    ``simbridge.model.sdf`` logger.

    Args:
        src: The file, as :func:`~simbridge.model.scene.resolve_scene_source` gives it.

    Returns:
        One body per ``<model>``.

    Raises:
        UrdfParseError, UrdfStructureError, MeshNotFoundError, UnsupportedJointError: naming
            the file, the line and the element.
    """
    root = read_scene_xml(src, "sdf")
    reader = _Reader(src)
    included = [f"line {line_of(e)} uri={e.findtext('uri')!r}" for e in root.iter("include")]
    if included:
        logging.getLogger("simbridge.model.sdf").warning(
            "%s: <include> not read (PyBullet's SDF importer does not read it; the included "
            "model is not loaded): %s",
            reader.file,
            "; ".join(included),
        )
    world = root.find("world")
    holder = world if world is not None else root
    models = holder.findall("model")
    if not models:
        raise reader.error(root, "<sdf>", "has no <model>: PyBullet creates no body from it")
    return [reader.model(m, k) for k, m in enumerate(models)]
