"""Look inside a PhysX-backed `Sim`: its SAPIEN objects, for tests and debugging. What it
returns is live engine state: read it, do not keep it across a ``load``, ``remove`` or
``reset``."""

from __future__ import annotations

from typing import Any

from simbridge.exceptions import InvalidArgumentError

from .backend import PhysxBackend
from .robots import Robot

__all__ = ["mjcf_world", "backend_of", "scene", "robot", "articulation"]


def backend_of(sim: Any) -> PhysxBackend:
    """The :class:`PhysxBackend` behind ``sim``.

    Args:
        sim: A `Sim`.

    Returns:
        Its backend.

    Raises:
        InvalidArgumentError: ``sim`` runs on another backend.
    """
    backend = getattr(sim, "_b", None)
    if not isinstance(backend, PhysxBackend):
        raise InvalidArgumentError(
            "sim", f"a Sim on the 'physx' backend is needed, got {type(backend).__name__}"
        )
    return backend


def scene(sim: Any) -> Any:
    """The world's ``sapien.Scene``.

    Args:
        sim: A `Sim` on the PhysX backend.

    Returns:
        The scene.
    """
    return backend_of(sim)._scene


def robot(sim: Any, body: int) -> Robot:
    """What the backend keeps of one body.

    Args:
        sim: A `Sim` on the PhysX backend.
        body: The body's id.

    Returns:
        Its :class:`Robot`: model, joint table, PhysX objects, motors.
    """
    return backend_of(sim)._robots[body]


def articulation(sim: Any, body: int) -> Any:
    """One body's ``PhysxArticulation``.

    Args:
        sim: A `Sim` on the PhysX backend.
        body: The body's id.

    Returns:
        The articulation, or None for a static body.
    """
    return robot(sim, body).built.articulation


def mjcf_world(sim: Any) -> Any:
    """The world of an MJCF model read with ``semantics="mujoco"`` on this engine.

    Args:
        sim: A `Sim` that loaded such a model on the 'physx' backend.

    Returns:
        Its :class:`~.native.NativePhysx`: ``plans`` (the build plans, link i = MuJoCo's row i),
        ``mirror`` (MuJoCo's data of the engine's state) and the engine's objects.

    Raises:
        InvalidArgumentError: ``sim`` holds no such world on this engine.
    """
    from .native import NativePhysx

    backend = getattr(sim, "_b", None)
    if not isinstance(backend, NativePhysx):
        raise InvalidArgumentError(
            "sim",
            "a Sim on the 'physx' backend holding an MJCF read with semantics='mujoco' is "
            f"needed, got {type(backend).__name__}",
        )
    return backend
