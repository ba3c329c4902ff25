"""The backend registry.

Backends are registered by ``"module:Class"`` strings and imported on first use, so
``import simbridge`` imports no engine. Third-party packages add backends through the
``simbridge.backends`` entry-point group::

    [project.entry-points."simbridge.backends"]
    mybackend = "mypackage.backend:MyBackend"
"""

from __future__ import annotations

import importlib
import importlib.util
import logging
import re
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from simbridge.engine_output import captured
from simbridge.exceptions import (
    BackendError,
    BackendNotInstalledError,
    InvalidArgumentError,
    UnknownBackendError,
)

if TYPE_CHECKING:
    from simbridge.backend import Backend

__all__ = [
    "BackendSpec",
    "register",
    "available_backends",
    "load_backend",
    "backend_spec",
    "engine_dists",
    "unavailable_reason",
    "state_dtype",
    "STATE_DTYPES",
    "ENTRY_POINT_GROUP",
]

ENTRY_POINT_GROUP = "simbridge.backends"


@dataclass(frozen=True)
class BackendSpec:
    name: str
    entry_point: str  # "module:Class"
    requires: tuple[str, ...] = ()  # importable module names the backend needs
    pip_name: str = ""  # what to pip install when one is missing
    settings: str = ""  # "module:ATTR": its engine settings (engine_settings.Setting), no engine
    state_dtype: str = ""  # its class's state_dtype, declared; "": read from the class (imports it)
    engine_dists: tuple[str, ...] = ()  # distributions whose versions its runs depend on
    describe: str = ""  # "module:function" -> str: how it runs here (``simbridge info``)


_REGISTRY: dict[str, BackendSpec] = {}
_LOADED: dict[str, type[Backend]] = {}
_entry_points_read = False


def register(
    name: str,
    entry_point: str,
    *,
    requires: tuple[str, ...] = (),
    pip_name: str = "",
    settings: str = "",
    state_dtype: str = "",
    engine_dists: tuple[str, ...] | None = None,
    describe: str = "",
) -> None:
    """Register a backend under ``name``, importing nothing of it.

    Args:
        name: The backend's name (``Sim(backend=name)``); registering it again replaces it.
        entry_point: ``"module:Class"``, the :class:`~simbridge.backend.Backend` subclass.
        requires: Importable module names the backend needs (its engine).
        pip_name: What to ``pip install`` when one is missing; by default the ``requires``.
        settings: ``"module:ATTR"``, a sequence of :class:`simbridge.engine_settings.Setting`
            in a module that imports no engine (read when a profile or scenario sets one).
        state_dtype: One of :data:`STATE_DTYPES`, declaring the class's
            :attr:`~simbridge.backend.Backend.state_dtype` so that :func:`state_dtype` imports
            no engine (a report rebuilt from the cache asks it of every engine of the study);
            the class must agree (:func:`load_backend` checks). ``""``: read from the class.
        engine_dists: The distributions (pip names) whose versions the backend's results depend
            on (its engine library; numpy counts for every backend): a cached run is reused only
            while their versions are the same (:func:`engine_dists`); None: the ``requires``
            modules' names.
        describe: ``"module:function"``, called with no argument, saying in a line how the
            backend runs here (``simbridge info``: MuJoCo's compiled or Python step loop).

    Raises:
        BackendError: ``entry_point`` is not ``"module:Class"``.
        InvalidArgumentError: ``state_dtype`` not in :data:`STATE_DTYPES`, or ``engine_dists``
            not a tuple of names.
    """
    if ":" not in entry_point:
        raise BackendError(f"backend {name!r}: entry point {entry_point!r} is not 'module:Class'")
    if state_dtype and state_dtype not in STATE_DTYPES:
        raise InvalidArgumentError(
            "state_dtype",
            f"backend {name!r}: expected one of {list(STATE_DTYPES)} (or '' for the class's own), "
            f"got {state_dtype!r}",
        )
    if isinstance(engine_dists, str) or not all(
        isinstance(d, str) and d for d in (engine_dists or ())
    ):
        raise InvalidArgumentError(
            "engine_dists",
            f"backend {name!r}: expected a tuple of distribution names, got {engine_dists!r}",
        )
    _REGISTRY[name] = BackendSpec(
        name,
        entry_point,
        requires,
        pip_name or " ".join(requires),
        settings,
        state_dtype,
        tuple(requires if engine_dists is None else engine_dists),
        describe,
    )
    _LOADED.pop(name, None)


def _read_entry_points() -> None:
    global _entry_points_read
    if _entry_points_read:
        return
    _entry_points_read = True
    from importlib.metadata import entry_points  # costs ~20 ms: only when a lookup needs it

    for ep in entry_points(group=ENTRY_POINT_GROUP):
        if ep.name not in _REGISTRY:
            _REGISTRY[ep.name] = BackendSpec(ep.name, ep.value, engine_dists=_provider_dists(ep))


def _provider_dists(ep: Any) -> tuple[str, ...]:
    """An entry-point backend's engine distributions: the distribution that provides it and
    the ones it requires (not under an extra or a marker; simbridge itself aside), which is how
    a third-party backend declares its engine (its package's ``dependencies``)."""
    dist = getattr(ep, "dist", None)
    if dist is None:
        return ()
    names = [str(dist.metadata["Name"] or "")]
    for req in dist.requires or ():
        if ";" in req:  # an extra's or a platform's requirement
            continue
        name = re.split(r"[\s\[<>=!~(@]", req.strip(), maxsplit=1)[0]
        if name and _normal(name) not in ("simbridge", _normal(names[0])):
            names.append(name)
    return tuple(n for n in dict.fromkeys(names) if n)


def _normal(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def engine_dists(name: str) -> tuple[str, ...]:
    """The distributions whose versions backend ``name``'s results depend on. Imports nothing of
    the backend.

    Args:
        name: A registered backend's name.

    Returns:
        Their pip names, numpy first, then as registered (``register(..., engine_dists=)``; an
        entry-point backend: its package and what that requires).

    Raises:
        UnknownBackendError: as :func:`backend_spec`.
    """
    return tuple(dict.fromkeys(("numpy", *backend_spec(name).engine_dists)))


def available_backends() -> list[str]:
    """Every registered backend, installed or not (entry points included).

    Returns:
        Their names, in registration order.
    """
    _read_entry_points()
    return list(_REGISTRY)


def backend_spec(name: str) -> BackendSpec:
    """How backend ``name`` is registered. Imports nothing of the backend.

    Args:
        name: A backend's name.

    Returns:
        Its spec: ``"module:Class"``, the engine modules it requires and the rest of
        :func:`register`'s arguments.

    Raises:
        UnknownBackendError: ``name`` is not registered (the message lists those that are).
    """
    if isinstance(name, str) and name not in _REGISTRY:
        _read_entry_points()
    if not isinstance(name, str) or name not in _REGISTRY:
        raise UnknownBackendError(repr(name) if not isinstance(name, str) else name, _REGISTRY)
    return _REGISTRY[name]


def load_backend(name: str) -> type[Backend]:
    """Import the backend class registered as ``name`` (once; later calls return the same class).

    Args:
        name: A registered backend's name.

    Returns:
        The :class:`~simbridge.backend.Backend` subclass.

    Raises:
        UnknownBackendError: ``name`` is not registered.
        BackendNotInstalledError: one of its required modules does not import (the message
            says what to install).
        BackendError: its module or class cannot be loaded, or the class's ``state_dtype``
            differs from the one registered.
    """
    if not isinstance(name, str):
        _read_entry_points()
        raise UnknownBackendError(repr(name), _REGISTRY)
    if name in _LOADED:
        return _LOADED[name]
    if name not in _REGISTRY:
        _read_entry_points()
    if not isinstance(name, str) or name not in _REGISTRY:
        raise UnknownBackendError(str(name), _REGISTRY)
    spec = _REGISTRY[name]
    module_name, _, attr = spec.entry_point.partition(":")
    # an engine's banner goes to the log (engine_output.py), and so do the Python warnings its
    # import raises (SAPIEN: "Failed to find system libvulkan", where its CPU physics needs none)
    with captured(name, "importing"), warnings.catch_warnings(record=True) as raised:
        warnings.simplefilter("always")
        for required in spec.requires:
            try:
                importlib.import_module(required)
            except ImportError as exc:
                raise BackendNotInstalledError(name, required, spec.pip_name, exc) from exc
        try:
            module = importlib.import_module(module_name)
            cls: type[Backend] = getattr(module, attr)
        except (ImportError, AttributeError) as exc:
            raise BackendError(
                f"backend {name!r}: cannot load {spec.entry_point!r}: {exc}"
            ) from exc
    for w in raised:
        logging.getLogger(f"simbridge.{name}").info(
            "importing: %s: %s", w.category.__name__, w.message
        )
    declared = getattr(cls, "state_dtype", "float64")
    if spec.state_dtype and declared != spec.state_dtype:
        raise BackendError(
            f"backend {name!r}: registered with state_dtype {spec.state_dtype!r}, but its class "
            f"{spec.entry_point!r} declares {declared!r}"
        )
    _LOADED[name] = cls
    return cls


STATE_DTYPES = ("float64", "float32")
"""The values :attr:`simbridge.backend.Backend.state_dtype` may take."""


def state_dtype(name: str) -> str:
    """The floating-point type backend ``name`` keeps its state in; makes no engine.

    As registered (``register(..., state_dtype=)``, the shipped backends: its engine modules
    are looked for, not imported), else read from its class, which imports the backend.

    Args:
        name: A registered backend's name.

    Returns:
        Its class's :attr:`~simbridge.backend.Backend.state_dtype`: ``"float64"`` unless it
        declares another (``"float32"``).

    Raises:
        UnknownBackendError, BackendNotInstalledError: as :func:`load_backend`.
        BackendError: the backend declares a type not in :data:`STATE_DTYPES`.
    """
    spec = backend_spec(name)
    if spec.state_dtype:
        for required in spec.requires:
            if importlib.util.find_spec(required) is None:
                missing = ModuleNotFoundError(f"No module named {required!r}", name=required)
                raise BackendNotInstalledError(name, required, spec.pip_name, missing)
        return spec.state_dtype
    value = getattr(load_backend(name), "state_dtype", "float64")
    if value not in STATE_DTYPES:
        raise BackendError(
            f"backend {name!r}: state_dtype {value!r} is not one of {list(STATE_DTYPES)}"
        )
    return str(value)


def unavailable_reason(name: str) -> str | None:
    """Why backend ``name`` cannot be used here.

    Args:
        name: A registered backend's name.

    Returns:
        The reason (its engine or its module is missing), or None when it loads.

    Raises:
        UnknownBackendError: ``name`` is not registered.
        BackendError: its module is present but broken (re-raised as :func:`load_backend`
            raised it).
    """
    try:
        load_backend(name)
    except BackendNotInstalledError as exc:
        return str(exc)
    except BackendError as exc:
        cause = exc.__cause__
        missing_module = isinstance(cause, ModuleNotFoundError) and cause.name is not None
        if missing_module and name in _REGISTRY:
            module = _REGISTRY[name].entry_point.partition(":")[0]
            if module == cause.name or module.startswith(f"{cause.name}."):  # type: ignore[union-attr]
                return f"backend module {cause.name!r} is not installed"  # type: ignore[union-attr]
        raise
    return None


register(
    "pybullet",
    "simbridge.backends.pybullet:PyBulletBackend",
    requires=("pybullet",),
    pip_name="pybullet",
    settings="simbridge.backends.settings_pybullet:SETTINGS",
    state_dtype="float64",
    engine_dists=("pybullet",),
)
register(
    "mujoco",
    "simbridge.backends.mujoco:MujocoBackend",
    requires=("mujoco",),
    pip_name="'mujoco>=4'",
    settings="simbridge.backends.settings_mujoco:SETTINGS",
    state_dtype="float64",
    engine_dists=("mujoco",),
    describe="simbridge.backends.mujoco.kernel:describe",
)
register(
    "physx",
    "simbridge.backends.physx:PhysxBackend",
    requires=("sapien",),
    pip_name="'simbridge[physx]' (from a clone: pip install -e '.[physx]')",
    settings="simbridge.backends.settings_physx:SETTINGS",
    state_dtype="float32",
    engine_dists=("sapien",),
)
