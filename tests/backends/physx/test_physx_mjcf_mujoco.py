"""PhysX's own links of an MJCF read as MuJoCo reads it: each MuJoCo body's frame where
MuJoCo's forward kinematics puts it, for the same ``qpos``, within 1e-6 m (PhysX's float32:
measured 2e-7 m at most), MuJoCo's joint armature on PhysX's joints, and the whole body's mass
and centre of mass MuJoCo's (welded bodies merged into their link). The calls every engine
shares: tests/conformance/test_mjcf_mujoco_reading.py."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import mujoco
import numpy as np
import pytest

import simbridge
from simbridge.backends.physx.inspect import mjcf_world

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("gymnasium") is None,
    reason="gymnasium is not installed: pip install 'gymnasium[mujoco]==1.4.0'",
)


def _gym_asset(name: str) -> str:
    spec = importlib.util.find_spec("gymnasium")
    assert spec is not None and spec.origin is not None
    return str(Path(spec.origin).parent / "envs" / "mujoco" / "assets" / name)


@pytest.mark.parametrize("name", ["ant.xml", "half_cheetah.xml"])
def test_physxs_frames_are_mujocos(name: str) -> None:
    path = _gym_asset(name)
    m = mujoco.MjModel.from_xml_path(path)
    d = mujoco.MjData(m)
    q = m.qpos0 + np.random.default_rng(7).uniform(-0.3, 0.3, m.nq)
    if m.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE:
        q[3:7] /= np.linalg.norm(q[3:7])
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    with simbridge.Sim("physx") as sim:
        sim.load_mjcf(path, semantics="mujoco")
        sim.set_qpos_qvel(q, np.zeros(m.nv))
        world = mjcf_world(sim)
        for k, nb in enumerate(world.native.bodies):
            links = world._built[k].links
            masses, coms = [], []
            for i, j in enumerate(nb.joint_ids):
                link = links[i + 1]
                assert float(link.joint.armature[0]) == pytest.approx(
                    m.dof_armature[m.jnt_dofadr[j]], rel=1e-6
                )
                last = i + 1 == len(nb.joint_ids) or nb.link_bodies[i + 1] != nb.link_bodies[i]
                if not last:  # an intermediate link of a body with several joints
                    continue
                b = nb.link_bodies[i]
                pose = link.entity_pose
                frame = d.xpos[b] + d.xmat[b].reshape(3, 3) @ m.jnt_pos[j]
                np.testing.assert_allclose(pose.p, frame, atol=1e-6)
                rot = pose.to_transformation_matrix()[:3, :3]
                np.testing.assert_allclose(rot, d.xmat[b].reshape(3, 3), atol=1e-6)
            for i, link in enumerate(links):
                if i == 0 and nb.free_joint < 0:
                    continue  # a welded base
                plan = world.plans[k].links[i].inertial
                if plan.mass == 0.0:
                    continue  # a massless link: PhysX's minimum mass stands for it
                masses.append(link.mass)
                coms.append((link.entity_pose * link.cmass_local_pose).p)
            assert sum(masses) == pytest.approx(m.body_subtreemass[nb.body_id], rel=1e-6)
            if nb.free_joint >= 0:
                com = np.sum(np.array(masses)[:, None] * np.array(coms), axis=0) / sum(masses)
                np.testing.assert_allclose(com, d.subtree_com[nb.body_id], atol=1e-6)


def test_ignore_bits_leave_out_exactly_the_needed_pairs() -> None:
    """SAPIEN's g2 bits by a clique cover of the excluded pairs: two links share a bit only
    where their pair is excluded, every needed pair shares one, and a parent with two children
    excluded pairwise (a clique of three) takes one bit, not three."""
    from itertools import combinations

    from simbridge.backends.physx.model import ignore_bits

    rng = np.random.default_rng(3)
    nodes = list(range(12))
    excluded = {p for p in combinations(nodes, 2) if rng.random() < 0.3}
    needed = sorted(p for p in excluded if rng.random() < 0.7)
    bits = ignore_bits(excluded, needed)
    assert bits is not None
    for a, b in combinations(nodes, 2):
        shares = bool(bits.get(a, 0) & bits.get(b, 0))
        if (a, b) in needed:
            assert shares, (a, b)
        if shares:
            assert (a, b) in excluded, (a, b)
    tri = ignore_bits([(0, 1), (0, 2), (1, 2)], [(0, 1), (0, 2), (1, 2)])
    assert tri == {0: 1, 1: 1, 2: 1}
    star = [(0, k) for k in range(1, 34)]  # 33 pairs no two of which share a clique
    assert ignore_bits(star, star) is None


def test_bits_needed_counts_the_cover_past_32() -> None:
    """The refusal's count (``contact exclusions needing N groups``): the cover's bits,
    uncapped; a clique of three is one."""
    from simbridge.backends.physx.model import bits_needed

    star = [(0, k) for k in range(1, 34)]
    assert bits_needed(star, star) == 33
    assert bits_needed(star, star[:5]) == 5
    assert bits_needed([(0, 1), (0, 2), (1, 2)], [(0, 1), (0, 2), (1, 2)]) == 1
    assert bits_needed(star, []) == 0
