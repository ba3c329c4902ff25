"""A TorchScript file and a Stable-Baselines3 zip through :func:`load_policy` and ``simbridge
sim2sim`` (src/simbridge/envs/policies.py), each held against the same weights computed another
way, and the bad input each loader refuses.

- The shipped cart-pole policy's weights (simbridge/envs/policies/cartpole_ppo.npz, run in NumPy
  by :mod:`simbridge.envs.policy`) put into torch: traced to TorchScript, and set into a
  Stable-Baselines3 PPO actor saved as a zip. Both give the NumPy policy's actions, the zip
  also Stable-Baselines3's own ``predict(deterministic=True)``; through ``simbridge sim2sim``
  both balance every seed the NumPy policy balances, with the same episode lengths.
- A SAC zip loads through the algorithms tried in turn (PPO refuses it) and acts as SAC's own
  ``predict``. A model trained under ``VecNormalize`` acts on the task's observation normalised
  with those statistics, stated in the task's ``[normalisation]``.
- Bad input: a ``.pt`` that is not TorchScript, a ``.zip`` that is no zip, one that is no
  Stable-Baselines3 model, and policies whose input or output size does not fit the task: each a
  :class:`PolicyError` naming what is wrong (both layouts where sizes differ).

torch (the CPU build) and stable-baselines3 are in the extra ``test``; where they are missing
this file skips, saying what to install.
"""

from __future__ import annotations

import dataclasses
import json
import zipfile

import numpy as np
import pytest

torch = pytest.importorskip(
    "torch", reason='torch is not installed: pip install torch==2.13.0, then ".[rl]"'
)
sb3 = pytest.importorskip(
    "stable_baselines3", reason='stable-baselines3 is not installed: pip install ".[rl]"'
)

import gymnasium as gym  # noqa: E402

from simbridge.cli.main import main  # noqa: E402
from simbridge.envs import Normalisation, SimEnv  # noqa: E402
from simbridge.envs.errors import PolicyError  # noqa: E402
from simbridge.envs.policies import load_policy  # noqa: E402
from simbridge.envs.policy import shipped_policy  # noqa: E402
from simbridge.envs.reader import load_task  # noqa: E402

# torch 2.13 warns that torch.jit.trace and torch.jit.script are deprecated; loading a
# TorchScript file (torch.jit.load), which is what simbridge does, is not
pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

LAYOUT = r"joint_pos\[2\], joint_vel\[2\] \(x1 frames\)"
"""The cart-pole's observation as the errors name it."""
ACTION = (
    r"the task 'cartpole' takes 1, one torque entry per joint in this order: \['slider_to_cart'\]"
)
"""The cart-pole's action as the errors name it."""


class _Spaces(gym.Env):
    """An env of given observation and action sizes, only for making a model of that layout."""

    def __init__(self, obs: int, act: int) -> None:
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (obs,), np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (act,), np.float32)

    def reset(self, *, seed=None, options=None):
        return np.zeros(self.observation_space.shape, np.float32), {}

    def step(self, action):
        return np.zeros(self.observation_space.shape, np.float32), 0.0, False, False, {}


@pytest.fixture(scope="module")
def numpy_policy():
    """The shipped policy, in NumPy: the weights computed without torch."""
    return shipped_policy("cartpole_ppo")


@pytest.fixture(scope="module")
def env():
    e = SimEnv("cartpole", backend="mujoco")
    yield e
    e.close()


@pytest.fixture(scope="module")
def observations(numpy_policy):
    """256 observations, wide enough that the policy's action is clipped for some of them."""
    obs = np.random.default_rng(7).normal(0.0, 0.05, (256, 4)).astype(np.float32)
    actions = np.array([numpy_policy(o)[0] for o in obs])
    assert (np.abs(actions) == 1.0).any() and (np.abs(actions) < 1.0).any()
    return obs


def _linears(numpy_policy):
    """The shipped weights as torch Linear layers (torch stores a weight as (out, in))."""
    layers = []
    for w, b in zip(numpy_policy.weights, numpy_policy.biases, strict=True):
        lin = torch.nn.Linear(*w.shape)
        with torch.no_grad():
            lin.weight.copy_(torch.as_tensor(w.T, dtype=torch.float32))
            lin.bias.copy_(torch.as_tensor(b, dtype=torch.float32))
        layers.append(lin)
    return layers


class _Clipped(torch.nn.Module):
    def __init__(self, net: torch.nn.Module) -> None:
        super().__init__()
        self.net = net

    def forward(self, x):
        return torch.clamp(self.net(x), -1.0, 1.0)


@pytest.fixture(scope="module")
def torchscript_file(numpy_policy, tmp_path_factory):
    """The shipped weights as a traced TorchScript module: tanh MLP, its action clipped."""
    l0, l1, l2 = _linears(numpy_policy)
    net = _Clipped(torch.nn.Sequential(l0, torch.nn.Tanh(), l1, torch.nn.Tanh(), l2))
    path = tmp_path_factory.mktemp("ts") / "cartpole_ppo.pt"
    torch.jit.trace(net.eval(), torch.zeros(1, 4)).save(str(path))
    return path


@pytest.fixture(scope="module")
def ppo(numpy_policy):
    """A PPO model with the shipped weights in its actor (as examples/train_cartpole.py's
    network: two hidden layers of 32, tanh)."""
    model = sb3.PPO(
        "MlpPolicy",
        _Spaces(4, 1),
        policy_kwargs={"net_arch": [32, 32], "activation_fn": torch.nn.Tanh},
        seed=0,
        device="cpu",
    )
    l0, l1, l2 = _linears(numpy_policy)
    pi = model.policy.mlp_extractor.policy_net
    pi[0].load_state_dict(l0.state_dict())
    pi[2].load_state_dict(l1.state_dict())
    model.policy.action_net.load_state_dict(l2.state_dict())
    return model


@pytest.fixture(scope="module")
def ppo_file(ppo, tmp_path_factory):
    path = tmp_path_factory.mktemp("sb3") / "ppo.zip"
    ppo.save(str(path))
    return path


def test_a_torchscript_file_acts_as_the_numpy_policy(
    torchscript_file, numpy_policy, env, observations
):
    policy = load_policy(str(torchscript_file), env)
    ours = np.array([policy(o) for o in observations])
    want = np.array([numpy_policy(o) for o in observations], dtype=np.float64)
    assert ours.shape == want.shape == (256, 1) and ours.dtype == np.float64
    # float32 in torch against float64 in NumPy from the same float32 weights
    np.testing.assert_allclose(ours, want, atol=2e-6)


def test_a_ppo_zip_acts_as_predict_and_as_the_numpy_policy(
    ppo_file, ppo, numpy_policy, env, observations
):
    policy = load_policy(str(ppo_file), env)
    ours = np.array([policy(o) for o in observations])
    predicted = np.array([ppo.predict(o, deterministic=True)[0] for o in observations])
    want = np.array([numpy_policy(o) for o in observations], dtype=np.float64)
    assert ours.shape == (256, 1)
    np.testing.assert_allclose(ours, predicted, atol=1e-6)
    np.testing.assert_allclose(ours, want, atol=2e-6)


def test_a_sac_zip_loads_after_ppo_refuses_it(env, observations, tmp_path):
    sac = sb3.SAC(
        "MlpPolicy", _Spaces(4, 1), policy_kwargs={"net_arch": [16]}, seed=1, device="cpu"
    )
    path = tmp_path / "sac.zip"
    sac.save(str(path))
    with pytest.raises(Exception, match="use_sde"):  # noqa: B017 - SB3's own TypeError
        sb3.PPO.load(str(path), device="cpu")
    policy = load_policy(str(path), env)
    ours = np.array([policy(o) for o in observations[:64]])
    want = np.array([sac.predict(o, deterministic=True)[0] for o in observations[:64]])
    assert np.ptp(want) > 0  # the actions vary with the observation: a real comparison
    np.testing.assert_allclose(ours, want, atol=1e-6)


def test_vecnormalize_statistics_stated_in_the_task(ppo_file, ppo):
    """VecNormalize's statistics from a short random rollout, written into the task's
    ``[normalisation]``: the env's observation is VecNormalize's ``normalize_obs`` of the plain
    one, and the zip acts on it as ``predict`` on VecNormalize's observation."""
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    vec = VecNormalize(
        DummyVecEnv([lambda: SimEnv("cartpole", backend="mujoco")]), norm_reward=False
    )
    vec.seed(0)
    vec.reset()
    rng = np.random.default_rng(0)
    for _ in range(200):
        vec.step(rng.uniform(-1, 1, (1, 1)).astype(np.float32))
    mean, var = vec.obs_rms.mean, vec.obs_rms.var
    assert (var > 0).all() and np.abs(mean).max() > 0
    norm = Normalisation(tuple(mean), tuple(var), clip=vec.clip_obs, epsilon=vec.epsilon)
    task = dataclasses.replace(load_task("cartpole"), normalisation=norm)
    normed, plain = SimEnv(task, backend="mujoco"), SimEnv("cartpole", backend="mujoco")
    try:
        policy = load_policy(str(ppo_file), normed)
        on, _ = normed.reset(seed=3)
        op, _ = plain.reset(seed=3)
        for _ in range(40):
            want_obs = vec.normalize_obs(op)
            # VecNormalize normalises the float32 observation, the env its float64 terms
            np.testing.assert_allclose(on, want_obs, rtol=1e-5, atol=1e-5)
            a = policy(on)
            np.testing.assert_allclose(a, ppo.predict(want_obs, deterministic=True)[0], atol=1e-4)
            on, _, term_n, _, _ = normed.step(a)
            op, _, term_p, _, _ = plain.step(a)
            assert term_n == term_p
            if term_n:
                break
    finally:
        normed.close(), plain.close()
        vec.close()


def _sim2sim(policy: str, out, *extra: str) -> dict:
    code = main(
        [
            "sim2sim",
            policy,
            "--task",
            "cartpole",
            "--trained-on",
            "mujoco",
            "--backends",
            "pybullet",
            "--episodes",
            "2",
            "--openloop",
            "0",
            "--out",
            str(out),
            *extra,
        ]
    )
    assert code == 0
    return json.loads((out / "summary.json").read_text())


@pytest.mark.parametrize("kind", ["torchscript", "sb3"])
def test_sim2sim_balances_every_seed_with_the_file(kind, request, tmp_path):
    """The shipped weights balance the cart-pole on every engine (tests/envs/test_trained_policy.py
    holds the NumPy policy to it): through sim2sim, each file survives every episode to the
    task's end on both engines."""
    path = request.getfixturevalue(f"{'torchscript' if kind == 'torchscript' else 'ppo'}_file")
    extra = () if kind == "torchscript" else ("--no-replay",)  # the replay once, not twice
    doc = _sim2sim(str(path), tmp_path / kind, *extra)
    steps = load_task("cartpole").episode_steps
    assert [e["label"] for e in doc["engines"]] == ["mujoco", "pybullet"]
    for e in doc["engines"]:
        assert [(r["seed"], r["success"], r["steps"]) for r in e["episodes"]] == [
            (0, True, steps),
            (1, True, steps),
        ]
    assert str(path) in (tmp_path / kind / "report.md").read_text()


# ------------------------------------------------------------------------------- bad input


def test_a_pt_file_that_is_not_torchscript(tmp_path, env):
    path = tmp_path / "weights.pt"
    torch.save(torch.nn.Linear(4, 1).state_dict(), str(path))
    with pytest.raises(PolicyError, match=r"the TorchScript file does not load .*not torch\.save"):
        load_policy(str(path), env)


@pytest.mark.parametrize(
    ("module", "message"),
    [
        (
            torch.nn.Linear(5, 1),
            rf"does not take the task's observation of 4 entries \(RuntimeError: .*1x4 and 5x1"
            rf"\)\); the observation: {LAYOUT}",
        ),
        (torch.nn.Linear(4, 3), rf"returned 3 action entries; {ACTION}"),
    ],
    ids=["input 5", "output 3"],
)
def test_a_torchscript_policy_of_another_size(module, message, tmp_path, env):
    path = tmp_path / "wrong.pt"
    torch.jit.trace(module, torch.zeros(1, module.in_features)).save(str(path))
    with pytest.raises(PolicyError, match=message):
        load_policy(str(path), env)


class _TwoOutputs(torch.nn.Module):
    def forward(self, x):
        return x[:, :1], x


def test_a_torchscript_policy_returning_a_tuple(tmp_path, env):
    path = tmp_path / "two.pt"
    torch.jit.script(_TwoOutputs()).save(str(path))
    with pytest.raises(PolicyError, match="its forward returned a tuple, not one tensor"):
        load_policy(str(path), env)


def test_a_float64_torchscript_module_gets_float64(tmp_path, env, observations):
    lin = torch.nn.Linear(4, 1).double()
    path = tmp_path / "double.ts"
    torch.jit.script(lin).save(str(path))
    policy = load_policy(str(path), env)
    w = lin.weight.detach().numpy()
    b = lin.bias.detach().numpy()
    for o in observations[:16]:
        np.testing.assert_allclose(policy(o), o.astype(np.float64) @ w.T + b, rtol=1e-12)


def test_a_zip_that_is_no_zip(tmp_path, env):
    path = tmp_path / "model.zip"
    path.write_bytes(b"not a zip at all")
    with pytest.raises(PolicyError, match="not a zip file; a Stable-Baselines3 model is the zip"):
        load_policy(str(path), env)


def test_a_zip_that_is_no_sb3_model(tmp_path, env):
    path = tmp_path / "model.zip"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("readme.txt", "hello")
    with pytest.raises(
        PolicyError,
        match=r"without Stable-Baselines3's 'data' entry.*its entries: \['readme\.txt'\]",
    ):
        load_policy(str(path), env)


def test_a_broken_sb3_zip_names_each_algorithm_once(tmp_path, env):
    path = tmp_path / "model.zip"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("data", "{}")
    with pytest.raises(PolicyError, match="no Stable-Baselines3 algorithm loads it") as info:
        load_policy(str(path), env)
    text = str(info.value)
    assert all(text.count(algo) == 1 for algo in ("PPO", "SAC", "TD3", "A2C", "DQN", "DDPG"))


@pytest.mark.parametrize(
    ("obs", "act", "message"),
    [
        (
            5,
            1,
            r"trained on observations of shape \(5,\); the task's observation has 4 entries: "
            + LAYOUT,
        ),
        (4, 2, rf"it returns actions of shape \(2,\); {ACTION}"),
    ],
    ids=["observation 5", "action 2"],
)
def test_an_sb3_model_of_another_layout(obs, act, message, tmp_path, env):
    path = tmp_path / "model.zip"
    sb3.PPO("MlpPolicy", _Spaces(obs, act), device="cpu").save(str(path))
    with pytest.raises(PolicyError, match=message):
        load_policy(str(path), env)
