"""MJCF and SDF files: the bodies PyBullet creates from one file, as core models.

``p.loadMJCF`` and ``p.loadSDF`` create several bodies from one file (one per top-level MJCF
``<body>`` or ``<geom>``, one per SDF ``<model>``), each a multibody with PyBullet's own link and
joint numbering. :func:`simbridge.model.scene_reader.parse_scene` reads a file into one
:class:`SceneBody` per body PyBullet creates, in its order, with its link and joint numbering
and names, so that every backend loads them through its ordinary path
(:meth:`simbridge.backend.Backend.load_scene`); the readers are :mod:`simbridge.model.mjcf` and
:mod:`simbridge.model.sdf`, and this module holds what they share.

A :class:`SceneBody` is a :class:`~simbridge.model.urdf_model.UrdfModel` (links, joints, inertials,
shapes, contact values) plus where PyBullet puts its base: ``base_position`` and
``base_orientation`` place the root's link frame in the world, as ``load``'s pose does for a
URDF. Lengths in metres, angles in radians, quaternions (x, y, z, w).
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
import xml.parsers.expat as expat
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from simbridge.exceptions import UrdfNotFoundError, UrdfParseError, UrdfStructureError
from simbridge.model.urdf_model import UrdfModel, Vec3
from simbridge.model.urdf_source import UrdfSource, locate, resolve_mesh
from simbridge.model.urdf_xml import XmlElement, c_atof, pybullet_numbers
from simbridge.types import Quat

__all__ = [
    "SceneBody",
    "SCENE_FORMATS",
    "resolve_scene_source",
    "read_scene_xml",
    "f32",
    "line_of",
    "numbers",
]

SCENE_FORMATS = ("mjcf", "sdf")
_ROOT_TAG = {"mjcf": "mujoco", "sdf": "sdf"}
_KIND = {"mjcf": "MJCF", "sdf": "SDF"}


@dataclass
class SceneBody(UrdfModel):
    """One body PyBullet creates from an MJCF or SDF file.

    ``links``/``joints`` follow :class:`~simbridge.model.urdf_model.UrdfModel`'s conventions
    (``links[0]`` the root, PyBullet link -1; joint i moves link i). ``base_position`` and
    ``base_orientation`` (x, y, z, w) place the root link's frame in the world where PyBullet
    puts it. ``file_format`` is ``"mjcf"`` or ``"sdf"``; ``body_index`` the body's place among
    the file's bodies (0-based, PyBullet's order); ``collision_filters`` each link's collision
    group and mask by link name (the file's ``contype``/``conaffinity``, SDF's ``<collision
    group mask>``; links not listed take PyBullet's defaults); ``ignored`` what the file says that
    PyBullet's importer does not read, one line each (with the element's line).
    """

    file_format: str = "mjcf"
    body_index: int = 0
    base_position: Vec3 = (0.0, 0.0, 0.0)
    base_orientation: Quat = (0.0, 0.0, 0.0, 1.0)
    collision_filters: dict[str, tuple[int | None, int | None]] = field(default_factory=dict)
    ignored: list[str] = field(default_factory=list)


def line_of(elem: ET.Element) -> int:
    """The source line of an element read by :func:`read_scene_xml`.

    Args:
        elem: An element of that tree.

    Returns:
        Its line (1-based; 0 when it has none).
    """
    return int(getattr(elem, "line", 0))


def f32(value: float) -> float:
    """A number rounded to float32 (PyBullet's MJCF importer reads vectors into float arrays).

    Args:
        value: The number.

    Returns:
        It rounded to float32, as a Python float.
    """
    return float(np.float32(value))


def numbers(text: str | None) -> list[float]:
    """PyBullet's reading of a list of numbers: split at spaces only, each piece through C's
    ``atof``.

    Args:
        text: An attribute's text, or None (no numbers).

    Returns:
        The numbers.
    """
    return pybullet_numbers(text or "")[0]


def number(text: str | None) -> float:
    """C's ``atof`` of the whole text (PyBullet's ``urdfLexicalCast``).

    Args:
        text: An attribute's text, or None (0).

    Returns:
        The number (0.0 where the text starts with none).
    """
    return c_atof(text or "")[0]


def resolve_scene_source(
    source: str | os.PathLike[str], kind: str, *, near: Path | None = None
) -> UrdfSource:
    """Find and read an MJCF or SDF file.

    Args:
        source: A path, a name on the search path (this package's robots, then pybullet_data,
            e.g. ``"mjcf/ant.xml"``), or the file's XML text.
        kind: ``"mjcf"`` or ``"sdf"``.
        near: A folder searched for a relative path first (a scenario's).

    Returns:
        The source: its text, its file and folder.

    Raises:
        UrdfNotFoundError: neither a path, a name nor text, or found nowhere.
        UrdfParseError: the file cannot be read.
    """
    label = _KIND[kind]
    if isinstance(source, str) and source.lstrip("\ufeff \t\r\n").startswith("<"):
        return UrdfSource(source.lstrip("\ufeff"), None, Path.cwd(), f"<{label} text>")
    if not isinstance(source, (str, os.PathLike)):
        raise UrdfNotFoundError(repr(source), ["a path, a name or XML text was expected"], label)
    found, itself = locate(source, near=near, kind=label)
    # the path as PyBullet would be given it: the caller's text, or the search folder's file
    as_given = os.path.expanduser(os.fspath(source)) if itself else str(found)
    found = found.resolve()
    try:
        data = found.read_bytes()
    except OSError as exc:
        raise UrdfParseError(str(found), f"cannot read the file: {exc}", label) from exc
    text = data.decode("utf-8", errors="surrogateescape")
    return UrdfSource(text, found, found.parent, str(found), as_given)


# PyBullet's XML reader (TinyXML-2) refuses a file whose elements nest deeper than this, the
# root counting 1 and an empty-element tag <x/> counting as its parent (measured on 3.2.7, MJCF
# and SDF alike: <x></x> at depth 98 loads, at 99 is XML_ELEMENT_DEPTH_EXCEEDED; <x/> at 99
# loads, at 100 refused)
MAX_XML_DEPTH = 98


def read_scene_xml(src: UrdfSource, kind: str) -> XmlElement:
    """Parse an MJCF or SDF file as PyBullet's XML reader does.

    Args:
        src: The source, as :func:`resolve_scene_source` gives it.
        kind: ``"mjcf"`` or ``"sdf"``.

    Returns:
        The file's root element (``<mujoco>`` or ``<sdf>``), every element with its source
        line.

    Raises:
        UrdfParseError: XML PyBullet's parser refuses too (with line and column).
        UrdfStructureError: elements nested deeper than :data:`MAX_XML_DEPTH`, or a root
            element other than the format's (PyBullet: "Cannot find <mujoco> root element",
            "expected an sdf element").
    """
    data = src.text.encode("utf-8", errors="surrogateescape")
    parser = expat.ParserCreate()
    builder = ET.TreeBuilder(element_factory=XmlElement)
    # the nesting depth as PyBullet's reader counts it: an element written with an end tag
    # (<x></x>, <x>1</x>) at its depth, an empty-element tag (<x/>) at its parent's (expat
    # reports the end of an empty-element tag just past its "/>", of any other at its "</")
    opened: list[list[Any]] = []  # [element, has content] from the root down
    deepest: list[Any] = [0, None]  # depth, the first element counted at it

    def start(tag: str, attrs: dict[str, str]) -> None:
        elem = builder.start(tag, attrs)
        elem.line = parser.CurrentLineNumber  # type: ignore[attr-defined]
        if opened:
            opened[-1][1] = True
        opened.append([elem, False])

    def text(chunk: str) -> None:
        if opened:
            opened[-1][1] = True
        builder.data(chunk)

    def end(tag: str) -> None:
        elem = builder.end(tag)
        had_content = opened.pop()[1]
        at = parser.CurrentByteIndex
        empty_tag = not had_content and data[at - 2 : at] == b"/>"
        level = len(opened) + (not empty_tag)
        if level > deepest[0]:
            deepest[0], deepest[1] = level, elem

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = text
    try:
        parser.Parse(data, True)
    except expat.ExpatError as exc:
        raise UrdfParseError(
            src.display_name,
            f"{expat.ErrorString(exc.code)}: line {exc.lineno}, column {exc.offset} "
            "(PyBullet's parser refuses it too)",
            _KIND[kind],
        ) from None
    root: XmlElement = builder.close()  # type: ignore[assignment]
    if deepest[0] > MAX_XML_DEPTH:  # counted as parsed: a reader's recursion could not
        raise UrdfStructureError(
            src.display_name,
            f"<{deepest[1].tag}>",
            f"elements nested {deepest[0]} deep: PyBullet's XML reader refuses more than "
            f"{MAX_XML_DEPTH} (XML_ELEMENT_DEPTH_EXCEEDED; an empty-element tag <x/> counts "
            f"as its parent), and an {_KIND[kind]} file is read as PyBullet reads it, on every "
            "backend",
            deepest[1].line,
        )
    want = _ROOT_TAG[kind]
    if root.tag != want:
        raise UrdfStructureError(
            src.display_name,
            f"<{root.tag}>",
            f"the root element of an {_KIND[kind]} file must be <{want}> (PyBullet refuses it too)",
            root.line,
        )
    return root


def find_mesh(uri: str, folder: str | Path) -> tuple[Path, list[str]]:
    """Where a mesh of an MJCF or SDF file is: PyBullet's MJCF and SDF importers look where its
    URDF importer does (:func:`~simbridge.model.urdf_source.resolve_mesh`, bullet3
    ``UrdfFindMeshFile.h``).

    Every folder tried is joined to the name as written, so ``/meshes/a.stl`` is also found as
    ``meshes/a.stl`` beside the file (pybullet_data's ``kuka_with_gripper.sdf`` writes its
    meshes so).

    Args:
        uri: The mesh's file name as written.
        folder: The file's folder, as :func:`~simbridge.model.urdf_source.resolve_mesh` takes
            it.

    Returns:
        As :func:`~simbridge.model.urdf_source.resolve_mesh`: the file found (or the first
        attempt) and every attempt.
    """
    return resolve_mesh(uri, folder)


def check_names(file: str, what: str, names: Sequence[tuple[str, int]]) -> None:
    """Refuse a name used twice in one body: PyBullet keys links and joints by name and keeps only
    the last of a name (silently dropping the other from its tree).

    Args:
        file: The file (for the message).
        what: ``"link"`` or ``"joint"``.
        names: Every name of that kind in the body, with its line (0: unknown).

    Raises:
        UrdfStructureError: at the second use of a name.
    """
    seen: dict[str, int] = {}
    for name, line in names:
        if name in seen:
            raise UrdfStructureError(
                file,
                f"{what} {name!r}",
                f"the name is used twice in one body (also line {seen[name]}); PyBullet keeps "
                "only one of them",
                line or None,
            )
        seen[name] = line
