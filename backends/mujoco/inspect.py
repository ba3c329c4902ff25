"""Look inside a MuJoCo-backed `Sim`: its engine objects, for tests and debugging.

The `Sim` interface is the way to use simbridge; this is the one door into the backend's
internals, so that nothing else reaches into private attributes (``sim._b._...``). What it
returns is live engine state: read it, do not keep it across a ``load``, ``remove`` or
``reset`` (each compiles a new model).
"""

from __future__ import annotations

from typing import Any

from simbridge.exceptions import InvalidArgumentError

from .backend import MujocoBackend
from .robots import Compiled, Robot

__all__ = ["backend_of", "mjcf_link_frames", "compiled", "model_and_data", "robot", "world_spec"]


def backend_of(sim: Any) -> MujocoBackend:
    """The :class:`MujocoBackend` behind ``sim``.

    Args:
        sim: A `Sim`.

    Returns:
        Its backend.

    Raises:
        InvalidArgumentError: ``sim`` runs on another backend.
    """
    backend = getattr(sim, "_b", None)
    if not isinstance(backend, MujocoBackend):
        raise InvalidArgumentError(
            "sim", f"a Sim on the 'mujoco' backend is needed, got {type(backend).__name__}"
        )
    return backend


def compiled(sim: Any) -> Compiled:
    """The world's current compiled state.

    Args:
        sim: A `Sim` on the MuJoCo backend.

    Returns:
        The :class:`~.robots.Compiled` state: model, data, motor table, the compiled loop or
        None, hot-path caches.
    """
    return backend_of(sim)._w


def model_and_data(sim: Any) -> tuple[Any, Any]:
    """The MuJoCo model and data of the world as it is now.

    Args:
        sim: A `Sim` on the MuJoCo backend.

    Returns:
        ``(MjModel, MjData)``.
    """
    c = compiled(sim)
    return c.m, c.d


def world_spec(sim: Any) -> Any:
    """The ``MjSpec`` the world is compiled from (a change shows at the next load or remove).

    Args:
        sim: A `Sim` on the MuJoCo backend.

    Returns:
        The world's ``mujoco.MjSpec``.
    """
    return backend_of(sim)._spec


def robot(sim: Any, body: int) -> Robot:
    """What the backend keeps of one body.

    Args:
        sim: A `Sim` on the MuJoCo backend.
        body: The body's id.

    Returns:
        Its :class:`Robot`: its MuJoCo body ids (base first), joint addresses (``qadr``,
        ``dofadr``, -1 for fixed joints), names in the spec.
    """
    return backend_of(sim)._robots[body]


def mjcf_link_frames(sim: Any) -> list[tuple[int, int, Any, Any]]:
    """The engine's own frame of each MuJoCo body that carries a joint, for an MJCF read with
    ``semantics="mujoco"``: the frame of its link at the joint's anchor,
    as the engine holds it (the backend's own ``MjData`` after ``mj_kinematics``).

    Args:
        sim: A `Sim` on the 'mujoco' backend holding such a model.

    Returns:
        One ``(body, joint, position, rotation)`` per row that ends a MuJoCo body (the
        intermediate links of a body with several joints are left out): the MuJoCo body and
        joint ids, the anchor's world position (3,) in m and the link's rotation matrix (3, 3),
        world from link. MuJoCo puts the same frame at ``xpos[body] + xmat[body] @
        jnt_pos[joint]`` with rotation ``xmat[body]``.

    Raises:
        InvalidArgumentError: ``sim`` holds no such world on this engine.
    """
    import mujoco

    from .native import NativeMujoco

    backend = getattr(sim, "_b", None)
    if not isinstance(backend, NativeMujoco):
        raise InvalidArgumentError(
            "sim",
            "a Sim on the 'mujoco' backend holding an MJCF read with semantics='mujoco' is "
            f"needed, got {type(backend).__name__}",
        )
    m, d = backend.m, backend.d
    mujoco.mj_kinematics(m, d)
    out = []
    for nb in backend.native.bodies:
        for i, j in enumerate(nb.joint_ids):
            if i + 1 < len(nb.joint_ids) and nb.link_bodies[i + 1] == nb.link_bodies[i]:
                continue  # an intermediate link of a body with several joints
            b = nb.link_bodies[i]
            rot = d.xmat[b].reshape(3, 3).copy()
            out.append((int(b), int(j), d.xpos[b] + rot @ m.jnt_pos[j], rot))
    return out
