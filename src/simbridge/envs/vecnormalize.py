"""A trained policy's observation statistics read from Stable-Baselines3's own file: the pickle
``VecNormalize.save(path)`` writes (RL Zoo ships it beside the model), for ``simbridge sim2sim
--normalisation`` (:func:`read_vecnormalize`, :func:`resolve`).

The file is read without running its code. A pickle names the classes and functions it is
rebuilt from, and a plain ``pickle.load`` (which ``VecNormalize.load`` is) imports and calls
them: a file can run anything. Here the unpickler (:class:`_StatisticsUnpickler`) runs NumPy's
array and scalar rebuilding alone (``_reconstruct``, ``_frombuffer``, ``scalar``, ``dtype``,
and ``_codecs.encode`` for protocol 2's bytes), each checked, and makes ``OrderedDict``, ``set``
and ``frozenset`` (containers); every other name it meets
(``VecNormalize``, ``RunningMeanStd``, Gymnasium's spaces, whatever an env put in its reset
info) becomes an inert record of its name and state: nothing is imported, nothing called.
Stable-Baselines3 need not be installed. The records are then read as ``VecNormalize``'s
``__getstate__`` writes them: ``obs_rms`` (a ``RunningMeanStd``: ``mean``, ``var``, ``count``),
``clip_obs``, ``epsilon``, ``norm_obs``.

The statistics become the task's :class:`~simbridge.envs.task.Normalisation` (its ``source``
the file): the env normalises its float32 observation as ``VecNormalize.normalize_obs`` does,
``clip((obs - mean) / sqrt(var + epsilon), -clip_obs, clip_obs)``, bit for bit.

- A ``VecNormalize`` over a ``Dict`` observation, or statistics that are not one vector, are
  refused: a simbridge task's observation is one ``Box`` vector.
- ``norm_obs=False`` (the statistics of rewards alone): the observation is passed as it is, and
  the run says so.
- Rewards are the task's own: ``norm_reward`` changes what the policy was trained on, not what
  it does.
"""

from __future__ import annotations

import io
import math
import os
import pickle
from collections import OrderedDict
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from simbridge.envs.errors import NormalisationFileError
from simbridge.envs.task import Normalisation, Task

__all__ = [
    "AUTO",
    "BESIDE",
    "NONE",
    "VecNormalizeFile",
    "find_beside",
    "read_vecnormalize",
    "resolve",
]

AUTO = "auto"
"""``--normalisation auto`` (the default): a ``VecNormalize`` file found beside a
Stable-Baselines3 zip (:data:`BESIDE`) is used, and the run says which."""
NONE = "none"
"""``--normalisation none``: no file, even where one lies beside the policy."""
BESIDE = ("vec_normalize.pkl", "vecnormalize.pkl", "{stem}/vecnormalize.pkl")
"""Where :func:`find_beside` looks, relative to a ``.zip`` policy's folder: Stable-Baselines3's
documented name, RL Zoo's, and RL Zoo's log folder (``ENV.zip`` beside ``ENV/vecnormalize.pkl``,
``{stem}`` the zip's name without ``.zip``)."""

_VECNORMALIZE = "stable_baselines3.common.vec_env.vec_normalize.VecNormalize"
_RUNNING_MEAN_STD = "stable_baselines3.common.running_mean_std.RunningMeanStd"


class _Record:
    """What a pickled object of a class other than NumPy's becomes: its class's dotted name,
    the arguments it was called with and the state it was given; nothing of it runs."""

    qualname = "?"

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self.args = args
        self.state: Any = None

    def __setstate__(self, state: Any) -> None:
        self.state = state

    def __setitem__(self, key: Any, value: Any) -> None:  # a mapping's items (SETITEMS)
        self.__dict__.setdefault("items", {})[key] = value

    def append(self, value: Any) -> None:  # a sequence's items (APPENDS)
        self.__dict__.setdefault("values", []).append(value)

    def extend(self, values: Any) -> None:
        self.__dict__.setdefault("values", []).extend(values)


def _record_class(module: str, name: str) -> type[_Record]:
    return type(name, (_Record,), {"qualname": f"{module}.{name}", "__module__": __name__})


class _NdarrayToken:
    """Stands in for ``numpy.ndarray`` as a pickle names it: accepted by
    :func:`_reconstruct` alone, so that no array of a size the file does not hold is made."""


def _reconstruct(subtype: Any, shape: Any, dtype: Any) -> np.ndarray:
    """NumPy's ``_reconstruct`` as ``ndarray.__reduce__`` writes it: an empty array, which the
    pickle's state then fills from bytes it holds."""
    if subtype is not _NdarrayToken or tuple(shape) != (0,):
        raise pickle.UnpicklingError(f"an array rebuilt from {subtype!r}, shape {shape!r}")
    return np.ndarray.__new__(np.ndarray, (0,), dtype=np.dtype(dtype))


def _frombuffer(buffer: Any, dtype: Any, shape: Any, order: Any) -> np.ndarray:
    """NumPy's ``_frombuffer`` (pickle protocol 5): an array of the bytes the file holds."""
    if not isinstance(buffer, (bytes, bytearray, memoryview)):
        raise pickle.UnpicklingError(f"an array rebuilt from a {type(buffer).__name__}")
    dt = np.dtype(dtype)
    if dt.hasobject:
        raise pickle.UnpicklingError("an object array from raw bytes")
    # a copy of the bytes first: the array then holds no export of the pickle's own buffer
    return np.frombuffer(bytes(buffer), dtype=dt).reshape(shape, order=order).copy()


def _scalar(dtype: Any, data: Any = None) -> Any:
    """NumPy's ``scalar``: a number of a plain dtype from the bytes the file holds."""
    dt = np.dtype(dtype)
    if dt.hasobject or not isinstance(data, (bytes, bytearray)) or len(data) != dt.itemsize:
        raise pickle.UnpicklingError(f"a NumPy scalar of {dt} from {type(data).__name__}")
    return np.frombuffer(bytes(data), dtype=dt)[0]


def _dtype(*args: Any) -> np.dtype[Any]:
    """``numpy.dtype`` as a pickle calls it (``dtype('f8', False, True)``)."""
    if not args or not isinstance(args[0], str):
        raise pickle.UnpicklingError(f"a dtype from {args!r}")
    return np.dtype(args[0])


def _encode(text: Any, encoding: str = "utf-8") -> bytes:
    """``_codecs.encode`` as pickle protocol 2 writes bytes: ``encode(str, 'latin1')``."""
    if not isinstance(text, str) or encoding not in ("latin1", "latin-1"):
        raise pickle.UnpicklingError(f"_codecs.encode of {type(text).__name__} as {encoding!r}")
    return text.encode("latin1")


_NUMPY: dict[tuple[str, str], Any] = {}
for _module in ("numpy.core.multiarray", "numpy._core.multiarray"):
    _NUMPY[(_module, "_reconstruct")] = _reconstruct
    _NUMPY[(_module, "scalar")] = _scalar
for _module in ("numpy.core.numeric", "numpy._core.numeric"):
    _NUMPY[(_module, "_frombuffer")] = _frombuffer
_NUMPY[("numpy", "ndarray")] = _NdarrayToken
_NUMPY[("numpy", "dtype")] = _dtype
_NUMPY[("_codecs", "encode")] = _encode
# containers that run no code of the file's: Gymnasium's Dict space holds an OrderedDict
_NUMPY[("collections", "OrderedDict")] = OrderedDict
_NUMPY[("builtins", "set")] = set
_NUMPY[("builtins", "frozenset")] = frozenset


class _StatisticsUnpickler(pickle.Unpickler):
    """Runs NumPy's array rebuilding alone (:data:`_NUMPY`, each checked); every other global a
    pickle names becomes a :class:`_Record` subclass of that name: imported by nobody."""

    def find_class(self, module: str, name: str) -> Any:
        return _NUMPY.get((module, name)) or _record_class(module, name)

    def persistent_load(self, pid: Any) -> Any:
        raise pickle.UnpicklingError("a persistent id: no VecNormalize pickle holds one")


@dataclass(frozen=True)
class VecNormalizeFile:
    """A ``VecNormalize`` file as read.

    Attributes:
        path: the file.
        found: ``"given"`` (``--normalisation FILE``) or ``"found beside the policy"``.
        normalisation: its observation statistics, or None under ``norm_obs=False``.
        norm_obs: VecNormalize's ``norm_obs``.
        count: the steps its statistics gathered (``obs_rms.count``), None under
            ``norm_obs=False``.
    """

    path: str
    found: str
    normalisation: Normalisation | None
    norm_obs: bool
    count: float | None

    def describe(self) -> str:
        """One line for the headline and report.md.

        Returns:
            What was read and how it was found.
        """
        if self.normalisation is None:
            what = "norm_obs=False: the observation passed as it is"
        else:
            n = self.normalisation
            what = (
                f"{len(n.mean)} entries, clip {n.clip:g}, epsilon {n.epsilon:g}, gathered over "
                f"{self.count:.0f} steps"
            )
        return f"observation statistics: VecNormalize file {self.path} ({self.found}; {what})"

    def as_dict(self) -> dict[str, Any]:
        """summary.json's ``normalisation``.

        Returns:
            The file, how it was found, ``norm_obs``, the count, clip and epsilon.
        """
        n = self.normalisation
        return {
            "file": self.path,
            "found": self.found,
            "norm_obs": self.norm_obs,
            "count": self.count,
            "entries": None if n is None else len(n.mean),
            "clip": None if n is None else n.clip,
            "epsilon": None if n is None else n.epsilon,
        }


def _unpickle(path: Path, shown: str) -> Any:
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise NormalisationFileError(shown, f"cannot be read ({exc.strerror or exc})") from None
    if not data.startswith(b"\x80"):
        raise NormalisationFileError(
            shown,
            f"not a pickle (its first bytes: {data[:16]!r}); VecNormalize.save(path) writes one",
        )
    try:
        return _StatisticsUnpickler(io.BytesIO(data)).load()
    except Exception as exc:  # a truncated or hostile pickle, refused as such
        raise NormalisationFileError(
            shown,
            f"not a pickle of VecNormalize statistics ({type(exc).__name__}: "
            f"{' '.join(str(exc).split())[:200]}); VecNormalize.save(path) writes one",
        ) from None


def _name(obj: Any) -> str:
    if isinstance(obj, _Record):
        return obj.qualname
    return type(obj).__name__


def _number(state: dict[str, Any], key: str, shown: str, *, positive: bool) -> float:
    value = state.get(key)
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float, np.integer, np.floating))
        or not math.isfinite(float(value))
        or (float(value) <= 0 if positive else float(value) < 0)
    ):
        want = "a finite number above 0" if positive else "a finite number, 0 or more"
        raise NormalisationFileError(shown, f"its {key} is {value!r}; expected {want}")
    return float(value)


def _statistics(rms: Any, shown: str) -> tuple[np.ndarray, np.ndarray, float]:
    """``obs_rms``'s mean, var and count, checked: one finite vector each, var >= 0."""
    if isinstance(rms, dict):
        raise NormalisationFileError(
            shown,
            f"VecNormalize over a Dict observation (keys {sorted(map(str, rms))}); a simbridge "
            "task's observation is one Box vector: normalise that",
        )
    if _name(rms) != _RUNNING_MEAN_STD or not isinstance(rms.state, dict):
        raise NormalisationFileError(
            shown, f"its obs_rms is a {_name(rms)}, not Stable-Baselines3's RunningMeanStd"
        )
    st = rms.state
    mean, var = st.get("mean"), st.get("var")
    if not isinstance(mean, np.ndarray) or not isinstance(var, np.ndarray):
        raise NormalisationFileError(
            shown,
            f"its obs_rms holds mean {type(mean).__name__} and var {type(var).__name__}, "
            "not arrays",
        )
    if mean.dtype.kind not in "fiu" or var.dtype.kind not in "fiu":
        raise NormalisationFileError(
            shown, f"its obs_rms holds mean of {mean.dtype} and var of {var.dtype}, not numbers"
        )
    if mean.ndim != 1 or mean.shape != var.shape:
        raise NormalisationFileError(
            shown,
            f"its statistics are of shape {mean.shape} (var {var.shape}); a simbridge task's "
            "observation is one vector: statistics of shape (size,)",
        )
    mean, var = mean.astype(np.float64), var.astype(np.float64)
    if not np.isfinite(mean).all() or not np.isfinite(var).all() or (var < 0).any():
        raise NormalisationFileError(
            shown, "its mean or var holds a NaN, an infinity or a negative variance"
        )
    count = st.get("count")
    return mean, var, float(count) if isinstance(count, (int, float, np.number)) else math.nan


def read_vecnormalize(path: str | os.PathLike[str], *, found: str = "given") -> VecNormalizeFile:
    """Read the observation statistics of a ``VecNormalize.save(path)`` pickle, running none of
    its code (the module docstring says how).

    Args:
        path: the file.
        found: how it was chosen, for the report (``"given"``, ``"found beside the policy"``).

    Returns:
        The :class:`VecNormalizeFile`; its ``normalisation`` is the statistics with ``source``
        the file, None under ``norm_obs=False``.

    Raises:
        NormalisationFileError: no such file, not a pickle, a pickle of something else than
            ``VecNormalize``, statistics of a Dict observation or not one vector, a NaN, an
            infinity or a negative variance, a ``clip_obs`` or ``epsilon`` that is no number.
    """
    shown = str(path)
    p = Path(path)
    if not p.is_file():
        raise NormalisationFileError(
            shown, "no such file; VecNormalize.save(path) writes it (RL Zoo: vecnormalize.pkl)"
        )
    obj = _unpickle(p, shown)
    if _name(obj) != _VECNORMALIZE or not isinstance(obj.state, dict):
        raise NormalisationFileError(
            shown,
            f"a pickle of {_name(obj)}, not of Stable-Baselines3's VecNormalize "
            "(what VecNormalize.save(path) writes)",
        )
    state = obj.state
    norm_obs = state.get("norm_obs", True)
    if not isinstance(norm_obs, bool):
        raise NormalisationFileError(shown, f"its norm_obs is {norm_obs!r}; expected True or False")
    if not norm_obs:
        return VecNormalizeFile(shown, found, None, False, None)
    if "obs_rms" not in state:
        raise NormalisationFileError(shown, "norm_obs is True but it holds no obs_rms")
    mean, var, count = _statistics(state["obs_rms"], shown)
    clip = _number(state, "clip_obs", shown, positive=True)
    epsilon = _number(state, "epsilon", shown, positive=False)
    norm = Normalisation(tuple(mean.tolist()), tuple(var.tolist()), clip, epsilon, source=shown)
    return VecNormalizeFile(shown, found, norm, True, count)


def find_beside(policy: str) -> list[Path]:
    """The ``VecNormalize`` files beside a Stable-Baselines3 zip, where :data:`BESIDE` looks.

    Args:
        policy: the policy as given (anything but a ``.zip`` file finds nothing).

    Returns:
        The files that exist, in :data:`BESIDE`'s order.
    """
    p = Path(policy)
    if p.suffix.lower() != ".zip" or not p.is_file():
        return []
    found = [p.parent / rel.format(stem=p.stem) for rel in BESIDE]
    return [f for f in found if f.is_file()]


def resolve(
    task: Task, policy: str, normalisation: str | os.PathLike[str] | None = AUTO
) -> tuple[Task, VecNormalizeFile | None]:
    """The task a policy runs on, with a ``VecNormalize`` file's statistics when one is given
    or found beside the policy.

    Args:
        task: the task.
        policy: the policy as given (a ``.zip`` is looked beside under :data:`AUTO`).
        normalisation: a file; :data:`AUTO` (look beside a ``.zip``: one file found is used,
            more than one is an error); :data:`NONE` or None: no file.

    Returns:
        The task (its ``normalisation`` the file's statistics, when the file has them) and the
        file as read, or None when no file is used.

    Raises:
        NormalisationFileError: the file's own errors (:func:`read_vecnormalize`); a file with
            a task that states its own ``[normalisation]`` (two sources of one statistics:
            refused, both named); more than one file found beside the policy (each named).
    """
    if normalisation is None or str(normalisation) == NONE:
        return task, None
    if str(normalisation) == AUTO:
        beside = find_beside(policy)
        if not beside:
            return task, None
        if len(beside) > 1:
            raise NormalisationFileError(
                str(beside[0]),
                f"{len(beside)} VecNormalize files lie beside the policy {policy!r}: "
                f"{[str(b) for b in beside]}; name one with --normalisation FILE (or none)",
            )
        path, found = str(beside[0]), "found beside the policy"
    else:
        path, found = str(normalisation), "given"
    if task.normalisation is not None:
        where = task.source or f"task {task.name!r}"
        raise NormalisationFileError(
            path,
            f"{'found beside the policy; ' if found != 'given' else ''}the task ({where}) "
            "states its own [normalisation] too: use one of the two (drop the task's table, "
            "or pass --normalisation none)",
        )
    vec = read_vecnormalize(path, found=found)
    if vec.normalisation is not None:
        task = replace(task, normalisation=vec.normalisation)
    return task, vec
