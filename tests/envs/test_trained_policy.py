"""The shipped trained policy (simbridge.envs.policy): PPO trained on MuJoCo by
examples/train_cartpole.py, carried as NumPy weights, so no test trains or needs torch.

Made by ``python examples/train_cartpole.py --backend mujoco --timesteps 60000 --out
runs/cartpole`` (its ``meta`` records the command and the training time); docs/rl_example.md.
"""

from __future__ import annotations

import numpy as np
import pytest

from simbridge.envs import SimEnv
from simbridge.envs.evaluate import success_rate
from simbridge.envs.policy import MlpPolicy, cartpole_ppo, load_mlp, save_mlp, shipped_policy
from simbridge.exceptions import InvalidArgumentError


def test_reaches_90_percent_on_its_training_engine() -> None:
    """At least 45 of 50 seeded episodes balanced on MuJoCo, its training engine."""
    env = SimEnv("cartpole", backend="mujoco")
    try:
        policy = cartpole_ppo(env)
        assert policy.policy.meta["trained_on"] == "mujoco"
        rate, episodes = success_rate(env, policy, range(50))
    finally:
        env.close()
    assert rate.n == 50
    assert rate.successes >= 45, [e for e in episodes if not e.success][:5]


def test_records_how_it_was_made() -> None:
    meta = shipped_policy("cartpole_ppo").meta
    assert meta["command"].startswith("python examples/train_cartpole.py --backend mujoco")
    assert meta["task"] == "cartpole" and meta["train_seconds"] > 0


def test_round_trip_and_the_mlp_by_hand(tmp_path) -> None:
    """save_mlp then load_mlp gives the same actions, and they are tanh(x W0 + b0) W1 + b1
    clipped, computed here by hand."""
    rng = np.random.default_rng(0)
    w = [rng.normal(size=(3, 5)), rng.normal(size=(5, 2))]
    b = [rng.normal(size=5), rng.normal(size=2)]
    saved = save_mlp(tmp_path / "p.npz", w, b, low=-0.5, high=0.5, meta={"k": 1})
    loaded = load_mlp(tmp_path / "p.npz")
    assert loaded.meta == {"k": 1}
    for _ in range(20):
        obs = rng.normal(size=3)
        w32 = [x.astype(np.float32).astype(float) for x in w]
        b32 = [x.astype(np.float32).astype(float) for x in b]
        hand = np.clip(np.tanh(obs @ w32[0] + b32[0]) @ w32[1] + b32[1], -0.5, 0.5)
        np.testing.assert_allclose(loaded(obs), hand, rtol=1e-6, atol=1e-6)
        np.testing.assert_array_equal(loaded(obs), saved(obs))


def test_a_policy_of_the_wrong_size_names_both_layouts() -> None:
    env = SimEnv("kuka_reach", backend="pybullet")
    try:
        with pytest.raises(InvalidArgumentError, match=r"takes 4 observation entries.*kuka_reach"):
            cartpole_ppo(env)
    finally:
        env.close()
    with pytest.raises(InvalidArgumentError, match=r"the policy takes \(4,\), got \(3,\)"):
        shipped_policy("cartpole_ppo")(np.zeros(3))


def test_bad_files_and_arguments(tmp_path) -> None:
    np.savez(tmp_path / "x.npz", a=np.zeros(2))
    with pytest.raises(InvalidArgumentError, match=r"holds \['a'\]; an MLP policy holds w0"):
        load_mlp(tmp_path / "x.npz")
    with pytest.raises(InvalidArgumentError, match=r"expected one of \['tanh', 'relu'\]"):
        MlpPolicy([np.zeros((2, 2))], [np.zeros(2)], activation="elu")
    with pytest.raises(InvalidArgumentError, match="do not chain"):
        MlpPolicy([np.zeros((2, 3)), np.zeros((2, 1))], [np.zeros(3), np.zeros(1)])
    with pytest.raises(InvalidArgumentError, match=r"expected one of \['cartpole_ppo'\]"):
        shipped_policy("walker")
