"""An MJCF read as MuJoCo reads it (``load_mjcf(path, semantics="mujoco")``) on every engine
that declares that reading: MuJoCo's joint order and names, ``qpos``/``qvel`` in MuJoCo's
conventions, actuators by MuJoCo's formulas, the features only MuJoCo simulates refused by
name, and the ant's standing height against raw MuJoCo (docs/mjcf_mujoco_reading.md has the
figures and the departures). The engines' own frames against MuJoCo's:
tests/backends/<engine>/test_<engine>_mjcf_mujoco.py."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import mujoco
import numpy as np
import pytest
from _gaps import gap, steps_mujocos_reading_raw

import simbridge
from simbridge.exceptions import BackendUnsupportedError, MjcfFeatureUnsupportedError

HAS_GYM = importlib.util.find_spec("gymnasium") is not None
NO_GYM = "gymnasium is not installed: pip install 'gymnasium[mujoco]==1.4.0'"


def _gym_asset(name: str) -> str:
    spec = importlib.util.find_spec("gymnasium")
    assert spec is not None and spec.origin is not None
    return str(Path(spec.origin).parent / "envs" / "mujoco" / "assets" / name)


def _reads_mujoco(backend: str) -> bool:
    return "mujoco" in simbridge.registry.load_backend(backend).semantics


# a hinge about z, no gravity, a 2 kg point 0.5 m out (I = 0.01 + 2 * 0.5² = 0.51 kg·m²) and
# four actuators on it: a motor of gear 3, one clamped by ctrlrange, one by forcerange, and a
# general one with gain 2 and bias (1, 0, -4) (force = 2 ctrl + 1 - 4 qdot)
ARM = """<mujoco><option gravity="0 0 0" timestep="0.001"/>
<worldbody><body name="arm"><joint name="hinge" type="hinge" axis="0 0 1"/>
<inertial pos="0.5 0 0" mass="2" diaginertia="0.01 0.01 0.01"/>
<geom type="sphere" size="0.05" pos="0.5 0 0" contype="0" conaffinity="0"/></body></worldbody>
<actuator><motor name="m" joint="hinge" gear="3"/>
<motor name="clamped" joint="hinge" gear="1" ctrllimited="true" ctrlrange="-1 1"/>
<motor name="capped" joint="hinge" gear="1" forcelimited="true" forcerange="-0.25 0.25"/>
<general name="g" joint="hinge" gainprm="2" biastype="affine" biasprm="1 0 -4"/>
</actuator></mujoco>"""
ARM_INERTIA = 0.51


@pytest.mark.parametrize(
    ("controls", "torque"),
    [
        ([0.5, 0.0, 0.0, -0.5], 1.5),  # gear 3 x 0.5; the general one: 2 (-0.5) + 1 = 0
        ([0.0, 5.0, 0.0, -0.5], 1.0),  # ctrl 5 clamped to ctrlrange's 1
        ([0.0, 0.0, 9.0, -0.5], 0.25),  # force 9 clamped to forcerange's 0.25
        ([0.0, 0.0, 0.0, 1.0], 3.0),  # general: 2 x 1 + 1
    ],
)
def test_an_actuator_gives_mujocos_torque(backend: str, controls: list, torque: float) -> None:
    """Known answer: from rest, one step of dt gives qdot = torque dt / I on every engine
    (float32 engines within their precision), and the joint's applied torque reads it."""
    if not _reads_mujoco(backend):
        pytest.skip(f"{backend!r} does not declare MuJoCo's reading of MJCF")
    with simbridge.Sim(backend) as sim:
        sim.load_mjcf(ARM, semantics="mujoco")
        sim.set_actuator_controls(controls)
        sim.step(1)
        qdot = float(sim.qvel()[0])
        assert qdot == pytest.approx(torque * 0.001 / ARM_INERTIA, rel=1e-4)
        assert sim.joint_states(0).applied_torques[0] == pytest.approx(torque, rel=1e-6)


def test_a_damped_general_actuator_slows_the_joint(backend: str) -> None:
    """The general actuator's velocity bias (-4 qdot) brakes a spinning joint the way MuJoCo's
    does: 0.2 s from 1 rad/s under ctrl -0.5 (no net constant force), within 2 %."""
    if not _reads_mujoco(backend):
        pytest.skip(f"{backend!r} does not declare MuJoCo's reading of MJCF")
    with simbridge.Sim(backend) as sim:
        sim.load_mjcf(ARM, semantics="mujoco")
        sim.set_actuator_controls([0.0, 0.0, 0.0, -0.5])
        sim.set_qpos_qvel([0.0], [1.0])
        sim.step(200)
        want = np.exp(-4.0 / ARM_INERTIA * 0.2)  # qdot' = -4 qdot / I
        assert float(sim.qvel()[0]) == pytest.approx(want, rel=0.02)


@pytest.mark.skipif(not HAS_GYM, reason=NO_GYM)
@pytest.mark.parametrize("name", ["ant.xml", "half_cheetah.xml"])
def test_mujocos_joint_table_and_coordinates(backend: str, name: str) -> None:
    """MuJoCo's joints in its order and names, the free joint as the base; ``qpos``/``qvel``
    at the load are MuJoCo's ``qpos0`` and rest; a state written reads back."""
    if not _reads_mujoco(backend):
        pytest.skip(f"{backend!r} does not declare MuJoCo's reading of MJCF")
    path = _gym_asset(name)
    m = mujoco.MjModel.from_xml_path(path)
    names = [
        mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
        for j in range(m.njnt)
        if m.jnt_type[j] != mujoco.mjtJoint.mjJNT_FREE
    ]
    tol = 1e-6 if simbridge.registry.state_dtype(backend) == "float32" else 1e-12
    with simbridge.Sim(backend) as sim:
        sim.load_mjcf(path, semantics="mujoco")
        assert [sim.joint_info(0, j).name for j in range(sim.num_joints(0))] == names
        np.testing.assert_allclose(sim.qpos(), m.qpos0, atol=tol)
        np.testing.assert_allclose(sim.qvel(), 0.0, atol=tol)
        rng = np.random.default_rng(3)
        q = m.qpos0 + rng.uniform(-0.2, 0.2, m.nq)
        if m.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE:
            q[3:7] /= np.linalg.norm(q[3:7])
        v = rng.uniform(-1.0, 1.0, m.nv)
        sim.set_qpos_qvel(q, v)
        np.testing.assert_allclose(sim.qpos(), q, atol=10 * tol)
        np.testing.assert_allclose(sim.qvel(), v, atol=10 * tol)
        manifest = sim.manifest()
        assert manifest["semantics"] == "mujoco"
        if not _steps_raw(backend):
            departures = manifest["departures"]
            assert {"mujoco_soft_contacts", "integrator", "actuators"} <= set(departures)
            assert ("armature" in departures) == bool(m.dof_armature.any())


ANT_SECONDS = (0.5, 5.0)


_steps_raw = steps_mujocos_reading_raw


def _raw_heights(path: str, integrator: int | None) -> list[float]:
    m = mujoco.MjModel.from_xml_path(path)
    if integrator is not None:
        m.opt.integrator = integrator
    d = mujoco.MjData(m)
    out = []
    for t in ANT_SECONDS:
        mujoco.mj_step(m, d, nstep=round(t / m.opt.timestep) - round(d.time / m.opt.timestep))
        out.append(float(d.qpos[2]))
    return out


@pytest.mark.skipif(not HAS_GYM, reason=NO_GYM)
def test_the_ant_stands_at_gymnasiums_height_or_the_departure_is_named(backend: str) -> None:
    """Gymnasium's ant, zero controls, from ``qpos0``: raw MuJoCo (RK4, the file's) stands at
    0.5930 m after 0.5 s and 0.5438 m after 5 s, and at 0.6206 / 0.6117 m under its Euler
    integrator. Each engine within its measured bound of its reference (_gaps.py); the
    MuJoCo backend is raw MuJoCo exactly; another engine names the integrator and MuJoCo's
    soft contacts as departures."""
    if not _reads_mujoco(backend):
        pytest.skip(f"{backend!r} does not declare MuJoCo's reading of MJCF")
    path = _gym_asset("ant.xml")
    refs = {
        "rk4": _raw_heights(path, None),
        "euler": _raw_heights(path, int(mujoco.mjtIntegrator.mjINT_EULER)),
    }
    with simbridge.Sim(backend) as sim:
        sim.load_mjcf(path, semantics="mujoco")
        heights = []
        for t in ANT_SECONDS:
            sim.step(round(t / 0.01) - round(sim.time / 0.01))
            heights.append(float(sim.qpos()[2]))
        if _steps_raw(backend):
            assert heights == refs["rk4"]
            return
        assert {"integrator", "mujoco_soft_contacts"} <= set(sim.manifest()["departures"])
    rk4 = gap(backend, "mjcf_ant_height_rk4")
    euler = gap(backend, "mjcf_ant_height_euler")
    ref, tol = ("rk4", rk4) if rk4 is not None else ("euler", euler)
    assert tol is not None
    assert abs(heights[1] - refs[ref][1]) < tol, (backend, heights, refs)
    assert 0.3 < heights[0] < 0.7, heights  # standing, not collapsed (0.25 m) nor thrown


@pytest.mark.skipif(not HAS_GYM, reason=NO_GYM)
def test_the_ant_rests_on_its_feet_on_the_files_floor(backend: str) -> None:
    """Contact points under MuJoCo's reading: after 5 s at rest the ant touches its file's
    floor (the world's geom: body -1, link -1) with its four feet only (the geoms of the bodies
    without joints below each ankle: the ankle rows 1, 3, 5, 7), each point's normal up from
    the floor, and the points carry its weight: the mean over 0.5 s of the total normal force
    within 2% of m g (measured: MuJoCo 1.0000, PyBullet 1.0001; at 2 s PyBullet's ant still
    sinks and carries 0.946)."""
    if not _reads_mujoco(backend):
        pytest.skip(f"{backend!r} does not declare MuJoCo's reading of MJCF")
    path = _gym_asset("ant.xml")
    m = mujoco.MjModel.from_xml_path(path)
    weight = float(np.sum(m.body_mass)) * float(-m.opt.gravity[2])
    with simbridge.Sim(backend) as sim:
        (ant,) = sim.load_mjcf(path, semantics="mujoco")
        sim.step(500)
        totals = []
        for _ in range(50):
            sim.step()
            points = sim.contact_points(ant)
            totals.append(sum(c.normal_force for c in points))
        assert {(c.body_a, c.link_a, c.body_b, c.link_b) for c in points} == {
            (ant, row, -1, -1) for row in (1, 3, 5, 7)
        }
        assert all(np.allclose(c.normal_on_b, (0.0, 0.0, 1.0), atol=1e-3) for c in points)
    assert float(np.mean(totals)) == pytest.approx(weight, rel=0.02)


TENDON = """<mujoco><worldbody>
<body name="a"><joint name="j1" type="hinge"/><geom size="0.1"/>
<body name="b" pos="0 0 -0.3"><joint name="j2" type="hinge"/><geom size="0.1"/></body></body>
</worldbody><tendon><fixed name="coupling"><joint joint="j1" coef="1"/><joint joint="j2" coef="-1"/>
</fixed></tendon></mujoco>"""
EQUALITY = """<mujoco><worldbody>
<body name="a"><joint name="j1" type="hinge"/><geom size="0.1"/></body>
<body name="b" pos="1 0 0"><joint name="j2" type="hinge"/><geom size="0.1"/></body>
</worldbody><equality><joint name="same" joint1="j1" joint2="j2"/></equality></mujoco>"""


@pytest.mark.parametrize(
    ("text", "feature", "element"),
    [
        (TENDON, "<tendon>", "coupling"),
        (EQUALITY, "<equality>", "same"),
    ],
)
def test_what_only_mujoco_simulates_is_refused_by_name(
    backend: str, text: str, feature: str, element: str
) -> None:
    """A tendon or an equality constraint: MuJoCo runs it; another engine refuses it, naming
    the feature and its element, and keeps its world as it was (a ball joint loads:
    test_mjcf_ball_joints.py)."""
    with simbridge.Sim(backend) as sim:
        if _steps_raw(backend):
            sim.load_mjcf(text, semantics="mujoco")
            sim.step(2)
            return
        if not _reads_mujoco(backend):
            with pytest.raises(BackendUnsupportedError, match="MJCF read as MuJoCo reads it"):
                sim.load_mjcf(text, semantics="mujoco")
            return
        with pytest.raises(
            MjcfFeatureUnsupportedError,
            match=rf"'{backend}' does not support {feature} \('{element}' in <MJCF text>\)",
        ) as info:
            sim.load_mjcf(text, semantics="mujoco")
        assert (info.value.feature, info.value.element) == (feature, element)
        sim.load_urdf("r2d2.urdf")  # the world is the Sim's own still


FRICTIONLOSS = """<mujoco><option gravity="0 0 0" timestep="0.001"/>
<worldbody><body name="arm"><joint name="hinge" type="hinge" axis="0 0 1" frictionloss="1"/>
<inertial pos="0.5 0 0" mass="2" diaginertia="0.01 0.01 0.01"/></body></worldbody>
<actuator><motor name="m" joint="hinge"/></actuator></mujoco>"""


def test_frictionloss_holds_below_it_and_slips_above(backend: str) -> None:
    """A hinge with frictionloss 1 N·m: a 0.5 N·m motor leaves it (nearly) still for 0.1 s
    (MuJoCo's soft friction creeps to 0.0010 rad/s, PhysX's clamped force 0.0010, PyBullet's
    velocity motor 0), a 2 N·m one turns it at (2 - 1) t / I (within 2 %: PhysX measured 1 %
    over, its friction force one step late)."""
    if not _reads_mujoco(backend):
        pytest.skip(f"{backend!r} does not declare MuJoCo's reading of MJCF")
    with simbridge.Sim(backend) as sim:
        sim.load_mjcf(FRICTIONLOSS, semantics="mujoco")
        sim.set_actuator_controls([0.5])
        sim.step(100)
        assert abs(float(sim.qvel()[0])) < 0.002
        sim.set_qpos_qvel([0.0], [0.0])
        sim.set_actuator_controls([2.0])
        sim.step(100)
        assert float(sim.qvel()[0]) == pytest.approx(1.0 * 0.1 / ARM_INERTIA, rel=0.02)


SPRING = """<mujoco><compiler angle="radian"/><option gravity="0 0 0" timestep="0.001"/>
<worldbody><body name="arm"><joint name="hinge" type="hinge" axis="0 0 1" stiffness="4"
springref="0.5"/><inertial pos="0.5 0 0" mass="2" diaginertia="0.01 0.01 0.01"/></body>
</worldbody></mujoco>"""


def test_a_joint_spring_pulls_toward_springref(backend: str) -> None:
    """``stiffness`` 4 N·m/rad, ``springref`` 0.5 rad: from q = 0 at rest one step gives
    qdot = 4 (0.5 - 0) dt / I on every engine (the spring is MuJoCo's ``qfrc_spring``)."""
    if not _reads_mujoco(backend):
        pytest.skip(f"{backend!r} does not declare MuJoCo's reading of MJCF")
    with simbridge.Sim(backend) as sim:
        sim.load_mjcf(SPRING, semantics="mujoco")
        sim.step(1)
        assert float(sim.qvel()[0]) == pytest.approx(4.0 * 0.5 * 0.001 / ARM_INERTIA, rel=1e-4)


DAMPED = """<mujoco><option gravity="0 0 0" timestep="0.01"/>
<worldbody><body name="arm"><joint name="hinge" type="hinge" axis="0 0 1" damping="5"
armature="0.1"/><inertial pos="0.5 0 0" mass="2" diaginertia="0.01 0.01 0.01"/></body>
</worldbody><actuator><motor name="m" joint="hinge"/></actuator></mujoco>"""


def test_joint_damping_is_implicit_in_every_force(backend: str) -> None:
    """Known answer of MuJoCo's Euler, whose damping is implicit in every force: from rest a
    2 N·m motor on a hinge of inertia I 0.51 plus armature A 0.1, damping D 5, gives after one
    step of dt 0.01 qdot = 2 dt / (I + A + dt D) = 0.030303 rad/s, on every engine (float32
    engines within their precision). A damping force implicit in the velocity alone is 0 at
    rest and gave 2 dt / (I + A) = 0.032787 (8 % over); on Gymnasium's half cheetah it made
    the actuators and springs stronger than MuJoCo's (docs/mjcf_mujoco_reading.md)."""
    if not _reads_mujoco(backend):
        pytest.skip(f"{backend!r} does not declare MuJoCo's reading of MJCF")
    with simbridge.Sim(backend) as sim:
        sim.load_mjcf(DAMPED, semantics="mujoco")
        sim.set_actuator_controls([2.0])
        sim.step(1)
        qdot = float(sim.qvel()[0])
    assert qdot == pytest.approx(2.0 * 0.01 / (ARM_INERTIA + 0.1 + 0.01 * 5.0), rel=1e-4)


@pytest.mark.skipif(not HAS_GYM, reason=NO_GYM)
def test_the_half_cheetah_in_the_air_follows_raw_mujoco(backend: str) -> None:
    """Gymnasium's half cheetah lifted 2 m, gravity 0 (no contact), under its reference gait's
    controls (HalfCheetahGait, held 5 steps) for 1 s: every joint within the engine's measured
    bound of raw MuJoCo's ``mj_step`` (_gaps.py ``mjcf_cheetah_air``; the MuJoCo backend:
    exactly). Its damping (1.5-6 N·m·s/rad) and armature (0.1) against joints of 0.1-0.5
    kg·m²: with the damping implicit in the velocity alone PyBullet was 0.13 rad off."""
    if not _reads_mujoco(backend):
        pytest.skip(f"{backend!r} does not declare MuJoCo's reading of MJCF")
    from simbridge.envs.controllers import GAITS

    gait = GAITS["half_cheetah"]
    amp, phase = np.array(gait["amplitude"]), np.array(gait["phase"])

    def ctrl(t: float) -> np.ndarray:
        return np.clip(amp * np.sin(2 * np.pi * gait["frequency"] * t + phase), -1, 1)

    path = _gym_asset("half_cheetah.xml")
    m = mujoco.MjModel.from_xml_path(path)
    m.opt.gravity[:] = 0.0
    d = mujoco.MjData(m)
    q0 = m.qpos0.copy()
    q0[1] += 2.0
    d.qpos[:] = q0
    ref = []
    for i in range(100):
        if i % 5 == 0:
            d.ctrl[:] = ctrl(i * 0.01)
        mujoco.mj_step(m, d)
        ref.append(d.qpos.copy())
    with simbridge.Sim(backend, gravity=(0.0, 0.0, 0.0)) as sim:
        sim.load_mjcf(path, semantics="mujoco")
        sim.set_qpos_qvel(q0, np.zeros(m.nv))
        out = []
        for i in range(100):
            if i % 5 == 0:
                sim.set_actuator_controls(ctrl(i * 0.01))
            sim.step(1)
            out.append(np.array(sim.qpos()))
    err = float(np.abs(np.array(out) - np.array(ref)).max())
    size = gap(backend, "mjcf_cheetah_air")
    if size is None:
        assert err == 0.0
    else:
        assert err < size, (backend, err)


def _cheetah_distances(backend: str) -> list[float]:
    """The half cheetah's distance along +x after 200 control steps (10 s) of its reference
    gait, seeds 0-3, through the ``half_cheetah`` env."""
    from simbridge.envs.controllers import HalfCheetahGait
    from simbridge.envs.env import SimEnv

    env = SimEnv("half_cheetah", backend=backend)
    try:
        gait, out = HalfCheetahGait(env), []
        for seed in range(4):
            obs, _ = env.reset(seed=seed)
            for _ in range(200):
                obs, *_ = env.step(gait(obs))
            out.append(float(env.sim.qpos()[0] - env.world.qpos_start[0]))
        return out
    finally:
        env.close()


@pytest.mark.skipif(not HAS_GYM, reason=NO_GYM)
def test_the_half_cheetah_runs_its_gait_as_on_mujoco(backend: str) -> None:
    """The armature and damping of a running gait, whose foot contacts change every step:
    Gymnasium's half cheetah under its reference gait covers 14.1-14.6 m in 10 s on MuJoCo
    (seeds 0-3); every engine within its measured bound of that, seed by seed (_gaps.py
    ``mjcf_cheetah_gait``; the MuJoCo backend: exactly). PyBullet's armature force with the
    step before's contact forces gave 2.5-11.9 m (2.2-12.1 m short)."""
    if not _reads_mujoco(backend):
        pytest.skip(f"{backend!r} does not declare MuJoCo's reading of MJCF")
    got, ref = _cheetah_distances(backend), _cheetah_distances("mujoco")
    assert min(ref) > 10.0, ref  # the gait runs on the reference
    size = gap(backend, "mjcf_cheetah_gait")
    if size is None:
        assert got == ref
    else:
        assert max(abs(a - b) for a, b in zip(got, ref, strict=True)) < size, (got, ref)


STACK = """<mujoco><option timestep="0.002"/><worldbody><geom type="plane" size="5 5 0.1"/>
<body name="low" pos="0 0 0.1"><freejoint/><geom type="sphere" size="0.1" mass="1"/></body>
<body name="high" pos="0 0 0.35"><freejoint/><geom type="sphere" size="0.1" mass="1"/></body>
<body name="ghost" pos="1 0 0.1"><freejoint/>
<geom type="sphere" size="0.1" mass="1" contype="0" conaffinity="0"/></body>
</worldbody>{contact}</mujoco>"""
EXCLUDE = '<contact><exclude body1="low" body2="high"/></contact>'


@pytest.mark.parametrize("exclude", [False, True])
def test_contype_conaffinity_and_exclude_filter_contacts(backend: str, exclude: bool) -> None:
    """After 1 s: a sphere of contype/conaffinity 0 has fallen through the floor; the upper of
    two stacked spheres rests on the lower (centre near 0.3 m), or, with an ``<exclude>`` of
    the pair (two top-level bodies: on PhysX one contact-filter tag and ignore bits shared by
    both), sinks into it (centre near 0.1 m)."""
    if not _reads_mujoco(backend):
        pytest.skip(f"{backend!r} does not declare MuJoCo's reading of MJCF")
    text = STACK.format(contact=EXCLUDE if exclude else "")
    with simbridge.Sim(backend) as sim:
        sim.load_mjcf(text, semantics="mujoco")
        sim.step(500)
        q = sim.qpos()
    low, high, ghost = q[2], q[9], q[16]
    assert ghost < -1.0
    assert low == pytest.approx(0.1, abs=0.01)
    assert high == pytest.approx(0.1 if exclude else 0.3, abs=0.01)


KEYED = """<mujoco><compiler angle="radian"/><option gravity="0 0 0"/><worldbody>
<body name="arm"><joint name="hinge" type="hinge" axis="0 0 1"/>
<geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.05"/>
<site name="tip" pos="0.5 0 0"/></body></worldbody>
<sensor><jointpos name="angle" joint="hinge"/><framepos name="where" objtype="site" objname="tip"/>
</sensor><keyframe><key name="quarter" qpos="1.5707963267948966" qvel="0.25"/></keyframe>
</mujoco>"""


def test_keyframes_sites_and_sensors_read_the_engines_state(backend: str) -> None:
    """``reset_keyframe`` puts the engine in the key's state; the site and the sensors are
    MuJoCo's of that state on every engine."""
    if not _reads_mujoco(backend):
        pytest.skip(f"{backend!r} does not declare MuJoCo's reading of MJCF")
    tol = 1e-6 if simbridge.registry.state_dtype(backend) == "float32" else 1e-12
    with simbridge.Sim(backend) as sim:
        sim.load_mjcf(KEYED, semantics="mujoco")
        sim.reset_keyframe("quarter")
        assert float(sim.qpos()[0]) == pytest.approx(np.pi / 2, abs=tol)
        assert float(sim.qvel()[0]) == pytest.approx(0.25, abs=tol)
        np.testing.assert_allclose(sim.site("tip").position, (0.0, 0.5, 0.0), atol=tol)
        np.testing.assert_allclose(sim.sensor("angle"), [np.pi / 2], atol=tol)
        sim.step(100)  # 0.2 s at 0.25 rad/s, nothing acting
        angle = np.pi / 2 + 0.05
        np.testing.assert_allclose(sim.sensor("angle"), [angle], atol=1e-5)
        np.testing.assert_allclose(
            sim.sensor("where"), (0.5 * np.cos(angle), 0.5 * np.sin(angle), 0.0), atol=1e-5
        )


@pytest.mark.skipif(not HAS_GYM, reason=NO_GYM)
def test_a_snapshot_restores_and_reset_empties_the_world(backend: str) -> None:
    """The ant under a constant control, its state taken after 0.2 s: 30 more steps from the
    restored state end where the unbroken run did (MuJoCo: exactly; PyBullet measured 4.8e-14,
    PhysX 3.6e-7: the engine's contact caches and the armature force's memory start afresh);
    ``reset()`` then gives back the Sim's own empty world."""
    if not _reads_mujoco(backend):
        pytest.skip(f"{backend!r} does not declare MuJoCo's reading of MJCF")
    tol = 1e-5 if simbridge.registry.state_dtype(backend) == "float32" else 1e-10
    with simbridge.Sim(backend) as sim:
        sim.load_mjcf(_gym_asset("ant.xml"), semantics="mujoco")
        sim.set_actuator_controls(np.full(8, 0.3))
        sim.step(20)
        state = sim.get_state()
        sim.step(30)
        unbroken = sim.qpos()
        sim.set_state(state)
        sim.step(30)
        np.testing.assert_allclose(sim.qpos(), unbroken, atol=0.0 if _steps_raw(backend) else tol)
        sim.reset()
        assert sim.load_urdf("r2d2.urdf") == 0
