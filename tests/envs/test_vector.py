"""The vector entry point: N worlds in one process, each world's episode the same as a lone
SimEnv's of the same seed (bit for bit), Gymnasium's three autoreset modes, and the thread pool
giving the serial results bit for bit."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

from simbridge.envs import SimEnv
from simbridge.envs.vector import SimVectorEnv


def _actions(n: int, k: int) -> np.ndarray:
    return np.random.default_rng(5).uniform(-1, 1, (k, n, 1)).astype(np.float32)


def test_make_vec_runs_each_world_as_a_lone_env(backend):
    venv = gymnasium.make_vec(
        "simbridge/CartPole-v0", 3, vectorization_mode="vector_entry_point", backend=backend
    )
    assert isinstance(venv.unwrapped, SimVectorEnv)
    assert venv.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    actions = _actions(3, 40)
    obs, _ = venv.reset(seed=10)
    batched = [obs]
    for a in actions:
        batched.append(venv.step(a)[0])
    venv.close()
    lone = SimEnv("cartpole", backend=backend)
    obs, _ = lone.reset(seed=11)  # world 1 is seeded 10 + 1
    ended = False
    for k, a in enumerate(actions):
        assert np.array_equal(batched[k][1], obs), k
        if ended:
            break
        obs, _, term, trunc, _ = lone.step(a[1])
        ended = term or trunc
    lone.close()


@pytest.mark.parametrize("mode", list(AutoresetMode))
def test_autoreset_modes_and_threads_agree_bit_for_bit(mode):
    runs = []
    for threads in (0, 2):
        venv = SimVectorEnv(2, "cartpole", backend="mujoco", autoreset_mode=mode, threads=threads)
        obs, _ = venv.reset(seed=0)
        seen, ends = [obs], 0
        for a in _actions(2, 80):
            if mode == AutoresetMode.DISABLED and venv._autoreset_envs.any():
                obs, _ = venv.reset(options={"reset_mask": venv._autoreset_envs.copy()})
            obs, reward, term, trunc, info = venv.step(a)
            seen.append(obs)
            ends += int(np.sum(term | trunc))
            if mode == AutoresetMode.SAME_STEP and (term | trunc).any():
                i = int(np.flatnonzero(term | trunc)[0])
                assert info["_final_obs"][i] and info["final_obs"][i].shape == (4,)
        venv.close()
        runs.append(np.stack(seen))
        assert ends >= 2  # random pushes drop the pole: episodes end and worlds reset
    assert np.array_equal(runs[0], runs[1])
