"""Gymnasium's own checker on every shipped task on every backend, made through its registered
id: spaces, seeded-reset determinism, step determinism (bit for bit: the checker compares the
observation after one step of two episodes of the same seed), and the "rgb_array" pictures
through Gymnasium's passive render checker. The "human" window needs a display: test_render.py.
"""

from __future__ import annotations

import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from gymnasium.utils.passive_env_checker import env_render_passive_checker

import simbridge.envs

IDS = sorted(simbridge.envs.IDS)


@pytest.mark.parametrize("env_id", IDS)
def test_check_env_passes(env_id, backend):
    env = gymnasium.make(env_id, backend=backend, render_mode="rgb_array")
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            check_env(env.unwrapped, skip_render_check=True)
            env.reset(seed=3)
            picture = env_render_passive_checker(env.unwrapped)
        # the checker's only remarks: an unbounded observation space (the task's terms are)
        remarks = {str(w.message) for w in caught if "infinity" not in str(w.message)}
        assert not remarks, remarks
        assert picture.shape == (240, 320, 3) and picture.dtype == np.uint8
        assert picture.std() > 5.0  # a scene, not a blank frame
    finally:
        env.close()


def test_the_ids_are_registered_on_import():
    registered = set(gymnasium.registry)
    assert set(simbridge.envs.IDS) <= registered
    spec = gymnasium.spec("simbridge/CartPole-v0")
    assert spec.entry_point == "simbridge.envs.env:SimEnv"
    assert spec.vector_entry_point == "simbridge.envs.vector:SimVectorEnv"
