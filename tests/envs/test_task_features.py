"""What a task states, checked against a plain computation: the contract's layout (legged RL's
for the A1), a task written in Python equal to its TOML, the PD action against a hand-written
Sim loop (bit for bit), action latency, observation history, noise and normalisation."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from simbridge import Sim
from simbridge.envs import (
    ActionSpec,
    Condition,
    Normalisation,
    ObsTerm,
    RewardTerm,
    RobotSpec,
    SimEnv,
    Task,
    load_task,
)


def _run(env: SimEnv, actions: np.ndarray, seed: int = 3) -> np.ndarray:
    obs = [env.reset(seed=seed)[0]]
    for a in actions:
        obs.append(env.step(a)[0])
    return np.stack(obs)


PUSHES = np.random.default_rng(0).uniform(-0.5, 0.5, (12, 1)).astype(np.float32)


def test_the_a1_contract_is_legged_rls_layout():
    env = SimEnv("a1_stand", backend="mujoco")
    c = env.contract()
    env.close()
    assert json.loads(json.dumps(c)) == c  # plain data, for a report
    obs = c["observation"]
    assert [(t["name"], t["start"], t["size"]) for t in obs["terms"]] == [
        ("base_ang_vel", 0, 3),
        ("projected_gravity", 3, 3),
        ("commands", 6, 3),
        ("joint_pos", 9, 12),
        ("joint_vel", 21, 12),
        ("last_action", 33, 12),
    ]
    assert obs["size"] == 45 and obs["dtype"] == "float32"
    assert obs["terms"][3]["entries"][:2] == [
        "joint_pos[FR_hip_joint]",
        "joint_pos[FR_upper_joint]",
    ]
    a = c["action"]
    assert a["joints"][:3] == ["FR_hip_joint", "FR_upper_joint", "FR_lower_joint"]
    assert (a["mode"], a["offset"], a["kp"][0], a["kd"][0], a["scale"][0]) == (
        "pd",
        "default",
        20.0,
        0.5,
        0.25,
    )
    assert (c["timestep"], c["decimation"], c["control_dt"]) == (0.005, 4, 0.02)
    assert [j["name"] for j in a["joint_table"]] == a["joints"]


def test_a_python_task_equals_its_toml():
    toml = load_task("cartpole")
    joints = ["slider_to_cart", "cart_to_pole"]
    task = Task(
        name="cartpole",
        robots=(
            RobotSpec("cartpole", "cartpole.urdf", fixed_base=True, released=("cart_to_pole",)),
        ),
        action=ActionSpec("cartpole", ("slider_to_cart",), "torque", 10.0, "zero", max_force=10.0),
        observation=(
            ObsTerm("joint_pos", params={"joints": joints}),
            ObsTerm("joint_vel", params={"joints": joints}),
        ),
        timestep=1 / 240,
        decimation=5,
        rewards=(RewardTerm("alive"),),
        terminations=toml.terminations,
        success=(Condition("survive"),),
        randomisation=toml.randomisation,
    )
    a, b = SimEnv(task), SimEnv(toml)
    ca, cb = a.contract(), b.contract()
    ca.pop("source"), cb.pop("source")
    assert ca == cb
    assert np.array_equal(_run(a, PUSHES), _run(b, PUSHES))
    a.close(), b.close()


def test_pd_actions_equal_a_hand_written_sim_loop():
    """The env's pd law, bit for bit against the same torques computed here from the Sim."""
    env = SimEnv("a1_stand", backend="mujoco")
    t = env.task
    env.reset(seed=4)
    robot = t.robot("a1")
    w = env.world
    start_q = env.sim.joint_states(w.body, w.joints)
    actions = np.random.default_rng(1).uniform(-1, 1, (10, 12))
    for a in actions:
        env.step(a)
    got = env.sim.joint_states(w.body, w.joints)
    env.close()

    sim = Sim("mujoco", timestep=t.timestep, profile=t.profile)
    sim.load_urdf("plane.urdf", fixed_base=True)
    body = sim.load_urdf(robot.urdf, base_position=robot.position)
    joints = list(t.action.joints)
    default = np.array([robot.joint_positions[j] for j in joints])
    sim.reset_joint_state(body, joints, start_q.positions, start_q.velocities)
    sim.set_joint_velocity(body, joints, 0.0, max_force=0.0)
    for a in actions:
        target = default + 0.25 * a
        for _ in range(t.decimation):
            s = sim.joint_states(body, joints)
            tau = np.clip(20.0 * (target - s.positions) - 0.5 * s.velocities, -33.5, 33.5)
            sim.set_joint_torque(body, joints, tau)
            sim.step()
    want = sim.joint_states(body, joints)
    sim.close()
    assert np.array_equal(got.positions, want.positions)
    assert np.array_equal(got.velocities, want.velocities)


def test_latency_delays_the_action_by_whole_control_steps():
    base = load_task("cartpole")
    late = dataclasses.replace(base, action=dataclasses.replace(base.action, latency=2))
    shifted = np.concatenate([np.zeros((2, 1), np.float32), PUSHES[:-2]])
    a, b = SimEnv(late, backend="mujoco"), SimEnv(base, backend="mujoco")
    assert np.array_equal(_run(a, PUSHES), _run(b, shifted))
    assert not np.array_equal(_run(a, PUSHES), _run(b, PUSHES))
    a.close(), b.close()


def test_history_stacks_frames_oldest_first():
    base = load_task("cartpole")
    stacked = SimEnv(dataclasses.replace(base, history=3))
    plain = SimEnv(base)
    h, p = _run(stacked, PUSHES), _run(plain, PUSHES)
    assert h.shape == (13, 12) and stacked.observation_space.shape == (12,)
    assert np.array_equal(h[0], np.tile(p[0], 3))  # the first frame fills every slot
    for k in range(2, 13):
        assert np.array_equal(h[k], np.concatenate([p[k - 2], p[k - 1], p[k]]))
    stacked.close(), plain.close()


def test_noise_is_seeded_and_bounded():
    base = load_task("cartpole")
    terms = tuple(dataclasses.replace(o, noise=0.01) for o in base.observation)
    noisy = SimEnv(dataclasses.replace(base, observation=terms))
    plain = SimEnv(base)
    n1, n2, p = _run(noisy, PUSHES), _run(noisy, PUSHES), _run(plain, PUSHES)
    assert np.array_equal(n1, n2)
    # the noise draws come after the initial state's, so the world is the same: noise alone
    # parts them, within its half-width (and float32 rounding)
    assert 0 < np.abs(n1 - p).max() <= 0.01 + 1e-6
    noisy.close(), plain.close()


def test_normalisation_is_vecnormalizes_formula():
    base = load_task("cartpole")
    mean, var = (0.1, -0.02, 0.3, 0.0), (0.5, 0.01, 2.0, 4.0)
    normed = SimEnv(dataclasses.replace(base, normalisation=Normalisation(mean, var, clip=5.0)))
    plain = SimEnv(base)
    n, p = _run(normed, PUSHES), _run(plain, PUSHES)
    want = np.clip((p.astype(np.float64) - mean) / np.sqrt(np.asarray(var) + 1e-8), -5, 5)
    # the env applies VecNormalize's formula to the float32 observation, as VecNormalize does:
    # the same elementwise float64 operations (each correctly rounded), then float32
    np.testing.assert_array_equal(n, want.astype(np.float32))
    assert normed.observation_space.high[0] == 5.0
    normed.close(), plain.close()


@pytest.mark.parametrize("offset", ["current", "default"])
def test_kuka_action_offsets(offset):
    base = load_task("kuka_reach")
    task = dataclasses.replace(base, action=dataclasses.replace(base.action, offset=offset))
    env = SimEnv(task, backend="mujoco")
    env.reset(seed=0)
    for _ in range(40):
        env.step(np.zeros(7, np.float32))
    q = env.sim.joint_states(env.world.body, env.world.joints).positions
    # action 0 holds the pose it started in (current: drifts by the tracking error; default:
    # returns to the default pose from the randomised start)
    err = np.abs(q - env.world.default).max()
    env.close()
    assert (err < 0.02) if offset == "default" else (err > 0.02)


def test_contacts_and_gait_phase_terms():
    base = load_task("husky_goto")
    wheels = ("front_left_wheel_link", "front_right_wheel_link")
    terms = (
        ObsTerm("contacts", params={"links": wheels}),
        ObsTerm("gait_phase", params={"period": 0.5}),
        ObsTerm("base_height"),
    )
    env = SimEnv(dataclasses.replace(base, observation=terms), backend="mujoco")
    env.reset(seed=0)
    obs = [env.step(np.zeros(4, np.float32))[0] for _ in range(15)][-1]
    c = env.contract()
    z = env.sim.base_state(env.world.body).position[2]
    env.close()
    assert [t["entries"] for t in c["observation"]["terms"]][:2] == [
        [f"contacts[{w}]" for w in wheels],
        ["gait_phase[sin]", "gait_phase[cos]"],
    ]
    assert obs[:2].tolist() == [1.0, 1.0]  # the wheels rest on the plane
    phase = 2 * np.pi * 15 * base.control_dt / 0.5
    np.testing.assert_allclose(obs[2:4], [np.sin(phase), np.cos(phase)], atol=1e-6)
    assert obs[4] == np.float32(z)


def test_observation_and_terminations_read_the_world_after_each_step(backend: str) -> None:
    """The joint read every term shares is taken once per control step and never reused across
    one: each observation equals a direct ``Sim.joint_states`` after that step or reset, and a
    pole pushed past its limit ends the episode at the step it crosses."""
    env = SimEnv("cartpole", backend=backend)
    try:
        sim, body = env.sim, env.world.body
        obs, _ = env.reset(seed=5)
        for k in range(40):
            s = sim.joint_states(body, ["slider_to_cart", "cart_to_pole"])
            direct = np.concatenate([s.positions, s.velocities]).astype(np.float32)
            np.testing.assert_array_equal(obs, direct, err_msg=f"step {k}")
            obs, _, terminated, _, info = env.step(np.array([1.0], np.float32))
            pole = sim.joint_states(body, ["cart_to_pole"]).positions[0]
            assert terminated == (abs(pole) > 0.2095), (k, pole, info)
            if terminated:
                assert info["failure"] == "joint_pos_outside"
                break
        assert terminated, "a full push for 40 steps topples the pole"
    finally:
        env.close()
