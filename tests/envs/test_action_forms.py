"""An action given in any form a policy hands it (a float32 or float64 array, a list, a tuple,
an integer array) is taken as the same float64 action, a copy of the caller's; a non-finite
entry is refused and one past the clip clipped and counted, whatever the form (the checks of a
float array run in plain floats, those of the rest through numpy). And a termination's joint
position is the observation's: one shared read of the world after each step."""

from __future__ import annotations

import numpy as np
import pytest

from simbridge.envs import ActionError, SimEnv

IN_RANGE = [0.5, -0.25, 0.0, 1.0, -1.0, 0.125, 0.75]


@pytest.fixture(scope="module")
def env():
    e = SimEnv("kuka_reach", backend="mujoco")
    e.reset(seed=0)
    yield e
    e.close()


@pytest.mark.parametrize(
    "form",
    [
        lambda v: np.array(v, dtype=np.float32),
        lambda v: np.array(v, dtype=np.float64),
        list,
        tuple,
        lambda v: np.array(v, dtype=np.float64)[::-1][::-1],  # a view with strides
    ],
)
def test_every_form_of_an_action_is_the_same_float64_copy(env, form):
    action = form(IN_RANGE)
    _, _, _, _, info = env.step(action)
    taken = env.world.last_action
    assert taken.dtype == np.float64 and info["action_clipped"] == 0
    np.testing.assert_array_equal(taken, np.array(IN_RANGE))
    if isinstance(action, np.ndarray):
        action[0] = 0.9  # the caller reuses its array: the env's copy does not move
        assert taken[0] == 0.5


def test_an_integer_array_is_taken_as_floats(env):
    env.step(np.array([1, 0, -1, 0, 0, 0, 1]))
    np.testing.assert_array_equal(env.world.last_action, [1.0, 0, -1.0, 0, 0, 0, 1.0])
    assert env.world.last_action.dtype == np.float64


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_entry_of_a_float_array_is_refused(env, dtype, bad):
    a = np.zeros(7, dtype=dtype)
    a[5] = bad
    with pytest.raises(ActionError, match=r"non-finite value for \['lbr_iiwa_joint_6'\]"):
        env.step(a)


def test_a_float32_action_past_the_clip_is_clipped_and_counted(env):
    _, _, _, _, info = env.step(np.array([3.0, 0, 0, -2.0, 0, 0, 1.0], dtype=np.float32))
    assert info["action_clipped"] == 2
    np.testing.assert_array_equal(env.world.last_action, [1.0, 0, 0, -1.0, 0, 0, 1.0])


def test_a_terminations_joint_position_is_the_observations():
    env = SimEnv("cartpole", backend="pybullet")
    try:
        env.reset(seed=3)
        for k in range(20):
            obs, *_ = env.step(np.array([0.4 if k % 3 else -0.6], dtype=np.float32))
            w = env.world
            q = env.sim.joint_states(w.body).positions
            for name in ("slider_to_cart", "cart_to_pole"):
                i = env.sim.joint_index(w.body, name)
                assert w.joint_position(name) == q[i]
                assert w.joint_position(i) == q[i]
            assert np.float32(w.joint_position("cart_to_pole")) == obs[1]
    finally:
        env.close()
