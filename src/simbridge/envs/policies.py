"""Policies from outside simbridge, as callables observation -> action, for ``simbridge sim2sim``
(:func:`load_policy`).

A policy is named by one string:

- ``reference``: the shipped task's reference controller (:mod:`.controllers`);
- ``module:callable``: a function ``obs -> action``, or a class whose instances are such
  callables. A class is made once per env, with the env as its one argument when its constructor
  takes one (the reference controllers do: ``simbridge.envs.controllers:DriveToGoal``), without
  arguments otherwise. ``module:Class.attribute`` reaches inside a module's object;
- a file: ``.onnx`` (onnxruntime), ``.pt``/``.ts``/``.jit`` (TorchScript, torch) or ``.zip``
  (a Stable-Baselines3 model: PPO, SAC, TD3, A2C, DQN or DDPG, the first that loads it). Each
  runtime is imported only when such a file is given; a missing one raises
  :class:`PolicyRuntimeMissingError` naming what to install.

Actions are deterministic: ONNX and TorchScript files are pure functions of the observation,
Stable-Baselines3 models are asked with ``deterministic=True``; a ``module:callable`` is the
caller's own.
"""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from simbridge.envs.errors import PolicyError, PolicyRuntimeMissingError

if TYPE_CHECKING:
    from simbridge.envs.env import SimEnv

__all__ = ["FILE_KINDS", "Policy", "check_output", "load_policy"]

Policy = Callable[[np.ndarray], Any]
"""observation ``(size,)`` float32 -> action ``(n,)``."""

FILE_KINDS = {
    ".onnx": "ONNX",
    ".pt": "TorchScript",
    ".ts": "TorchScript",
    ".jit": "TorchScript",
    ".zip": "Stable-Baselines3",
}
"""A policy file's suffix -> its kind."""

_SB3_ALGORITHMS = ("PPO", "SAC", "TD3", "A2C", "DQN", "DDPG")


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text[:300]}"


def _from_module(spec: str, env: SimEnv) -> Policy:
    """``module:callable``: a function, or a class made for ``env``."""
    module_name, _, attr = spec.partition(":")
    try:
        obj: Any = importlib.import_module(module_name)
    except ImportError as exc:
        raise PolicyError(
            spec, f"module {module_name!r} does not import ({_one_line(exc)})"
        ) from None
    for part in attr.split("."):
        if not hasattr(obj, part):
            names = sorted(n for n in dir(obj) if not n.startswith("_"))
            raise PolicyError(
                spec, f"{module_name!r} has no attribute {attr!r}; public names there: {names}"
            )
        obj = getattr(obj, part)
    if inspect.isclass(obj):  # a class: made for the env
        cls: Any = obj
        params = [
            p
            for p in inspect.signature(cls).parameters.values()
            if p.default is p.empty and p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)
        ]
        obj = cls(env) if params else cls()
    if not callable(obj):
        raise PolicyError(spec, f"{attr!r} is a {type(obj).__name__}, not a callable obs -> action")
    return obj


def _onnx(path: Path, env: SimEnv) -> Policy:
    try:
        import onnxruntime  # type: ignore[import-untyped]
    except ImportError:
        raise PolicyRuntimeMissingError(str(path), "ONNX", "pip install onnxruntime") from None
    try:
        session = onnxruntime.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    except Exception as exc:  # onnxruntime raises its own classes for a bad file
        raise PolicyError(str(path), f"the ONNX file does not load ({_one_line(exc)})") from None
    inp = session.get_inputs()[0]
    size = int(np.prod(env.observation_space.shape or (0,)))
    declared = inp.shape[-1] if inp.shape else None
    if isinstance(declared, int) and declared != size:
        raise PolicyError(
            str(path),
            f"its input {inp.name!r} takes {declared} entries, the task's observation has {size}: "
            f"{_layout(env)}",
        )
    name = inp.name

    def policy(obs: np.ndarray) -> np.ndarray:
        out = session.run(None, {name: np.asarray(obs, np.float32)[None]})[0]
        return np.asarray(out, dtype=np.float64).reshape(-1)

    return policy


def _torchscript(path: Path) -> Policy:
    try:
        import torch  # type: ignore[import-not-found]
    except ImportError:
        raise PolicyRuntimeMissingError(
            str(path), "TorchScript", "pip install torch (the CPU build is enough)"
        ) from None
    try:
        module = torch.jit.load(str(path), map_location="cpu").eval()
    except Exception as exc:  # torch raises RuntimeError or its own for a bad file
        raise PolicyError(
            str(path), f"the TorchScript file does not load ({_one_line(exc)})"
        ) from None

    def policy(obs: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            out = module(torch.as_tensor(np.asarray(obs, np.float32))[None])
        return np.asarray(out.numpy(), dtype=np.float64).reshape(-1)

    return policy


def _sb3(path: Path) -> Policy:
    try:
        import stable_baselines3  # type: ignore[import-not-found]
    except ImportError:
        raise PolicyRuntimeMissingError(
            str(path), "Stable-Baselines3", 'pip install "simbridge[rl]" (stable-baselines3)'
        ) from None
    errors = []
    for algo in _SB3_ALGORITHMS:
        try:
            model = getattr(stable_baselines3, algo).load(str(path), device="cpu")
        except Exception as exc:  # a zip of another algorithm, or no model at all
            errors.append(f"{algo}: {_one_line(exc)[:80]}")
            continue

        def policy(obs: np.ndarray, model: Any = model) -> np.ndarray:
            action, _ = model.predict(np.asarray(obs, np.float32), deterministic=True)
            return np.asarray(action, dtype=np.float64).reshape(-1)

        return policy
    raise PolicyError(str(path), f"no Stable-Baselines3 algorithm loads it ({'; '.join(errors)})")


def _layout(env: SimEnv) -> str:
    """The observation's layout in words: each term's name and size, the history."""
    obs = env.contract()["observation"]
    terms = ", ".join(f"{t['name']}[{t['size']}]" for t in obs["terms"])
    return f"{terms} (x{obs['history']} frames)"


def load_policy(spec: str, env: SimEnv) -> Policy:
    """The policy named by ``spec``, made for ``env`` (the module docstring lists the forms).

    Args:
        spec: ``reference``, ``module:callable`` or a policy file's path.
        env: the env it will act in (a class policy is made with it).

    Returns:
        A callable observation -> action.

    Raises:
        PolicyError: a module or attribute that does not exist, an object that is not
            callable, a file that does not load or of an unknown kind, an ONNX input of
            another size than the observation.
        PolicyRuntimeMissingError: a file whose runtime is not installed.
    """
    if spec == "reference":
        from simbridge.envs.controllers import CONTROLLERS

        if env.task.name not in CONTROLLERS:
            raise PolicyError(
                spec,
                f"task {env.task.name!r} has no reference controller; those that do: "
                f"{sorted(CONTROLLERS)}",
            )
        return CONTROLLERS[env.task.name](env)
    path = Path(spec)
    if path.suffix.lower() in FILE_KINDS:
        if not path.is_file():
            raise PolicyError(spec, "no such file")
        kind = FILE_KINDS[path.suffix.lower()]
        if kind == "ONNX":
            return _onnx(path, env)
        return _torchscript(path) if kind == "TorchScript" else _sb3(path)
    if ":" in spec:
        return _from_module(spec, env)
    raise PolicyError(
        spec,
        "expected 'reference', module:callable, or a file ending in "
        f"{', '.join(sorted(FILE_KINDS))}",
    )


def check_output(spec: str, env: SimEnv, action: Any) -> np.ndarray:
    """A policy's action as a ``(n,)`` float64 array, checked against the task's action size.

    Args:
        spec: the policy as given (for the message).
        env: the env.
        action: what the policy returned.

    Returns:
        ``(n,)`` float64 (NaN entries kept: the caller counts them).

    Raises:
        PolicyError: an output of another size than the task's action (the message names both
            sizes and the task's joints in order).
    """
    joints = list(env.task.action.joints)
    try:
        a = np.asarray(action, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise PolicyError(
            spec,
            f"returned {type(action).__name__}, not numbers; the task {env.task.name!r} "
            f"takes {len(joints)} entries, one per joint: {joints}",
        ) from None
    if a.size != len(joints):
        raise PolicyError(
            spec,
            f"returned {a.size} action entries; the task {env.task.name!r} takes {len(joints)}, "
            f"one {env.task.action.mode} entry per joint in this order: {joints}",
        )
    return a
