"""``Sim.load_urdf``'s loadURDF options on every backend, against raw PyBullet with the same
options: ``global_scaling``, ``merge_fixed_links``, ``inertia_source`` and ``self_collision``
(with PyBullet's parent-child filtering rule); each listed in the manifest."""

from __future__ import annotations

import logging
import math
import os

import _raw
import pytest
from _gaps import gap

from simbridge import exceptions as exc

FLAGS = {"collision_aabb": 0, "file": 2}  # p.URDF_USE_INERTIA_FROM_FILE
MERGE = 1 << 19  # p.URDF_MERGE_FIXED_LINKS
POSE = ((0.2, -0.1, 0.6), (0.0, 0.0, 0.2955202066613396, 0.955336489125606))  # yaw 0.6 rad


def _compare(sim, body, raw, rel=1e-7):
    assert _raw.table_difference(sim.joints(body), raw.table) is None
    assert (
        _raw.frames_difference(_raw.sim_frames(sim, body), raw.frames, _raw.frame_rel(sim.backend))
        is None
    )
    # moments: PyBullet's carry float32 rounding (measured worst 7.8e-8 relative)
    assert _raw.dynamics_difference(sim, body, raw.dynamics, rel) is None


@pytest.mark.parametrize(
    ("name", "scale", "fixed"),
    [
        ("kuka_iiwa/model.urdf", 1.7, True),  # .stl hulls, snapped by Bullet after scaling
        ("r2d2.urdf", 0.5, False),
        ("cartpole.urdf", 2.0, False),  # a prismatic joint: its limits scale
        ("quadruped/minitaur.urdf", 3.0, False),  # .obj meshes, cylinders
    ],
)
@pytest.mark.parametrize("source", ["collision_aabb", "file"])
def test_a_scaled_robot_has_pybullets_frames_and_masses(make_sim, name, scale, fixed, source):
    path = os.path.join(_raw.DATA, name)
    raw = _raw.raw_load(
        path,
        base_position=POSE[0],
        base_orientation=POSE[1],
        fixed_base=fixed,
        flags=FLAGS[source],
        global_scaling=scale,
    )
    sim = make_sim()
    body = sim.load_urdf(
        path,
        base_position=POSE[0],
        base_orientation=POSE[1],
        fixed_base=fixed,
        global_scaling=scale,
        inertia_source=source,
    )
    _compare(sim, body, raw)


def test_scaling_scales_lengths_not_masses(make_sim):
    sim = make_sim()
    one = sim.load_urdf("cartpole.urdf")
    two = sim.load_urdf("cartpole.urdf", global_scaling=2.0)
    assert sim.joint_info(two, 0).lower_limit == 2 * sim.joint_info(one, 0).lower_limit
    assert sim.joint_info(two, 1).parent_frame_position == pytest.approx(
        [2 * v for v in sim.joint_info(one, 1).parent_frame_position], abs=1e-15
    )
    assert [sim.dynamics_info(two, i).mass for i in (-1, 0, 1)] == [
        sim.dynamics_info(one, i).mass for i in (-1, 0, 1)
    ]


@pytest.mark.parametrize(
    ("name", "fixed"),
    [
        ("r2d2.urdf", False),  # 15 joints, 8 of them fixed: 6 left
        ("r2d2.urdf", True),  # a welded root keeps its mass; its inertial frame is reset
        ("kuka_iiwa/model.urdf", True),
        ("quadruped/minitaur.urdf", False),
        ("husky/husky.urdf", False),  # merges into links without <inertial>
    ],
)
@pytest.mark.parametrize("source", ["collision_aabb", "file"])
def test_merged_fixed_links_give_pybullets_joint_table(make_sim, name, fixed, source, caplog):
    caplog.set_level(logging.ERROR, logger="simbridge")
    path = os.path.join(_raw.DATA, name)
    raw = _raw.raw_load(
        path,
        base_position=POSE[0],
        base_orientation=POSE[1],
        fixed_base=fixed,
        flags=FLAGS[source] | MERGE,
    )
    sim = make_sim()
    body = sim.load_urdf(
        path,
        base_position=POSE[0],
        base_orientation=POSE[1],
        fixed_base=fixed,
        merge_fixed_links=True,
        inertia_source=source,
    )
    _compare(sim, body, raw)


def test_merging_r2d2_keeps_its_eight_moving_joints_in_pybullets_order(make_sim, capfd):
    """Bullet removes a merged child by swapping the last child into its place, so the head,
    last of the base's children, comes first (the same as raw PyBullet, checked above). The
    merge's printout goes to the log, not to stdout."""
    sim = make_sim()
    capfd.readouterr()
    body = sim.load_urdf("r2d2.urdf", merge_fixed_links=True)
    assert capfd.readouterr() == ("", "")
    assert [(j.name, j.parent_index) for j in sim.joints(body)] == [
        ("head_swivel", -1),
        ("right_back_wheel_joint", -1),
        ("gripper_extension", -1),
        ("left_gripper_joint", 2),
        ("right_gripper_joint", 2),
        ("right_front_wheel_joint", -1),
        ("left_front_wheel_joint", -1),
        ("left_back_wheel_joint", -1),
    ]
    whole = sim.load_urdf("r2d2.urdf")
    total = sum(sim.dynamics_info(whole, i).mass for i in range(-1, sim.num_joints(whole)))
    merged = sum(sim.dynamics_info(body, i).mass for i in range(-1, sim.num_joints(body)))
    assert merged == pytest.approx(total, rel=1e-12)


def test_inertia_source_per_body_overrides_the_profile(make_sim):
    path = os.path.join(_raw.DATA, "r2d2.urdf")
    for profile, source in (("pybullet", "file"), ("urdf", "collision_aabb")):
        raw = _raw.raw_load(path, flags=FLAGS[source])
        sim = make_sim(profile=profile)
        body = sim.load_urdf(path, inertia_source=source)
        assert _raw.dynamics_difference(sim, body, raw.dynamics, 1e-7) is None
        default = sim.load_urdf(path)
        assert sim.dynamics_info(default, 0) != sim.dynamics_info(body, 0)


# A fixed base and three boxes on revolute joints, all overlapping at spawn: base -> a -> c,
# base -> b. Link pairs: (-1, a) (-1, b) (a, c) parent-child; (-1, c) grandparent; (a, b) and
# (b, c) unrelated.
_BOX = (
    '<inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/>'
    '</inertial><collision><geometry><box size="{s} {s} {s}"/></geometry></collision>'
)
TREE = (
    '<robot name="tree">'
    + "".join(
        f'<link name="{n}">{_BOX.format(s=s)}</link>'
        for n, s in (("base", 0.4), ("a", 0.3), ("b", 0.25), ("c", 0.2))
    )
    + "".join(
        f'<joint name="{c}_joint" type="revolute"><parent link="{p}"/><child link="{c}"/>'
        f'<origin xyz="{x} 0 0"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        for p, c, x in (("base", "a", 0.02), ("base", "b", -0.03), ("a", "c", 0.01))
    )
    + "</robot>"
)
A, B, C = 0, 2, 1  # PyBullet's link indices: depth first, a then its child c, then b
PAIRS = {
    "off": set(),
    "exclude_parent": {(-1, C), (A, B), (C, B)},
    "exclude_all_parents": {(A, B), (C, B)},
    "include_parent": {(-1, A), (-1, B), (-1, C), (A, C), (A, B), (C, B)},
}
SELF_FLAGS = {
    "off": 0,
    "exclude_parent": 8,
    "exclude_all_parents": 8 | 32,
    "include_parent": 8 | 8192,
}


def _pairs(points) -> set[tuple[int, int]]:
    return {(min(c.link_a, c.link_b), max(c.link_a, c.link_b)) for c in points}


@pytest.mark.parametrize("mode", sorted(PAIRS))
def test_self_collision_follows_pybullets_parent_rule(make_sim, mode):
    p, client = _raw.raw_client()
    raw = _raw.raw_load(TREE, fixed_base=True, flags=SELF_FLAGS[mode], keep=True)
    p.setGravity(0, 0, 0, physicsClientId=client)
    p.stepSimulation(physicsClientId=client)
    raw_pairs = _pairs(
        type("C", (), {"link_a": r[3], "link_b": r[4]})
        for r in p.getContactPoints(raw.body, raw.body, physicsClientId=client)
    )
    p.removeBody(raw.body, physicsClientId=client)
    expected = {(min(a, b), max(a, b)) for a, b in PAIRS[mode]}
    assert raw_pairs == expected
    sim = make_sim(gravity=(0, 0, 0))
    body = sim.load_urdf(TREE, fixed_base=True, self_collision=mode)
    sim.step()
    got = _pairs(sim.contact_points(body, body))
    missing = gap(sim.backend, "self_collision_pairs_missing") if mode == "include_parent" else None
    if missing is None:
        assert got == expected
    else:  # never a pair PyBullet does not make; as many missing as measured
        assert got < expected and len(expected - got) == missing


def test_self_collision_true_is_exclude_parent_and_none_is_the_profile(make_sim):
    sim = make_sim(gravity=(0, 0, 0))
    body = sim.load_urdf(TREE, fixed_base=True, self_collision=True)
    off = sim.load_urdf(TREE, fixed_base=True, base_position=(5, 0, 0))
    sim.step()
    assert _pairs(sim.contact_points(body, body)) == PAIRS["exclude_parent"]
    assert sim.contact_points(off, off) == ()
    assert sim.manifest()["bodies"][body]["self_collision"] == "exclude_parent"
    assert sim.manifest()["bodies"][off]["self_collision"] == "off"


def test_the_manifest_lists_each_bodys_load(make_sim):
    sim = make_sim()
    body = sim.load_urdf(
        "r2d2.urdf",
        base_position=(0, 0, 0.5),
        global_scaling=0.5,
        merge_fixed_links=True,
        inertia_source="file",
    )
    entry = sim.manifest()["bodies"][body]
    assert entry["source"].endswith("r2d2.urdf")
    assert entry["base_position"] == (0.0, 0.0, 0.5)
    assert entry["fixed_base"] is False
    assert (entry["global_scaling"], entry["merge_fixed_links"]) == (0.5, True)
    assert (entry["inertia_source"], entry["self_collision"]) == ("file", "off")
    sim.remove(body)
    assert body not in sim.manifest()["bodies"]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"global_scaling": 0}, r"'global_scaling': must be a finite number > 0, got 0"),
        ({"global_scaling": float("nan")}, r"'global_scaling': must be a finite number > 0"),
        ({"global_scaling": "2"}, r"'global_scaling': must be a finite number > 0, got '2'"),
        (
            {"self_collision": "yes"},
            r"'self_collision': must be True, False or one of \['off', 'exclude_parent', "
            r"'exclude_all_parents', 'include_parent'\], got 'yes'",
        ),
        (
            {"inertia_source": "mesh"},
            r"'inertia_source': must be one of \['collision_aabb', 'file'\], got 'mesh'",
        ),
        ({"merge_fixed_links": 1}, r"'merge_fixed_links': must be True or False, got 1"),
    ],
)
def test_bad_options_name_the_argument_and_the_choices(make_sim, kwargs, message):
    sim = make_sim()
    with pytest.raises(exc.InvalidArgumentError, match=message):
        sim.load_urdf("r2d2.urdf", **kwargs)
    assert sim.bodies() == []


def test_merging_two_massless_links_is_refused_where_pybullet_divides_by_zero(make_sim):
    text = (
        '<robot name="m"><link name="a"><inertial><mass value="1"/><inertia ixx="1" iyy="1" '
        'izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        '<link name="b"><inertial><mass value="0"/><inertia ixx="0" iyy="0" izz="0" ixy="0" '
        'ixz="0" iyz="0"/></inertial></link><link name="c"><inertial><mass value="0"/>'
        '<inertia ixx="0" iyy="0" izz="0" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        '<joint name="ab" type="continuous"><parent link="a"/><child link="b"/></joint>'
        '<joint name="bc" type="fixed"><parent link="b"/><child link="c"/></joint></robot>'
    )
    raw = _raw.raw_load(text, flags=MERGE)
    assert all(math.isnan(v) for v in raw.dynamics[1][3])  # PyBullet: a centre of mass of NaN
    with pytest.raises(exc.UrdfStructureError, match=r"joint 'bc': merge_fixed_links: links"):
        make_sim().load_urdf(text, merge_fixed_links=True)
