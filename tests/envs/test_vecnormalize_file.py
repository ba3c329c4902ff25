"""A trained policy's observation statistics read from Stable-Baselines3's own ``VecNormalize``
file (src/simbridge/envs/vecnormalize.py, ``simbridge sim2sim --normalisation``).

- The statistics a real ``VecNormalize`` gathered over the cart-pole, saved with its own
  ``save``, read without running the pickle's code: the env's observation is then
  ``VecNormalize.normalize_obs`` of the plain one, bit for bit (the same float64 arithmetic on
  the same float32 observation), its clipping included.
- End to end: a PPO zip whose actor balances the cart-pole only on normalised observations (the
  shipped weights with the statistics folded into the first layer), its ``vec_normalize.pkl``
  beside it. ``simbridge sim2sim`` finds the file, says so, and balances every seed (the
  replayed seed too, which reloads the task); with ``--normalisation none`` it does not.
- Bad input, each a :class:`NormalisationFileError` naming the file: not a pickle, a pickle of
  something else, a hostile pickle (its code does not run), a truncated one, randomly mutated
  ones (read or refused, nothing else escapes), statistics of
  another size (both layouts named), a Dict observation, a task that states its own
  ``[normalisation]``, two files beside one policy. ``norm_obs=False`` is taken: no
  normalisation, and said.

torch (the CPU build) and stable-baselines3 are in the extra ``test``; where they are missing
this file skips, saying what to install.
"""

from __future__ import annotations

import dataclasses
import json
import pickle
import shutil

import numpy as np
import pytest

torch = pytest.importorskip(
    "torch", reason='torch is not installed: pip install torch==2.13.0, then ".[rl]"'
)
sb3 = pytest.importorskip(
    "stable_baselines3", reason='stable-baselines3 is not installed: pip install ".[rl]"'
)

import gymnasium as gym  # noqa: E402
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize  # noqa: E402

from simbridge.cli.main import main  # noqa: E402
from simbridge.envs import Normalisation, SimEnv  # noqa: E402
from simbridge.envs.errors import NormalisationFileError  # noqa: E402
from simbridge.envs.policy import shipped_policy  # noqa: E402
from simbridge.envs.reader import load_task  # noqa: E402
from simbridge.envs.sim2sim import sim2sim  # noqa: E402
from simbridge.envs.vecnormalize import read_vecnormalize, resolve  # noqa: E402

LAYOUT = r"joint_pos\[2\], joint_vel\[2\] \(x1 frames\)"
"""The cart-pole's observation as the errors name it."""


class _Boxes(gym.Env):
    """An env of a given observation space, only for gathering statistics of that layout."""

    def __init__(self, space: gym.spaces.Space) -> None:
        self.observation_space = space
        self.action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        return self.observation_space.sample(), {}

    def step(self, action):
        return self.observation_space.sample(), 0.0, False, False, {}


def _gathered(env_fn, steps: int, **kwargs) -> VecNormalize:
    vec = VecNormalize(DummyVecEnv([env_fn]), **kwargs)
    vec.seed(0)
    vec.reset()
    rng = np.random.default_rng(0)
    for _ in range(steps):
        vec.step(rng.uniform(-1, 1, (1, 1)).astype(np.float32))
    return vec


@pytest.fixture(scope="module")
def cartpole_vec(tmp_path_factory):
    """VecNormalize over the cart-pole, 300 random steps, a tight clip_obs and its own epsilon
    (so that clipping and epsilon are both exercised); saved with its own ``save``."""
    vec = _gathered(lambda: SimEnv("cartpole", backend="mujoco"), 300, clip_obs=2.0, epsilon=1e-4)
    path = tmp_path_factory.mktemp("vecnorm") / "vec_normalize.pkl"
    vec.save(str(path))
    yield vec, path
    vec.close()


def test_the_file_is_read_as_saved(cartpole_vec):
    vec, path = cartpole_vec
    got = read_vecnormalize(path)
    n = got.normalisation
    assert n is not None and got.norm_obs and got.found == "given"
    assert np.array_equal(n.mean, vec.obs_rms.mean) and np.array_equal(n.var, vec.obs_rms.var)
    assert (n.clip, n.epsilon, n.source) == (2.0, 1e-4, str(path))
    assert got.count == pytest.approx(vec.obs_rms.count)
    assert "4 entries, clip 2, epsilon 0.0001, gathered over 301 steps" in got.describe()


def test_the_observation_is_normalize_obs_bit_for_bit(cartpole_vec):
    """The env with the file's statistics against VecNormalize's own ``normalize_obs`` of the
    plain env's observations, the same actions on both."""
    vec, path = cartpole_vec
    task, read = resolve(load_task("cartpole"), "reference", path)
    assert read is not None and task.normalisation == read.normalisation
    normed, plain = SimEnv(task, backend="mujoco"), SimEnv("cartpole", backend="mujoco")
    try:
        assert normed.observation_space.high[0] == 2.0
        rng = np.random.default_rng(5)
        rows, clipped = 0, 0
        for seed in (11, 12):
            on, _ = normed.reset(seed=seed)
            op, _ = plain.reset(seed=seed)
            for _ in range(60):
                want = vec.normalize_obs(op)
                assert on.dtype == want.dtype == np.float32
                np.testing.assert_array_equal(on, want)
                rows += 1
                clipped += int(np.count_nonzero(np.abs(want) == 2.0))
                a = rng.uniform(-1, 1, 1).astype(np.float32)
                on, _, done, _, _ = normed.step(a)
                op, _, done_p, _, _ = plain.step(a)
                assert done == done_p
                if done:
                    break
        # a real comparison: clipped entries and unclipped ones both
        assert rows >= 60 and 0 < clipped < rows * 4
    finally:
        normed.close(), plain.close()


# ------------------------------------------------------------------ end to end: a PPO zip


@pytest.fixture(scope="module")
def ppo_with_stats(tmp_path_factory):
    """A PPO zip that balances the cart-pole on VecNormalize's observation alone: the shipped
    weights with the statistics folded into the first layer (``o = z * s + m`` with
    ``s = sqrt(var + epsilon)``: ``o @ W0 + b0 = z @ (s * W0) + (m @ W0 + b0)``), and the
    statistics as ``vec_normalize.pkl`` beside it."""
    vec = _gathered(lambda: SimEnv("cartpole", backend="mujoco"), 300)
    folder = tmp_path_factory.mktemp("zoo")
    vec.save(str(folder / "vec_normalize.pkl"))
    m, s = vec.obs_rms.mean, np.sqrt(vec.obs_rms.var + vec.epsilon)
    vec.close()
    numpy_policy = shipped_policy("cartpole_ppo")
    weights = [np.asarray(w, np.float64) for w in numpy_policy.weights]
    biases = [np.asarray(b, np.float64) for b in numpy_policy.biases]
    biases[0] = m @ weights[0] + biases[0]
    weights[0] = s[:, None] * weights[0]
    model = sb3.PPO(
        "MlpPolicy",
        _Boxes(gym.spaces.Box(-np.inf, np.inf, (4,), np.float32)),
        policy_kwargs={"net_arch": [32, 32], "activation_fn": torch.nn.Tanh},
        seed=0,
        device="cpu",
    )
    layers = [*model.policy.mlp_extractor.policy_net[::2], model.policy.action_net]
    with torch.no_grad():
        for layer, w, b in zip(layers, weights, biases, strict=True):
            layer.weight.copy_(torch.as_tensor(w.T, dtype=torch.float32))
            layer.bias.copy_(torch.as_tensor(b, dtype=torch.float32))
    model.save(str(folder / "ppo.zip"))
    return folder / "ppo.zip"


def _cli(policy, out, *extra: str, capsys) -> tuple[dict, str]:
    code = main(
        [
            "sim2sim",
            str(policy),
            "--task",
            "cartpole",
            "--trained-on",
            "mujoco",
            "--backends",
            "mujoco",
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
    return json.loads((out / "summary.json").read_text()), capsys.readouterr().out


def test_sim2sim_finds_the_file_beside_the_zip_and_says_so(ppo_with_stats, tmp_path, capsys):
    pkl = str(ppo_with_stats.parent / "vec_normalize.pkl")
    doc, out = _cli(ppo_with_stats, tmp_path / "auto", capsys=capsys)
    steps = load_task("cartpole").episode_steps
    (engine,) = doc["engines"]
    assert [(r["success"], r["steps"]) for r in engine["episodes"]] == [(True, steps)] * 2
    assert doc["normalisation"]["file"] == pkl
    assert doc["normalisation"]["found"] == "found beside the policy"
    assert f"observation statistics: VecNormalize file {pkl} (found beside the policy" in out
    assert engine["contract"]["observation"]["normalisation"]["source"] == pkl
    report = (tmp_path / "auto" / "report.md").read_text()
    assert f"| observation normalisation | VecNormalize file {pkl}: clip 10, epsilon 1e-08 |" in (
        report
    )
    # the replayed seed reloads the task by name: it ran with the file's statistics too
    assert doc["replay"]["matches_evaluation"] == {"mujoco": True}

    doc, out = _cli(
        ppo_with_stats, tmp_path / "none", "--normalisation", "none", "--no-replay", capsys=capsys
    )
    assert doc["normalisation"] is None and "observation statistics" not in out
    (engine,) = doc["engines"]
    assert not all(r["success"] for r in engine["episodes"])  # the raw observation fails it


def test_the_library_call_takes_the_file(ppo_with_stats, tmp_path):
    """The file given by path beside nothing: the same episodes as found beside the zip."""
    moved = tmp_path / "stats.pkl"
    shutil.copy(ppo_with_stats.parent / "vec_normalize.pkl", moved)
    result = sim2sim(
        str(ppo_with_stats),
        "cartpole",
        trained_on="mujoco",
        backends=["mujoco"],
        episodes=1,
        normalisation=moved,
    )
    assert result.statistics.path == str(moved) and result.statistics.found == "given"
    assert result.runs[0].records[0].success


# ------------------------------------------------------------------------------- bad input


def test_statistics_that_are_not_numbers(tmp_path):
    vec = _gathered(lambda: SimEnv("cartpole", backend="mujoco"), 5)
    vec.obs_rms.mean = np.array(["a", "b", "c", "d"])
    path = tmp_path / "text.pkl"
    vec.save(str(path))
    vec.close()
    with pytest.raises(NormalisationFileError, match=r"holds mean of <U1 and var of float64"):
        read_vecnormalize(path)


def test_not_a_pickle(tmp_path):
    path = tmp_path / "stats.pkl"
    path.write_text("mean = [0, 0]\n")
    with pytest.raises(NormalisationFileError, match=r"stats\.pkl': not a pickle \(its first"):
        read_vecnormalize(path)
    with pytest.raises(NormalisationFileError, match="no such file"):
        read_vecnormalize(tmp_path / "missing.pkl")


def test_a_pickle_of_something_else(tmp_path):
    path = tmp_path / "stats.pkl"
    path.write_bytes(pickle.dumps({"mean": [0.0]}))
    with pytest.raises(
        NormalisationFileError, match="a pickle of dict, not of Stable-Baselines3's VecNormalize"
    ):
        read_vecnormalize(path)


class _Hostile:
    """A pickle that, loaded by ``pickle.load``, would write a file."""

    def __init__(self, marker: str) -> None:
        self.marker = marker

    def __reduce__(self):
        return (exec, (f"open({self.marker!r}, 'w').close()",))


def test_a_hostile_pickle_runs_nothing(tmp_path):
    marker = tmp_path / "ran"
    path = tmp_path / "stats.pkl"
    path.write_bytes(pickle.dumps(_Hostile(str(marker))))
    with pytest.raises(NormalisationFileError, match=r"a pickle of builtins\.exec, not of"):
        read_vecnormalize(path)
    assert not marker.exists()
    pickle.loads(path.read_bytes())  # what a plain load does: the test's own check
    assert marker.exists()


def test_a_truncated_file(cartpole_vec, tmp_path):
    _, good = cartpole_vec
    path = tmp_path / "cut.pkl"
    path.write_bytes(good.read_bytes()[:200])
    with pytest.raises(NormalisationFileError, match=r"not a pickle of VecNormalize statistics"):
        read_vecnormalize(path)


def test_mutated_files_are_read_or_refused(cartpole_vec, tmp_path):
    """1 to 3 bytes of the real file changed at random, 400 times: each file reads, or is
    refused with NormalisationFileError; no other exception escapes."""
    _, good = cartpole_vec
    data = good.read_bytes()
    rng = np.random.default_rng(0)
    path = tmp_path / "mutated.pkl"
    outcomes = {"read": 0, "refused": 0}
    for _ in range(400):
        b = bytearray(data)
        for _ in range(rng.integers(1, 4)):
            b[rng.integers(2, len(b))] = rng.integers(0, 256)
        path.write_bytes(bytes(b))
        try:
            read_vecnormalize(path)
            outcomes["read"] += 1
        except NormalisationFileError:
            outcomes["refused"] += 1
    assert outcomes["read"] > 0 and outcomes["refused"] > 0, outcomes


def test_statistics_of_another_size_name_both_layouts(tmp_path):
    vec = _gathered(lambda: _Boxes(gym.spaces.Box(-1, 1, (5,), np.float32)), 20)
    path = tmp_path / "five.pkl"
    vec.save(str(path))
    vec.close()
    task, _ = resolve(load_task("cartpole"), "reference", path)
    with pytest.raises(
        NormalisationFileError,
        match=rf"five\.pkl': its statistics have 5 entries \(VecNormalize over observations of "
        rf"shape \(5,\)\); the task 'cartpole''s observation has 4: {LAYOUT}",
    ):
        SimEnv(task, backend="mujoco")


def test_a_dict_observation_is_refused(tmp_path):
    space = gym.spaces.Dict(
        {
            "pos": gym.spaces.Box(-1, 1, (2,), np.float32),
            "vel": gym.spaces.Box(-1, 1, (2,), np.float32),
        }
    )
    vec = _gathered(lambda: _Boxes(space), 10)
    path = tmp_path / "dict.pkl"
    vec.save(str(path))
    vec.close()
    with pytest.raises(
        NormalisationFileError,
        match=r"VecNormalize over a Dict observation \(keys \['pos', 'vel'\]\); a simbridge "
        "task's observation is one Box vector",
    ):
        read_vecnormalize(path)


def test_norm_obs_false_passes_the_observation(tmp_path):
    vec = _gathered(lambda: SimEnv("cartpole", backend="mujoco"), 10, norm_obs=False)
    path = tmp_path / "rewards_only.pkl"
    vec.save(str(path))
    vec.close()
    base = load_task("cartpole")
    task, read = resolve(base, "reference", path)
    assert task is base and read is not None and read.normalisation is None
    assert "norm_obs=False: the observation passed as it is" in read.describe()


def test_a_task_with_its_own_table_takes_no_file(cartpole_vec):
    _, path = cartpole_vec
    task = dataclasses.replace(
        load_task("cartpole"), normalisation=Normalisation((0.0,) * 4, (1.0,) * 4)
    )
    with pytest.raises(
        NormalisationFileError,
        match=r"vec_normalize\.pkl': the task \(.*cartpole\.toml\) states its own "
        r"\[normalisation\] too: use one of the two",
    ):
        resolve(task, "reference", path)
    assert resolve(task, "reference", "none") == (task, None)


def test_two_files_beside_one_zip(cartpole_vec, tmp_path):
    _, path = cartpole_vec
    zipped = tmp_path / "CartPole.zip"
    zipped.write_bytes(b"PK")
    assert resolve(load_task("cartpole"), str(zipped)) == (load_task("cartpole"), None)
    (tmp_path / "CartPole").mkdir()
    shutil.copy(path, tmp_path / "CartPole" / "vecnormalize.pkl")  # RL Zoo's log folder
    task, read = resolve(load_task("cartpole"), str(zipped))
    assert read is not None and read.path == str(tmp_path / "CartPole" / "vecnormalize.pkl")
    shutil.copy(path, tmp_path / "vec_normalize.pkl")
    with pytest.raises(
        NormalisationFileError, match=r"2 VecNormalize files lie beside the policy .*CartPole\.zip"
    ):
        resolve(load_task("cartpole"), str(zipped))
