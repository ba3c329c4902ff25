"""Known answers from Gymnasium's own MuJoCo envs: on the MuJoCo backend the ``half_cheetah``
and ``ant`` tasks (Gymnasium's files read as MuJoCo reads them, stepped by ``mj_step``) reset to
the same state as ``gymnasium.make("HalfCheetah-v5")`` / ``("Ant-v5")`` from the same seed (the
same draws from the same generator) and follow it bit for bit under the same actions: MuJoCo's
qpos and qvel, the observation (float32 here, float64 there: equal once Gymnasium's is cast;
Ant-v5's default 105 entries, its 78 clipped ``cfrc_ext`` included), the control cost, the
contact cost, the healthy reward, the forward velocity, termination. Ant-v5 reads the torso's
x from ``data.xpos``, which after ``mj_step`` with RK4 is the kinematics of the last
Runge-Kutta stage, not of the final state: the task reads it so too (``Sim.xpos``), however
the Sim is read between steps. Ant-v5's reward sums its terms in another order: equal to
rounding."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest

from simbridge.envs import SimEnv

STEPS = 60


def _lockstep(task: str, gym_id: str, seed: int, amplitude: float, poke: bool = False):
    """The two envs side by side; ``poke``: a read that refreshes the Sim's kinematics
    (``base_state``) after every third step, which must change nothing."""
    env = SimEnv(task, backend="mujoco")
    ref = gymnasium.make(gym_id).unwrapped
    try:
        obs, _ = env.reset(seed=seed)
        ref_obs, _ = ref.reset(seed=seed)
        n = obs.size
        assert ref_obs.shape == (n,)  # Gymnasium's default observation, all of it
        np.testing.assert_array_equal(env.sim.qpos(), ref.data.qpos)
        np.testing.assert_array_equal(env.sim.qvel(), ref.data.qvel)
        np.testing.assert_array_equal(obs, ref_obs[:n].astype(np.float32))
        rng = np.random.default_rng(seed)
        rows = []
        for step in range(STEPS):
            a = amplitude * rng.uniform(-1.0, 1.0, env.action_space.shape)  # float64
            x_before = float(ref.data.qpos[0])
            obs, reward, terminated, truncated, info = env.step(a)
            ref_obs, ref_reward, ref_terminated, _, ref_info = ref.step(a)
            np.testing.assert_array_equal(env.sim.qpos(), ref.data.qpos, err_msg=f"step {step}")
            np.testing.assert_array_equal(env.sim.qvel(), ref.data.qvel, err_msg=f"step {step}")
            np.testing.assert_array_equal(obs, ref_obs[:n].astype(np.float32))
            assert terminated == ref_terminated, step
            if poke and step % 3 == 1:
                env.sim.base_state(env.world.body)
            rows.append((info, reward, ref_info, ref_reward, x_before, float(ref.data.qpos[0])))
            if terminated:
                break
        return rows, ref.dt
    finally:
        env.close()
        ref.close()


@pytest.mark.parametrize("seed", [0, 5])
def test_half_cheetah_is_gymnasiums_half_cheetah_bit_for_bit(seed):
    rows, _ = _lockstep("half_cheetah", "HalfCheetah-v5", seed, 1.0)
    assert len(rows) == STEPS
    for info, reward, ref_info, ref_reward, _, _ in rows:
        assert reward == ref_reward
        assert info["reward_terms"]["forward_velocity"] == ref_info["x_velocity"]
        assert info["reward_terms"]["action_l2"] == ref_info["reward_ctrl"]


def test_later_episodes_are_gymnasiums_too():
    """The env's reset (its world restored, then the noise drawn) gives Gymnasium's
    ``mj_resetData`` state episode after episode."""
    env = SimEnv("half_cheetah", backend="mujoco")
    ref = gymnasium.make("HalfCheetah-v5").unwrapped
    try:
        for episode in range(3):
            env.reset(seed=10 + episode)
            ref.reset(seed=10 + episode)
            action = np.full(6, 0.4 - 0.3 * episode)
            for _ in range(20):
                _, reward, *_ = env.step(action)
                _, ref_reward, *_ = ref.step(action)
            np.testing.assert_array_equal(env.sim.qpos(), ref.data.qpos)
            np.testing.assert_array_equal(env.sim.qvel(), ref.data.qvel)
            assert reward == ref_reward
    finally:
        env.close()
        ref.close()


def test_ant_is_gymnasiums_default_ant_bit_for_bit():
    rows, dt = _lockstep("ant", "Ant-v5", 3, 0.6, poke=True)
    assert len(rows) >= 20
    lag = 0.0
    contact = [ref_info["reward_contact"] for _, _, ref_info, *_ in rows]
    assert min(contact) < 0.0  # the feet touched: the contact cost was exercised
    for info, reward, ref_info, ref_reward, x0, x1 in rows:
        terms = info["reward_terms"]
        assert terms["action_l2"] == ref_info["reward_ctrl"]
        assert terms["healthy"] == ref_info["reward_survive"]
        assert terms["contact_cost"] == ref_info["reward_contact"]  # its cfrc_ext, clipped
        assert terms["forward_velocity"] == ref_info["x_velocity"]  # the torso's xpos
        assert reward == sum(terms.values())
        # Ant-v5 sums (forward + healthy) - (ctrl + contact): equal to rounding
        assert reward == pytest.approx(ref_reward, rel=0.0, abs=1e-12)
        lag = max(lag, abs(ref_info["x_velocity"] - (x1 - x0) / dt))
    # xpos after RK4 is the last stage's: a few cm/s apart from qpos's difference (0.022 m/s
    # measured over 59 steps of uniform actions in [-1, 1]), never the same bits: the
    # xpos read is what makes the forward term Ant-v5's
    assert 0.0 < lag < 0.1


def test_the_ids_make_the_tasks():
    env = gymnasium.make("simbridge/Ant-v0", backend="mujoco")
    try:
        obs, _ = env.reset(seed=0)
        assert obs.shape == (105,) and env.action_space.shape == (8,)
        assert env.unwrapped.task.control_dt == pytest.approx(0.05)
        contract = env.unwrapped.contract()
        table = contract["action"]["joint_table"]
        # ant.xml's motors are unnamed: MuJoCo's order, each with the joint it drives
        assert [row["actuator"] for row in table][:2] == ["actuator0", "actuator1"]
        assert [row["name"] for row in table][:2] == ["hip_4", "ankle_4"]
        assert table[0]["gear"] == 150.0
        assert table[0]["ctrl_range"] == [-1.0, 1.0]
        names = contract["observation"]["terms"][0]["entries"]
        assert names[0] == "qpos[2]" and len(names) == 13
        forces = contract["observation"]["terms"][2]["entries"]  # bodies 1..13 of cfrc_ext
        assert len(forces) == 78 and forces[:4] == [
            f"cfrc_ext[1.{c}]" for c in ("tx", "ty", "tz", "fx")
        ]
        assert forces[-1] == "cfrc_ext[13.fz]"
    finally:
        env.close()


def test_sim2sim_takes_a_gymnasium_policy_as_a_callable(tmp_path):
    """``simbridge sim2sim module:callable --task ant --trained-on external:gymnasium``: the
    ant's reference gait as the policy, on two engines; MuJoCo's episode is the env's own."""
    import json

    from simbridge.cli import main
    from simbridge.envs.controllers import AntGait

    policy = "simbridge.envs.controllers:AntGait"
    args = ["sim2sim", policy, "--task", "ant", "--trained-on", "external:gymnasium"]
    args += ["--backends", "mujoco", "physx", "--episodes", "1", "--openloop", "0"]
    code = main([*args, "--out", str(tmp_path)])
    assert code == 0
    summary = json.loads((tmp_path / "summary.json").read_text(encoding="utf-8"))
    assert [e["label"] for e in summary["engines"]] == ["mujoco", "physx"]
    assert (tmp_path / "report.md").is_file()
    env = SimEnv("ant", backend="mujoco")
    try:
        gait = AntGait(env)
        obs, _ = env.reset(seed=0)
        total, steps = 0.0, 0
        while True:
            obs, reward, terminated, truncated, info = env.step(gait(obs))
            total, steps = total + reward, steps + 1
            if terminated or truncated:
                break
    finally:
        env.close()
    first = summary["engines"][0]
    assert first["successes"] == int(info["is_success"]) and first["n"] == 1
    assert first["steps"]["value"] == steps and first["return"]["value"] == total
    # the gait's controls stay within 0.35 of ctrlrange's bound 1: never saturated
    assert [e["saturated_share"] for e in summary["engines"]] == [0.0, 0.0]


@pytest.mark.slow  # 2 tasks x 10 episodes of 1000 steps: 45 s on 2 cores at load 10
@pytest.mark.parametrize("task", ["ant", "half_cheetah"])
def test_the_gait_goes_forward_and_doing_nothing_does_not(task):
    """On MuJoCo, seeds 0-4: the reference gait succeeds on most (measured over 20 seeds: ant
    16, half_cheetah every one; docs/envs.md), zero controls on none."""
    from simbridge.envs.controllers import reference_controller
    from simbridge.envs.evaluate import success_rate

    env = SimEnv(task, backend="mujoco")
    try:
        gait, _ = success_rate(env, reference_controller(env), range(5))
        idle, _ = success_rate(env, lambda obs: np.zeros(env.action_space.shape), range(5))
    finally:
        env.close()
    assert gait.successes >= 3
    assert idle.successes == 0


def test_an_actuator_at_its_ctrlrange_bound_counts_as_saturated():
    from simbridge.envs.sim2sim_effort import EffortProbe

    env = SimEnv("half_cheetah", backend="mujoco")
    try:
        probe = EffortProbe(env).install()
        env.reset(seed=0)
        for value, share in ((1.0, 1.0), (0.5, 0.0)):
            probe.start()
            for _ in range(3):
                env.step(np.full(6, value))
            assert probe.steps == 15 and probe.shares()[0] == share
    finally:
        env.close()
