"""Spherical joints on every backend, against raw PyBullet 3.2.7 (issue 14, item 2).

What PyBullet does, measured and read in its source (simbridge/spherical.py has the whole
story): a URDF ``type="spherical"`` joint is ``getJointInfo`` type 2 with 4 position and 3
velocity coordinates, axis (0, 0, 0) and flags 0; ``getJointState`` reports its first
coordinate; ``resetJointState`` leaves it as it is; its motor (``btMultiBodySphericalJointMotor``,
one row per axis of the child's inertial frame) is at load a hold at the identity with kp 0.2
and 1000 N·m·s per step, and ``setJointMotorControlMultiDof``'s POSITION_CONTROL changes its
target, kp, damping and force per axis (velocityGain and targetVelocity are read by nothing;
VELOCITY_CONTROL is refused); TORQUE_CONTROL adds 3 torques for one step.

Each backend is held to raw PyBullet making the same calls on the same robot
(``robots/spherical_pendulum.urdf``, whose bob's inertial frame is turned, and pybullet_data's
``humanoid/humanoid.urdf`` and ``spherical_joint_limit.urdf``); the tolerances carry the
largest difference measured over the run and why it is not zero. The cross-engine agreement on
the free-swinging pendulum, under both profiles, closes the file.
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Callable
from typing import Any

import _raw
import _reference as ref
import numpy as np
import pytest
from _gaps import REFERENCE, against_reference, gap, tolerance, usable_backends

import simbridge
from simbridge import exceptions as exc
from simbridge.transforms import quat_from_rpy

DATA = _raw.DATA
PENDULUM = ref.robot_path("spherical_pendulum.urdf")
HUMANOID = os.path.join(DATA, "humanoid", "humanoid.urdf")
LIMITED = os.path.join(DATA, "spherical_joint_limit.urdf")
POSE = ((0.1, -0.2, 1.3), (0.0, 0.0, math.sin(0.3), math.cos(0.3)))
DT = 1.0 / 240.0


def _normalised(q: tuple[float, ...]) -> tuple[float, ...]:
    """As the Sim divides a quaternion by its norm (so raw PyBullet gets the same bits)."""
    norm = math.sqrt(sum(c * c for c in q))
    return tuple(c / norm for c in q)


Q0 = _normalised(quat_from_rpy((0.6, -0.4, 0.3)))  # the start: 0.7 rad from hanging
V0 = (1.5, -0.7, 2.0)  # rad/s, in the bob's inertial frame
TARGET = _normalised(quat_from_rpy((-0.2, 0.4, 0.5)))


def _pybullet() -> Any:
    p, _ = _raw.raw_client()
    return p


# ---------------------------------------------------------------- the joint table and frames


@pytest.mark.parametrize("fixed_base", [False, True], ids=["free", "fixed"])
@pytest.mark.parametrize("path", [PENDULUM, HUMANOID, LIMITED], ids=os.path.basename)
def test_joint_table_and_link_frames_are_raw_pybullets(make_sim, path, fixed_base):
    raw = _raw.raw_load(
        path, base_position=POSE[0], base_orientation=POSE[1], fixed_base=fixed_base
    )
    sim = make_sim()
    body = sim.load_urdf(
        path, base_position=POSE[0], base_orientation=POSE[1], fixed_base=fixed_base
    )
    assert _raw.table_difference(sim.joints(body), raw.table) is None
    assert (
        _raw.frames_difference(_raw.sim_frames(sim, body), raw.frames, _raw.frame_rel(sim.backend))
        is None
    )
    spherical = [j for j in sim.joints(body) if j.type == simbridge.JointType.SPHERICAL]
    assert spherical, "the file has spherical joints"
    for j in spherical:  # the measured facts, written out
        assert j.axis == (0.0, 0.0, 0.0) and j.flags == 0
    qs = [j.q_index for j in sim.joints(body) if j.q_index >= 0]
    us = [j.u_index for j in sim.joints(body) if j.u_index >= 0]
    sizes = [4 if j.type == 2 else 1 for j in sim.joints(body) if j.q_index >= 0]
    assert qs == [7 + sum(sizes[:k]) for k in range(len(qs))]
    assert us == [6 + sum(3 if s == 4 else 1 for s in sizes[:k]) for k in range(len(us))]


def test_a_floating_joint_is_welded_as_pybullet_welds_it(make_sim, caplog):
    text = (
        '<robot name="f"><link name="a"><inertial><mass value="1"/><inertia ixx="1" ixy="0" '
        'ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link><link name="b"><inertial><mass '
        'value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>'
        '</link>\n<joint name="j" type="floating"><parent link="a"/><child link="b"/>'
        '<origin xyz="0 0 1"/><limit lower="-1" upper="1" effort="5" velocity="2"/></joint>'
        "</robot>"
    )
    raw = _raw.raw_load(text)
    assert raw.table[0][2] == simbridge.JointType.FIXED  # "creating a fixed joint instead"
    caplog.set_level(logging.WARNING, logger="simbridge.model.urdf")
    sim = make_sim()
    body = sim.load_urdf(text)
    assert _raw.table_difference(sim.joints(body), raw.table) is None
    assert "line 2: joint 'j' type 'floating' read as 'fixed'" in caplog.text


# ---------------------------------------------------------------- states after resets


def _unit(v: np.ndarray) -> list[float]:
    return (v / np.linalg.norm(v)).tolist()


@pytest.mark.known_bug("spherical_emulation")
def test_states_after_resets_are_raw_pybullets(make_sim, within):
    """Every joint of the humanoid reset to a random state; states and link frames read back."""
    p, c = _raw.raw_client()
    raw = _raw.raw_load(
        HUMANOID, base_position=POSE[0], base_orientation=POSE[1], fixed_base=True, keep=True
    )
    try:
        sim = make_sim()
        body = sim.load_urdf(
            HUMANOID, base_position=POSE[0], base_orientation=POSE[1], fixed_base=True
        )
        rng = np.random.default_rng(14)
        movable = [j for j in sim.joints(body) if j.q_index >= 0]
        qs, vs = [], []
        for j in movable:
            if j.type == simbridge.JointType.SPHERICAL:
                qs.append(_unit(rng.normal(size=4)))
                vs.append(rng.uniform(-2, 2, 3).tolist())
            else:
                qs.append([float(rng.uniform(-1, 0))])  # within the knees' and elbows' limits
                vs.append([float(rng.uniform(-2, 2))])
            p.resetJointStateMultiDof(raw.body, j.index, qs[-1], vs[-1], physicsClientId=c)
        sim.reset_joint_state_multi_dof(body, [j.index for j in movable], qs, vs)
        everything = list(range(sim.num_joints(body)))
        got = sim.joint_states_multi_dof(body)
        want = p.getJointStatesMultiDof(raw.body, everything, physicsClientId=c)
        # a float32 state (_gaps "state_float32"): to its rounding, velocities up to 2 rad/s
        tol_q, tol_v = tolerance(sim.backend, 1e-15), tolerance(sim.backend, 0.0, scale=2.0)
        dq = dv = 0.0
        signs = []  # per joint: -1 where a quaternion reads back negated (the same rotation)
        for g, w in zip(got, want, strict=True):
            assert len(g.position) == len(w[0]) and len(g.velocity) == len(w[1])
            assert g.applied_torque == tuple(0.0 for _ in w[3])  # no step yet
            if not w[0]:
                assert g.position == () and g.velocity == ()
                signs.append(1.0)
                continue
            flip = len(w[0]) == 4 and np.abs(np.add(g.position, w[0])).max() < 0.5
            signs.append(-1.0 if flip else 1.0)
            dq = max(dq, float(np.abs(np.subtract(g.position, np.multiply(signs[-1], w[0]))).max()))
            dv = max(dv, float(np.abs(np.subtract(g.velocity, w[1])).max()))
        # raw PyBullet keeps the quaternion as written, w < 0 included
        within("reset read-back: quaternions negated", signs.count(-1.0), 0)
        within("reset read-back: positions (quaternions up to sign)", dq, tol_q)
        within("reset read-back: velocities", dv, tol_v)
        # getJointStates: the first coordinate of each (of the quaternion as read back above)
        scalar = sim.joint_states(body)
        rows = p.getJointStates(raw.body, everything, physicsClientId=c)
        firsts = [s * r[0] for s, r in zip(signs, rows, strict=True)]
        dq = float(np.abs(scalar.positions - firsts).max())
        dv = float(np.abs(scalar.velocities - [r[1] for r in rows]).max())
        within("reset read-back: first coordinates", dq, tol_q)
        within("reset read-back: first velocities", dv, tol_v)
        frames = [
            tuple(p.getLinkState(raw.body, i, computeForwardKinematics=1, physicsClientId=c)[4:6])
            for i in everything
        ]
        ours = _raw.sim_frames(sim, body)[1:]
        assert len(ours) == len(frames)
        worst = _raw.largest_frame_error(ours, frames)
        within("reset read-back: link frames", worst, _raw.frame_rel(sim.backend))
    finally:
        p.removeBody(raw.body, physicsClientId=c)


def test_a_quaternion_is_normalised_as_pybullet_does(make_sim, caplog):
    sim = make_sim()
    body = sim.load_urdf(PENDULUM, fixed_base=True)
    caplog.set_level(logging.WARNING, logger="simbridge.sim")
    sim.reset_joint_state_multi_dof(body, "ball", [0.0, 0.0, 0.5, 0.5], [0.5, 0.2, 0.1])
    state = sim.joint_states_multi_dof(body, "ball")[0]
    # raw PyBullet reads back (0, 0, 0.7071067811865476, 0.7071067811865476) (measured); MuJoCo
    # one ulp less (the Sim's division by the norm)
    # (PhysX: 0.70710680, 0.70710677, a float32 state: 2.2e-8)
    half = math.sqrt(0.5)
    assert _raw.close(state.position, (0.0, 0.0, half, half), tolerance(sim.backend, 2e-16))
    assert state.velocity == pytest.approx((0.5, 0.2, 0.1), abs=tolerance(sim.backend, 0.0))
    assert "has norm 0.707107: normalised" in caplog.text


def test_joint_states_shapes(make_sim):
    sim = make_sim()
    body = sim.load_urdf(HUMANOID, fixed_base=True)
    states = sim.joint_states_multi_dof(body)
    kinds = {
        simbridge.JointType.SPHERICAL: (4, 3, 3),
        simbridge.JointType.REVOLUTE: (1, 1, 1),
        simbridge.JointType.FIXED: (0, 0, 0),
    }
    for info, s in zip(sim.joints(body), states, strict=True):
        assert tuple(map(len, s)) == kinds[info.type], info.name
    one = sim.joint_states_multi_dof(body, "chest")
    assert len(one) == 1 and one[0].position == (0.0, 0.0, 0.0, 1.0)
    assert sim.joint_states(body).positions.shape == (15,)


# ---------------------------------------------------------------- commands against raw PyBullet

RawSetup = Callable[[Any, int, int], None]
SimSetup = Callable[[simbridge.Sim, int], None]


def _raw_run(setup: RawSetup, steps: int) -> np.ndarray:
    """Raw PyBullet: the pendulum reset to Q0, V0, ``setup``, then ``steps`` steps; each step's
    quaternion, velocity and motor torques (10 numbers)."""
    p = _pybullet()
    c = p.connect(p.DIRECT)
    try:
        p.setGravity(0.0, 0.0, -9.8, physicsClientId=c)
        p.setTimeStep(DT, physicsClientId=c)
        b = p.loadURDF(PENDULUM, useFixedBase=True, physicsClientId=c)
        p.resetJointStateMultiDof(b, 0, Q0, V0, physicsClientId=c)
        setup(p, c, b)
        out = np.empty((steps, 10))
        for k in range(steps):
            p.stepSimulation(physicsClientId=c)
            s = p.getJointStateMultiDof(b, 0, physicsClientId=c)
            out[k] = (*s[0], *s[1], *s[3])
        return out
    finally:
        p.disconnect(physicsClientId=c)


def _sim_run(sim: simbridge.Sim, setup: SimSetup, steps: int) -> np.ndarray:
    body = sim.load_urdf(PENDULUM, fixed_base=True)
    sim.reset_joint_state_multi_dof(body, "ball", Q0, V0)
    setup(sim, body)
    out = np.empty((steps, 10))
    for k in range(steps):
        sim.step()
        s = sim.joint_states_multi_dof(body, "ball")[0]
        out[k] = (*s.position, *s.velocity, *s.applied_torque)
    return out


def _raw_motor(kp: Any, force: Any, damping: Any, target: Any = (0.0, 0.0, 0.0, 1.0)) -> RawSetup:
    def setup(p: Any, c: int, b: int) -> None:
        p.setJointMotorControlMultiDof(
            b,
            0,
            p.POSITION_CONTROL,
            targetPosition=list(target),
            positionGain=list(kp),
            velocityGain=[1.0, 1.0, 1.0],
            force=list(force),
            damping=list(damping),
            physicsClientId=c,
        )

    return setup


def _release_then(then: RawSetup | None = None) -> RawSetup:
    def setup(p: Any, c: int, b: int) -> None:
        _raw_motor([0.0] * 3, [0.0] * 3, [1.0] * 3)(p, c, b)
        if then is not None:
            then(p, c, b)

    return setup


# case -> (raw setup, Sim setup, steps, MuJoCo's tolerance on quaternion, velocity, torque).
# Measured on MuJoCo against raw PyBullet ("pybullet" profile, the whole run): what is left is
# PyBullet's link damping, which the backend reproduces to 1e-9 relative (the hinge pendulum's
# figure: docs/mujoco_backend.md), carried through a 3-D swing; under the "urdf" profile the same
# runs agree to 2e-13 (test_cross_engine_free_swing and bench figures in the docs).
CASES: dict[str, tuple[RawSetup, SimSetup, int, tuple[float, float, float]]] = {
    # PyBullet's motor at load holds the identity (kp 0.2, 1000 N·m·s per step): measured 1e-15
    "default motor": (lambda p, c, b: None, lambda sim, b: None, 240, (1e-13, 1e-12, 1e-7)),
    # set_joint_velocity(0, max_force=0) releases the joint: a free swing, measured 1.3e-9, 5e-9
    "released": (
        _release_then(),
        lambda sim, b: sim.set_joint_velocity(b, 0, 0, max_force=0),
        240,
        (2e-8, 2e-7, 0.0),
    ),
    # a brake per axis, saturated: measured 6.6e-10, 1.0e-8, 3.5e-9 (480 steps)
    "brake": (
        _raw_motor([0.0] * 3, [0.05, 0.03, 0.02], [1.0] * 3),
        lambda sim, b: sim.set_joint_velocity(b, 0, [0, 0, 0], max_force=[0.05, 0.03, 0.02]),
        240,
        (1e-8, 1e-7, 1e-7),
    ),
    # a position motor with gains and forces per axis: measured 6.4e-10, 5.6e-9, 3.3e-7 (480)
    "position": (
        _raw_motor([0.3, 0.2, 0.1], [5.0, 2.0, 1.0], [0.8, 1.0, 0.5], TARGET),
        lambda sim, b: sim.set_joint_position(
            b, 0, TARGET, max_force=[5, 2, 1], kp=[0.3, 0.2, 0.1], kd=[0.8, 1.0, 0.5]
        ),
        240,
        (1e-8, 1e-7, 1e-5),
    ),
    # one force for every axis, saturated: measured 1.1e-9, 8.2e-9, 5.8e-9 (480)
    "position, saturated": (
        _raw_motor([0.5] * 3, [0.2] * 3, [1.0] * 3, TARGET),
        lambda sim, b: sim.set_joint_position(b, 0, TARGET, max_force=0.2, kp=0.5),
        240,
        (1e-8, 1e-7, 1e-7),
    ),
    # two torques before one step add up and act for that step only: measured 7e-13, 1.3e-10
    "torque": (
        _release_then(
            lambda p, c, b: [
                p.setJointMotorControlMultiDof(b, 0, p.TORQUE_CONTROL, force=t, physicsClientId=c)
                for t in ([0.01, 0.0, -0.03], [0.0, 0.02, 0.0])
            ]
        ),
        lambda sim, b: (
            sim.set_joint_velocity(b, 0, 0, max_force=0),
            sim.set_joint_torque(b, 0, [0.01, 0.0, -0.03]),
            sim.set_joint_torque(b, "ball", [[0.0, 0.02, 0.0]]),
        ),
        20,
        (1e-11, 1e-9, 0.0),
    ),
}


@pytest.mark.known_bug("spherical_emulation")
@pytest.mark.parametrize("case", sorted(CASES))
def test_commands_as_raw_pybullet(make_sim, backend, case, within):
    raw_setup, sim_setup, steps, tolerances = CASES[case]
    want = _raw_run(raw_setup, steps)
    got = _sim_run(make_sim(), sim_setup, steps)
    diff = np.abs(got - want)
    measured = (diff[:, :4].max(), diff[:, 4:7].max(), diff[:, 7:].max())
    print(
        f"{backend} {case}: quaternion {measured[0]:.2g}, velocity {measured[1]:.2g}, "
        f"torque {measured[2]:.2g}"
    )
    # the exact rule: the same engine calls give the same bits; with the backend's known gap,
    # the case's measured tolerances scaled by it
    scale = gap(backend, "spherical_commands_vs_raw")
    rules = (0.0, 0.0, 0.0) if scale is None else tuple(scale * t for t in tolerances)
    for what, m, rule in zip(("quaternion", "velocity", "torque"), measured, rules, strict=True):
        within(f"{case}: {what}", m, rule)
    assert np.abs(want[:, 4:7]).max() > 0.5  # the joint moved: nothing was compared at rest


def test_the_default_motor_holds_the_humanoid(make_sim):
    """Every spherical joint of a fixed humanoid held at the identity by PyBullet's motor at
    load against gravity: measured drift over 1 s, 5.8e-6 on PyBullet (its iterative solver on
    the coupled rows of a chain), 0 on MuJoCo (rows solved exactly, and asking for 0)."""
    sim = make_sim()
    body = sim.load_urdf(HUMANOID, base_position=(0, 0, 3), fixed_base=True)
    sim.step(240)
    worst = 0.0
    for info, s in zip(sim.joints(body), sim.joint_states_multi_dof(body), strict=True):
        if info.type == simbridge.JointType.SPHERICAL:
            worst = max(worst, float(np.abs(np.subtract(s.position, (0, 0, 0, 1))).max()))
            assert max(map(abs, s.applied_torque)) < 1000.0  # held, far below the limit
    assert worst < 2e-5, worst


# ---------------------------------------------------------------- get_state and set_state


def _spherical_world(sim: simbridge.Sim) -> tuple[int, int]:
    """A fixed humanoid and the pendulum, mid-run: position motors per axis, a brake, a 1-DoF
    velocity motor, torques pending on two spherical joints."""
    h = sim.load_urdf(HUMANOID, base_position=(0, 0, 3), fixed_base=True)
    b = sim.load_urdf(PENDULUM, base_position=(2, 0, 1), fixed_base=True)
    sim.reset_joint_state_multi_dof(b, 0, Q0, V0)
    sim.set_joint_position(
        h,
        ["neck", "left_hip"],
        [quat_from_rpy((0.2, 0.0, 0.0)), quat_from_rpy((0.0, 0.4, 0.1))],
        max_force=[50.0, 20.0, 10.0],
        kp=[0.3, 0.2, 0.1],
        kd=0.8,
    )
    sim.set_joint_velocity(b, 0, 0, max_force=[0.05, 0.03, 0.0])
    sim.set_joint_velocity(h, "right_elbow", 1.0, max_force=5)
    sim.step(10)
    sim.set_joint_torque(h, "chest", [1.0, -2.0, 0.5])
    sim.set_joint_torque(b, 0, [0.01, 0.0, 0.02])
    return h, b


def _record(sim: simbridge.Sim, bodies: tuple[int, int], steps: int = 30) -> np.ndarray:
    out = []
    for _ in range(steps):
        sim.step()
        out.append([x for b in bodies for s in sim.joint_states_multi_dof(b) for x in s[0] + s[1]])
    return np.array(out)


def test_get_state_and_set_state_carry_spherical_joints(make_sim):
    sim = make_sim()
    bodies = _spherical_world(sim)
    state = sim.get_state()
    pendulum = state.bodies[1].spherical[0]
    assert [e.joint for e in state.bodies[0].spherical] == [1, 2, 3, 6, 9, 11, 12, 14]
    assert pendulum.motor_mode == simbridge.MotorMode.VELOCITY
    assert pendulum.motor_max_force == (0.05, 0.03, 0.0)
    assert pendulum.pending_torque == (0.01, 0.0, 0.02)
    neck = state.bodies[0].spherical[1]
    assert (neck.motor_mode, neck.motor_kp, neck.motor_kd) == (2, (0.3, 0.2, 0.1), (0.8,) * 3)
    # PyBullet's motor at load, on the joints no command reached
    chest = state.bodies[0].spherical[0]
    assert (chest.motor_mode, chest.motor_kp, chest.motor_max_force) == (
        2,
        (0.2,) * 3,
        (240000.0,) * 3,
    )
    assert state.bodies[0].joint_positions[2] == neck.position[0]  # the first coordinate
    first = _record(sim, bodies)
    sim.set_state(state)  # into the same world: bit for bit
    same = float(np.abs(_record(sim, bodies) - first).max())
    other = make_sim()
    theirs = _spherical_world(other)
    other.step(7)
    other.set_state(state.portable())  # another world: the state, the motors, the torques
    there = float(np.abs(_record(other, theirs) - first).max())
    print(f"{sim.backend}: after set_state {same:.3g} (same Sim), {there:.3g} (another)")
    # no contact in this world: a float32 state's rounding only (PhysX measured 3.4e-7 both)
    assert same <= tolerance(sim.backend, 0.0)
    assert there < tolerance(sim.backend, 1e-12)  # measured 6.7e-16 on PyBullet


def test_a_spherical_state_crosses_engines(backend):
    """A state taken on one backend, set on each other one: every spherical field reads back."""
    others = [name for name in usable_backends() if name != backend]
    assert others, "one backend alone: nothing to cross to"
    for other in others:
        _cross(backend, other)


def _cross(backend: str, other: str) -> None:
    with simbridge.Sim(backend) as a, simbridge.Sim(other) as b:
        _spherical_world(a)
        state = a.get_state()
        b.load_urdf(HUMANOID, base_position=(0, 0, 3), fixed_base=True)
        b.load_urdf(PENDULUM, base_position=(2, 0, 1), fixed_base=True)
        b.set_state(state)
        back = b.get_state()
        # read back by the receiving engine: to its float32 rounding where its state is float32
        # (PhysX: 2.9e-14 on a -2.0e-6 quaternion component, measured)
        tol = tolerance(other, 1e-15)
        for mine, theirs in zip(state.bodies, back.bodies, strict=True):
            assert len(mine.spherical) == len(theirs.spherical)
            for e, f in zip(mine.spherical, theirs.spherical, strict=True):
                for x, y in zip(e, f, strict=True):
                    assert _raw.close(x, y, tol), (e.joint, x, y)
            for field in ("joint_positions", "motor_mode", "motor_max_force", "pending_torque"):
                assert _raw.close(getattr(mine, field), getattr(theirs, field), tol), field


def test_a_bad_spherical_state_is_refused_before_anything_is_set(make_sim):
    sim = make_sim()
    _spherical_world(sim)
    state = sim.get_state()
    body = state.bodies[1]
    e = body.spherical[0]
    bad = {
        "not a unit quaternion": e._replace(position=(0.0, 0.0, 0.0, 2.0)),
        "a VELOCITY motor \\(a brake\\) has kp 0": e._replace(motor_kp=(0.1, 0.0, 0.0)),
        "values must be >= 0": e._replace(motor_max_force=(-1.0, 0.0, 0.0)),
        "expected 3 finite numbers": e._replace(pending_torque=(math.nan, 0.0, 0.0)),
    }
    before = sim.joint_states_multi_dof(1, 0)[0]
    for message, entry in bad.items():
        broken = state.bodies[:1] + (body._replace(spherical=(entry,)),)
        with pytest.raises(exc.InvalidArgumentError, match=message):
            sim.set_state(type(state)(state.backend, state.timestep, state.time, broken))
    missing = state.bodies[:1] + (body._replace(spherical=()),)
    with pytest.raises(exc.InvalidArgumentError, match=r"one SphericalJointState per spherical"):
        sim.set_state(type(state)(state.backend, state.timestep, state.time, missing))
    assert sim.joint_states_multi_dof(1, 0)[0] == before


# ---------------------------------------------------------------- what is refused, and why


def test_what_spherical_joints_refuse(make_sim):
    sim = make_sim()
    body = sim.load_urdf(HUMANOID, fixed_base=True)
    with pytest.raises(exc.InvalidArgumentError, match=r"take no reset_joint_state: use "):
        sim.reset_joint_state(body, "chest", 0.1)  # PyBullet ignores it (measured)
    with pytest.raises(
        exc.InvalidArgumentError, match=r"velocity target of 0 alone.*refuses VELOCITY_CONTROL"
    ):
        sim.set_joint_velocity(body, "chest", [1.0, 0, 0], max_force=5)
    with pytest.raises(exc.InvalidArgumentError, match=r"\['right_elbow'\] .* are not spherical"):
        sim.set_joint_position(body, ["chest", "right_elbow"], (0, 0, 0, 1), max_force=5)
    with pytest.raises(exc.InvalidArgumentError, match=r"target.*shape \(2, 4\), got shape \(3,\)"):
        sim.set_joint_position(body, ["chest", "neck"], (0, 0, 1), max_force=5)
    with pytest.raises(exc.InvalidArgumentError, match=r"max_force.*got shape \(2,\)"):
        sim.set_joint_position(body, "chest", (0, 0, 0, 1), max_force=[1, 2])
    with pytest.raises(exc.InvalidArgumentError, match=r"'max_force': values must be >= 0"):
        sim.set_joint_velocity(body, "chest", 0, max_force=[1, -2, 3])
    with pytest.raises(exc.InvalidArgumentError, match=r"'torque': a spherical joint takes 3"):
        sim.set_joint_torque(body, "chest", 1.0)
    with pytest.raises(exc.InvalidArgumentError, match=r"'torque': values must be finite"):
        sim.set_joint_torque(body, "chest", [1.0, math.nan, 0.0])
    with pytest.raises(exc.InvalidArgumentError, match=r"a quaternion of norm 0"):
        sim.set_joint_position(body, "chest", (0, 0, 0, 0), max_force=5)
    with pytest.raises(exc.InvalidArgumentError, match=r"positions of joint 'chest'"):
        sim.reset_joint_state_multi_dof(body, "chest", [0.0, 0.0, 1.0])
    with pytest.raises(exc.InvalidArgumentError, match=r"velocities of joint 'chest'"):
        sim.reset_joint_state_multi_dof(body, "chest", [0, 0, 0, 1], [1.0, 2.0])
    with pytest.raises(exc.InvalidArgumentError, match=r"is fixed and takes no command"):
        sim.reset_joint_state_multi_dof(body, "root", [])
    with pytest.raises(exc.InvalidArgumentError, match=r"take no a bound command"):
        sim.position_command(body, "neck", 0.0, max_force=5)
    # nothing refused was half done: the joints are where they were, held as at load
    sim.step()
    chest = sim.joint_states_multi_dof(body, "chest")[0].position
    assert chest == pytest.approx((0, 0, 0, 1), abs=1e-5)  # PyBullet drifts 3e-7 in a step


def test_a_planar_joint_is_refused_with_the_measured_reason(make_sim):
    text = (
        '<robot name="p"><link name="a"/><link name="b"/><joint name="j" type="planar">'
        '<parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint></robot>'
    )
    _raw.raw_load(text)  # raw PyBullet builds it (broken: see the message)
    with pytest.raises(exc.UnsupportedJointError, match=r"centre of mass .* 2 of its 3"):
        make_sim().load_urdf(text)


# ---------------------------------------------------------------- against PyBullet's behaviour


def _swing(backend: str, profile: str, steps: int) -> np.ndarray:
    with simbridge.Sim(backend, profile=profile) as sim:
        out = _sim_run(sim, lambda s, b: s.set_joint_velocity(b, 0, 0, max_force=0), steps)
        return out[:, :7]


@pytest.mark.known_bug("spherical_emulation")
@pytest.mark.parametrize(
    ("profile", "tol_q", "tol_v"),
    [
        # measured over 2 s: 6e-15 in the quaternion, 5e-14 rad/s: round-off
        ("urdf", 5e-14, 5e-13),
        # measured over 2 s: 9.5e-9, 8.2e-8 rad/s: PyBullet's link damping, reproduced to 1e-9
        # relative per step (1.9e-9 on the hinge pendulum), carried through the 3-D swing
        ("pybullet", 1e-7, 1e-6),
    ],
)
@pytest.mark.parametrize("backend", against_reference(), indirect=True)  # not PyBullet twice
def test_cross_engine_free_swing(backend, profile, tol_q, tol_v, within):
    """The free-swinging spherical pendulum (released, 0.7 rad from hanging, spun at 2.6 rad/s)
    for 2 s on the backend under test against PyBullet, the reference (the tolerances are
    MuJoCo's measured differences, the tightest any backend met)."""
    a = _swing(REFERENCE, profile, 480)
    b = _swing(backend, profile, 480)
    gap_q, gap_v = np.abs(a[:, :4] - b[:, :4]).max(), np.abs(a[:, 4:] - b[:, 4:]).max()
    print(f"{profile}: quaternion {gap_q:.2g}, angular velocity {gap_v:.2g} rad/s")
    within(f"free swing, {profile!r} profile: quaternion", gap_q, tol_q)
    within(f"free swing, {profile!r} profile: velocity", gap_v, tol_v)
    assert np.abs(a[:, 4:]).max() > 3.0  # it swung


COUPLED = """<robot name="coupled"><link name="pivot"><inertial><mass value="1"/>
<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
<link name="bob"><inertial><origin xyz="0.1 0.05 -0.5" rpy="0.3 0.2 0.1"/><mass value="1"/>
<inertia ixx="0.0010416666666666667" ixy="0" ixz="0" iyy="0.0035416666666666665" iyz="0"
izz="0.004166666666666667"/></inertial></link><joint name="ball" type="spherical">
<parent link="pivot"/><child link="bob"/></joint></robot>"""


@pytest.mark.known_bug("spherical_emulation")
def test_coupled_motor_rows(backend, within):
    """Where the child's inertia about the joint is not diagonal in its inertial frame, the
    spherical motor's three rows are coupled and PyBullet's 50 solver iterations do not reach
    what they ask for: one step from rest 0.7 rad from the target, measured 2.07 rad/s short of
    6.68 asked (0.03 at 200 iterations; the gap "spherical_motor_coupled_rows"). MuJoCo's rows
    are solved exactly, the rule for a backend without the gap: the departure ("motors" in the
    MuJoCo backend's manifest) is PyBullet's solver, not the law."""
    from scipy.spatial.transform import Rotation

    # Bullet's motor error, matrixToEulerXYZ of conj(q) * target (its matrix read column-major),
    # is scipy's intrinsic XYZ angles of conj(target) * q (measured against the MuJoCo
    # backend's arithmetic: within 6e-15 rad over 2000 random pairs)
    e = (Rotation.from_quat((0.0, 0.0, 0.0, 1.0)).inv() * Rotation.from_quat(Q0)).as_euler("XYZ")
    asked = np.array([-0.2 * 0.2 * x / DT for x in e])  # v = -erp kp e / dt from rest
    with simbridge.Sim(backend, profile="urdf", gravity=(0, 0, 0)) as sim:
        body = sim.load_urdf(COUPLED, fixed_base=True)
        sim.reset_joint_state_multi_dof(body, 0, Q0, [0, 0, 0])
        sim.set_joint_position(body, 0, (0, 0, 0, 1), max_force=1e5, kp=0.2)
        sim.step()
        v = np.array(sim.joint_states_multi_dof(body, 0)[0].velocity)
        short = float(np.abs(v - asked).max())
    print(f"{backend}: asked {np.abs(asked).max():.3g} rad/s; short by {short:.3g}")
    known = gap(backend, "spherical_motor_coupled_rows")
    if known is None:
        within("coupled rows: short of the asked velocity", short, 1e-12)
    else:  # still real: PyBullet measured 2.07 of its 2.5
        assert known / 2 < short < known


def test_the_swing_twist_limit_holds_or_is_a_listed_departure(backend, caplog):
    """spherical_joint_limit.urdf: its neck's <limit lower="0.2" upper=".8" twist=".3"
    effort="1000"> makes PyBullet add a btMultiBodySphericalJointLimit. Released and pushed about
    x (5 N·m for one step) it stops at the 0.2 rad swing on PyBullet (measured 0.2000 rad after
    1 s). A backend that does not enforce it says so at load and in its manifest (the MuJoCo
    backend, measured: it falls over, 2.01 rad); one that does not say so holds the limit."""
    caplog.set_level(logging.WARNING, logger="simbridge")
    with simbridge.Sim(backend) as sim:
        body = sim.load_urdf(LIMITED, fixed_base=True)
        sim.set_joint_velocity(body, "neck", 0, max_force=0)
        sim.set_joint_torque(body, "neck", [5.0, 0.0, 0.0])
        sim.step(240)
        x, y, z, w = sim.joint_states_multi_dof(body, "neck")[0].position
        angle = 2 * math.atan2(math.sqrt(x * x + y * y + z * z), w)
        listed = "body 0 spherical joint limits" in sim.manifest()["departures"]
    said = "spherical joints ['neck'] have PyBullet's swing/twist limit" in caplog.text
    assert said == listed
    if listed:
        assert angle > 1.0
    else:
        assert angle == pytest.approx(0.2, abs=1e-3)
