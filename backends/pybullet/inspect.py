"""Look inside a PyBullet-backed `Sim`: its physics client, for tests, benchmarks and debugging.

The `Sim` interface is the way to use simbridge; this is the one door into the PyBullet
backend's internals, so that nothing else reaches into private attributes (``sim._b._...``).
A raw PyBullet call made on :func:`client_id` acts on the very world the `Sim` steps: read
from it freely; a change made behind the backend's back (a body added or removed, a motor set)
is not seen by its tables.
"""

from __future__ import annotations

from typing import Any

from simbridge.exceptions import InvalidArgumentError

from .backend import PyBulletBackend

__all__ = ["mjcf_world", "mjcf_link_frames", "backend_of", "client_id", "set_check_every"]


def backend_of(sim: Any) -> PyBulletBackend:
    """The :class:`PyBulletBackend` behind ``sim``.

    Args:
        sim: An open `Sim`.

    Returns:
        Its backend.

    Raises:
        InvalidArgumentError: ``sim`` runs on another backend, or is closed.
    """
    backend = getattr(sim, "_b", None)
    if not isinstance(backend, PyBulletBackend):
        raise InvalidArgumentError(
            "sim", f"an open Sim on the 'pybullet' backend is needed, got {type(backend).__name__}"
        )
    return backend


def client_id(sim: Any) -> int:
    """The PyBullet physics client id of ``sim``'s world.

    Args:
        sim: An open `Sim` on the PyBullet backend.

    Returns:
        The ``physicsClientId`` argument of every raw PyBullet call; it is disconnected when the
        `Sim` closes.
    """
    return backend_of(sim)._c


def set_check_every(sim: Any, every: int) -> None:
    """Probe ``sim``'s bodies for a divergence after every ``every``-th step.

    The probe (NaN or inf state) runs at that cadence instead of the backend's default, from the
    next step on; for benchmarks that time the probe (bench/divergence.py). A teleport or a load
    still asks for a probe after the next step.

    Args:
        sim: An open `Sim` on the PyBullet backend.
        every: Steps between probes, at least 1.

    Raises:
        InvalidArgumentError: ``every`` is not an integer >= 1.
    """
    if isinstance(every, bool) or not isinstance(every, int) or every < 1:
        raise InvalidArgumentError("every", f"expected an integer >= 1 (steps), got {every!r}")
    backend = backend_of(sim)
    backend._check_every = every
    backend._next_check = backend._steps + every


def mjcf_world(sim: Any) -> Any:
    """The world of an MJCF model read with ``semantics="mujoco"`` on this engine.

    Args:
        sim: A `Sim` that loaded such a model on the 'pybullet' backend.

    Returns:
        Its :class:`~.native.NativePyBullet`: ``plans`` (the build plans, link i = MuJoCo's row i),
        ``mirror`` (MuJoCo's data of the engine's state) and the engine's objects.

    Raises:
        InvalidArgumentError: ``sim`` holds no such world on this engine.
    """
    from .native import NativePyBullet

    backend = getattr(sim, "_b", None)
    if not isinstance(backend, NativePyBullet):
        raise InvalidArgumentError(
            "sim",
            "a Sim on the 'pybullet' backend holding an MJCF read with semantics='mujoco' is "
            f"needed, got {type(backend).__name__}",
        )
    return backend


def mjcf_link_frames(sim: Any) -> list[tuple[int, int, Any, Any]]:
    """The engine's own frame of each MuJoCo body that carries a joint, for an MJCF read with
    ``semantics="mujoco"``: the frame of its link at the joint's anchor,
    as the engine holds it (``p.getLinkState``, forward kinematics recomputed).

    Args:
        sim: A `Sim` on the 'pybullet' backend holding such a model.

    Returns:
        One ``(body, joint, position, rotation)`` per row that ends a MuJoCo body (the
        intermediate links of a body with several joints are left out): the MuJoCo body and
        joint ids, the anchor's world position (3,) in m and the link's rotation matrix (3, 3),
        world from link. MuJoCo puts the same frame at ``xpos[body] + xmat[body] @
        jnt_pos[joint]`` with rotation ``xmat[body]``.

    Raises:
        InvalidArgumentError: ``sim`` holds no such world on this engine.
    """
    import numpy as np
    import pybullet as p

    world = mjcf_world(sim)
    out = []
    for k, nb in enumerate(world.native.bodies):
        for i, j in enumerate(nb.joint_ids):
            if i + 1 < len(nb.joint_ids) and nb.link_bodies[i + 1] == nb.link_bodies[i]:
                continue  # an intermediate link of a body with several joints
            state = p.getLinkState(
                world._ids[k], i, computeForwardKinematics=1, physicsClientId=world._c
            )
            rot = np.array(p.getMatrixFromQuaternion(state[5])).reshape(3, 3)
            out.append((int(nb.link_bodies[i]), int(j), np.array(state[4]), rot))
    return out
