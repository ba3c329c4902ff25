"""simbridge.model.meshes: the one reader per mesh format (vertices and triangles), cached per
path."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pybullet_data
import pytest

from simbridge.model.meshes import MeshData, MeshReadError, mesh_vertices, read_mesh

DATA = Path(pybullet_data.getDataPath())

OBJ = """# a quad, a triangle by negative indices, a bad face
o first
v 0 0 0
v 1 0 0 1.0
v 1 1 0
v 0 1 0
vt 0 0
vn 0 0 1
f 1/1/1 2/1/1 3/1/1 4/1/1
f -3 -2 -1
f 1 x 3
v 0 0 1
"""


def test_obj_faces_are_fans_of_every_polygon(tmp_path):
    path = tmp_path / "probe.obj"
    path.write_text(OBJ, encoding="utf-8")
    mesh = read_mesh(path)
    assert isinstance(mesh, MeshData)
    assert mesh.vertices.dtype == np.float64 and mesh.faces.dtype == np.int64
    assert mesh.vertices.tolist() == [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1]]
    # the quad as two triangles around its first corner; negative indices count back from the
    # last vertex of the file (5 vertices: -3 is vertex 3, index 2); "f 1 x 3" is left out
    assert mesh.faces.tolist() == [[0, 1, 2], [0, 2, 3], [2, 3, 4]]


def test_an_obj_face_past_its_vertices_is_an_error(tmp_path):
    """A face corner that names no vertex (was: the triangle left out) raises MeshReadError
    with the file and line (issue 15: garbage meshes)."""
    from simbridge.model.meshes import MeshReadError

    path = tmp_path / "past.obj"
    path.write_text(OBJ + "f 1 2 9\n", encoding="utf-8")
    with pytest.raises(MeshReadError, match=r"past\.obj:13: a face corner is vertex 9; the file "):
        read_mesh(path)


def test_cached_per_path_and_read_only(tmp_path):
    path = tmp_path / "cached.obj"
    path.write_text(OBJ, encoding="utf-8")
    mesh = read_mesh(path)
    assert read_mesh(str(path)) is mesh
    assert mesh_vertices(path) is mesh.vertices
    for array in mesh:
        assert not array.flags.writeable
        with pytest.raises(ValueError):
            array[0, 0] = 7


def test_cache_holds_the_most_recent_files_within_its_bytes(tmp_path, monkeypatch):
    """The cache is bounded by the bytes of its arrays, least recently used first out; a file
    rewritten since it was read is read again."""
    from simbridge.model import meshes

    paths = [tmp_path / f"m{i}.obj" for i in range(3)]
    for path in paths:
        path.write_text(OBJ, encoding="utf-8")
    meshes.clear_cache()
    first = read_mesh(paths[0])
    each = first.vertices.nbytes + first.faces.nbytes
    monkeypatch.setattr(meshes, "CACHE_BYTES", 2 * each)  # room for two of them
    second = read_mesh(paths[1])
    assert read_mesh(paths[0]) is first  # paths[0] now the most recent
    read_mesh(paths[2])  # over the bound: paths[1], the least recent, goes
    assert read_mesh(paths[0]) is first
    assert read_mesh(paths[1]) is not second
    assert meshes._HELD[0] <= 2 * each
    paths[0].write_text(OBJ + "v 9 9 9\n", encoding="utf-8")
    assert len(read_mesh(paths[0]).vertices) == len(first.vertices) + 1
    meshes.clear_cache()


def test_shipped_obj():
    mesh = read_mesh(DATA / "cube.obj")
    assert mesh.vertices.shape == (8, 3) and mesh.faces.shape == (12, 3)
    assert sorted(map(tuple, mesh.vertices * 2)) == sorted(
        (x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)
    )
    # every face is a triangle of the cube's surface: its corners share one coordinate
    for face in mesh.vertices[mesh.faces]:
        assert any(len(set(face[:, axis])) == 1 for axis in range(3))


def _triangles() -> np.ndarray:
    return np.array(
        [[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 0, 0], [0, 1, 0], [0, 0, 0.5]]], dtype=np.float32
    )


def test_binary_and_ascii_stl_read_alike(tmp_path):
    tri = _triangles()
    binary = tmp_path / "b.stl"
    body = b"".join(struct.pack("<3f", 0, 0, 1) + t.tobytes() + b"\0\0" for t in tri)
    binary.write_bytes(b"\0" * 80 + struct.pack("<I", len(tri)) + body)
    ascii_ = tmp_path / "a.STL"
    lines = ["solid probe"]
    for t in tri:
        lines += ["facet normal 0 0 1", "outer loop"]
        lines += [f"vertex {x} {y} {z}" for x, y, z in t]
        lines += ["endloop", "endfacet"]
    ascii_.write_text("\n".join([*lines, "endsolid probe"]), encoding="utf-8")
    for path in (binary, ascii_):
        mesh = read_mesh(path)
        assert mesh.vertices.tolist() == tri.reshape(-1, 3).astype(float).tolist()
        assert mesh.faces.tolist() == [[0, 1, 2], [3, 4, 5]]


def test_shipped_stl_agrees_with_trimesh():
    import trimesh

    path = DATA / "laikago" / "hip_motor.stl"
    mesh = read_mesh(path)
    ref = trimesh.load(str(path), force="mesh", process=False)
    assert np.array_equal(mesh.vertices[mesh.faces], np.asarray(ref.vertices)[ref.faces])


def test_collada_through_trimesh():
    mesh = read_mesh(DATA / "racecar" / "meshes" / "cone.dae")
    assert mesh.vertices.ndim == 2 and mesh.vertices.shape[1] == 3 and len(mesh.vertices) > 3
    assert mesh.faces.shape[1] == 3 and len(mesh.faces) > 0
    assert mesh.faces.min() >= 0 and mesh.faces.max() < len(mesh.vertices)


def test_a_missing_file_is_an_os_error(tmp_path):
    with pytest.raises(OSError):
        read_mesh(tmp_path / "missing.obj")


def test_a_collada_index_past_its_vertices_is_named(tmp_path):
    """A <triangles> <p> indexing vertex 7 of 3: trimesh drops the mesh quietly (simbridge
    said 'holds no geometry (no vertices)') and raw PyBullet 3.2.7 crashes on it (SIGSEGV,
    measured); the reader names the index and the vertex count."""
    path = tmp_path / "past.dae"
    path.write_text(
        '<?xml version="1.0"?><COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" '
        'version="1.4.1"><library_geometries><geometry id="g"><mesh><source id="p">'
        '<float_array id="pa" count="9">0 0 0 1 0 0 0 1 0</float_array><technique_common>'
        '<accessor source="#pa" count="3" stride="3"><param name="X" type="float"/>'
        '<param name="Y" type="float"/><param name="Z" type="float"/></accessor>'
        '</technique_common></source><vertices id="v"><input semantic="POSITION" source="#p"/>'
        '</vertices><triangles count="2"><input semantic="VERTEX" source="#v" offset="0"/>'
        "<p>0 1 2 0 7 99</p></triangles></mesh></geometry></library_geometries></COLLADA>"
    )
    with pytest.raises(MeshReadError, match=r"<triangles> indexes vertex 7 \(of 2 indices out "
                       r"of range\); its <vertices> 'v' hold 3"):  # fmt: skip
        read_mesh(path)


def test_a_collada_material_with_a_missing_texture_keeps_its_geometry(tmp_path):
    """A material whose sampler names a surface the file lacks (example-robot-data's
    anymal_foot.dae): trimesh alone returns an empty scene (pycollada drops the effect, then
    the meshes that use it); PyBullet reads the geometry, and so does read_mesh."""
    import trimesh

    text = (DATA / "racecar" / "meshes" / "cone.dae").read_text()
    broken = text.replace(
        "<profile_COMMON>",
        '<profile_COMMON><newparam sid="s"><sampler2D><source>no-such-surface</source>'
        "</sampler2D></newparam>",
        1,
    )
    assert broken != text
    path = tmp_path / "broken_texture.dae"
    path.write_text(broken)
    assert len(trimesh.load(path, force="mesh", process=False).vertices) == 0
    mesh, whole = read_mesh(path), read_mesh(DATA / "racecar" / "meshes" / "cone.dae")
    assert np.array_equal(mesh.vertices, whole.vertices)
    assert np.array_equal(mesh.faces, whole.faces)
