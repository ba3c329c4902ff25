"""``load_mjcf(source, semantics="mujoco")``: the model as MuJoCo compiles it, stepped as raw
MuJoCo steps it (issue 33, items 1, 2 and 6's refusals).

Known answers: bit for bit ``mujoco.mj_step`` on ``MjModel.from_xml_path`` under the same
controls (gymnasium's ant and half cheetah, mujoco's own test model with ball joints, position
actuators, a keyframe, sensors and sites), and Gymnasium's Ant-v5 and HalfCheetah-v5 step for
step (skipped with a reason when gymnasium is not installed).
"""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import mujoco
import numpy as np
import pytest

import simbridge
from simbridge.exceptions import (
    BackendUnsupportedError,
    InvalidArgumentError,
    MjcfCompileError,
    MjcfFeatureUnsupportedError,
    SimClosedError,
    UnknownBodyError,
    UnknownObjectError,
)
from simbridge.types import JointType

MUJOCO_TEST_MODEL = Path(mujoco.__file__).parent / "testdata" / "model.xml"  # ball joints
HAS_GYM = importlib.util.find_spec("gymnasium") is not None
NO_GYM = "gymnasium is not installed: pip install 'gymnasium[mujoco]==1.4.0'"


def _gym_asset(name: str) -> str:
    spec = importlib.util.find_spec("gymnasium")
    assert spec is not None and spec.origin is not None
    return os.path.join(os.path.dirname(spec.origin), "envs", "mujoco", "assets", name)


MODELS = [
    pytest.param("ant.xml", marks=pytest.mark.skipif(not HAS_GYM, reason=NO_GYM)),
    pytest.param("half_cheetah.xml", marks=pytest.mark.skipif(not HAS_GYM, reason=NO_GYM)),
    pytest.param(str(MUJOCO_TEST_MODEL)),
]


def _path(name: str) -> str:
    return name if os.path.isabs(name) else _gym_asset(name)


@pytest.mark.parametrize("name", MODELS)
def test_steps_bit_for_bit_as_raw_mj_step(name: str) -> None:
    path = _path(name)
    m = mujoco.MjModel.from_xml_path(path)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(1)
    with simbridge.Sim("mujoco") as sim:
        sim.load_mjcf(path, semantics="mujoco")
        assert sim.timestep == m.opt.timestep  # the file's <option>
        for k in range(200):
            ctrl = rng.uniform(-1.0, 1.0, m.nu)
            d.ctrl[:] = ctrl
            mujoco.mj_step(m, d, nstep=3)
            sim.set_actuator_controls(ctrl)
            sim.step(3)
            if k % 5 == 0:  # reads change nothing
                for body in sim.bodies():
                    sim.base_state(body)
                    sim.joint_states(body)
            if k % 11 == 0 and m.nsensor:
                sim.sensor(0)
            assert np.array_equal(sim.qpos(), d.qpos), k
            assert np.array_equal(sim.qvel(), d.qvel), k
        assert sim.time == d.time


@pytest.mark.skipif(not HAS_GYM, reason=NO_GYM)
@pytest.mark.parametrize("env_id", ["Ant-v5", "HalfCheetah-v5"])
def test_gymnasium_env_step_for_step(env_id: str) -> None:
    import gymnasium

    env = gymnasium.make(env_id)
    env.reset(seed=7)
    raw = env.unwrapped
    xml = "ant.xml" if env_id == "Ant-v5" else "half_cheetah.xml"
    rng = np.random.default_rng(7)
    with simbridge.Sim("mujoco") as sim:
        sim.load_mjcf(_gym_asset(xml), semantics="mujoco")
        sim.set_qpos_qvel(raw.data.qpos, raw.data.qvel)
        for k in range(300):
            action = rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32)
            env.step(action)
            sim.set_actuator_controls(action)
            sim.step(raw.frame_skip)
            assert np.array_equal(sim.qpos(), raw.data.qpos), k
            assert np.array_equal(sim.qvel(), raw.data.qvel), k
    env.close()


@pytest.mark.skipif(not HAS_GYM, reason=NO_GYM)
def test_the_ant_stands_at_gymnasiums_height() -> None:
    """Zero controls, no reset noise: 0.593 m after 0.5 s, 0.544 m after 5 s, as raw MuJoCo
    (through PyBullet's reading of the file it collapses to 0.266 m)."""
    with simbridge.Sim("mujoco") as sim:
        (ant,) = sim.load_mjcf(_gym_asset("ant.xml"), semantics="mujoco")
        sim.set_qpos_qvel(sim.qpos())  # the init pose: Ant-v5's without noise
        sim.step(50)
        assert sim.base_state(ant).position[2] == pytest.approx(0.5930, abs=1e-4)
        sim.step(450)
        assert sim.base_state(ant).position[2] == pytest.approx(0.5438, abs=1e-4)


def test_the_mapping_onto_bodies_and_joints() -> None:
    m = mujoco.MjModel.from_xml_path(str(MUJOCO_TEST_MODEL))
    with simbridge.Sim("mujoco") as sim:
        ids = sim.load_mjcf(MUJOCO_TEST_MODEL, semantics="mujoco")
        tops = [b for b in range(1, m.nbody) if m.body_parentid[b] == 0]
        assert ids == tuple(range(len(tops)))
        head = sim.joints(0)
        names = [r.name for r in head]
        assert names[:3] == ["hipz_0", "hipy_0", "wheel_0"]
        assert head[2].type == JointType.SPHERICAL
        assert head[0].q_index == m.jnt_qposadr[1] and head[0].damping == m.dof_damping[6]
        assert head[1].parent_index == 0  # a body's second joint hangs from its first
        assert sim.manifest()["bodies"][0]["semantics"] == "mujoco"
        assert sim.manifest()["option"]["integrator"] == "mjINT_EULER"
        assert len(sim.actuators()) == m.nu
        position = [a for a in sim.actuators() if a.bias == "affine"]
        assert position and position[0].gain_params[0] == 100.0  # <position kp="100">


def test_keyframe_sensor_site_and_state() -> None:
    m = mujoco.MjModel.from_xml_path(str(MUJOCO_TEST_MODEL))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    mujoco.mj_forward(m, d)
    with simbridge.Sim("mujoco") as sim:
        sim.load_mjcf(MUJOCO_TEST_MODEL, semantics="mujoco")
        sim.reset_keyframe("start")
        assert np.array_equal(sim.qpos(), d.qpos)
        assert np.array_equal(sim.sensor(3), d.sensordata[m.sensor_adr[3] :][: m.sensor_dim[3]])
        assert sim.site("head").position == tuple(d.site_xpos[1])
        # get_state/set_state with its ball joints: MuJoCo's own state back, bit for bit
        sim.step(5)
        state = sim.get_state()
        loose = sim.get_state(exact=False)
        balls = [e for b in state.bodies for e in b.spherical]
        assert balls and balls[0].position == tuple(
            sim.qpos()[sim.joint_info(0, balls[0].joint).q_index :][[1, 2, 3, 0]]
        )
        sim.step(10)
        after = sim.qpos()
        sim.set_state(state)
        sim.step(10)
        assert np.array_equal(sim.qpos(), after)
        sim.set_state(loose)  # the portable state alone (no MjData snapshot)
        sim.step(10)
        assert np.allclose(sim.qpos(), after, atol=1e-9)


@pytest.mark.skipif(not HAS_GYM, reason=NO_GYM)
def test_get_state_and_set_state_step_on_bit_for_bit() -> None:
    with simbridge.Sim("mujoco") as sim:
        sim.load_mjcf(_gym_asset("ant.xml"), semantics="mujoco")
        sim.set_actuator_controls(np.full(8, 0.3))
        sim.step(20)
        state = sim.get_state()
        sim.step(10)
        after = sim.qpos()
        sim.set_state(state)
        sim.step(10)
        assert np.array_equal(sim.qpos(), after)


def test_the_files_option_wins_unless_given() -> None:
    with simbridge.Sim("mujoco", timestep=0.005, gravity=(0, 0, -1)) as sim:
        sim.load_mjcf(MUJOCO_TEST_MODEL, semantics="mujoco")
        assert sim.timestep == 0.005 and sim.gravity == (0.0, 0.0, -1.0)
    with simbridge.Sim("mujoco") as sim:
        assert sim.timestep == 1 / 240  # the Sim's default until such a model is loaded
        sim.load_mjcf(MUJOCO_TEST_MODEL, semantics="mujoco")
        assert sim.timestep == mujoco.MjModel.from_xml_path(str(MUJOCO_TEST_MODEL)).opt.timestep
        sim.reset()
        assert sim.timestep == 1 / 240 and sim.bodies() == []
        sim.load_urdf("plane.urdf")  # an ordinary world again


def test_reset_remakes_the_sims_own_engine_and_close_ends_the_model() -> None:
    sim = simbridge.Sim("mujoco", gravity=(0, 0, -2), divergence_check="every_step")
    ids = sim.load_mjcf(MUJOCO_TEST_MODEL, semantics="mujoco")
    sim.reset()  # a new engine of the Sim's own recipe: its gravity, time step and check
    assert sim.gravity == (0.0, 0.0, -2.0) and sim.timestep == 1 / 240
    assert sim.manifest()["divergence_check"] == "every_step"
    with pytest.raises(BackendUnsupportedError, match="without a model read with"):
        sim.qpos()
    assert sim.load_mjcf(MUJOCO_TEST_MODEL, semantics="mujoco") == ids  # again after reset
    sim.close()
    assert sim.closed
    with pytest.raises(SimClosedError):
        sim.qpos()
    with pytest.raises(SimClosedError):
        sim.load_mjcf(MUJOCO_TEST_MODEL, semantics="mujoco")


def test_the_model_is_the_whole_world() -> None:
    with simbridge.Sim("mujoco") as sim:
        sim.load_urdf("plane.urdf")
        with pytest.raises(BackendUnsupportedError, match=r"already holds bodies \[0\].*whole"):
            sim.load_mjcf(MUJOCO_TEST_MODEL, semantics="mujoco")
    with simbridge.Sim("mujoco") as sim:
        sim.load_mjcf(MUJOCO_TEST_MODEL, semantics="mujoco")
        with pytest.raises(BackendUnsupportedError, match="load_urdf after an MJCF read with"):
            sim.load_urdf("plane.urdf")
        with pytest.raises(BackendUnsupportedError, match="load_mjcf after an MJCF read"):
            sim.load_mjcf("mjcf/ant.xml")
        with pytest.raises(BackendUnsupportedError, match="actuators drive it|set_actuator"):
            sim.set_joint_torque(0, 0, 1.0)
        with pytest.raises(UnknownObjectError, match="no actuator 'nope'; valid actuators"):
            sim.set_actuator_controls([0.0], ["nope"])
        with pytest.raises(InvalidArgumentError, match="expected 49 numbers, got 2"):
            sim.set_qpos_qvel([0.0, 1.0])


@pytest.mark.parametrize("backend", ["pybullet", "physx"])
def test_other_engines_refuse_what_only_mujoco_simulates(backend: str) -> None:
    """MuJoCo's test model has a spatial tendon: PyBullet and PhysX run MuJoCo's reading
    (tests/backends/<engine>/test_*_mjcf_mujoco.py) but refuse a tendon by its name, and the
    world stays as it was."""
    if backend == "physx" and importlib.util.find_spec("sapien") is None:
        pytest.skip("sapien is not installed")
    with simbridge.Sim(backend) as sim:
        with pytest.raises(
            MjcfFeatureUnsupportedError,
            match=r"'\w+' does not support <tendon> \('spatial' in .*model\.xml\) under "
            r"semantics='mujoco' \(a tendon couples joints.*only the 'mujoco' backend",
        ):
            sim.load_mjcf(MUJOCO_TEST_MODEL, semantics="mujoco")
        with pytest.raises(BackendUnsupportedError, match="without a model read with"):
            sim.qpos()


def test_bad_semantics_and_files_mujoco_refuses(tmp_path: Path) -> None:
    with simbridge.Sim("mujoco") as sim:
        with pytest.raises(InvalidArgumentError, match=r"expected one of \['pybullet', 'mujoco'\]"):
            sim.load_mjcf(MUJOCO_TEST_MODEL, semantics="MuJoCo")
        bad = tmp_path / "bad.xml"
        bad.write_text(
            '<mujoco>\n<worldbody>\n<body>\n<joint type="bogus"/>\n</body>\n'
            "</worldbody>\n</mujoco>\n"
        )
        with pytest.raises(
            MjcfCompileError,
            match=r"bad\.xml:4: MuJoCo's compiler refuses the MJCF: XML Error: invalid "
            r"keyword: 'bogus' Element 'joint', line 4",
        ):
            sim.load_mjcf(bad, semantics="mujoco")
        assert sim.bodies() == []
        # not well-formed XML: the parser's own "Line number=4" becomes FILE:LINE too
        broken = tmp_path / "broken.xml"
        broken.write_text(
            '<mujoco>\n<worldbody>\n<body>\n<geom type="sphere" size="0.1">\n</body>\n'
            "</worldbody>\n</mujoco>\n"
        )
        with pytest.raises(
            MjcfCompileError,
            match=r"broken\.xml:4: MuJoCo's compiler refuses the MJCF: XML parse error .*"
            r"Line number=4",
        ):
            sim.load_mjcf(broken, semantics="mujoco")
        assert sim.bodies() == []


@pytest.mark.skipif(not HAS_GYM, reason=NO_GYM)
def test_contact_points_are_mujocos_own_with_the_floor_as_body_minus_one() -> None:
    """The ant at rest on its file's floor: one contact per foot, each MuJoCo's own force
    (``mj_contactForce`` of the same step), the floor (a geom of the world body) as body -1."""
    path = _gym_asset("ant.xml")
    m = mujoco.MjModel.from_xml_path(path)
    d = mujoco.MjData(m)
    mujoco.mj_step(m, d, nstep=100)
    raw = np.zeros(6)
    raw_total = 0.0
    for i in range(d.ncon):
        mujoco.mj_contactForce(m, d, i, raw)
        raw_total += raw[0]
    with simbridge.Sim("mujoco") as sim:
        (ant,) = sim.load_mjcf(path, semantics="mujoco")
        sim.step(100)
        points = sim.contact_points(ant)
        feet = sorted(c.link_a for c in points)
        names = [sim.joint_info(ant, j).link_name for j in feet]
        assert len(points) == d.ncon == 4
        assert all(c.body_a == ant and c.body_b == -1 and c.link_b == -1 for c in points)
        # each foot geom hangs from a body with no joint of its own: its ankle's link
        assert names == ["body4", "body7", "body10", "body13"]
        # B's normal points from the floor (B) up to the foot (A), as PyBullet's does
        assert all(c.normal_on_b == pytest.approx((0.0, 0.0, 1.0)) for c in points)
        assert sum(c.normal_force for c in points) == pytest.approx(raw_total, rel=1e-12)
        with pytest.raises(UnknownBodyError):  # the world is no body a caller selects
            sim.contact_points(-1)
