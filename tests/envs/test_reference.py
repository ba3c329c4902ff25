"""Each shipped task's reference controller succeeds on each engine: 5 seeds (0-4), every one a
success (measured: 20 of 20 seeds on every task and engine, `python -m simbridge.envs.evaluate
TASK --episodes 20`, docs/envs.md); and the tasks are not won by doing nothing: the cart-pole
without its controller and the A1 without its PD fail every seed."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from simbridge.envs import SimEnv, load_task
from simbridge.envs.controllers import reference_controller
from simbridge.envs.evaluate import success_rate

SEEDS = range(5)


@pytest.mark.parametrize(
    "task",
    # the A1's 3 x 5 episodes take 25 s of this file's 50 (on 2 loaded cores): slow
    ["cartpole", "kuka_reach", "husky_goto", pytest.param("a1_stand", marks=pytest.mark.slow)],
)
def test_the_reference_controller_succeeds(task, backend):
    env = SimEnv(task, backend=backend)
    try:
        rate, episodes = success_rate(env, reference_controller(env), SEEDS)
    finally:
        env.close()
    assert rate.successes == len(SEEDS), episodes
    assert rate.low > 0.5  # Wilson 95%: 5 of 5 -> 0.57-1.0


def test_doing_nothing_fails():
    env = SimEnv("cartpole", backend="mujoco")
    rate, episodes = success_rate(env, lambda obs: np.zeros(1), SEEDS)
    env.close()
    assert rate.successes == 0
    assert all(e.failure == "joint_pos_outside" and e.steps < 100 for e in episodes), episodes
    task = load_task("a1_stand")
    limp = dataclasses.replace(task, action=dataclasses.replace(task.action, kp=0.0, kd=0.0))
    env = SimEnv(limp, backend="mujoco")
    rate, episodes = success_rate(env, reference_controller(env), SEEDS)
    env.close()
    assert rate.successes == 0, episodes
