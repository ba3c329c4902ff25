"""PyBullet's own bodies of an MJCF read as MuJoCo reads it: each MuJoCo body's frame where
MuJoCo's forward kinematics puts it, for the same ``qpos``, within 1e-6 m, and the whole
body's mass and centre of mass MuJoCo's (welded bodies merged into their link). The calls
every engine shares: tests/conformance/test_mjcf_mujoco_reading.py."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import mujoco
import numpy as np
import pybullet as p
import pytest

import simbridge
from simbridge.backends.pybullet.inspect import mjcf_world

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("gymnasium") is None,
    reason="gymnasium is not installed: pip install 'gymnasium[mujoco]==1.4.0'",
)


def _gym_asset(name: str) -> str:
    spec = importlib.util.find_spec("gymnasium")
    assert spec is not None and spec.origin is not None
    return str(Path(spec.origin).parent / "envs" / "mujoco" / "assets" / name)


@pytest.mark.parametrize("name", ["ant.xml", "half_cheetah.xml"])
def test_pybullets_frames_are_mujocos(name: str) -> None:
    path = _gym_asset(name)
    m = mujoco.MjModel.from_xml_path(path)
    d = mujoco.MjData(m)
    q = m.qpos0 + np.random.default_rng(7).uniform(-0.3, 0.3, m.nq)
    if m.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE:
        q[3:7] /= np.linalg.norm(q[3:7])
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    with simbridge.Sim("pybullet") as sim:
        sim.load_mjcf(path, semantics="mujoco")
        sim.set_qpos_qvel(q, np.zeros(m.nv))
        world = mjcf_world(sim)
        c = world._c
        for k, nb in enumerate(world.native.bodies):
            body = world._ids[k]
            for i, j in enumerate(nb.joint_ids):
                last = i + 1 == len(nb.joint_ids) or nb.link_bodies[i + 1] != nb.link_bodies[i]
                if not last:  # an intermediate link of a body with several joints
                    continue
                b = nb.link_bodies[i]
                state = p.getLinkState(body, i, computeForwardKinematics=1, physicsClientId=c)
                frame = d.xpos[b] + d.xmat[b].reshape(3, 3) @ m.jnt_pos[j]
                np.testing.assert_allclose(state[4], frame, atol=1e-6)
                rot = np.array(p.getMatrixFromQuaternion(state[5])).reshape(3, 3)
                np.testing.assert_allclose(rot, d.xmat[b].reshape(3, 3), atol=1e-6)
            masses = [p.getDynamicsInfo(body, -1, physicsClientId=c)[0]]
            coms = [p.getBasePositionAndOrientation(body, physicsClientId=c)[0]]
            for i in range(len(nb.joint_ids)):
                masses.append(p.getDynamicsInfo(body, i, physicsClientId=c)[0])
                coms.append(p.getLinkState(body, i, physicsClientId=c)[0])
            top = nb.body_id
            assert sum(masses) == pytest.approx(m.body_subtreemass[top], rel=1e-9)
            if nb.free_joint >= 0:  # a massless root's base is welded: its mass 0 is PyBullet's
                com = np.sum(np.array(masses)[:, None] * np.array(coms), axis=0) / sum(masses)
                np.testing.assert_allclose(com, d.subtree_com[top], atol=1e-6)


SPUN = """<mujoco><option gravity="0 0 0" timestep="0.01"/><worldbody>
<body name="slab" pos="0 0 10"><freejoint/><geom type="box" size="0.3 0.1 0.05" pos="0.2 0 0"/>
</body></worldbody></mujoco>"""


@pytest.mark.parametrize("spin", [1.0, 10.0])
def test_a_spinning_free_base_has_no_constraint_force(spin: float) -> None:
    """A free slab (its centre of mass 0.2 m from its frame's origin) spun at ``spin`` rad/s
    without gravity or contact: the constraint forces the armature force infers from a step
    (``M qacc - applied + c``) are 0 to rounding, the free base's change of velocity taken as
    PyBullet steps it (its centre of mass's velocity and world angular velocity); with
    ``v1 - v0`` in MuJoCo's coordinates they are not (measured 0.21 N·m on dm_control's
    humanoid at 10 rad/s, fed back by the armature force)."""
    with simbridge.Sim("pybullet") as sim:
        sim.load_mjcf(SPUN, semantics="mujoco")
        w = mjcf_world(sim)
        v = np.zeros(6)
        v[3:6] = np.array([0.3, -0.5, 0.8]) * spin
        sim.set_qpos_qvel(sim.qpos(), v)
        sim.step(3)
        q0, v0, mass0, c0, applied0 = w._last
        change = w.velocity_change(q0, v0, sim.qpos(), sim.qvel())
        residual = mass0 @ (change / w.dt) - applied0 + c0
        naive = mass0 @ ((sim.qvel() - v0) / w.dt) - applied0 + c0
    assert float(np.abs(residual).max()) < 1e-9
    assert float(np.abs(naive).max()) > 1e-6


def test_the_soft_limits_push_only_the_joints_outside_their_range() -> None:
    """PyBullet's soft limits (every limited joint, every step) find the hinges inside their
    range from a table read once: the ant's joints placed at random in and out of their
    ranges, moving outward, get a force on exactly the joints whose MuJoCo violation
    ``r = dist - margin`` is negative (read here from the model's ranges), and none
    elsewhere."""
    with simbridge.Sim("pybullet") as sim:
        sim.load_mjcf(_gym_asset("ant.xml"), semantics="mujoco")
        w = mjcf_world(sim)
        m = w.m
        joints = [j for j in range(m.njnt) if m.jnt_limited[j] and m.jnt_type[j] == 3]
        rng = np.random.default_rng(5)
        mass = np.eye(m.nv) * 0.5
        pushed = inside = 0
        for _ in range(30):
            q = m.qpos0.copy()
            for j in joints:
                lo, hi = m.jnt_range[j]
                q[m.jnt_qposadr[j]] = rng.uniform(lo - 0.3, hi + 0.3)
            mid = {j: 0.5 * (m.jnt_range[j][0] + m.jnt_range[j][1]) for j in joints}
            v = np.zeros(m.nv)  # each joint moving away from its range's middle
            for j in joints:
                v[m.jnt_dofadr[j]] = np.sign(q[m.jnt_qposadr[j]] - mid[j])
            sim.set_qpos_qvel(q, v)
            w._sync()
            force = w.limit_recovery(mass, np.zeros(m.nv))
            for j in joints:
                x, (lo, hi) = q[m.jnt_qposadr[j]], m.jnt_range[j]
                r = min(x - lo, hi - x) - m.jnt_margin[j]
                f = force[m.jnt_dofadr[j]]
                assert (f != 0.0) == (r < 0.0), (j, x, lo, hi, f)
                pushed += r < 0.0
                inside += r >= 0.0
    assert pushed and inside  # both cases were read
