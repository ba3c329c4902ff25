"""Look inside a PhysX-backed `Sim`: its SAPIEN objects, for tests and debugging. What it
returns is live engine state: read it, do not keep it across a ``load``, ``remove`` or
``reset``."""

from __future__ import annotations

from typing import Any

from simbridge.exceptions import InvalidArgumentError

from .backend import PhysxBackend
from .robots import Robot

__all__ = ["mjcf_world", "mjcf_link_frames", "backend_of", "scene", "robot", "articulation"]


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


def mjcf_link_frames(sim: Any) -> list[tuple[int, int, Any, Any]]:
    """The engine's own frame of each MuJoCo body that carries a joint, for an MJCF read with
    ``semantics="mujoco"``: the frame of its link at the joint's anchor,
    as the engine holds it (the link's ``entity_pose``, float32).

    Args:
        sim: A `Sim` on the 'physx' backend holding such a model.

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

    world = mjcf_world(sim)
    out = []
    for k, nb in enumerate(world.native.bodies):
        links = world._built[k].links
        for i, j in enumerate(nb.joint_ids):
            if i + 1 < len(nb.joint_ids) and nb.link_bodies[i + 1] == nb.link_bodies[i]:
                continue  # an intermediate link of a body with several joints
            pose = links[i + 1].entity_pose
            rot = pose.to_transformation_matrix()[:3, :3]
            out.append((int(nb.link_bodies[i]), int(j), np.array(pose.p, float), np.array(rot)))
    return out
