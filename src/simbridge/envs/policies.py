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

A file's policy is checked against the task when it is loaded, before any engine runs: a
Stable-Baselines3 model's observation and action spaces against the task's, and every file's
policy is called once on a zero observation of the task's size, its output's size checked
against the action's. A policy that does not fit raises :class:`PolicyError` naming both layouts.

Actions are deterministic: ONNX and TorchScript files are pure functions of the observation,
Stable-Baselines3 models are asked with ``deterministic=True``; a ``module:callable`` is the
caller's own.
"""

from __future__ import annotations

import importlib
import inspect
import zipfile
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


def _last_line(exc: BaseException) -> str:
    """An error's last line: torch puts the TorchScript traceback first and the reason last
    (``RuntimeError: mat1 and mat2 shapes cannot be multiplied (1x4 and 5x1)``)."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    last = lines[-1] if lines else ""
    text = last if last.startswith(type(exc).__name__) else f"{type(exc).__name__}: {last}"
    return text[:300]


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
    size = _obs_size(env)
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
    """A TorchScript file's module, given the observation as ``(1, size)`` in the dtype of its
    first floating parameter (float32 when it has none)."""
    try:
        import torch  # type: ignore[import-not-found, unused-ignore]
    except ImportError:
        raise PolicyRuntimeMissingError(
            str(path), "TorchScript", "pip install torch (the CPU build is enough)"
        ) from None
    try:
        module = torch.jit.load(str(path), map_location="cpu").eval()
    except Exception as exc:  # torch raises RuntimeError or its own for a bad file
        raise PolicyError(
            str(path),
            f"the TorchScript file does not load ({_one_line(exc)}); a TorchScript file is "
            "what torch.jit.script(module).save(path) or torch.jit.trace(module, example)"
            ".save(path) writes, not torch.save's pickle of a module or its state_dict",
        ) from None
    floats = [p.dtype for p in module.parameters() if p.is_floating_point()]
    dtype = floats[0] if floats else torch.float32

    def policy(obs: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            out = module(torch.as_tensor(np.asarray(obs, np.float32)).to(dtype)[None])
        if not isinstance(out, torch.Tensor):
            raise PolicyError(
                str(path),
                f"its forward returned a {type(out).__name__}, not one tensor: the action",
            )
        return np.asarray(out.numpy(), dtype=np.float64).reshape(-1)

    return policy


def _sb3_zip(path: Path) -> None:
    """Refuse a file that is no zip, or a zip without Stable-Baselines3's ``data`` entry."""
    if not zipfile.is_zipfile(path):
        raise PolicyError(
            str(path),
            "not a zip file; a Stable-Baselines3 model is the zip model.save(path) writes",
        )
    with zipfile.ZipFile(path) as z:
        names = z.namelist()
    if "data" not in names:
        raise PolicyError(
            str(path),
            "a zip without Stable-Baselines3's 'data' entry, so no model.save(path) wrote it "
            f"(its entries: {names[:8]}{' ...' if len(names) > 8 else ''})",
        )


def _sb3(path: Path, env: SimEnv) -> Policy:
    """A Stable-Baselines3 model: the first of :data:`_SB3_ALGORITHMS` that loads the zip, its
    spaces checked against the task's."""
    try:
        import stable_baselines3  # type: ignore[import-not-found, unused-ignore]
    except ImportError:
        raise PolicyRuntimeMissingError(
            str(path), "Stable-Baselines3", 'pip install "simbridge[rl]" (stable-baselines3)'
        ) from None
    _sb3_zip(path)
    errors: dict[str, list[str]] = {}
    for algo in _SB3_ALGORITHMS:
        try:
            model = getattr(stable_baselines3, algo).load(str(path), device="cpu")
        except Exception as exc:  # a zip of another algorithm, or no model at all
            errors.setdefault(_one_line(exc)[:120], []).append(algo)
            continue
        _sb3_spaces(path, env, model)

        def policy(obs: np.ndarray, model: Any = model) -> np.ndarray:
            action, _ = model.predict(np.asarray(obs, np.float32), deterministic=True)
            return np.asarray(action, dtype=np.float64).reshape(-1)

        return policy
    why = "; ".join(f"{', '.join(algos)}: {text}" for text, algos in errors.items())
    raise PolicyError(str(path), f"no Stable-Baselines3 algorithm loads it ({why})")


def _sb3_spaces(path: Path, env: SimEnv, model: Any) -> None:
    """A model's observation and action spaces against the task's (both layouts named)."""
    obs_shape = getattr(model.observation_space, "shape", None)
    if obs_shape != env.observation_space.shape:
        raise PolicyError(
            str(path),
            f"it was trained on observations {_space(model.observation_space)}; the task's "
            f"observation has {_obs_size(env)} entries: {_layout(env)}",
        )
    act_shape = getattr(model.action_space, "shape", None)
    if act_shape != env.action_space.shape or not act_shape:
        raise PolicyError(
            str(path),
            f"it returns actions {_space(model.action_space)}; {_action_layout(env)}",
        )


def _space(space: Any) -> str:
    """A Gymnasium space in words: ``of shape (5,)``, or the space itself when it has none."""
    shape = getattr(space, "shape", None)
    return f"of shape {shape}" if shape else f"of {space}"


def _obs_size(env: SimEnv) -> int:
    return int(np.prod(env.observation_space.shape or (0,)))


def _action_layout(env: SimEnv) -> str:
    """The task's action in words: its size, mode and joints in order."""
    joints = list(env.task.action.joints)
    return (
        f"the task {env.task.name!r} takes {len(joints)}, one {env.task.action.mode} entry "
        f"per joint in this order: {joints}"
    )


def _probe(spec: str, env: SimEnv, policy: Policy) -> None:
    """Call a file's policy once on a zero observation of the task's size: a policy that does
    not take it, or returns another size than the action's, is refused before any engine runs."""
    size = _obs_size(env)
    try:
        out = policy(np.zeros(size, np.float32))
    except PolicyError:
        raise
    except Exception as exc:  # the runtime's own error for an input it does not take
        raise PolicyError(
            spec,
            f"it does not take the task's observation of {size} entries ({_last_line(exc)}); "
            f"the observation: {_layout(env)}",
        ) from None
    check_output(spec, env, out)


def _layout(env: SimEnv) -> str:
    """The observation's layout in words: each term's name and size, the history."""
    from simbridge.envs.contract import observation_layout

    return observation_layout(env)


def load_policy(spec: str, env: SimEnv) -> Policy:
    """The policy named by ``spec``, made for ``env`` (the module docstring lists the forms).

    Args:
        spec: ``reference``, ``module:callable`` or a policy file's path.
        env: the env it will act in (a class policy is made with it).

    Returns:
        A callable observation -> action.

    Raises:
        PolicyError: a module or attribute that does not exist, an object that is not
            callable, a file that does not load or of an unknown kind, a file's policy that
            does not fit the task (an ONNX input or a Stable-Baselines3 observation space of
            another size than the observation, an action space of another shape than the
            action, a policy that fails on a zero observation of the task's size or returns
            another size than the action's: the message names both layouts).
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
            policy = _onnx(path, env)
        elif kind == "TorchScript":
            policy = _torchscript(path)
        else:
            policy = _sb3(path, env)
        _probe(spec, env, policy)
        return policy
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
        raise PolicyError(spec, f"returned {a.size} action entries; {_action_layout(env)}")
    return a
