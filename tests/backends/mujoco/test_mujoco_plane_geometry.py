"""Bullet's ``<plane normal>`` geometry: PyBullet moves a plane with its link; MuJoCo takes a plane
only on a body welded to the world, so the MuJoCo backend refuses a moving one, naming the line.
The collision-box inertia of a plane alone is zero, as PyBullet's (btStaticPlaneShape)."""

from __future__ import annotations

import pybullet as p
import pytest

import simbridge
from simbridge import exceptions as exc
from simbridge.model.inertia import model_inertials
from simbridge.model.urdf import parse_urdf, resolve_source

PLANE_LINK = (
    '<robot name="p">\n<link name="a"><inertial><mass value="1"/><inertia ixx="1" iyy="1" '
    'izz="1" ixy="0" ixz="0" iyz="0"/></inertial>\n'
    '<collision><geometry><plane normal="0 0 1"/></geometry></collision></link></robot>'
)


def test_a_moving_plane_is_refused_on_mujoco_and_loads_on_pybullet():
    with simbridge.Sim("mujoco") as sim:
        with pytest.raises(
            exc.UrdfStructureError,
            match=r"<urdf text>:3: link 'a' <collision> #0 <plane>: MuJoCo takes a plane only on "
            r"a body welded to the world",
        ):
            sim.load_urdf(PLANE_LINK)
        assert sim.load_urdf(PLANE_LINK, fixed_base=True) >= 0
    with simbridge.Sim("pybullet") as sim:
        body = sim.load_urdf(PLANE_LINK)
        assert sim.dynamics_info(body).local_inertia_diagonal == (0.0, 0.0, 0.0)


def test_a_plane_alone_has_pybullets_zero_inertia(tmp_path):
    path = tmp_path / "plane_link.urdf"
    path.write_text(PLANE_LINK)
    model = parse_urdf(resolve_source(str(path)))
    assert model_inertials(model, False, "collision_aabb")[0].diagonal == (0.0, 0.0, 0.0)
    c = p.connect(p.DIRECT)
    try:
        body = p.loadURDF(str(path), physicsClientId=c)
        assert p.getDynamicsInfo(body, -1, physicsClientId=c)[2] == (0.0, 0.0, 0.0)
    finally:
        p.disconnect(c)
