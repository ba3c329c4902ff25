"""Trained policies as plain NumPy: a multilayer perceptron's weights in a ``.npz`` file, run
without torch, deterministic (the mean action).

::

    python -m simbridge.envs.evaluate cartpole --policy simbridge.envs.policy:cartpole_ppo

``cartpole_ppo`` is a ``module:callable`` taking the env and returning observation -> action: the
PPO policy examples/train_cartpole.py trained on MuJoCo and shipped in ``policies/`` beside this
module (how it was made: its ``meta``, and docs/rl_example.md). :func:`save_mlp` writes such a
file from any MLP's layers; :func:`load_mlp` reads one.

The file's arrays: ``w0, b0, w1, b1, ...`` (layer i maps ``(n_in,)`` to ``(n_out,)`` as
``x @ w_i + b_i``, ``w_i`` of shape ``(n_in, n_out)``), ``activation`` (``"tanh"`` or
``"relu"``, after every layer but the last), ``low`` and ``high`` (the action's clip) and
``meta`` (a JSON string: task, engine, the command that made it, its training time).
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from importlib import resources
from typing import TYPE_CHECKING, Any

import numpy as np

from simbridge.exceptions import InvalidArgumentError

if TYPE_CHECKING:
    from simbridge.envs.env import SimEnv

__all__ = [
    "ACTIVATIONS",
    "CartPolePPO",
    "MlpPolicy",
    "cartpole_ppo",
    "load_mlp",
    "save_mlp",
    "shipped_policy",
]

ACTIVATIONS = ("tanh", "relu")
"""The hidden layers' activations a file may name."""


class MlpPolicy:
    """observation -> action through an MLP's layers, in float64, the output clipped.

    Args:
        weights: one ``(n_in, n_out)`` matrix per layer, each layer's ``n_in`` the previous
            layer's ``n_out``.
        biases: one ``(n_out,)`` vector per layer.
        activation: one of :data:`ACTIVATIONS`, applied after every layer but the last.
        low, high: the action's bounds (scalars or ``(n_act,)``).
        meta: what the file says of itself (task, engine, command, training time).

    Raises:
        InvalidArgumentError: an unknown activation, no layers, or layers whose sizes do not
            chain.
    """

    def __init__(
        self,
        weights: Sequence[np.ndarray],
        biases: Sequence[np.ndarray],
        activation: str = "tanh",
        low: Any = -1.0,
        high: Any = 1.0,
        meta: dict[str, Any] | None = None,
    ) -> None:
        if activation not in ACTIVATIONS:
            raise InvalidArgumentError(
                "activation", f"expected one of {list(ACTIVATIONS)}, got {activation!r}"
            )
        if not weights or len(weights) != len(biases):
            raise InvalidArgumentError(
                "weights",
                f"expected as many layers as biases (>= 1): {len(weights)} and {len(biases)}",
            )
        self.weights = [np.asarray(w, dtype=np.float64) for w in weights]
        self.biases = [np.asarray(b, dtype=np.float64) for b in biases]
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            fits_prev = i == 0 or w.shape[0] == self.weights[i - 1].shape[1]
            if w.ndim != 2 or b.shape != (w.shape[1],) or not fits_prev:
                raise InvalidArgumentError(
                    "weights",
                    f"layer {i}: w {w.shape} and b {b.shape} do not chain "
                    f"({[x.shape for x in self.weights]})",
                )
        self.activation = activation
        self.low = np.asarray(low, dtype=np.float64)
        self.high = np.asarray(high, dtype=np.float64)
        self.meta = dict(meta or {})

    @property
    def obs_size(self) -> int:
        """Entries the policy takes."""
        return int(self.weights[0].shape[0])

    @property
    def act_size(self) -> int:
        """Entries it returns."""
        return int(self.weights[-1].shape[1])

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The action for one observation.

        Args:
            obs: ``(obs_size,)``.

        Returns:
            ``(act_size,)`` float32, clipped to ``[low, high]``.

        Raises:
            InvalidArgumentError: an observation of another size.
        """
        x = np.asarray(obs, dtype=np.float64)
        if x.shape != (self.obs_size,):
            raise InvalidArgumentError("obs", f"the policy takes ({self.obs_size},), got {x.shape}")
        act = np.tanh if self.activation == "tanh" else (lambda v: np.maximum(v, 0.0))
        last = len(self.weights) - 1
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            x = x @ w + b
            if i < last:
                x = act(x)
        return np.clip(x, self.low, self.high).astype(np.float32)

    def check_env(self, env: SimEnv) -> None:
        """Check that the env's observation and action have this policy's sizes.

        Args:
            env: the env the policy will run in.

        Raises:
            InvalidArgumentError: a size that differs (the message gives both layouts).
        """
        obs = env.observation_space.shape[0]  # type: ignore[index]
        act = env.action_space.shape[0]  # type: ignore[index]
        if (obs, act) != (self.obs_size, self.act_size):
            o = env.contract()["observation"]
            terms = ", ".join(f"{t['name']} ({t['size']})" for t in o["terms"])
            raise InvalidArgumentError(
                "policy",
                f"takes {self.obs_size} observation entries and returns {self.act_size} "
                f"actions; task {env.task.name!r} gives {obs} ({terms}; history "
                f"{o['history']}) and takes {act} ({list(env.task.action.joints)})",
            )


def save_mlp(
    path: str | os.PathLike[str],
    weights: Sequence[np.ndarray],
    biases: Sequence[np.ndarray],
    *,
    activation: str = "tanh",
    low: Any = -1.0,
    high: Any = 1.0,
    meta: dict[str, Any] | None = None,
) -> MlpPolicy:
    """Write an MLP policy to an ``.npz`` file (float32 weights).

    Args:
        path: the file.
        weights, biases, activation, low, high, meta: as :class:`MlpPolicy`'s.

    Returns:
        The policy as :func:`load_mlp` will read it back (float32 weights).
    """
    policy = MlpPolicy(
        [np.asarray(w, np.float32) for w in weights],
        [np.asarray(b, np.float32) for b in biases],
        activation,
        low,
        high,
        meta,
    )
    arrays: dict[str, Any] = {}
    for i, (w, b) in enumerate(zip(weights, biases, strict=True)):
        arrays[f"w{i}"], arrays[f"b{i}"] = np.asarray(w, np.float32), np.asarray(b, np.float32)
    np.savez_compressed(
        path,
        activation=np.array(activation),
        low=policy.low,
        high=policy.high,
        meta=np.array(json.dumps(policy.meta, sort_keys=True)),
        **arrays,
    )
    return policy


def load_mlp(path: str | os.PathLike[str]) -> MlpPolicy:
    """Read an MLP policy written by :func:`save_mlp`.

    Args:
        path: the ``.npz`` file.

    Returns:
        The :class:`MlpPolicy`.

    Raises:
        InvalidArgumentError: a file that is not such a policy (no ``w0``, or a layer missing
            its bias).
    """
    with np.load(path, allow_pickle=False) as f:
        n = sum(1 for k in f.files if k.startswith("w") and k[1:].isdigit())
        missing = [k for i in range(n) for k in (f"w{i}", f"b{i}") if k not in f.files]
        if n == 0 or missing:
            raise InvalidArgumentError(
                "path",
                f"{os.fspath(path)} holds {sorted(f.files)}; an MLP policy holds w0, b0, "
                f"w1, b1, ... (missing: {missing or ['w0']})",
            )
        return MlpPolicy(
            [f[f"w{i}"] for i in range(n)],
            [f[f"b{i}"] for i in range(n)],
            str(f["activation"]) if "activation" in f.files else "tanh",
            f["low"] if "low" in f.files else -1.0,
            f["high"] if "high" in f.files else 1.0,
            json.loads(str(f["meta"])) if "meta" in f.files else {},
        )


def shipped_policy(name: str) -> MlpPolicy:
    """A policy shipped with simbridge (``policies/NAME.npz`` beside this module).

    Args:
        name: the file's stem (``"cartpole_ppo"``).

    Returns:
        The :class:`MlpPolicy`.

    Raises:
        InvalidArgumentError: no such policy (the message lists the shipped ones).
    """
    folder = resources.files("simbridge.envs").joinpath("policies")
    names = sorted(p.name[:-4] for p in folder.iterdir() if p.name.endswith(".npz"))
    if name not in names:
        raise InvalidArgumentError("name", f"expected one of {names}, got {name!r}")
    with resources.as_file(folder.joinpath(f"{name}.npz")) as path:
        return load_mlp(path)


class CartPolePPO:
    """The shipped PPO cart-pole policy (``simbridge.envs.policy:cartpole_ppo``): a class
    made once per env, as both ``simbridge sim2sim`` and ``evaluate --policy`` make a
    ``module:callable`` class, then called observation -> action.

    Args:
        env: a ``cartpole`` env (its sizes are checked).

    Raises:
        InvalidArgumentError: an env of other observation or action sizes.
    """

    def __init__(self, env: SimEnv) -> None:
        self.policy = shipped_policy("cartpole_ppo")
        self.policy.check_env(env)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The mean action for ``obs``, clipped to [-1, 1].

        Args:
            obs: the env's observation.

        Returns:
            The action.
        """
        return self.policy(obs)


cartpole_ppo = CartPolePPO
"""The name commands and the docs give the shipped policy."""
