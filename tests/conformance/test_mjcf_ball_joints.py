"""Ball joints in an MJCF read as MuJoCo reads it (``load_mjcf(path, semantics="mujoco")``) on
every engine that declares that reading: each is a SPHERICAL row of the joint table whose
coordinates are MuJoCo's (``qpos``: the quaternion w, x, y, z turning the child body's frame;
``qvel``: its angular velocity in that frame), ``qpos()``/``qvel()`` of MuJoCo's sizes
``nq``/``nv``; the engine's own link frames are raw MuJoCo's forward kinematics within 1e-6 m
at ``qpos0`` and at a random ``qpos``; the chain swings under gravity and a ball's cone
(``range``) stops it as raw MuJoCo's do, within each engine's measured gap (_gaps.py); and
``get_state``/``set_state`` put a world with ball joints back. docs/mjcf_mujoco_reading.md has
the figures."""

from __future__ import annotations

import importlib

import mujoco
import numpy as np
import pytest
from _gaps import gap, steps_mujocos_reading_raw

import simbridge
from simbridge.exceptions import BackendUnsupportedError, MjcfFeatureUnsupportedError
from simbridge.types import JointType

# dm_control's mujoco/testing/assets/model_with_ball_joints.xml (two ball joints, damping 0.005,
# capsules along diagonals: inertial frames turned from the body frames), with MuJoCo's other
# ball-joint features on it: a spring and armature on the shoulder, a 60° cone on the elbow and
# a welded box on the lower arm (a link of two bodies); no contacts, gravity MuJoCo's default
CHAIN = """<mujoco model="ball_chain"><option timestep="0.002"/>
<default><geom type="capsule" size="0.01" contype="0" conaffinity="0"/>
<joint type="ball" damping="0.005"/></default>
<worldbody><body name="root" pos="0 0 1"><geom fromto="0 0 0 0 0 0.1"/>
<body name="upper" pos="0 0 0.1"><joint name="shoulder" stiffness="0.05" armature="0.0005"/>
<geom fromto="0 0 0 0 0.1 0.1"/>
<body name="lower" pos="0 0.1 0.1"><joint name="elbow" range="0 60"/>
<geom fromto="0 0 0 0 0.1 0.0"/><site name="tip" pos="0 0.1 0"/>
<body name="hand" pos="0 0.1 0" euler="0 30 0"><geom type="box" size="0.02 0.03 0.01"
pos="0.02 0 0"/></body></body></body></body></worldbody></mujoco>"""
# a ball pendulum (a 0.3 m capsule, horizontal) whose cone of 30° stops its fall
CONE = """<mujoco><option timestep="0.002"/><worldbody><body name="bob" pos="0 0 1">
<joint name="ball" type="ball" range="0 30" damping="0.001"/>
<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" contype="0" conaffinity="0"/></body>
</worldbody></mujoco>"""
BALL_ACTUATED = """<mujoco><worldbody><body name="a" pos="0 0 1">
<joint name="shoulder" type="ball"/><geom type="capsule" fromto="0 0 0 0.3 0.1 -0.4"
size="0.05"/></body></worldbody><actuator><motor name="twist" joint="shoulder" gear="0 0 1 0 0 0"/>
</actuator></mujoco>"""
SWING_SECONDS = 0.5


def _reads_mujoco(backend: str) -> bool:
    return "mujoco" in simbridge.registry.load_backend(backend).semantics


def _skip_unless_mujocos_reading(backend: str) -> None:
    if not _reads_mujoco(backend):
        pytest.skip(f"{backend!r} does not declare MuJoCo's reading of MJCF")


def _state_tol(backend: str) -> float:
    return 1e-6 if simbridge.registry.state_dtype(backend) == "float32" else 1e-12


def _link_frames(backend: str, sim: simbridge.Sim) -> list:
    """The engine's own link frames, from the ``inspect`` module beside the backend's class
    (or the class it derives from), as tests/conformance/test_mjcf_corpus.py reads them."""
    for cls in simbridge.registry.load_backend(backend).__mro__:
        package = cls.__module__.rpartition(".")[0]
        if not package:
            continue
        try:
            inspect = importlib.import_module(f"{package}.inspect")
        except ImportError:
            continue
        frames = getattr(inspect, "mjcf_link_frames", None)
        if frames is not None:
            return frames(sim)
    pytest.skip(f"backend {backend!r} has no inspect.mjcf_link_frames to read its frames")


def _frames_error(m: mujoco.MjModel, frames: list, q: np.ndarray) -> float:
    """The largest anchor position error (m) or rotation-matrix element error."""
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    return max(
        max(
            float(np.linalg.norm(p - (d.xpos[b] + d.xmat[b].reshape(3, 3) @ m.jnt_pos[j]))),
            float(np.max(np.abs(r - d.xmat[b].reshape(3, 3)))),
        )
        for b, j, p, r in frames
    )


def _random_state(m: mujoco.MjModel, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A random unit quaternion per ball joint (within its cone where it has one) and random
    angular velocities."""
    rng = np.random.default_rng(seed)
    q = m.qpos0.copy()
    for j in range(m.njnt):
        a = m.jnt_qposadr[j]
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        top = np.radians(50.0) if m.jnt_limited[j] else 2.5
        angle = rng.uniform(0.3, top)
        q[a : a + 4] = (np.cos(angle / 2), *(np.sin(angle / 2) * axis))
    return q, rng.uniform(-1.0, 1.0, m.nv)


def _angle_between(q1: np.ndarray, q2: np.ndarray) -> float:
    """The rotation angle (rad) between two unit quaternions w, x, y, z: of ``q1^-1 q2``,
    ``2 atan2(|v|, |w|)`` (exact near 0, where ``arccos`` of the dot product is 1e-7 off)."""
    rel = np.empty(4)
    mujoco.mju_mulQuat(rel, np.array((q1[0], -q1[1], -q1[2], -q1[3])), np.asarray(q2, float))
    return 2.0 * float(np.arctan2(np.linalg.norm(rel[1:]), abs(rel[0])))


def _raw_run(m: mujoco.MjModel, seconds: float) -> np.ndarray:
    d = mujoco.MjData(m)
    out = []
    for _ in range(round(seconds / m.opt.timestep)):
        mujoco.mj_step(m, d)
        out.append(d.qpos.copy())
    return np.array(out)


def _sim_run(sim: simbridge.Sim, seconds: float) -> np.ndarray:
    out = []
    for _ in range(round(seconds / sim.timestep)):
        sim.step()
        out.append(sim.qpos())
    return np.array(out)


def _ball_gap(m: mujoco.MjModel, a: np.ndarray, b: np.ndarray) -> float:
    """The largest rotation angle between two runs' ball joints (rad), over the runs."""
    return max(
        _angle_between(qa[k : k + 4], qb[k : k + 4])
        for qa, qb in zip(a, b, strict=True)
        for k in m.jnt_qposadr
    )


def test_ball_joints_are_spherical_rows_in_mujocos_layout(backend: str) -> None:
    """Each ball joint is a SPHERICAL row at MuJoCo's addresses; ``qpos()``/``qvel()`` have
    MuJoCo's ``nq``/``nv`` and read ``qpos0`` at rest after the load; a random state written
    reads back (float32 engines to their precision), and the joint's multi-DoF state is that
    state's quaternion (x, y, z, w) and angular velocity; a multi-DoF reset writes them."""
    _skip_unless_mujocos_reading(backend)
    m = mujoco.MjModel.from_xml_string(CHAIN)
    tol = _state_tol(backend)
    with simbridge.Sim(backend) as sim:
        (body,) = sim.load_mjcf(CHAIN, semantics="mujoco")
        rows = sim.joints(body)
        assert [r.name for r in rows] == ["shoulder", "elbow"]
        assert all(r.type == JointType.SPHERICAL for r in rows)
        assert [(r.q_index, r.u_index) for r in rows] == [
            (int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j])) for j in range(m.njnt)
        ]
        assert (sim.qpos().shape, sim.qvel().shape) == ((m.nq,), (m.nv,)) == ((8,), (6,))
        np.testing.assert_allclose(sim.qpos(), m.qpos0, atol=tol)
        np.testing.assert_allclose(sim.qvel(), 0.0, atol=tol)
        q, v = _random_state(m, 3)
        sim.set_qpos_qvel(q, v)
        np.testing.assert_allclose(sim.qpos(), q, atol=10 * tol)
        np.testing.assert_allclose(sim.qvel(), v, atol=10 * tol)
        elbow = sim.joint_states_multi_dof(body, ["elbow"])[0]
        np.testing.assert_allclose(elbow.position, sim.qpos()[[5, 6, 7, 4]], atol=10 * tol)
        np.testing.assert_allclose(elbow.velocity, sim.qvel()[3:6], atol=10 * tol)
        turn = np.array((0.1, -0.2, 0.3, 0.9))  # x, y, z, w; the Sim normalises it
        sim.reset_joint_state_multi_dof(body, "shoulder", turn, (0.5, -0.25, 1.0))
        turn /= np.linalg.norm(turn)
        np.testing.assert_allclose(sim.qpos()[:4], turn[[3, 0, 1, 2]], atol=10 * tol)
        np.testing.assert_allclose(sim.qvel()[:3], (0.5, -0.25, 1.0), atol=10 * tol)
        np.testing.assert_allclose(sim.qpos()[4:], q[4:], atol=10 * tol)  # the elbow kept
        if not steps_mujocos_reading_raw(backend):
            assert "ball_joints" in sim.manifest()["departures"]


@pytest.mark.parametrize("seed", [None, 7])
def test_ball_joint_frames_are_mujocos(backend: str, seed: int | None) -> None:
    """The engine's own frame of each body with a ball joint is raw MuJoCo's forward
    kinematics within 1e-6 m (and 1e-6 in each rotation-matrix element) at ``qpos0`` (seed
    None) and at a random ``qpos``, which moves every link."""
    _skip_unless_mujocos_reading(backend)
    m = mujoco.MjModel.from_xml_string(CHAIN)
    with simbridge.Sim(backend) as sim:
        sim.load_mjcf(CHAIN, semantics="mujoco")
        q = m.qpos0.copy()
        if seed is not None:
            q = _random_state(m, seed)[0]
            before = _link_frames(backend, sim)
            sim.set_qpos_qvel(q, np.zeros(m.nv))
        frames = _link_frames(backend, sim)
        assert len(frames) == m.njnt
        assert _frames_error(m, frames, q) < 1e-6
        if seed is not None:
            assert all(
                np.abs(a[3] - b[3]).max() > 1e-2 for a, b in zip(before, frames, strict=True)
            )


def test_the_ball_chain_swings_as_mujocos(backend: str) -> None:
    """From ``qpos0`` under gravity the chain swings (its spring, damping, armature and the
    elbow's cone acting) for 0.5 s: every ball joint's rotation within the engine's measured gap
    of raw MuJoCo's at every step (the MuJoCo backend: raw MuJoCo's bits)."""
    _skip_unless_mujocos_reading(backend)
    m = mujoco.MjModel.from_xml_string(CHAIN)
    raw = _raw_run(m, SWING_SECONDS)
    assert max(_angle_between(r[:4], m.qpos0[:4]) for r in raw) > 2.0  # it swings (2.6 rad)
    with simbridge.Sim(backend) as sim:
        sim.load_mjcf(CHAIN, semantics="mujoco")
        run = _sim_run(sim, SWING_SECONDS)
    if steps_mujocos_reading_raw(backend):
        assert np.array_equal(run, raw)
        return
    size = gap(backend, "mjcf_ball_swing")
    assert size is not None, f"{backend!r} declares no mjcf_ball_swing gap"
    assert _ball_gap(m, run, raw) <= size


def test_a_ball_joints_cone_stops_it_as_mujocos(backend: str) -> None:
    """A horizontal ball pendulum with a 30° cone falls into it: its largest rotation angle
    over 0.5 s is raw MuJoCo's (0.677 rad: MuJoCo's soft limit lets it 8.8° past the 30°)
    within the engine's measured gap, far from the 3.07 rad it reaches without the cone."""
    _skip_unless_mujocos_reading(backend)
    m = mujoco.MjModel.from_xml_string(CONE)
    raw = max(_angle_between(q, m.qpos0) for q in _raw_run(m, SWING_SECONDS))
    free = mujoco.MjModel.from_xml_string(CONE.replace(' range="0 30"', ""))
    assert max(_angle_between(q, free.qpos0) for q in _raw_run(free, SWING_SECONDS)) > 3.0
    assert 0.6 < raw < 0.7
    with simbridge.Sim(backend) as sim:
        sim.load_mjcf(CONE, semantics="mujoco")
        run = _sim_run(sim, SWING_SECONDS)
    reached = max(_angle_between(q, m.qpos0) for q in run)
    size = gap(backend, "mjcf_ball_cone") or 0.0
    assert abs(reached - raw) <= size, (reached, raw)


def test_get_state_and_set_state_with_ball_joints(backend: str) -> None:
    """``get_state`` holds each ball joint's quaternion (x, y, z, w) and angular velocity as
    ``qpos``/``qvel`` have them; ``set_state`` puts the world back: the run after it is the run
    after the state was taken (exactly from the state with the engine's own data; within the
    engine's precision from the portable state alone, also in a second Sim)."""
    _skip_unless_mujocos_reading(backend)
    tol = 1e3 * _state_tol(backend)
    with simbridge.Sim(backend) as sim:
        sim.load_mjcf(CHAIN, semantics="mujoco")
        sim.step(60)
        state = sim.get_state()
        loose = sim.get_state(exact=False)
        q = sim.qpos()
        balls = state.bodies[0].spherical
        assert [e.joint for e in balls] == [0, 1]
        np.testing.assert_allclose(balls[1].position, q[[5, 6, 7, 4]], atol=1e-15)
        np.testing.assert_allclose(balls[1].velocity, sim.qvel()[3:6], atol=1e-15)
        sim.step(40)
        after = sim.qpos()
        assert np.abs(after - q).max() > 1e-2  # the run moved on
        sim.set_state(state)
        sim.step(40)
        np.testing.assert_allclose(sim.qpos(), after, atol=tol, rtol=0)
        sim.set_state(loose)
        np.testing.assert_allclose(sim.qpos(), q, atol=tol, rtol=0)
        sim.step(40)
        np.testing.assert_allclose(sim.qpos(), after, atol=tol, rtol=0)
    with simbridge.Sim(backend) as other:
        other.load_mjcf(CHAIN, semantics="mujoco")
        other.set_state(loose)
        np.testing.assert_allclose(other.qpos(), q, atol=tol, rtol=0)
        other.step(40)
        np.testing.assert_allclose(other.qpos(), after, atol=tol, rtol=0)


def test_an_actuator_on_a_ball_joint_is_refused_by_name(backend: str) -> None:
    """MuJoCo runs a motor on a ball joint; another engine refuses it, naming the actuator."""
    _skip_unless_mujocos_reading(backend)
    with simbridge.Sim(backend) as sim:
        if steps_mujocos_reading_raw(backend):
            sim.load_mjcf(BALL_ACTUATED, semantics="mujoco")
            sim.set_actuator_controls([1.0])
            sim.step(2)
            assert abs(float(sim.qvel()[2])) > 0.0
            return
        with pytest.raises(MjcfFeatureUnsupportedError, match=r"<actuator> on a ball.*'twist'"):
            sim.load_mjcf(BALL_ACTUATED, semantics="mujoco")
        assert sim.bodies() == []


def test_a_fixed_base_takes_its_own_pose_only(backend: str) -> None:
    """The chain's base is welded where the file puts it: its own pose (what a state of this
    model holds, on any engine) is accepted and changes nothing; another is refused."""
    _skip_unless_mujocos_reading(backend)
    with simbridge.Sim(backend) as sim:
        (body,) = sim.load_mjcf(CHAIN, semantics="mujoco")
        sim.step(10)
        base, q = sim.base_state(body), sim.qpos()
        sim.reset_base_state(body, base.position, base.orientation, (0, 0, 0), (0, 0, 0))
        assert np.array_equal(sim.qpos(), q)
        moved = (base.position[0] + 0.1, *base.position[1:])
        with pytest.raises(BackendUnsupportedError, match="moving a fixed base"):
            sim.reset_base_state(body, moved)
