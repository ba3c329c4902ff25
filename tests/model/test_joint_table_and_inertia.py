"""simbridge.model.joint_table and simbridge.model.inertia: PyBullet's joint table and link
inertia computed from a UrdfModel, checked against PyBullet itself (these tests import pybullet on
purpose)."""

from __future__ import annotations

import math
import os
import tempfile

import numpy as np
import pybullet as p
import pybullet_data
import pytest

from simbridge.model.inertia import is_fixed_base, model_inertials
from simbridge.model.joint_table import joint_table
from simbridge.model.urdf import parse_urdf, resolve_source

DATA = pybullet_data.getDataPath()


@pytest.fixture(scope="module")
def client():
    c = p.connect(p.DIRECT)
    yield c
    p.disconnect(c)


def _pybullet(client: int, text: str, fixed: bool, flags: int):
    fd, path = tempfile.mkstemp(prefix="simbridge_test_", suffix=".urdf")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
        body = p.loadURDF(path, useFixedBase=fixed, flags=flags, physicsClientId=client)
    finally:
        os.unlink(path)
    joints = [
        p.getJointInfo(body, i, physicsClientId=client)
        for i in range(p.getNumJoints(body, physicsClientId=client))
    ]
    dyn = [p.getDynamicsInfo(body, i, physicsClientId=client) for i in range(-1, len(joints))]
    p.removeBody(body, physicsClientId=client)
    return joints, dyn


def _ours(text: str, fixed: bool, source: str):
    model = parse_urdf(resolve_source(text))
    inertials = model_inertials(model, fixed, source)
    return joint_table(model, fixed, inertials), inertials


def _same_quat(a, b, tol=1e-9) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return bool(np.abs(a - b).max() < tol or np.abs(a + b).max() < tol)


def _assert_matches(client, text, fixed, source):
    flags = p.URDF_USE_INERTIA_FROM_FILE if source == "file" else 0
    joints, dyn = _pybullet(client, text, fixed, flags)
    table, inertials = _ours(text, fixed, source)
    assert len(table) == len(joints)
    for ref, row in zip(joints, table, strict=True):
        assert row[:3] == (ref[0], ref[1].decode(), ref[2])
        assert row[3:13] == (*ref[3:12], ref[12].decode())  # indices, flags, dynamics, limits
        assert row.axis == pytest.approx(ref[13], abs=1e-12)
        assert row.parent_frame_position == pytest.approx(ref[14], abs=1e-12)
        # with its sign: Bullet's getRotation picks it (joint_table._rot_parent_to_this)
        assert row.parent_frame_orientation == pytest.approx(ref[15], abs=1e-12)
        assert row.parent_index == ref[16]
    for ref, ine in zip(dyn, inertials, strict=True):
        assert ine.mass == ref[0]
        assert ine.diagonal == pytest.approx(ref[2], rel=1e-6, abs=1e-15)
        assert ine.position == pytest.approx(ref[3], abs=1e-12)
        assert _same_quat(ine.orientation, ref[4])


# Rotated inertial frames, rotated joint frames, an unnormalised axis, every shape, no <inertial>.
PROBE = """<robot name="probe">
  <link name="base">
    <inertial><origin xyz="0.1 0.2 0.3" rpy="0.3 0.2 0.1"/><mass value="2"/>
      <inertia ixx="1" ixy="0" ixz="0" iyy="2" iyz="0" izz="3"/></inertial>
    <collision><origin xyz="0.05 0 0" rpy="0 0.5 0"/><geometry><box size="0.4 0.2 0.1"/>
      </geometry></collision>
  </link>
  <link name="l1">
    <inertial><origin xyz="0 0 0.5" rpy="0.4 0 0"/><mass value="1.5"/>
      <inertia ixx="0.1" ixy="0.01" ixz="0.02" iyy="0.2" iyz="0.03" izz="0.3"/></inertial>
    <collision><origin xyz="0 0 0.5"/><geometry><cylinder radius="0.05" length="1"/></geometry>
      </collision>
  </link>
  <link name="l2">
    <inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.2" iyz="0" izz="0.3"/>
      </inertial>
    <collision><geometry><sphere radius="0.1"/></geometry></collision>
  </link>
  <link name="l3"><collision><geometry><capsule radius="0.1" length="0.3"/></geometry>
    </collision></link>
  <link name="l4"><inertial><mass value="0.7"/>
    <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.2" iyz="0" izz="0.3"/></inertial></link>
  <link name="l5">
    <inertial><origin xyz="0.01 0 0"/><mass value="0.3"/>
      <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
    <contact><inertia_scaling value="3.0"/></contact>
    <collision><geometry><mesh filename="DATA/cube.obj" scale="0.1 0.2 0.3"/></geometry>
      </collision>
    <collision><origin xyz="0 0 0.2" rpy="0.3 0 0"/><geometry><sphere radius="0.05"/>
      </geometry></collision>
  </link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0.2 0.1 0.4" rpy="0.1 0.7 -0.3"/><axis xyz="0 2 1"/>
    <limit lower="-1" upper="1.5" effort="10" velocity="3"/>
      <dynamics damping="0.3" friction="0.2"/></joint>
  <joint name="j2" type="continuous"><parent link="l1"/><child link="l2"/>
    <origin xyz="0 0 1" rpy="0 0 0.2"/><axis xyz="1 0 0"/></joint>
  <joint name="j3" type="prismatic"><parent link="l1"/><child link="l3"/>
    <origin xyz="0 0.3 1"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="0.5" effort="5" velocity="1"/></joint>
  <joint name="j4" type="fixed"><parent link="base"/><child link="l4"/>
    <origin xyz="0 -0.3 0" rpy="0.5 0 0"/></joint>
  <joint name="j5" type="revolute"><parent link="l4"/><child link="l5"/><origin xyz="0 0 0.1"/>
    <axis xyz="0 0 1"/>
    <limit lower="1" upper="-1" effort="5" velocity="1"/></joint>
</robot>""".replace("DATA", DATA)


@pytest.mark.parametrize("source", ["collision_aabb", "file"])
@pytest.mark.parametrize("fixed", [False, True])
def test_probe_table_and_inertia_match_pybullet(client, source, fixed):
    _assert_matches(client, PROBE, fixed, source)


@pytest.mark.parametrize(
    "shape, origin",
    [
        ('<box size="0.4 0.2 0.1"/>', ""),
        ('<box size="0.4 0.2 0.1"/>', '<origin xyz="0.1 0 0"/>'),
        ('<cylinder radius="0.1" length="0.5"/>', ""),
        ('<cylinder radius="0.1" length="0.5"/>', '<origin xyz="0 0 0" rpy="0.2 0 0"/>'),
        ('<sphere radius="0.1"/>', ""),
        ('<sphere radius="0.1"/>', '<origin xyz="0.1 0 0"/>'),
        ('<capsule radius="0.1" length="0.3"/>', ""),
        ('<capsule radius="0.1" length="0.3"/>', '<origin xyz="0.1 0 0"/>'),
        (f'<mesh filename="{DATA}/cube.obj"/>', ""),
        (f'<mesh filename="{DATA}/cube.obj"/>', '<origin xyz="0.1 0 0"/>'),
        (f'<mesh filename="{DATA}/duck_vhacd.obj" scale="0.05 0.05 0.05"/>', ""),
        ("", ""),
    ],
)
def test_collision_aabb_inertia_rules(client, shape, origin):
    """The measured rules of the module docstring, one shape at a time (mass 2)."""
    collision = f"<collision>{origin}<geometry>{shape}</geometry></collision>" if shape else ""
    text = (
        '<robot name="one"><link name="a"><inertial><mass value="2"/>'
        '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>'
        f"{collision}</link></robot>"
    )
    _assert_matches(client, text, False, "collision_aabb")


def test_world_link_without_inertial_has_mass_zero_and_fixes_the_base():
    text = (
        '<robot name="w"><link name="world"/><link name="a"><inertial><mass value="1"/>'
        '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>'
        '<joint name="j" type="revolute"><parent link="world"/><child link="a"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>'
    )
    model = parse_urdf(resolve_source(text))
    assert is_fixed_base(model, False)
    assert model_inertials(model, False, "collision_aabb")[0].mass == 0.0


def test_r2d2_and_a_sample_of_pybullet_data_match(client):
    names = [
        "r2d2.urdf",
        "kuka_iiwa/model.urdf",
        "franka_panda/panda.urdf",
        "laikago/laikago.urdf",
        "cube_small.urdf",
        "duck_vhacd.urdf",
        "quadruped/minitaur.urdf",
    ]
    for name in names:
        with open(os.path.join(DATA, name)) as f:
            text = f.read()
        model = parse_urdf(resolve_source(os.path.join(DATA, name)))
        flags = 0
        body = p.loadURDF(os.path.join(DATA, name), flags=flags, physicsClientId=client)
        try:
            inertials = model_inertials(model, False, "collision_aabb")
            table = joint_table(model, False, inertials)
            for i, row in enumerate(table):
                ref = p.getJointInfo(body, i, physicsClientId=client)
                assert row.parent_frame_position == pytest.approx(ref[14], abs=1e-9), name
                assert row.parent_frame_orientation == pytest.approx(ref[15], abs=1e-9), name
                assert row.axis == pytest.approx(ref[13], abs=1e-9), name
            for link in range(-1, len(table)):
                ref = p.getDynamicsInfo(body, link, physicsClientId=client)
                # meshes too: the hull's points are snapped to Bullet's grid as PyBullet does
                # (it was 1.7e-4 smaller before inertia.py reproduced that)
                assert inertials[link + 1].diagonal == pytest.approx(ref[2], rel=1e-7, abs=1e-15), (
                    name
                )
        finally:
            p.removeBody(body, physicsClientId=client)
        del text


def test_bad_file_inertia_becomes_zero_as_in_pybullet():
    text = (
        '<robot name="b"><link name="a"><inertial><mass value="1"/>'
        '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="5"/></inertial></link></robot>'
    )
    model = parse_urdf(resolve_source(text))
    assert model_inertials(model, False, "file")[0].diagonal == (0.0, 0.0, 0.0)
    assert math.isclose(
        model_inertials(model, False, "collision_aabb")[0].diagonal[0], 2 * 0.002**2 / 12
    )


BAD_TENSORS = {
    # izz > ixx + iyy: the triangle inequality broken
    "triangle": ('ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="1"', "triangle inequality"),
    # positive diagonal, principal moments -0.99, 1.01, 0.01
    "not-positive": ('ixx="0.01" ixy="1" ixz="0" iyy="0.01" iyz="0" izz="0.01"', "negative"),
}


@pytest.mark.parametrize("backend", ["pybullet", "mujoco"])
@pytest.mark.parametrize("case", sorted(BAD_TENSORS))
def test_bad_file_inertia_is_zero_with_one_warning_on_both_backends(
    client, backend, case, tmp_path, caplog
):
    """Raw PyBullet with URDF_USE_INERTIA_FROM_FILE zeroes both tensors ("Bad inertia tensor
    properties, setting inertia to zero for link: b", measured); both backends simulate the
    same zero inertia and simbridge says so in one warning naming the file, line, link and
    why (MuJoCo zeroed it silently)."""
    import logging

    import simbridge

    tensor, why = BAD_TENSORS[case]
    text = (
        '<robot name="r">\n<link name="a"/>\n<link name="b"><inertial><mass value="1"/>\n'
        f"<inertia {tensor}/></inertial>"
        '<collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>\n'
        '<joint name="j" type="revolute"><parent link="a"/><child link="b"/>'
        '<axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="10" velocity="5"/></joint>\n'
        "</robot>\n"
    )
    path = tmp_path / "bad_inertia.urdf"
    path.write_text(text)
    _, dyn = _pybullet(client, text, False, p.URDF_USE_INERTIA_FROM_FILE)
    assert dyn[1][2] == (0.0, 0.0, 0.0)  # PyBullet's own reading
    caplog.set_level(logging.WARNING, logger="simbridge")
    with simbridge.Sim(backend, profile="urdf") as sim:
        body = sim.load_urdf(path)
        assert sim.dynamics_info(body, 0).local_inertia_diagonal == (0.0, 0.0, 0.0)
    ours = [r.getMessage() for r in caplog.records if r.name == "simbridge.model.urdf"]
    # link a has no <inertial>: that is said too (PyBullet: "No inertial data for link")
    assert "link 'a' has no <inertial>" in ours.pop(0)
    assert len(ours) == 1, ours
    assert ours[0].startswith(f"{path}:4: link 'b' <inertia>: principal moments (")
    assert why in ours[0] and "simulated with zero inertia, as PyBullet does" in ours[0]
    # PyBullet's own line says the same without file or line: at DEBUG, not a second warning
    assert not [
        r
        for r in caplog.records
        if r.name == "simbridge.pybullet" and "Bad inertia tensor" in r.getMessage()
    ]
