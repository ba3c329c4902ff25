"""The elements of a URDF link, read for :func:`simbridge.model.urdf.parse_urdf`.

Geometry (boxes, cylinders, capsules, spheres, planes, meshes), the mesh files read before any
engine reads them, the ``<inertial>``, the ``<contact>`` values and the colours of materials,
each read as PyBullet 3.2.7 reads it with a :class:`~simbridge.model.urdf_values._Reader`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from simbridge.exceptions import MeshNotFoundError
from simbridge.model.meshes import MeshReadError, mesh_vertices, pybullet_reads_stl
from simbridge.model.urdf_model import CONTACT_TAGS, Contact, Geometry, Inertial
from simbridge.model.urdf_source import UrdfSource, not_a_regular_file, resolve_mesh
from simbridge.model.urdf_values import _fmt, _Reader
from simbridge.model.urdf_xml import LOGGER, XmlElement, c_atof

MESH_FORMATS = (".obj", ".stl", ".dae")  # what PyBullet's URDF importer reads


def _geometry(
    r: _Reader,
    elem: XmlElement,
    where: str,
    src: UrdfSource,
    rgba: tuple[float, float, float, float] | None,
) -> Geometry:
    file = src.display_name
    xyz, rpy = r.origin(elem, where)
    geom = elem.find("geometry")
    if geom is None or len(geom) == 0:
        raise r.error(elem, where, "has no <geometry> (PyBullet refuses it too)")
    shape: XmlElement = geom[0]  # type: ignore[assignment]
    tag, line = shape.tag, shape.line
    name = elem.get("name", "")
    common = {"rgba": rgba, "name": name, "line": elem.line}
    if tag == "box":
        r.require(shape, "size", f"{where} <box>")
        size = r.vector(shape, "size", 3, f"{where} <box size>")
        if size is None:
            r.short(shape, "size", f"{where} <box size>", "(0, 0, 0)")
            size = (0.0, 0.0, 0.0)
        _sizes(r, shape, size, f"{where} <box size>")
        return Geometry("box", xyz, rpy, size, **common)  # type: ignore[arg-type]
    if tag in ("cylinder", "capsule"):
        radius = r.number(shape, "radius", 0.0, f"{where} <{tag}>", required=True)
        length = r.number(shape, "length", 0.0, f"{where} <{tag}>", required=True)
        _sizes(r, shape, (radius, length), f"{where} <{tag} radius, length>")
        return Geometry(tag, xyz, rpy, (radius, length), **common)  # type: ignore[arg-type]
    if tag == "sphere":
        radius = r.number(shape, "radius", 0.0, f"{where} <sphere>", required=True)
        _sizes(r, shape, (radius,), f"{where} <sphere radius>")
        return Geometry("sphere", xyz, rpy, (radius,), **common)  # type: ignore[arg-type]
    if tag == "plane":
        r.require(shape, "normal", f"{where} <plane>")
        normal = r.vector(shape, "normal", 3, f"{where} <plane normal>")
        if normal is None or not any(normal):
            raise r.error(
                shape,
                f"{where} <plane normal>",
                f"must be 3 numbers, not all 0, got {shape.get('normal')!r}",
            )
        return Geometry("plane", xyz, rpy, normal, **common)  # type: ignore[arg-type]
    if tag == "mesh":
        uri = shape.get("filename")
        if not uri:
            raise r.error(shape, f"{where} <mesh>", "has no filename (PyBullet refuses it too)")
        scale: tuple[float, ...] = (1.0, 1.0, 1.0)
        if shape.get("scale") is not None:
            read = r.vector(shape, "scale", 3, f"{where} <mesh scale>")
            if read is None:  # PyBullet: one number s is (s, s, s); no number leaves zeros
                s = c_atof(shape.get("scale", ""))[0]
                read = (s, s, s)
                r.lenient.add(
                    line,
                    f"{where} <mesh scale> {shape.get('scale')!r} read as {_fmt(read)}: fewer "
                    "than 3 numbers, PyBullet's workaround uses the first for all three",
                )
                r._finite(shape, f"{where} <mesh scale>", read, shape.get("scale", ""))
            scale = read
        path, tried = resolve_mesh(uri, src.mesh_from)
        if not path.is_file():
            odd = not_a_regular_file(tried)
            if odd is not None:
                raise r.error(shape, f"{where} <mesh>", f"mesh file {uri!r}: {odd}")
            raise MeshNotFoundError(file, where, uri, tried, line)
        if path.suffix.lower() not in MESH_FORMATS:
            raise r.error(
                shape,
                f"{where} <mesh>",
                f"{uri!r}: unsupported mesh format; valid: {', '.join(MESH_FORMATS)}",
            )
        if path.suffix.lower() == ".dae":
            _check_collada(r, shape, path, uri, f"{where} <mesh>")
        else:
            _check_mesh(r, shape, path, uri, f"{where} <mesh>")
        return Geometry("mesh", xyz, rpy, scale, mesh_path=path, mesh_uri=uri, **common)  # type: ignore[arg-type]
    raise r.error(
        shape,
        where,
        f"unknown geometry <{tag}>; valid: box, cylinder, sphere, capsule, mesh, plane",
    )


def _sizes(r: _Reader, elem: XmlElement, values: Sequence[float], where: str) -> None:
    if any(v < 0 for v in values):
        raise r.error(elem, where, f"sizes must be >= 0, got {tuple(values)}")


def _check_mesh(r: _Reader, elem: XmlElement, path: Path, uri: str, where: str) -> None:
    """Read an .obj/.stl before any engine does (the read is cached for the inertia and the
    MuJoCo model): a file that is not one of its format is refused here (PyBullet loads random
    bytes as a link without a shape, and an .obj's unreadable numbers as garbage inertia)."""
    try:
        mesh_vertices(path)
    except MeshReadError as exc:
        at = "" if exc.line is None else f" (line {exc.line})"
        raise r.error(elem, where, f"{uri!r} cannot be read as a mesh{at}: {exc.detail}") from None
    except OSError as exc:
        raise r.error(elem, where, f"{uri!r} cannot be read: {exc.strerror}") from None


def _without_unread_stl(file: str, shapes: list[Geometry], where: str) -> list[Geometry]:
    """``shapes`` less the .stl meshes PyBullet does not read (an ASCII STL: PyBullet reads
    binary ones only, :func:`~simbridge.model.meshes.pybullet_reads_stl`): PyBullet loads the link
    without that shape and warns ("cannot extract mesh from"); every backend leaves it out
    (its inertia, its collisions and its looks), with one warning per shape on the
    ``simbridge.model.urdf`` logger naming the file, the line and the element."""
    kept = []
    for k, g in enumerate(shapes):
        drop = (
            g.kind == "mesh"
            and g.mesh_path is not None
            and g.mesh_path.suffix.lower() == ".stl"
            and not pybullet_reads_stl(g.mesh_path)
        )
        if not drop:
            kept.append(g)
            continue
        at = f"{file}:{g.line}" if g.line else file
        LOGGER.warning(
            "%s: %s #%d <mesh>: %r is not a binary STL, which PyBullet alone reads: the shape "
            "is left out, as PyBullet leaves it out ('cannot extract mesh from')",
            at,
            where,
            k,
            g.mesh_uri,
        )
    return kept


def _check_collada(r: _Reader, elem: XmlElement, path: Path, uri: str, where: str) -> None:
    """Read a .dae before any engine does: PyBullet's COLLADA reader ends the process on some
    malformed files (an empty <scene>), and MuJoCo's backend converts .dae through trimesh."""
    try:
        vertices = mesh_vertices(path)
    except Exception as exc:  # noqa: BLE001 - any reader failure is a bad file
        raise r.error(
            elem, where, f"{uri!r} cannot be read as COLLADA ({type(exc).__name__}: {exc})"
        ) from None
    if len(vertices) < 3:
        raise r.error(elem, where, f"{uri!r} holds no geometry (no vertices)")


def _inertial(r: _Reader, elem: XmlElement | None, where: str) -> Inertial:
    if elem is None:
        return Inertial()
    xyz, rpy = r.origin(elem, f"{where} <inertial>")
    mass_elem = elem.find("mass")
    if mass_elem is None:
        raise r.error(elem, f"{where} <inertial>", "has no <mass> (PyBullet refuses it too)")
    mass = r.number(mass_elem, "value", 0.0, f"{where} <mass>", required=True)  # type: ignore[arg-type]
    if mass < 0:
        raise r.error(mass_elem, f"{where} <mass>", f"mass must be >= 0, got {mass}")  # type: ignore[arg-type]
    ie: XmlElement | None = elem.find("inertia")  # type: ignore[assignment]
    if ie is None:
        raise r.error(elem, f"{where} <inertial>", "has no <inertia> (PyBullet refuses it too)")
    keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    present = [ie.get(k) is not None for k in keys]
    if not all(present[k] for k in (0, 3, 5)):
        raise r.error(
            ie, f"{where} <inertia>", "needs at least ixx, iyy and izz (PyBullet refuses it too)"
        )
    # PyBullet reads the products of inertia only when all six are there
    used = keys if all(present) else ("ixx", "iyy", "izz")
    inertia = tuple(r.number(ie, k, 0.0, f"{where} <inertia>") if k in used else 0.0 for k in keys)
    if not all(present) and any(present):
        given = [k for k, p in zip(keys, present, strict=True) if p and k not in used]
        if given:
            r.lenient.add(
                ie.line,
                f"{where} <inertia>: {', '.join(given)} ignored "
                "(PyBullet reads products of inertia only when all six are given)",
            )
    return Inertial(xyz, rpy, mass, inertia, True, line=ie.line)  # type: ignore[arg-type]


def _contact(r: _Reader, elem: XmlElement | None, where: str) -> Contact:
    if elem is None:
        return Contact()
    values: dict[str, float] = {}
    for tag in CONTACT_TAGS:
        child: XmlElement | None = elem.find(tag)  # type: ignore[assignment]
        if child is not None:
            values[tag] = r.number(child, "value", 0.0, f"{where} <contact><{tag}>", required=True)
    return Contact(**values)


def _material_color(
    r: _Reader, elem: XmlElement, where: str
) -> tuple[float, float, float, float] | None:
    """A ``<material>``'s ``<color rgba>``: exactly 4 numbers, else (0, 0, 0, 0) as in PyBullet;
    None without a color."""
    color: XmlElement | None = elem.find("color")  # type: ignore[assignment]
    if color is None or color.get("rgba") is None:
        return None
    rgba = r.vector(color, "rgba", 4, f"{where} <color rgba>")
    if rgba is None:
        r.lenient.add(
            color.line,
            f"{where} <color rgba> {color.get('rgba')!r}: not 4 numbers, read as (0, 0, 0, 0)",
        )
        return (0.0, 0.0, 0.0, 0.0)
    return rgba  # type: ignore[return-value]


def _visual_color(
    r: _Reader,
    visual: XmlElement,
    where: str,
    materials: dict[str, tuple[float, float, float, float] | None],
) -> tuple[float, float, float, float] | None:
    material: XmlElement | None = visual.find("material")  # type: ignore[assignment]
    if material is None:
        return None
    name = material.get("name")
    if name is None:
        raise r.error(
            material, f"{where} <material>", "has no name attribute (PyBullet refuses it too)"
        )
    if any(material.find(t) is not None for t in ("texture", "color", "specular")):
        rgba = _material_color(r, material, f"{where} <material>")
        materials[name] = rgba  # a local material replaces one of the same name
        return rgba
    return materials.get(name)
