"""simbridge.model.meshes caches a mesh per file version: a file rewritten while the process runs is
read again (the cache is keyed on path, modification time and size), an unchanged one is not;
the MuJoCo world's mesh assets likewise."""

from __future__ import annotations

import os

import simbridge
from simbridge.backends.mujoco.inspect import model_and_data
from simbridge.model.meshes import read_mesh

TRIANGLE = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"


def test_a_rewritten_mesh_is_read_again(tmp_path):
    path = tmp_path / "m.obj"
    path.write_text(TRIANGLE)
    first = read_mesh(path)
    assert read_mesh(path) is first  # unchanged: the cached arrays
    path.write_text(TRIANGLE.replace("v 1 0 0", "v 2 0 0"))  # same size, a new mtime
    stat = os.stat(path)
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000))
    assert read_mesh(path).vertices[1, 0] == 2.0
    path.write_text(TRIANGLE.replace("v 1 0 0", "v 30 0 0"))  # a new size
    assert read_mesh(path).vertices[1, 0] == 30.0


def test_a_robot_loaded_after_its_mesh_changed_gets_the_new_inertia(tmp_path):
    mesh = tmp_path / "m.obj"
    mesh.write_text(TRIANGLE + "v 0 0 1\nf 1 2 4\nf 1 3 4\nf 2 3 4\n")
    urdf = tmp_path / "r.urdf"
    urdf.write_text(
        '<robot name="r"><link name="a"><inertial><mass value="1"/><inertia ixx="1" iyy="1" '
        'izz="1" ixy="0" ixz="0" iyz="0"/></inertial><collision><geometry>'
        '<mesh filename="m.obj"/></geometry></collision></link></robot>'
    )
    with simbridge.Sim("mujoco") as sim:
        small = sim.dynamics_info(sim.load_urdf(urdf)).local_inertia_diagonal
        mesh.write_text(mesh.read_text().replace("v 0 0 1", "v 0 0 3"))
        tall = sim.dynamics_info(sim.load_urdf(urdf)).local_inertia_diagonal
        m, _ = model_and_data(sim)
        assert m.nmesh == 2  # the rewritten file is a new collision mesh, not the first one
    assert tall[0] > small[0]
