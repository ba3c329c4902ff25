"""The visual shapes of MuJoCo's reading's build plans (``native_plans(..., visuals=True)``),
which PyBullet's and PhysX's windows draw under ``gui=True``: MuJoCo's visible geoms in
MuJoCo's colours, and none at all in a headless build."""

from __future__ import annotations

import numpy as np
import pytest

from simbridge.model.mjcf_native import compile_mjcf
from simbridge.model.mjcf_native_plan import (
    PLANE_THICKNESS,
    ground_plan,
    native_plans,
)
from simbridge.transforms import quat_rotate

# a floor of half size 3 x 2 m; a body with a coloured box, a visual-only sphere (contype and
# conaffinity 0), a geom in group 3 (hidden by MuJoCo's viewer) and a capsule whose material's
# colour is not its own
MODEL = """
<mujoco>
  <asset><material name="red" rgba="0.9 0.1 0.1 1"/></asset>
  <worldbody>
    <geom name="floor" type="plane" size="3 2 0.1" rgba="0.5 0.5 0.5 1"/>
    <body name="torso" pos="0 0 1">
      <freejoint/>
      <geom name="box" type="box" size="0.1 0.2 0.3" rgba="0.2 0.4 0.6 1"/>
      <geom name="marker" type="sphere" size="0.05" pos="0 0 0.4" contype="0" conaffinity="0"
            rgba="0 1 0 1"/>
      <geom name="hidden" type="sphere" size="0.05" pos="0.3 0 0" group="3"/>
      <body name="arm" pos="0.2 0 0">
        <joint name="hinge" type="hinge" axis="0 1 0"/>
        <geom name="arm" type="capsule" fromto="0 0 0 0.4 0 0" size="0.04" material="red"
              rgba="0 0 1 1"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture(scope="module")
def native():
    return compile_mjcf(MODEL)


def test_a_headless_build_has_no_visual_shapes(native):
    """visuals=False (every headless Sim): the plans are what they were, no shape drawn."""
    (plan,) = native_plans(native)
    ground = ground_plan(native)
    assert ground is not None
    assert all(not link.visuals for link in (*plan.links, *ground.links))


def test_the_visible_geoms_are_drawn_in_mujocos_colours(native):
    """Each link draws its bodies' geoms of groups 0-2, visual-only ones included, in the
    material's colour where the geom has one; the group-3 geom is not drawn."""
    (plan,) = native_plans(native, visuals=True)
    base, arm = plan.links
    assert [s.name for s in base.visuals] == ["box", "marker"]
    assert [s.name for s in base.collisions] == ["box", "hidden"]  # the marker never collides
    assert base.visuals[0].rgba == pytest.approx((0.2, 0.4, 0.6, 1.0))
    assert base.visuals[1].rgba == pytest.approx((0.0, 1.0, 0.0, 1.0))
    assert base.visuals[1].kind == "sphere"
    assert base.visuals[1].position == pytest.approx((0.0, 0.0, 0.4))  # in the link frame
    assert [s.name for s in arm.visuals] == ["arm"]
    assert arm.visuals[0].rgba == pytest.approx((0.9, 0.1, 0.1, 1.0))  # the material's
    # a visual shape is its collision shape's twin where the geom collides
    for drawn, hit in ((base.visuals[0], base.collisions[0]), (arm.visuals[0], arm.collisions[0])):
        assert (drawn.kind, drawn.size) == (hit.kind, hit.size)
        assert np.allclose(drawn.position, hit.position) and drawn.ground is None


def test_the_floor_is_drawn_as_a_thin_box_under_the_plane(native):
    """The world's plane, size 3 x 2: a box 6 x 4 m and PLANE_THICKNESS thick, its top face on
    the plane (a plane has no drawn shape on either engine)."""
    ground = ground_plan(native, visuals=True)
    assert ground is not None
    (floor,) = ground.links[0].visuals
    assert floor.kind == "box"
    assert floor.size == pytest.approx((6.0, 4.0, PLANE_THICKNESS))
    top = np.add(floor.position, quat_rotate(floor.orientation, (0, 0, PLANE_THICKNESS / 2)))
    assert top == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)
    assert floor.rgba == pytest.approx((0.5, 0.5, 0.5, 1.0))
