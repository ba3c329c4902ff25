"""simbridge.model.build_plan: what every engine builder gets, checked against raw PyBullet on
pybullet_data robots (these tests import pybullet on purpose): the link order and joints of
PyBullet's joint table and its link frames, the inertials of each inertia source, the collision
shapes (meshes with their vertices read, their frames), the ground shapes, and the contact
filter (which pairs of links PyBullet's collision detection pairs, and which carry force)."""

from __future__ import annotations

import itertools
import math
import os

import numpy as np
import pybullet as p
import pybullet_data
import pytest

from simbridge.exceptions import InvalidArgumentError
from simbridge.model.build_plan import (
    BuildPlan,
    ContactValues,
    build_plan,
    combine_contact,
    links_collide,
)
from simbridge.model.load_options import load_options
from simbridge.model.meshes import read_mesh
from simbridge.model.scene_reader import parse_scene
from simbridge.model.urdf import UrdfModel, parse_urdf, resolve_source
from simbridge.profiles import get_profile
from simbridge.transforms import transform_multiply

DATA = pybullet_data.getDataPath()
PYBULLET = get_profile("pybullet")
URDFS = ("r2d2.urdf", "kuka_iiwa/model.urdf", "laikago/laikago_toes.urdf", "duck_vhacd.urdf")
# PyBullet's joint type numbers
P_TYPE = {"revolute": 0, "continuous": 0, "prismatic": 1, "spherical": 2, "fixed": 4}
SELF_FLAGS = {
    "off": 0,
    "exclude_parent": p.URDF_USE_SELF_COLLISION,
    "exclude_all_parents": p.URDF_USE_SELF_COLLISION
    | p.URDF_USE_SELF_COLLISION_EXCLUDE_ALL_PARENTS,
    "include_parent": p.URDF_USE_SELF_COLLISION | p.URDF_USE_SELF_COLLISION_INCLUDE_PARENT,
}


@pytest.fixture(scope="module")
def client():
    c = p.connect(p.DIRECT)
    yield c
    p.disconnect(c)


def _model(name: str) -> UrdfModel:
    return parse_urdf(resolve_source(name))


def _plan(model: UrdfModel, fixed: bool = False, **options) -> BuildPlan:
    return build_plan(model, PYBULLET, load_options(PYBULLET, **options), fixed_base=fixed)


def _load(client: int, model: UrdfModel, fixed: bool = False, flags: int = 0, pos=(0, 0, 0)):
    """The file the model was read from, loaded by raw PyBullet (the same meshes)."""
    assert model.source.path is not None
    return p.loadURDF(
        str(model.source.path), pos, useFixedBase=fixed, flags=flags, physicsClientId=client
    )


def _same_quat(a, b, tol: float) -> bool:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return bool(np.abs(a - b).max() < tol or np.abs(a + b).max() < tol)


def _link_frames(plan: BuildPlan) -> list[tuple]:
    """Every link frame in the world at zero joint positions, from the plan alone."""
    frames: list[tuple] = [(plan.base_position, plan.base_orientation)]
    for link in plan.links[1:]:
        assert link.joint is not None and link.parent == link.joint.parent
        frames.append(
            transform_multiply(
                frames[link.parent + 1], (link.joint.position, link.joint.orientation)
            )
        )
    return frames


# ---------------------------------------------------------------- links and joints


def _assert_joint_table(plan: BuildPlan, client: int, body: int, names: bool = True) -> None:
    n = p.getNumJoints(body, physicsClientId=client)
    assert len(plan.links) == n + 1 and len(plan.joints) == n
    assert plan.links[0].index == -1 and plan.links[0].parent is None
    assert plan.links[0].joint is None
    for i in range(n):
        info = p.getJointInfo(body, i, physicsClientId=client)
        link = plan.link(i)
        joint = link.joint
        assert joint is not None and link.index == joint.index == i
        assert link.name == info[12].decode()
        if names:  # an MJCF file's made-up joint names carry a process-wide counter
            assert joint.name == info[1].decode()
        assert P_TYPE[joint.type] == info[2]
        assert joint.parent == link.parent == info[16]
        if joint.type in ("revolute", "continuous", "prismatic"):
            written = np.asarray(info[13], float)
            assert joint.axis == pytest.approx(written / np.linalg.norm(written), abs=1e-12)
            assert math.isclose(float(np.linalg.norm(joint.axis)), 1.0, rel_tol=1e-15)
        if joint.limited:
            assert (joint.lower, joint.upper) == pytest.approx(info[8:10], abs=1e-12)
        assert (joint.damping, joint.friction) == pytest.approx(info[6:8], abs=1e-12)
    # link frames at zero joint positions: the plan's chain of joint frames against PyBullet's
    # forward kinematics
    frames = _link_frames(plan)
    base = p.getBasePositionAndOrientation(body, physicsClientId=client)
    local = p.getDynamicsInfo(body, -1, physicsClientId=client)[3:5]
    base_link = p.multiplyTransforms(*base, *p.invertTransform(*local))
    assert frames[0][0] == pytest.approx(base_link[0], abs=1e-9)
    assert _same_quat(frames[0][1], base_link[1], 1e-9)
    for i in range(n):
        state = p.getLinkState(body, i, computeForwardKinematics=1, physicsClientId=client)
        assert frames[i + 1][0] == pytest.approx(state[4], abs=1e-7), f"link {i} position"
        assert _same_quat(frames[i + 1][1], state[5], 1e-7), f"link {i} orientation"


@pytest.mark.parametrize("name", URDFS)
def test_links_and_joints_are_pybullets_joint_table(client, name):
    model = _model(name)
    plan = _plan(model)
    body = _load(client, model)
    try:
        _assert_joint_table(plan, client, body)
    finally:
        p.removeBody(body, physicsClientId=client)
    assert plan.name == model.name and plan.file == model.source.display_name


def test_spherical_limit_and_locked_joint_rules():
    """PyBullet's limit rules, as the plan states them: a revolute joint with lower > upper is
    unlimited; a spherical joint is limited only with lower, upper, twist and effort all > 0."""
    text = """<robot name="s">
      <link name="a"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1"
        iyz="0" izz="1"/></inertial></link>
      <link name="b"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1"
        iyz="0" izz="1"/></inertial></link>
      <link name="c"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1"
        iyz="0" izz="1"/></inertial></link>
      <link name="d"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1"
        iyz="0" izz="1"/></inertial></link>
      <joint name="ball" type="spherical"><parent link="a"/><child link="b"/>
        <limit lower="0.5" upper="0.6" twist="0.7" effort="10" velocity="1"/></joint>
      <joint name="free_ball" type="spherical"><parent link="a"/><child link="c"/>
        <limit lower="0.5" upper="0.6" effort="10" velocity="1"/></joint>
      <joint name="inverted" type="revolute"><parent link="a"/><child link="d"/>
        <axis xyz="0 0 2"/><limit lower="1" upper="-1" effort="1" velocity="1"/></joint>
    </robot>"""
    plan = _plan(_model(text))
    ball, free_ball, inverted = plan.joints
    assert ball.spherical_limit == (0.5, 0.6, 0.7)
    assert free_ball.spherical_limit is None
    assert not inverted.limited and inverted.axis == (0.0, 0.0, 1.0)


# ---------------------------------------------------------------- inertials


@pytest.mark.parametrize("name", URDFS)
@pytest.mark.parametrize("source", ["collision_aabb", "file"])
@pytest.mark.parametrize("fixed", [False, True])
def test_inertials_follow_the_inertia_source(client, name, source, fixed):
    """Mass, principal moments and principal frame per link as PyBullet simulates them, for
    the inertia source the options give (``file``: URDF_USE_INERTIA_FROM_FILE)."""
    model = _model(name)
    plan = _plan(model, fixed, inertia_source=source)
    assert plan.inertia_source == source
    flags = p.URDF_USE_INERTIA_FROM_FILE if source == "file" else 0
    body = _load(client, model, fixed, flags)
    try:
        for link in plan.links:
            ref = p.getDynamicsInfo(body, link.index, physicsClientId=client)
            ine = link.inertial
            assert ine.mass == ref[0], link.name
            assert ine.diagonal == pytest.approx(ref[2], rel=1e-6, abs=1e-15), link.name
            assert ine.position == pytest.approx(ref[3], abs=1e-12), link.name
            assert _same_quat(ine.orientation, ref[4], 1e-9), link.name
            # the profile's contact values (no <contact> in these files: the profile's)
            assert link.contact.lateral_friction == ref[1]
            assert (link.contact.rolling_friction, link.contact.spinning_friction) == (
                ref[6],
                ref[7],
            )
            assert link.contact.restitution == ref[5]
    finally:
        p.removeBody(body, physicsClientId=client)
    if fixed:
        assert plan.fixed_base and plan.links[0].static and plan.links[0].inertial.mass == 0.0


def test_the_two_sources_differ_where_the_file_says_otherwise():
    """The rule is applied, not ignored: kuka's file inertia is not its collision box's."""
    model = _model("kuka_iiwa/model.urdf")
    box = _plan(model, inertia_source="collision_aabb").link(2).inertial
    file = _plan(model, inertia_source="file").link(2).inertial
    assert box.mass == file.mass
    assert not np.allclose(box.diagonal, file.diagonal, rtol=1e-3)


def test_a_bad_inertia_source_is_refused_by_the_options():
    with pytest.raises(InvalidArgumentError, match="inertia_source"):
        load_options(PYBULLET, inertia_source="cad")


# ---------------------------------------------------------------- shapes


@pytest.mark.parametrize("name", URDFS)
def test_collision_shapes_are_pybullets_with_their_meshes_read(client, name):
    """Per link the same shapes as PyBullet's collision shape data, in order: kind, mesh file
    and scale, and frame (PyBullet gives it in the inertial frame); a mesh's vertices are the
    file's times its scale, read-only, its triangles within them."""
    model = _model(name)
    plan = _plan(model)
    body = _load(client, model)
    meshes = 0
    kinds = {"box": p.GEOM_BOX, "sphere": p.GEOM_SPHERE, "cylinder": p.GEOM_CYLINDER}
    kinds |= {"capsule": p.GEOM_CAPSULE, "mesh": p.GEOM_MESH, "plane": p.GEOM_PLANE}
    try:
        for link in plan.links:
            data = p.getCollisionShapeData(body, link.index, physicsClientId=client)
            assert len(data) == len(link.collisions), link.name
            ine = link.inertial
            for ref, shape in zip(data, link.collisions, strict=True):
                # PyBullet makes a URDF cylinder a convex hull (a mesh) unless asked
                # (URDF_USE_IMPLICIT_CYLINDER); the plan keeps the cylinder
                ref_kind = p.GEOM_CYLINDER if shape.kind == "cylinder" else ref[2]
                assert kinds[shape.kind] == ref_kind
                pos, orn = transform_multiply((ine.position, ine.orientation), (ref[5], ref[6]))
                assert shape.position == pytest.approx(pos, abs=1e-9)
                assert _same_quat(shape.orientation, orn, 1e-9)
                if shape.kind != "mesh":
                    assert shape.mesh is None
                    continue
                meshes += 1
                mesh = shape.mesh
                assert mesh is not None
                assert os.path.samefile(ref[4].decode(), mesh.path)
                assert mesh.scale == pytest.approx(ref[3], rel=1e-15)
                verts, faces = read_mesh(mesh.path)
                assert mesh.file_vertices is verts and mesh.faces is faces  # read once
                assert np.array_equal(mesh.vertices, verts * np.asarray(mesh.scale))
                assert not mesh.vertices.flags.writeable
                assert mesh.vertices.shape[1] == 3 and len(mesh.vertices) > 0
                assert faces.min() >= 0 and faces.max() < len(verts)
    finally:
        p.removeBody(body, physicsClientId=client)
    assert meshes > 0  # each of these robots has mesh collision shapes


def test_mesh_robots_carry_vertices():
    """Every mesh collision shape of kuka and laikago holds its vertices (kuka: one per
    link; laikago: its .obj and .stl meshes), scaled."""
    for name, expected in (("kuka_iiwa/model.urdf", 8), ("laikago/laikago_toes.urdf", 13)):
        plan = _plan(_model(name))
        shapes = [s for link in plan.links for s in link.collisions if s.kind == "mesh"]
        assert len(shapes) == expected, name
        assert all(s.mesh is not None and len(s.mesh.vertices) >= 4 for s in shapes)


def test_degenerate_and_dropped_shapes(tmp_path):
    """A collision primitive of size 0 is kept and marked (PyBullet keeps a point-like shape);
    a visual one is left out and listed, as are meshes PyBullet gets nothing from."""
    plan = _plan(_model("laikago/laikago_toes.urdf"))
    toes = [link for link in plan.links if link.name.startswith("toe")]
    assert len(toes) == 4
    assert all(not link.visuals for link in toes)
    assert list(plan.dropped_shapes) == [f"link {t.name!r} <visual> #0" for t in toes]
    text = """<robot name="d"><link name="a">
      <visual><geometry><sphere radius="0"/></geometry></visual>
      <collision><geometry><sphere radius="0"/></geometry></collision>
      <collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision>
      <collision><geometry><mesh filename="DATA/empty.obj"/></geometry></collision>
    </link></robot>"""
    empty = tmp_path / "empty.obj"
    empty.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")  # vertices, no face: PyBullet drops it
    plan = _plan(_model(text.replace("DATA/empty.obj", str(empty))))
    (link,) = plan.links
    assert [(s.element, s.kind, s.degenerate) for s in link.collisions] == [
        (0, "sphere", True),
        (1, "box", False),
    ]
    assert plan.dropped_shapes == ("link 'a' <visual> #0", "link 'a' <collision> #2")


def test_ground_shapes():
    """plane.urdf's 200 x 200 x 10 m box welded to the world: ground at its top face (z = 0);
    plane_implicit.urdf's <plane>: an unbounded plane; not a ground on a tilted body or on a
    box that is not welded to the world."""
    plan = _plan(_model("plane.urdf"))
    assert plan.fixed_base  # mass 0
    (shape,) = plan.links[0].collisions
    assert shape.kind == "box" and shape.ground is not None
    assert shape.ground.position == (0.0, 0.0, 0.0)
    assert shape.ground.half_extents == (100.0, 100.0)
    (implicit,) = _plan(_model("plane_implicit.urdf")).links[0].collisions
    assert implicit.kind == "plane" and implicit.ground is not None
    assert implicit.ground.half_extents is None
    tilted = build_plan(
        _model("plane.urdf"),
        PYBULLET,
        load_options(PYBULLET),
        fixed_base=True,
        base_orientation=(0.0, math.sin(0.05), 0.0, math.cos(0.05)),
    )
    assert not tilted.upright and tilted.links[0].collisions[0].ground is None
    for link in _plan(_model("r2d2.urdf")).links:
        assert all(s.ground is None for s in link.collisions)


# ---------------------------------------------------------------- contact filter


@pytest.mark.parametrize(
    ("name", "fixed"),
    [("r2d2.urdf", False), ("r2d2.urdf", True), ("kuka_iiwa/model.urdf", True)],
)
@pytest.mark.parametrize("mode", list(SELF_FLAGS))
def test_self_collision_pairs_are_pybullets(client, name, fixed, mode):
    """For every pair of links that touch at rest: PyBullet's collision detection pairs them
    exactly when the plan's mode, exclusions and filter let them; of those, the pairs of two
    links welded to the world (which the plan leaves out: ``self_collides``) carry no force."""
    model = _model(name)
    plan = _plan(model, fixed, self_collision=mode)
    assert plan.self_collision == mode
    body = _load(client, model, fixed, SELF_FLAGS[mode])
    try:
        p.performCollisionDetection(physicsClientId=client)
        contacts = p.getContactPoints(body, body, physicsClientId=client)
        detected = {(min(c[3], c[4]), max(c[3], c[4])) for c in contacts}
        touching = set()
        ids = [link.index for link in plan.links]
        for a, b in itertools.combinations(ids, 2):
            if p.getClosestPoints(body, body, 0.0, a, b, physicsClientId=client):
                touching.add((a, b))
        p.setGravity(0, 0, -10, physicsClientId=client)
        p.stepSimulation(physicsClientId=client)
        contacts = p.getContactPoints(body, body, physicsClientId=client)
        forced = {(min(c[3], c[4]), max(c[3], c[4])) for c in contacts if c[9] > 0}
    finally:
        p.removeBody(body, physicsClientId=client)
    pairs = set(plan.self_pairs())
    shaped = [link.index for link in plan.links if link.collisions]
    assert pairs == {
        (a, b) for a, b in itertools.combinations(shaped, 2) if plan.self_collides(a, b)
    }

    def paired(a: int, b: int) -> bool:  # the filter, without the static rule
        la, lb = plan.link(a), plan.link(b)
        return mode != "off" and (a, b) not in plan.excluded_pairs and la.filter.passes(lb.filter)

    assert detected == {pair for pair in touching if paired(*pair)}
    assert forced <= pairs
    static_pairs = {(a, b) for a, b in detected if plan.link(a).static and plan.link(b).static}
    assert detected - pairs == static_pairs
    if mode == "off":
        assert not pairs and not plan.excluded_pairs
    if mode in ("exclude_parent", "exclude_all_parents"):
        parents = {(min(j.index, j.parent), max(j.index, j.parent)) for j in plan.joints}
        assert parents <= plan.excluded_pairs
    if mode == "include_parent":
        assert not plan.excluded_pairs


def test_the_modes_exclude_what_they_say():
    """r2d2: touching pairs that each mode keeps apart (so the comparison above can fail)."""
    model = _model("r2d2.urdf")
    parent = _plan(model, self_collision="exclude_parent").excluded_pairs
    ancestors = _plan(model, self_collision="exclude_all_parents").excluded_pairs
    assert parent < ancestors
    assert (-1, 1) in ancestors - parent  # right_base's grandparent, the base


def test_two_bodies_filter(client):
    """Between bodies: a fixed base is group 2, mask -1 ^ 2, so two bodies welded to the world
    never meet, and a moving link meets both (PyBullet's contacts, measured)."""
    plane = _model("plane.urdf")
    r2d2 = _model("r2d2.urdf")
    a, b = _plan(plane), _plan(plane)
    robot = _plan(r2d2)
    assert (a.links[0].filter.group, a.links[0].filter.mask) == (2, -1 ^ 2)
    assert not links_collide(a.links[0], b.links[0])
    assert all(links_collide(a.links[0], link) for link in robot.links)
    ids = [_load(client, plane), _load(client, plane, pos=(0, 0, 0.01))]
    ids.append(_load(client, r2d2, pos=(0, 0, 0.3)))
    try:
        p.performCollisionDetection(physicsClientId=client)
        assert not p.getContactPoints(ids[0], ids[1], physicsClientId=client)
        wheels = {c[4] for c in p.getContactPoints(ids[0], ids[2], physicsClientId=client)}
        assert wheels and all(links_collide(a.links[0], robot.link(k)) for k in wheels)
    finally:
        for body in ids:
            p.removeBody(body, physicsClientId=client)


def test_contact_values_and_their_combination():
    """The file's <contact> values where the profile reads them, else the profile's; a pair
    combines as Bullet does (product, rolling/spinning x_a mu_b + x_b mu_a, clamped to 10)."""
    text = """<robot name="c"><link name="a">
      <contact><lateral_friction value="0.8"/><rolling_friction value="0.01"/>
        <stiffness value="3000"/><damping value="20"/><restitution value="0.5"/></contact>
      <collision><geometry><sphere radius="0.1"/></geometry></collision></link></robot>"""
    model = _model(text)
    ct = _plan(model).links[0].contact
    assert ct == ContactValues(0.8, 0.01, 0.0, 0.5, 3000.0, 20.0)
    ignored = build_plan(
        model, PYBULLET.with_(read_urdf_contact=False), load_options(PYBULLET), fixed_base=False
    ).links[0]
    assert ignored.contact.lateral_friction == PYBULLET.lateral_friction
    assert ignored.contact.restitution == PYBULLET.restitution
    profile = ContactValues(0.5, 0.0, 0.0, 0.0)
    pair = combine_contact(ct, profile)
    assert pair.lateral_friction == 0.8 * 0.5
    assert pair.rolling_friction == 0.01 * 0.5
    assert pair.restitution == 0.0
    huge = ContactValues(100.0, 100.0, 100.0, 1.0)
    assert combine_contact(huge, huge).rolling_friction == 10.0


# ---------------------------------------------------------------- MJCF and SDF


# Moments PyBullet's float32 reading leaves 1e-7 relative apart, except (file, link) here,
# measured: the finger tips' .stl hulls, 4.7e-5 relative on Ix and Iz (simbridge.model.inertia's
# rule for a hull's bounding box; tests/conformance/test_mjcf_sdf.py MOMENTS_OFF)
MOMENTS_OFF = {
    ("kuka_iiwa/kuka_with_gripper2.sdf", 10): 5e-5,
    ("kuka_iiwa/kuka_with_gripper2.sdf", 13): 5e-5,
}


@pytest.mark.parametrize(
    "name", ["mjcf/ant.xml", "mjcf/hopper.xml", "kuka_iiwa/kuka_with_gripper2.sdf"]
)
def test_mjcf_and_sdf_bodies(client, name):
    """A SceneBody's plan against raw loadMJCF/loadSDF: link order, joint types and parents,
    link frames, inertials (the readers' own moments), and the file's collision filter."""
    kind = "mjcf" if name.endswith(".xml") else "sdf"
    bodies = parse_scene(os.path.join(DATA, name), kind)
    path = os.path.join(DATA, name)
    ids = (
        p.loadMJCF(path, physicsClientId=client)
        if kind == "mjcf"
        else p.loadSDF(path, physicsClientId=client)
    )
    try:
        assert len(ids) == len(bodies)
        for scene, body in zip(bodies, ids, strict=True):
            plan = build_plan(
                scene,
                PYBULLET,
                load_options(PYBULLET),
                fixed_base=False,
                base_position=scene.base_position,
                base_orientation=scene.base_orientation,
            )
            _assert_joint_table(plan, client, body, names=kind == "sdf")
            for link in plan.links:
                ref = p.getDynamicsInfo(body, link.index, physicsClientId=client)
                ine = link.inertial
                mass = 0.0 if link.index == -1 and plan.fixed_base else ine.mass
                assert math.isclose(mass, ref[0], rel_tol=1e-12, abs_tol=1e-15)
                scale = max(1e-12, max(abs(v) for v in ref[2]))
                rel = MOMENTS_OFF.get((name, link.index), 1e-7)
                assert ine.diagonal == pytest.approx(ref[2], abs=rel * scale), link.name
                own = scene.collision_filters.get(link.name)
                if own is not None:
                    assert (link.filter.group, link.filter.mask) == tuple(
                        d if v is None else v for v, d in zip(own, (1, -1), strict=True)
                    ) or link.index == -1
    finally:
        for body in ids:
            p.removeBody(body, physicsClientId=client)


def test_mjcf_filter_keeps_the_ant_off_itself(client):
    """ant.xml: the ant's geoms are contype 1, conaffinity 0: no pair of its links collides,
    even with every pair asked for (raw loadMJCF with self-collision detects none of its
    touching pairs), while each meets the ground (plane.urdf's welded base)."""
    (ant,) = parse_scene(os.path.join(DATA, "mjcf/ant.xml"), "mjcf")
    opts = load_options(PYBULLET, self_collision="include_parent")
    plan = build_plan(ant, PYBULLET, opts, fixed_base=False, base_position=ant.base_position)
    assert plan.self_pairs() == ()
    shaped = [link for link in plan.links if link.collisions]
    assert len(shaped) == 13
    assert all((link.filter.group, link.filter.mask) == (1, 0) for link in shaped)
    ground = _plan(_model("plane.urdf")).links[0]
    assert all(links_collide(ground, link) for link in shaped)
    flags = p.URDF_USE_SELF_COLLISION | p.URDF_USE_SELF_COLLISION_INCLUDE_PARENT
    (body,) = p.loadMJCF(os.path.join(DATA, "mjcf/ant.xml"), flags=flags, physicsClientId=client)
    try:
        p.performCollisionDetection(physicsClientId=client)
        assert not p.getContactPoints(body, body, physicsClientId=client)
        touching = [
            (a, b)
            for a, b in itertools.combinations([link.index for link in shaped], 2)
            if p.getClosestPoints(body, body, 0.0, a, b, physicsClientId=client)
        ]
        assert touching  # legs meet their torso: the filter, not the distance, keeps them apart
    finally:
        p.removeBody(body, physicsClientId=client)
