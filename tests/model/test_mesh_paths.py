"""Mesh filenames are found where PyBullet finds them (bullet3 ``UrdfFindMeshFile.h``): the
name as written from the working directory, the URDF's path's folders, then ``./``, ``../``
and ``../../``; ``package://NAME/`` and ``model://`` dropped, ``NAME`` kept.

Every case is a real tree of files in a temporary folder, loaded from a chosen working
directory by raw PyBullet (in a child process: PyBullet caches files by name for the process)
and by both backends; a mesh that is not found raises MeshNotFoundError listing every path
tried."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pybullet_data
import pytest

import simbridge
from simbridge import exceptions as exc

BACKENDS = ("pybullet", "mujoco")
PKG = "package://mypkg/meshes/m.obj"

RAW = """
import os, sys
import pybullet as p
os.chdir(sys.argv[2])
c = p.connect(p.DIRECT)
if sys.argv[3]:
    p.setAdditionalSearchPath(sys.argv[3], physicsClientId=c)
try:
    body = p.loadURDF(sys.argv[1], physicsClientId=c)
    shape = p.getCollisionShapeData(body, -1, physicsClientId=c)[0]
    print("\\nRAW", os.path.realpath(shape[4].decode()))
except p.error:
    print("\\nRAW refused")
"""


def raw_load(urdf: str, cwd: Path, search_path: Path | None = None) -> str | None:
    """The mesh file raw PyBullet reads for the URDF's collision (its real path), or None
    where it refuses the file."""
    args = [sys.executable, "-c", RAW, urdf, str(cwd), str(search_path or "")]
    out = subprocess.run(args, capture_output=True, text=True, timeout=120, check=True).stdout
    verdict = [line for line in out.splitlines() if line.startswith("RAW ")][-1][4:]
    return None if verdict == "refused" else verdict


@pytest.fixture()
def tree(tmp_path: Path) -> Path:
    """``a/b/share/mypkg/meshes/m.obj`` (the package) and empty ``a/b/out/deep``, under a
    real-path temporary folder."""
    root = tmp_path.resolve() / "a" / "b"
    (root / "share" / "mypkg" / "meshes").mkdir(parents=True)
    (root / "out" / "deep").mkdir(parents=True)
    shutil.copy(Path(pybullet_data.getDataPath()) / "cube.obj", root / "share/mypkg/meshes/m.obj")
    return root


def write(root: Path, where: str, filename: str) -> Path:
    path = root / where
    path.write_text(
        '<robot name="r"><link name="l"><inertial><mass value="1"/>'
        '<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>'
        f'<collision><geometry><mesh filename="{filename}"/></geometry></collision>'
        "</link></robot>"
    )
    return path


def layer_load(backend: str, urdf: str) -> str:
    """The mesh file the backend's model holds for the collision (its real path)."""
    from simbridge.model.urdf import parse_urdf, resolve_source

    model = parse_urdf(resolve_source(urdf))
    with simbridge.Sim(backend) as sim:
        sim.load_urdf(urdf)
    return str(model.base.collisions[0].mesh_path)


# (what, where the URDF is, its mesh filename, the path given to loadURDF, the working
# directory), paths relative to a/b; every case measured on raw PyBullet 3.2.7 (loads: True)
CASES = [
    (
        "package, copied URDF, run from the package's parent",
        "out/r.urdf",
        PKG,
        "ABS",
        "share",
        True,
    ),
    (
        "package, run from the package's meshes (../../)",
        "out/r.urdf",
        PKG,
        "ABS",
        "share/mypkg/meshes",
        True,
    ),
    ("package, run from inside the package (../)", "out/r.urdf", PKG, "ABS", "share/mypkg", True),
    ("package, URDF beside the package", "share/r.urdf", PKG, "ABS", "/", True),
    ("package, URDF inside its package", "share/mypkg/r.urdf", PKG, "ABS", "/", True),
    (
        "package://meshes/ (no package name)",
        "share/mypkg/r.urdf",
        "package://meshes/m.obj",
        "ABS",
        "/",
        True,
    ),
    ("model://", "share/r.urdf", "model://mypkg/meshes/m.obj", "ABS", "/", True),
    ("file:// relative", "share/mypkg/r.urdf", "file://meshes/m.obj", "ABS", "/", True),
    (
        "a name from the root, found beside the file",
        "share/mypkg/r.urdf",
        "/meshes/m.obj",
        "ABS",
        "/",
        True,
    ),
    (
        "relative, from the working directory",
        "out/r.urdf",
        "meshes/m.obj",
        "ABS",
        "share/mypkg",
        True,
    ),
    (
        "relative, from a folder above the URDF",
        "out/deep/r.urdf",
        "b/share/mypkg/meshes/m.obj",
        "ABS",
        "/",
        True,
    ),
    (
        "relative URDF path: ../../ of the working directory",
        "out/deep/r.urdf",
        "b/share/mypkg/meshes/m.obj",
        "deep/r.urdf",
        "out",
        True,
    ),
    ("package, copied URDF, run from elsewhere", "out/r.urdf", PKG, "ABS", ".", False),
    ("relative, nowhere PyBullet looks", "out/r.urdf", "meshes/m.obj", "ABS", "/", False),
    (
        "relative URDF path: folders above it not written",
        "out/deep/r.urdf",
        "b/share/mypkg/meshes/m.obj",
        "r.urdf",
        "out/deep",
        False,
    ),
]


@pytest.mark.parametrize(
    ("where", "filename", "given", "cwd", "loads"),
    [case[1:] for case in CASES],
    ids=[case[0] for case in CASES],
)
def test_mesh_found_where_raw_pybullet_finds_it(
    tree, monkeypatch, where, filename, given, cwd, loads
):
    path = write(tree, where, filename)
    urdf = str(path) if given == "ABS" else given
    folder = tree / cwd if cwd != "/" else Path("/")
    expected = raw_load(urdf, folder)
    assert (expected is not None) == loads  # the case is what it says
    monkeypatch.chdir(folder)
    for backend in BACKENDS:
        if expected is None:
            with pytest.raises(exc.MeshNotFoundError):
                layer_load(backend, urdf)
        else:
            assert layer_load(backend, urdf) == expected


def test_additional_search_path_finds_the_urdf_not_its_meshes(tree, monkeypatch):
    """PyBullet's additional search path is searched for the URDF, not for its meshes; a URDF
    found on it gives its own folders (simbridge's search path: SIMBRIDGE_URDF_PATH)."""
    write(tree, "out/r.urdf", PKG)
    # the URDF by absolute path, its package's parent on the search path: refused
    assert raw_load(str(tree / "out/r.urdf"), tree, search_path=tree / "share") is None
    # the URDF by name on the search path, run from the package's parent: loads
    found = raw_load("r.urdf", tree / "share", search_path=tree / "out")
    assert found == str(tree / "share/mypkg/meshes/m.obj")
    monkeypatch.setenv("SIMBRIDGE_URDF_PATH", str(tree / "out"))
    monkeypatch.chdir(tree / "share")
    for backend in BACKENDS:
        assert layer_load(backend, "r.urdf") == found
    monkeypatch.chdir(tree)
    for backend in BACKENDS:
        with pytest.raises(exc.MeshNotFoundError):
            layer_load(backend, "r.urdf")


def test_missing_mesh_lists_every_path_tried_in_pybullets_order(tree, monkeypatch):
    path = write(tree, "out/deep/r.urdf", "package://mypkg/meshes/gone.obj")
    monkeypatch.chdir(tree / "share")
    here = tree / "share"
    expected = [
        here / "mypkg/meshes/gone.obj",
        *(Path(str(folder) + "/mypkg/meshes/gone.obj") for folder in path.parents),
        here / "./mypkg/meshes/gone.obj",
        here / "../mypkg/meshes/gone.obj",
        here / "../../mypkg/meshes/gone.obj",
    ]
    expected = [Path(os.fspath(p).replace("//", "/")) for p in expected]
    for backend in BACKENDS:
        with pytest.raises(exc.MeshNotFoundError) as info, simbridge.Sim(backend) as sim:
            sim.load_urdf(str(path))
        tried = [Path(t.replace("//", "/")) for t in info.value.tried]
        assert tried == expected
        message = str(info.value)
        assert f"tried {len(expected)} paths" in message
        for t in info.value.tried:
            assert repr(t) in message


@pytest.mark.parametrize("backend", BACKENDS)
def test_one_relative_name_two_files_in_one_sim(tmp_path, monkeypatch, backend):
    """PyBullet is given the URDF's path as written and caches files by name: the same
    relative name read from another working directory is the other file."""
    link = '<link name="{n}"/>'
    joint = '<joint name="j{n}" type="fixed"><parent link="a"/><child link="{n}"/></joint>'
    for folder, children in (("one", "b"), ("two", "bc")):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "r.urdf").write_text(
            '<robot name="r"><link name="a"/>'
            + "".join(link.format(n=c) + joint.format(n=c) for c in children)
            + "</robot>"
        )
    with simbridge.Sim(backend) as sim:
        monkeypatch.chdir(tmp_path / "one")
        first = sim.load_urdf("r.urdf")
        monkeypatch.chdir(tmp_path / "two")
        second = sim.load_urdf("r.urdf")
        assert (sim.num_joints(first), sim.num_joints(second)) == (1, 2)
