"""The joint table (``getJointInfo``'s 17 fields) and the inertial frames, against yourdfpy's
reading of the same file plus PyBullet's documented rules (``_reference.py``).

Covers this package's robots, r2d2, and every URDF of pybullet_data that simbridge loads and
yourdfpy reads (``YOURDFPY_CANNOT_READ`` lists the others); the files it refuses are listed in
``REFUSED`` with the reason, and a test checks that each one still fails with the documented
exception (so the list cannot go stale).
"""

from __future__ import annotations

import glob
import os
from pathlib import Path

import _reference as ref
import numpy as np
import pybullet_data  # data files only: this imports no engine
import pytest
from _gaps import declared

import simbridge
from simbridge import exceptions as exc

DATA = Path(pybullet_data.getDataPath())
SHIPPED = [
    "r2d2.urdf",
    "plane.urdf",
    "pendulum.urdf",
    "double_pendulum.urdf",
    "wheel.urdf",
    "slider.urdf",
    "free_box.urdf",
    "spherical_pendulum.urdf",
]

# pybullet_data files simbridge refuses, with the exception and message it raises: raw PyBullet
# refuses them too, but random_urdfs/168, whose mesh it loads as no shape (every vertex NaN).
# Every other file loads (the spherical joints of humanoid.urdf and
# spherical_joint_limit.urdf included: test_spherical.py), read as PyBullet reads it
# (test_pybullet_data.py checks the joint tables and link frames against raw PyBullet's, files
# yourdfpy cannot read included).
REFUSED: dict[str, tuple[type[Exception], str, str]] = {
    "kuka_iiwa/model_for_sdf.urdf": (
        exc.MeshNotFoundError,
        r"model_for_sdf\.urdf:76: link 'lbr_iiwa_link_0' <collision> #0: mesh file "
        r"'meshes/coarse/link_0\.stl' not found",
        "its meshes live beside the SDF, not beside this file; raw PyBullet refuses it too",
    ),
    "torus_deform.urdf": (
        exc.UrdfStructureError,
        r"torus_deform\.urdf:2: robot 'torus': has no <link>",
        "a deformable (<deformable>), not a robot; raw PyBullet refuses it in this world too",
    ),
    "toys/concave_box.urdf": (
        exc.UrdfStructureError,
        r"concave_box\.urdf:25: link 'base_link' <collision> #0: unknown geometry <cdf>",
        "Bullet's signed-distance-field geometry; raw PyBullet refuses it too",
    ),
    "random_urdfs/168/168.urdf": (
        exc.UrdfStructureError,
        r"'168\.obj' cannot be read as a mesh \(line 5\): vertex 1 is not finite",
        "every vertex of its mesh is NaN (raw PyBullet loads the link without a shape)",
    ),
}

# Files simbridge loads (as PyBullet reads them) that yourdfpy, the reference here, cannot read:
# their joint tables are checked against raw PyBullet's in test_pybullet_data.py instead.
YOURDFPY_CANNOT_READ = {
    "bicycle/bike.urdf": "comma-separated numbers ('0.07, 0, -0.69')",
    "biped/biped2d_pybullet.urdf": "blank lines before the XML declaration",
    "husky/husky.urdf": "unexpanded $(optenv ...) arguments where numbers belong",
    "plane_implicit.urdf": "Bullet's <plane> geometry",
    "humanoid/humanoid.urdf": "Bullet's <capsule> geometry (test_spherical.py checks it)",
}

# Files one backend cannot load although simbridge's parser accepts them (an engine limit): backend
# -> file -> (exception, message, reason). Such a file must fail exactly so on that backend (the
# test checks it, so the entry cannot go stale) and load everywhere else. Empty so far.
BACKEND_REFUSED: dict[str, dict[str, tuple[type[Exception], str, str]]] = {}


def _load_or_documented_refusal(sim, name: str) -> bool:
    """True when ``name`` is a documented refusal of this backend (and it did fail as written)."""
    entry = (declared(BACKEND_REFUSED, sim.backend) or {}).get(name)
    if entry is None:
        return False
    error, message, _reason = entry
    with pytest.raises(error, match=message):
        sim.load_urdf(DATA / name)
    return True


ALL_DATA = sorted(
    os.path.relpath(f, DATA) for f in glob.glob(str(DATA / "**" / "*.urdf"), recursive=True)
)
LOADABLE = [f for f in ALL_DATA if f not in REFUSED and f not in YOURDFPY_CANNOT_READ]
RANDOM = [f for f in LOADABLE if f.startswith("random_urdfs/")]
FAST_DATA = [f for f in LOADABLE if not f.startswith("random_urdfs/")] + RANDOM[::50]
RANDOM_CHUNKS = [RANDOM[i : i + 100] for i in range(0, len(RANDOM), 100)]

# Tolerances. Frames: PyBullet computes them in double precision from the same numbers; measured
# worst 2e-16 over all of pybullet_data. 1e-9 leaves room for an engine that stores float32-exact
# values nowhere but composes transforms differently.
TOL = 1e-9


def _inertial_rotation(sim: simbridge.Sim, body: int, link_index: int, link: object) -> np.ndarray:
    """The inertial frame's rotation (in the link frame) that the table must be expressed in.

    The file's ``<inertial><origin rpy>`` when the profile takes the collision AABB's inertia or
    the file's inertia is diagonal. With the file's non-diagonal inertia PyBullet diagonalises it
    and turns the inertial frame onto the principal axes: then the reported frame is checked to
    be a principal frame of the file's tensor with the reported moments, and used."""
    written = ref.inertial_frame(link)[:3, :3]
    info = sim.dynamics_info(body, link_index)
    reported = ref.quat_to_matrix(info.local_inertial_orientation)
    if sim.profile.inertia_source == "collision_aabb" or ref.inertia_is_diagonal(link):
        np.testing.assert_allclose(reported, written, atol=TOL, err_msg="inertial orientation")
        return written
    tensor = np.asarray(link.inertial.inertia, dtype=float)  # type: ignore[attr-defined]
    physical = ref.inertia_is_physical(link)
    if physical is False:  # PyBullet: "Bad inertia tensor properties, setting inertia to zero"
        assert tuple(info.local_inertia_diagonal) == (0.0, 0.0, 0.0)
        return reported
    if physical is None:  # on the triangle boundary: either answer is PyBullet's
        return reported
    principal = written.T @ reported
    np.testing.assert_allclose(principal.T @ principal, np.eye(3), atol=1e-9)
    # Bullet's Jacobi diagonalisation stops at a relative off-diagonal of about 1e-9 (measured
    # 3e-10 on pybullet_data's tensors): the moments match to that.
    scale = float(np.abs(tensor).max())
    np.testing.assert_allclose(
        principal.T @ tensor @ principal,
        np.diag(info.local_inertia_diagonal),
        atol=1e-8 * scale,
        err_msg="reported inertial frame is not a principal frame of the file's inertia",
    )
    return reported


def check_joint_table(sim: simbridge.Sim, path: str, fixed_base: bool = False) -> None:
    """Load ``path`` and compare the whole joint table and the inertial frames with yourdfpy."""
    robot = ref.load(path).robot
    body = sim.load_urdf(path, fixed_base=fixed_base)
    rows = ref.joint_table(robot, fixed_base)
    links = ref.link_by_name(robot)
    names = ref.link_names_in_order(robot)
    assert sim.num_joints(body) == len(rows)
    table = sim.joints(body)
    assert len(table) == len(rows)

    rotations = {}
    for index, name in enumerate(names, start=-1):
        link = links[name]
        info = sim.dynamics_info(body, index)
        np.testing.assert_allclose(
            info.local_inertial_position, ref.inertial_frame(link)[:3, 3], atol=TOL
        )
        if not (index == -1 and fixed_base):  # PyBullet reports a fixed base's mass as 0
            assert info.mass == pytest.approx(ref.link_mass(link), rel=1e-12), name
        rotations[name] = _inertial_rotation(sim, body, index, link)

    for row, got in zip(rows, table, strict=True):
        where = f"{path} joint {row.index} {row.name!r}"
        assert tuple(got[:13]) == (
            row.index,
            row.name,
            row.type,
            row.q_index,
            row.u_index,
            row.flags,
            row.damping,
            row.friction,
            row.lower,
            row.upper,
            row.max_force,
            row.max_velocity,
            row.link_name,
        ), where
        assert got.parent_index == row.parent_index, where
        assert isinstance(got.type, simbridge.JointType) and isinstance(got.index, int)
        parent_com = ref.inertial_frame(links[row.parent_link])
        rp, rc, rj = rotations[row.parent_link], rotations[row.link_name], row.joint_origin[:3, :3]
        # axis in the child's inertial frame, not normalised (FRAMES_PROBE's j1 is written
        # (0 2 0) and must come back with length 2)
        np.testing.assert_allclose(got.axis, rc.T @ row.axis, atol=TOL, err_msg=where)
        np.testing.assert_allclose(
            got.parent_frame_position,
            rp.T @ (row.joint_origin[:3, 3] - parent_com[:3, 3]),
            atol=TOL,
            err_msg=where,
        )
        np.testing.assert_allclose(
            ref.quat_to_matrix(got.parent_frame_orientation),
            rc.T @ rj.T @ rp,
            atol=TOL,
            err_msg=where,
        )
        assert abs(np.linalg.norm(got.parent_frame_orientation) - 1.0) < 1e-12, where


@pytest.mark.parametrize("fixed_base", [False, True], ids=["free", "fixed"])
@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_robots_joint_table(make_sim, profile, name, fixed_base):
    check_joint_table(make_sim(profile=profile), ref.robot_path(name), fixed_base)


def test_r2d2_table_facts_from_the_tutorial(make_sim):
    """The tutorial's own statements, written out by hand (TUTORIAL.md step 4)."""
    sim = make_sim()
    body = sim.load_urdf("r2d2.urdf")
    table = sim.joints(body)
    assert len(table) == 15
    assert table[0].name == "base_to_right_leg" and table[0].type == simbridge.JointType.FIXED
    for i in (2, 3, 6, 7):
        assert table[i].type == simbridge.JointType.REVOLUTE
        assert (table[i].lower_limit, table[i].upper_limit) == (0.0, -1.0)
        assert table[i].name.endswith("wheel_joint")
    # right leg: 10 kg, tilted 90 degrees about y (rpy 0 1.57075 0), PyBullet's info[12] works
    assert table[0][12] == "right_leg"
    assert sim.dynamics_info(body, 0).mass == 10.0


@pytest.mark.parametrize("name", FAST_DATA)
def test_pybullet_data_joint_table(make_sim, name):
    sim = make_sim()
    if not _load_or_documented_refusal(sim, name):
        check_joint_table(sim, str(DATA / name))


@pytest.mark.parametrize("name", FAST_DATA[:: max(1, len(FAST_DATA) // 12)])
def test_pybullet_data_joint_table_file_inertia(make_sim, name):
    """A spread of the same files under the "urdf" profile (file inertia, principal frames)."""
    sim = make_sim(profile="urdf")
    if not _load_or_documented_refusal(sim, name):
        check_joint_table(sim, str(DATA / name))


@pytest.mark.exhaustive
@pytest.mark.parametrize("chunk", range(len(RANDOM_CHUNKS)))
def test_pybullet_data_random_urdfs_joint_table(make_sim, chunk):
    """Every one of pybullet_data's random_urdfs, 100 per Sim (reset between files)."""
    sim = make_sim()
    failures = []
    for name in RANDOM_CHUNKS[chunk]:
        try:
            if not _load_or_documented_refusal(sim, name):
                check_joint_table(sim, str(DATA / name))
        except (AssertionError, simbridge.SimbridgeError) as e:  # collect all, report all
            failures.append(f"{name}: {str(e)[:300]}")
        sim.reset()
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize("name", sorted(REFUSED))
def test_refused_pybullet_data_files_fail_as_documented(make_sim, name):
    error, message, _reason = REFUSED[name]
    sim = make_sim()
    with pytest.raises(error, match=message):
        sim.load_urdf(DATA / name)
    assert sim.bodies() == []
    sim.close()


def test_refused_list_names_real_files():
    assert set(REFUSED) <= set(ALL_DATA), set(REFUSED) - set(ALL_DATA)
    assert set(YOURDFPY_CANNOT_READ) <= set(ALL_DATA), set(YOURDFPY_CANNOT_READ) - set(ALL_DATA)
    assert len(ALL_DATA) > 1000  # pybullet_data 3.2.7 ships 1095 URDFs


FRAMES_PROBE = """<?xml version="1.0"?>
<robot name="frames_probe">
  <link name="a">
    <inertial><origin xyz="0.1 0.2 0.3" rpy="0.3 0.2 0.1"/><mass value="2"/>
      <inertia ixx="1" ixy="0.1" ixz="0" iyy="2" iyz="0" izz="3"/></inertial>
    <collision><geometry><box size="0.2 0.4 0.6"/></geometry></collision>
  </link>
  <link name="b">
    <inertial><origin xyz="0 0.5 0" rpy="0.5 0 0"/><mass value="1"/>
      <inertia ixx="1" ixy="0" ixz="0" iyy="2" iyz="0" izz="3"/></inertial>
    <collision><geometry><box size="0.2 0.4 0.6"/></geometry></collision>
  </link>
  <link name="c"/>
  <link name="d"/>
  <joint name="j1" type="revolute"><parent link="a"/><child link="b"/>
    <origin xyz="1 2 3" rpy="0.1 0.2 0.3"/><axis xyz="0 2 0"/>
    <limit effort="5" velocity="6" upper="1"/></joint>
  <joint name="j2" type="fixed"><parent link="b"/><child link="c"/>
    <origin xyz="1 0 0"/><limit lower="-1" upper="2" effort="3" velocity="4"/>
    <dynamics damping="0.5" friction="0.25"/></joint>
  <joint name="j3" type="continuous"><parent link="a"/><child link="d"/>
    <origin xyz="0 0 -1" rpy="0 1.5 0"/><limit lower="-1" effort="3" velocity="4"/></joint>
</robot>
"""


def test_frames_limits_and_inertial_rotations_probe(make_sim, profile, tmp_path):
    """Rotated inertial frames on both sides of a joint, an unnormalised axis, a half-written
    range, a fixed joint with a <limit> and <dynamics> (PyBullet reports both), a link without
    <inertial>, and a non-diagonal file inertia (principal frames under the "urdf" profile)."""
    path = tmp_path / "frames_probe.urdf"
    path.write_text(FRAMES_PROBE)
    check_joint_table(make_sim(profile=profile), str(path))
