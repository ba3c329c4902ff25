"""Mesh files read once: one reader per format, cached per path.

Every user of a mesh (PyBullet's inertia rules, the URDF's COLLADA check, the MuJoCo model
builder) reads it through :func:`read_mesh`, which returns the vertex positions (n, 3) float64,
in the file's own units and frame, unscaled, and the triangles (m, 3) int64 as indices into
them. Both arrays are read-only: the result is cached per file (its path, modification time
and size: a file rewritten in the meantime is read again), the least recently used files
forgotten once the cached arrays pass :data:`CACHE_BYTES`.

* ``.obj``: ``v`` lines (x y z; any further number is ignored) and ``f`` lines, each polygon a
  fan of triangles around its first corner; ``i/t/n`` corners use ``i``; a negative index
  counts back from the last vertex of the file; a face with a corner that is not an integer is
  left out;
* ``.stl``: binary (when the size matches the triangle count in its header) or ASCII
  (``vertex`` lines); three vertices per triangle, as written, not merged;
* a file that is not one of its format raises :class:`MeshReadError` naming the file, the line
  where there is one, and what is wrong: an .obj that is not text, has a ``v`` line without
  3 numbers or a face corner past its vertices; an .stl that is neither binary (its size
  matches its triangle count) nor ASCII text starting with ``solid``, or with a ``vertex`` line
  without 3 numbers; an .obj or .stl without a vertex, or with a vertex that is not finite; a
  .dae with a number in a ``<float_array>`` that is not finite (trimesh would drop the vertex
  quietly) or a primitive whose ``<p>`` indices run past its vertices (trimesh drops the
  mesh, raw PyBullet crashes). PyBullet loads random bytes or NaN vertices as a link without a
  shape, and reads an .obj's missing numbers as uninitialised memory (measured: inertia 1e41);
* anything else (``.dae``): through trimesh, imported only then (about 1 s): each geometry
  as its scene loader makes it (repeated vertices merged, no repair), placed by its node's
  transform; texture images are not read.
"""

from __future__ import annotations

import math
import os
import re
import threading
import warnings
from collections import OrderedDict
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

__all__ = [
    "MeshData",
    "MeshReadError",
    "read_mesh",
    "mesh_vertices",
    "clear_cache",
    "pybullet_reads_stl",
]


CACHE_BYTES = 256 << 20
"""The most bytes of vertex and triangle arrays the cache holds (256 MiB). It was 256 files:
a sweep over more files than that, once per backend (the conformance suite's 1,000
random_urdfs of pybullet_data, 16 MiB of arrays, on each of three engines), read every
file again for every engine."""


class MeshReadError(ValueError):
    """A mesh file that is not one of its format (see the module docstring).

    Args:
        path: The file.
        detail: What is wrong.
        line: The line of an .obj that is to blame (1-based), or None.
    """

    def __init__(self, path: str, detail: str, line: int | None = None) -> None:
        self.path = path
        self.line = line
        self.detail = detail
        super().__init__(f"{path}{'' if line is None else f':{line}'}: {detail}")


class MeshData(NamedTuple):
    """A mesh as its file holds it (both arrays read-only)."""

    vertices: np.ndarray
    """(n, 3) float64 vertex positions, unscaled."""
    faces: np.ndarray
    """(m, 3) int64 triangles, indices into ``vertices``."""


def read_mesh(path: str | Path) -> MeshData:
    """The vertices and triangles of a mesh file (see the module docstring). Cached per path,
    modification time and size.

    Args:
        path: The mesh file (.obj, .stl, or what trimesh reads).

    Returns:
        (n, 3) float64 vertices, unscaled, and (m, 3) int64 triangles, both read-only.

    Raises:
        OSError: the file cannot be read.
        MeshReadError: an .obj/.stl that is not one (a ValueError); trimesh's own errors on a
            file trimesh cannot read.
    """
    name = str(path)
    stat = os.stat(name)
    return _read_cached(name, stat.st_mtime_ns, stat.st_size)


def mesh_vertices(path: str | Path) -> np.ndarray:
    """The vertex positions of :func:`read_mesh`.

    Args:
        path: The mesh file.

    Returns:
        (n, 3) float64 positions, unscaled, read-only.

    Raises:
        OSError, MeshReadError: as :func:`read_mesh`.
    """
    return read_mesh(path).vertices


def clear_cache() -> None:
    """Forget every mesh read so far (the next read of each file reads it again)."""
    with _LOCK:
        _CACHE.clear()
        _HELD[0] = 0


_CACHE: OrderedDict[tuple[str, int, int], MeshData] = OrderedDict()  # least recent first
_HELD = [0]  # bytes of the arrays in _CACHE
_LOCK = threading.Lock()


def _read_cached(path: str, mtime_ns: int, size: int) -> MeshData:
    """One version of a file (``mtime_ns`` and ``size``, in bytes, are the cache's key), from
    the cache or read (a file that fails to read is not cached: it fails again)."""
    key = (path, mtime_ns, size)
    with _LOCK:
        mesh = _CACHE.get(key)
        if mesh is not None:
            _CACHE.move_to_end(key)
            return mesh
    mesh = _read(path, size)
    nbytes = mesh.vertices.nbytes + mesh.faces.nbytes
    with _LOCK:
        if key not in _CACHE and nbytes <= CACHE_BYTES:
            _CACHE[key] = mesh
            _HELD[0] += nbytes
            while _HELD[0] > CACHE_BYTES:
                _, old = _CACHE.popitem(last=False)
                _HELD[0] -= old.vertices.nbytes + old.faces.nbytes
    return mesh


def _read(path: str, size: int) -> MeshData:
    """The file read (``size``: its size in bytes, for the message on an empty one)."""
    suffix = Path(path).suffix.lower()
    if suffix == ".obj":
        mesh, rows = _read_obj(path)
    elif suffix == ".stl":
        mesh, rows = _read_stl(path)
    else:
        mesh, rows = _read_with_trimesh(path), None
    if rows is not None:  # .obj, .stl: vertices, all finite
        if not len(mesh.vertices):
            raise MeshReadError(path, "holds no vertex" + (" (an empty file)" if not size else ""))
        finite = np.isfinite(mesh.vertices).all(axis=1)
        if not finite.all():
            k = int(np.flatnonzero(~finite)[0])
            where, line = rows(k)
            vertex = ", ".join(f"{v:g}" for v in mesh.vertices[k])
            raise MeshReadError(path, f"{where} is not finite: ({vertex})", line)
    mesh.vertices.setflags(write=False)
    mesh.faces.setflags(write=False)
    return mesh


def _three(path: str, parts: list[str], number: int, line: str) -> tuple[float, float, float]:
    """x, y, z from ``v x y z`` or ``vertex x y z`` (line ``number`` of ``path``)."""
    try:
        return float(parts[1]), float(parts[2]), float(parts[3])
    except (IndexError, ValueError):
        raise MeshReadError(
            path, f"{parts[0]!r} needs 3 numbers (x y z), got {line.strip()[:60]!r}", number
        ) from None


# where vertex k was read: (what it is, its line or None), for MeshReadError
_Rows = Callable[[int], tuple[str, int | None]]


def _read_obj(path: str) -> tuple[MeshData, _Rows]:
    rows = []
    lines: list[int] = []
    face_lines = []
    data = Path(path).read_bytes()
    if b"\0" in data:
        raise MeshReadError(path, "not an .obj: binary data (a NUL byte), not text")
    text = data.decode("utf-8", errors="replace").replace("\r\n", "\n").replace("\r", "\n")
    quick = _read_obj_quickly(text)
    if quick is not None:
        return quick, lambda k: (f"vertex {k + 1}", None)  # all finite: never called
    for number, line in enumerate(text.split("\n"), 1):  # as a text-mode file's lines
        if line.startswith("v "):
            rows.append(_three(path, line.split(), number, line))
            lines.append(number)
        elif line.startswith("f "):
            face_lines.append((number, line))
    vertices = np.array(rows, dtype=float).reshape(-1, 3)
    n = len(vertices)
    tris: list[tuple[int, int, int]] = []
    for number, line in face_lines:
        idx: list[int] = []
        for token in line.split()[1:]:
            head = token.split("/", 1)[0]
            if not head:
                continue
            try:
                i = int(head)
            except ValueError:  # not an index: the face is unusable, as for PyBullet
                idx = []
                break
            k = i - 1 if i > 0 else n + i
            if not 0 <= k < n:
                raise MeshReadError(
                    path, f"a face corner is vertex {i}; the file has {n} vertices", number
                )
            idx.append(k)
        for a in range(1, len(idx) - 1):
            tris.append((idx[0], idx[a], idx[a + 1]))
    faces = np.array(tris, dtype=np.int64).reshape(-1, 3)
    return MeshData(vertices, faces), lambda k: (f"vertex {k + 1}", lines[k])


def _read_obj_quickly(text: str) -> MeshData | None:
    """:func:`_read_obj`'s result read with numpy, for the common file: every ``v`` line with
    3 numbers or more, all finite, every ``f`` line the same number of corners (3 or more),
    each an index within the file's vertices. None for any other file (the line by line
    reading then says what is wrong). The same arrays, bit for bit (compared on the 1,199
    .obj files of pybullet_data, example-robot-data and this project)."""
    lines = text.split("\n")
    parts = [line.split() for line in lines if line.startswith("v ")]
    if any(len(p) < 4 for p in parts):
        return None
    try:
        vertices = np.array([p[1:4] for p in parts], dtype=np.float64).reshape(-1, 3)
    except ValueError:
        return None
    if not np.isfinite(vertices).all():
        return None
    faces = [line.split()[1:] for line in lines if line.startswith("f ")]
    corners = len(faces[0]) if faces else 3
    if corners < 3 or any(len(f) != corners for f in faces):
        return None
    try:  # a corner is its index before any "/"; an empty or other one: the slow reading
        index = np.array([c.partition("/")[0] for f in faces for c in f], dtype=np.int64).reshape(
            -1, corners
        )
    except ValueError:
        return None
    n = len(vertices)
    if ((index == 0) | (index > n) | (index < -n)).any():
        return None
    index = np.where(index > 0, index - 1, index + n)
    # each polygon a fan of triangles around its first corner, in the file's order
    fan = [index[:, [0, a, a + 1]] for a in range(1, corners - 1)]
    return MeshData(vertices, np.stack(fan, axis=1).reshape(-1, 3))


def pybullet_reads_stl(path: str | Path) -> bool:
    """Whether PyBullet's STL reader (bullet3 ``LoadMeshFromSTL``) takes the file.

    Binary only, its header's triangle count (a signed 32-bit integer at byte 80) not 0 and the
    size 84 bytes + 50 per triangle. PyBullet leaves any other .stl out of the link (an ASCII
    STL, which :func:`read_mesh` reads, among them) and warns "cannot extract mesh from".

    Args:
        path: An .stl file.

    Returns:
        True when PyBullet reads it.

    Raises:
        OSError: the file cannot be opened.
    """
    with open(path, "rb") as f:
        head = f.read(84)
        size = os.fstat(f.fileno()).st_size
    if len(head) < 84:
        return False
    n = int(np.frombuffer(head, dtype="<i4", count=1, offset=80)[0])
    return n != 0 and 84 + 50 * n == size


def _read_stl(path: str) -> tuple[MeshData, _Rows]:
    data = Path(path).read_bytes()
    if len(data) >= 84:
        n = int(np.frombuffer(data, dtype="<u4", count=1, offset=80)[0])
        if 84 + 50 * n == len(data):
            rec = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
            tri = np.frombuffer(data, dtype=rec, count=n, offset=84)
            vertices = tri["v"].reshape(-1, 3).astype(float)
            return _stl(vertices), lambda k: (f"triangle {k // 3 + 1} vertex {k % 3 + 1}", None)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        text = ""
    if not text.lstrip().startswith("solid"):
        size = "an empty file" if not data else f"{len(data)} bytes"
        raise MeshReadError(
            path,
            f"not an .stl: neither binary (84 bytes + 50 per triangle its header counts) nor "
            f"ASCII text starting with 'solid' ({size})",
        )
    rows = []
    lines: list[int] = []
    for number, line in enumerate(text.splitlines(), 1):
        parts = line.split()
        if parts and parts[0] == "vertex":
            rows.append(_three(path, parts, number, line))
            lines.append(number)
    vertices = np.array(rows, dtype=float).reshape(-1, 3)
    return _stl(vertices), lambda k: (f"vertex {k + 1}", lines[k])


def _stl(vertices: np.ndarray) -> MeshData:
    """Three vertices per triangle, as written."""
    return MeshData(vertices, np.arange(len(vertices) // 3 * 3, dtype=np.int64).reshape(-1, 3))


def _read_with_trimesh(path: str) -> MeshData:
    if path.lower().endswith(".dae"):  # trimesh drops a non-finite vertex without a word
        text = Path(path).read_text(encoding="utf-8", errors="replace")
        for m in re.finditer(r"<float_array\b[^>]*>([^<]*)<", text):
            quick = _numbers(m.group(1), np.float64)
            if quick is not None and np.isfinite(quick).all():
                continue
            for token in m.group(1).split():
                try:
                    value = float(token)
                except ValueError:
                    continue  # trimesh says what it cannot read
                if not math.isfinite(value):
                    line = text.count("\n", 0, m.start()) + 1
                    raise MeshReadError(
                        path, f"a number of a <float_array> is not finite: {token!r}", line
                    )
        _collada_indices(path, text)
    import trimesh  # ~1 s to import: only for formats read nowhere else (.dae)

    # texture images are never read: an empty resolver finds none (reading and packing them
    # took most of the time; the vertices and faces are bit for bit the same, compared on the
    # 298 .dae files of pybullet_data and example-robot-data)
    loaded: Any = trimesh.load(path, force="mesh", process=False, resolver={})
    if path.lower().endswith(".dae") and not len(loaded.vertices):
        loaded = _collada_without_materials(path, trimesh)
    vertices = np.asarray(loaded.vertices, dtype=np.float64).reshape(-1, 3)
    faces = np.asarray(loaded.faces, dtype=np.int64).reshape(-1, 3)
    return MeshData(vertices, faces)


def _numbers(text: str, dtype: type) -> np.ndarray | None:
    """The whitespace-separated numbers of ``text`` read by numpy (the fast path of the
    COLLADA checks); None where numpy does not read every token (the checks then read them
    one by one, as Python's ``float``/``int``)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # older numpy warns where it stops short
            values: np.ndarray = np.fromstring(text, dtype=dtype, sep=" ")
    except ValueError:  # numpy 2: a token it cannot read
        return None
    return values if values.size == len(text.split()) else None


_LOOKS = ("library_effects", "library_materials", "library_images", "bind_material")


def _collada_without_materials(path: str, trimesh: Any) -> Any:
    """The geometry of a COLLADA file read again without its materials, effects and images.
    A material that names a missing texture surface (example-robot-data's anymal_foot.dae:
    "Missing surface carbon_uv_texture_jpg_001-surface") makes pycollada drop the effect, and
    trimesh then every mesh that uses it: an empty scene. PyBullet's COLLADA reader reads the
    geometry and its node transforms alone; so does this second reading."""
    import io
    import xml.etree.ElementTree as ET

    root = ET.parse(path).getroot()
    for parent in list(root.iter()):
        for child in list(parent):
            if isinstance(child.tag, str) and child.tag.rsplit("}", 1)[-1] in _LOOKS:
                parent.remove(child)
    data = io.BytesIO(ET.tostring(root))
    return trimesh.load(data, file_type="dae", force="mesh", process=False)


_PRIMITIVES = ("triangles", "polylist", "polygons", "lines", "linestrips", "trifans", "tristrips")


def _collada_indices(path: str, text: str) -> None:
    """MeshReadError for a COLLADA primitive whose ``<p>`` indexes a vertex past its
    ``<vertices>``' position source (trimesh drops such a mesh quietly; raw PyBullet 3.2.7
    crashes on it, measured). A file this cannot follow is left to trimesh."""
    import xml.etree.ElementTree as ET

    try:
        root = ET.fromstring(text)
    except ET.ParseError:
        return  # trimesh says what it cannot read
    local = {e: e.tag.rsplit("}", 1)[-1] for e in root.iter() if isinstance(e.tag, str)}
    for mesh in (e for e, tag in local.items() if tag == "mesh"):
        counts: dict[str, int] = {}  # source id -> number of points
        positions: dict[str, str] = {}  # vertices id -> source id
        for child in mesh:
            tag = local.get(child, "")
            if tag == "source":
                for acc in (e for e in child.iter() if local.get(e) == "accessor"):
                    try:
                        counts[child.get("id", "")] = int(acc.get("count", ""))
                    except ValueError:
                        pass
            elif tag == "vertices":
                for inp in child:
                    if local.get(inp) == "input" and inp.get("semantic") == "POSITION":
                        positions[child.get("id", "")] = inp.get("source", "").lstrip("#")
        for prim in (e for e in mesh if local.get(e) in _PRIMITIVES):
            inputs = [e for e in prim if local.get(e) == "input"]
            try:
                offsets = [int(e.get("offset", "0")) for e in inputs]
            except ValueError:
                continue
            vertex = [
                (off, e.get("source", "").lstrip("#"))
                for off, e in zip(offsets, inputs, strict=True)
                if e.get("semantic") == "VERTEX"
            ]
            if not vertex or vertex[0][1] not in positions:
                continue
            offset, vid = vertex[0]
            n = counts.get(positions[vid])
            if n is None:
                continue
            stride = max(offsets) + 1
            for p in (e for e in prim if local.get(e) == "p"):
                quick = _numbers(p.text or "", np.int64)
                if quick is not None:
                    picked = quick[offset::stride]
                    if ((picked >= 0) & (picked < n)).all():
                        continue
                try:
                    values = [int(v) for v in (p.text or "").split()]
                except ValueError:
                    continue
                bad = [v for v in values[offset::stride] if not 0 <= v < n]
                if bad:
                    raise MeshReadError(
                        path,
                        f"<{local[prim]}> indexes vertex {bad[0]} (of {len(bad)} indices out of "
                        f"range); its <vertices> {vid!r} hold {n}",
                    )
