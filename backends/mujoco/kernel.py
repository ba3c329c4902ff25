"""Loads the MuJoCo backend's compiled step loop (``_mjkernel``, backends/mujoco/_mjkernel.c).

The kernel is used only when it was built against the very MuJoCo that runs (its header version
equals ``mujoco.mj_version()``), the MuJoCo library file can be found next to the bindings, and
``SIMBRIDGE_MUJOCO_STEP`` is not ``python``. Otherwise the backend steps in Python (same
arithmetic, same results, about 12x slower per step), :func:`reason` says why, and the first
MuJoCo ``Sim`` of the process warns once (:func:`warn_if_lost`): the loop is never lost
silently. ``Sim.manifest()["step_loop"]`` says which loop runs.
"""

from __future__ import annotations

import ctypes
import glob
import importlib
import os
import threading
import warnings
from typing import Any

import mujoco

from simbridge.exceptions import SimBusyError, SlowStepWarning

__all__ = [
    "ENV",
    "kernel_class",
    "functions",
    "reason",
    "warn_if_lost",
    "built_against",
    "describe",
]

ENV = "SIMBRIDGE_MUJOCO_STEP"  # "python" forces the Python step loop
_FUNCTIONS = (
    "mj_step1",
    "mj_step2",
    "mj_fwdActuation",
    "mj_fwdAcceleration",
    "mj_fwdConstraint",
    "mj_checkAcc",
    "mj_Euler",
    "mj_kinematics",
    "mj_comPos",
    "mj_comVel",
    "mj_solveM",
    "mju_mat2Quat",
    "mj_objectVelocity",
    # MuJoCo's thread-local log handler, as its own Python bindings use it: an engine error
    # inside the compiled loop becomes a Python exception instead of exit() (_mjkernel.c)
    "_mjPRIVATE_setTlsLogHandler",
    "_mjPRIVATE_getGlobalLogHandler",
)
_state: dict[str, Any] = {}
_lock = threading.Lock()  # one loader at a time (_load)
_REBUILD = (
    "rebuild it against the installed MuJoCo: `pip install -U 'setuptools>=77' wheel`, then "
    "`pip install --no-build-isolation --no-deps --force-reinstall -e .` in simbridge's folder "
    "(for an installed copy: the same with `simbridge` in place of `-e .`)"
)


def _version(header: int) -> str:
    """MuJoCo's header version number as its release name: 4000000 is 4.0.0 (MuJoCo 4 gives
    three digits to the minor and patch numbers), 331 is 3.3.1 (before 4: one digit each)."""
    if header >= 1_000_000:
        return f"{header // 1_000_000}.{header // 1000 % 1000}.{header % 1000}"
    return f"{header // 100}.{header // 10 % 10}.{header % 10}"


def _find() -> dict[str, Any]:
    """The loader's answer: the ``Kernel`` type (or None), MuJoCo's function addresses, and
    why the kernel is not used ("" when it is)."""
    found: dict[str, Any] = {"class": None, "functions": (), "built": None}
    try:
        _mjkernel = importlib.import_module(f"{__package__}._mjkernel")  # the C extension
    except ImportError as exc:
        found["reason"] = (
            f"the compiled step loop is not installed ({exc}); it is built at install where a "
            f"C compiler exists: {_REBUILD}"
        )
        return found
    # the release setup.py compiled in; a loop built before it was recorded: read the header's
    found["built"] = getattr(_mjkernel, "MUJOCO_RELEASE", None) or _version(
        _mjkernel.HEADER_VERSION
    )
    if mujoco.mj_version() != _mjkernel.HEADER_VERSION:
        found["reason"] = (
            f"the compiled step loop was built for MuJoCo {found['built']}, "
            f"this is MuJoCo {mujoco.__version__}: {_REBUILD}"
        )
        return found
    # built from an older source (LIMIT_RULES: bind_world takes the limit rows' inside gain)
    if not hasattr(_mjkernel.Kernel, "check_since") or not hasattr(_mjkernel, "LIMIT_RULES"):
        found["reason"] = f"the compiled step loop is older than this simbridge: {_REBUILD}"
        return found
    folder = os.path.dirname(mujoco.__file__)
    files = sorted(
        glob.glob(os.path.join(folder, "libmujoco.so*"))
        + glob.glob(os.path.join(folder, "libmujoco*.dylib"))
        + glob.glob(os.path.join(folder, "mujoco.dll"))
    )
    if not files:
        found["reason"] = f"no MuJoCo library file in {folder}"
        return found
    try:
        lib = ctypes.CDLL(files[0])
        lib.mj_version.restype = ctypes.c_int
        if lib.mj_version() != mujoco.mj_version():
            found["reason"] = f"{files[0]} is not the MuJoCo the bindings run"
            return found
        addresses = tuple(ctypes.cast(getattr(lib, f), ctypes.c_void_p).value for f in _FUNCTIONS)
    except (OSError, AttributeError) as exc:
        found["reason"] = f"cannot read MuJoCo's functions from {files[0]}: {exc}"
        return found
    _mjkernel.set_busy_error(SimBusyError)
    found["class"] = _mjkernel.Kernel
    found["functions"] = addresses
    found["reason"] = ""
    return found


def _load() -> None:
    """Fill ``_state`` once per process. Sims made at once in several threads wait for the first
    to finish: the answer is published whole (its "reason" last), never half made (before, a
    thread that came in while another imported the extension read ``class`` None without a
    ``reason``: a raw KeyError, or a Sim on the 12x slower Python loop)."""
    if "reason" in _state:
        return
    with _lock:
        if "reason" in _state:
            return
        found = _find()
        _state["class"] = found["class"]
        _state["functions"] = found["functions"]
        _state["built"] = found["built"]
        _state["reason"] = found["reason"]


def kernel_class() -> Any:
    """The compiled step loop's type.

    Returns:
        The ``Kernel`` type, or None when the Python step loop must be used.
    """
    if os.environ.get(ENV, "").strip().lower() == "python":
        return None
    _load()
    return _state["class"]


def functions() -> tuple[int, ...]:
    """The addresses of the MuJoCo functions the compiled loop calls, read from MuJoCo's library.

    Returns:
        One address per function the loop calls, in its order; empty when the loop cannot be
        used.
    """
    _load()
    return _state["functions"]


def reason() -> str:
    """Why the kernel is not used.

    Returns:
        The reason, or "" when it is used.
    """
    if os.environ.get(ENV, "").strip().lower() == "python":
        return f"{ENV}=python"
    _load()
    return _state["reason"]


def built_against() -> str | None:
    """The MuJoCo release whose headers the installed compiled loop was built against (its
    ``HEADER_VERSION``), whether or not it is used.

    Returns:
        The release (e.g. ``4.0.0``), or None when no compiled loop is installed.
    """
    _load()
    return _state["built"]


def describe() -> str:
    """The step loop in use, for ``simbridge info``.

    Returns:
        ``step loop: compiled (C), built against MuJoCo X (running Y)``, or the Python one and
        why (the MuJoCo it was built against among the reasons).
    """
    why = reason()
    if why:
        return f"step loop: Python, about 12x slower: {why}"
    return (
        f"step loop: compiled (C), built against MuJoCo {built_against()} "
        f"(running {mujoco.__version__})"
    )


def warn_if_lost() -> None:
    """One :class:`SlowStepWarning` per process when the compiled loop cannot be used (not built,
    or built against another MuJoCo), naming why and what to run; nothing when it is in use or
    ``SIMBRIDGE_MUJOCO_STEP=python`` chose the Python loop."""
    if _state.get("warned") or os.environ.get(ENV, "").strip().lower() == "python":
        return
    _load()
    with _lock:  # Sims made at once in several threads: one of them warns
        if _state.get("warned") or _state["class"] is not None:
            return
        _state["warned"] = True
    warnings.warn(
        f"MuJoCo steps in Python, about 12x slower: {_state['reason']}",
        SlowStepWarning,
        stacklevel=4,
    )
