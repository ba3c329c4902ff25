"""The expectations of this suite, checked against the raw reference engine.

``_reference.py`` derives PyBullet's joint table from yourdfpy's reading of a URDF and a few
written rules. This module (the only one here that imports pybullet, because it compares with the
raw engine) checks those rules against raw ``p.getJointInfo``/``p.getDynamicsInfo``, so that a
backend is never held to a rule PyBullet itself does not follow. It does not involve simbridge.
"""

from __future__ import annotations

import glob
import os
from pathlib import Path

import _reference as ref
import numpy as np
import pybullet_data
import pytest

DATA = Path(pybullet_data.getDataPath())
ROBOTS = Path(__file__).resolve().parents[2] / "robots"
YOURDFPY_OR_PYBULLET_REFUSE = {  # (the simbridge side of these is in test_joint_table.REFUSED)
    "bicycle/bike.urdf",
    "biped/biped2d_pybullet.urdf",
    "humanoid/humanoid.urdf",
    "husky/husky.urdf",
    "plane_implicit.urdf",
    "spherical_joint_limit.urdf",
    "kuka_iiwa/model_for_sdf.urdf",
    "torus_deform.urdf",
    "toys/concave_box.urdf",
}
ALL = sorted(
    os.path.relpath(f, DATA) for f in glob.glob(str(DATA / "**" / "*.urdf"), recursive=True)
)
CHECKED = [f for f in ALL if f not in YOURDFPY_OR_PYBULLET_REFUSE]
FAST = [f for f in CHECKED if not f.startswith("random_urdfs/")]
SLOW = [f for f in CHECKED if f.startswith("random_urdfs/")]


@pytest.fixture(scope="module")
def client():
    import pybullet as p  # the raw engine, on purpose (see the module docstring)

    c = p.connect(p.DIRECT)
    yield p, c
    p.disconnect(c)


def _compare(p, c, path: str, fixed_base: bool, file_inertia: bool) -> list[str]:
    flags = p.URDF_USE_INERTIA_FROM_FILE if file_inertia else 0
    p.resetSimulation(physicsClientId=c)
    body = p.loadURDF(path, useFixedBase=fixed_base, flags=flags, physicsClientId=c)
    robot = ref.load(path).robot
    rows = ref.joint_table(robot, fixed_base)
    links = ref.link_by_name(robot)
    errors = []
    if len(rows) != p.getNumJoints(body, physicsClientId=c):
        return [f"{path}: {len(rows)} joints expected"]
    rotation = {}
    for index, name in enumerate(ref.link_names_in_order(robot), start=-1):
        dyn = p.getDynamicsInfo(body, index, physicsClientId=c)
        link = links[name]
        if not (index == -1 and fixed_base) and dyn[0] != ref.link_mass(link):
            errors.append(f"{path} link {name}: mass {dyn[0]} != {ref.link_mass(link)}")
        frame = ref.inertial_frame(link)
        if np.abs(np.array(dyn[3]) - frame[:3, 3]).max() > 1e-12:
            errors.append(f"{path} link {name}: inertial position {dyn[3]}")
        reported = ref.quat_to_matrix(dyn[4])
        if not file_inertia or ref.inertia_is_diagonal(link):
            if np.abs(reported - frame[:3, :3]).max() > 1e-12:
                errors.append(f"{path} link {name}: inertial orientation {dyn[4]}")
        rotation[name] = reported
    for row in rows:
        r = p.getJointInfo(body, row.index, physicsClientId=c)
        got = (r[0], r[1].decode(), r[2], r[3], r[4], r[5], *r[6:12], r[12].decode(), r[16])
        want = (row.index, row.name, row.type, row.q_index, row.u_index, row.flags,
                row.damping, row.friction, row.lower, row.upper, row.max_force,
                row.max_velocity, row.link_name, row.parent_index)  # fmt: skip
        if got != want:
            errors.append(f"{path} joint {row.name}: {got} != {want}")
        rp, rc = rotation[row.parent_link], rotation[row.link_name]
        rj = row.joint_origin[:3, :3]
        com = ref.inertial_frame(links[row.parent_link])[:3, 3]
        checks = {
            "axis": (r[13], rc.T @ row.axis),
            "parent position": (r[14], rp.T @ (row.joint_origin[:3, 3] - com)),
            "parent orientation": (ref.quat_to_matrix(r[15]), rc.T @ rj.T @ rp),
        }
        for what, (a, b) in checks.items():
            if np.abs(np.asarray(a) - b).max() > 1e-12:  # measured worst: 2.3e-16
                errors.append(f"{path} joint {row.name}: {what} {a} != {b}")
    return errors


@pytest.mark.parametrize("fixed_base", [False, True], ids=["free", "fixed"])
@pytest.mark.parametrize("file_inertia", [False, True], ids=["aabb", "file"])
def test_rules_hold_on_shipped_robots(client, fixed_base, file_inertia):
    p, c = client
    errors = []
    for path in sorted(glob.glob(str(ROBOTS / "*.urdf"))):
        errors += _compare(p, c, path, fixed_base, file_inertia)
    assert not errors, "\n".join(errors)


@pytest.mark.parametrize("file_inertia", [False, True], ids=["aabb", "file"])
def test_rules_hold_on_pybullet_data(client, file_inertia):
    p, c = client
    errors = []
    for name in FAST:
        errors += _compare(p, c, str(DATA / name), False, file_inertia)
    assert not errors, "\n".join(errors)


@pytest.mark.exhaustive
def test_rules_hold_on_pybullet_data_random_urdfs(client):
    p, c = client
    errors = []
    for name in SLOW:
        errors += _compare(p, c, str(DATA / name), False, False)
    assert not errors, "\n".join(errors)
