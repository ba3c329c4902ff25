"""The `Sim`'s contacts and whole-world state: ``contact_points``, ``get_state`` and
``set_state``. Functions of the Sim's :class:`~simbridge.sim.shared.Shared` state; the state
records are :mod:`simbridge.types`, their checks :mod:`simbridge.sim.state_check`."""

from __future__ import annotations

import numpy as np

from simbridge.backend import Backend
from simbridge.exceptions import InvalidArgumentError
from simbridge.sim.arguments import LinkArg, flag
from simbridge.sim.lookups import body_table, joint_indices, link_index
from simbridge.sim.shared import Shared
from simbridge.types import BodyState, ContactPoint, MotorMode, WorldState

__all__ = ["contact_points", "external_forces", "get_state", "set_state"]


def contact_points(
    s: Shared,
    body_a: int | None,
    body_b: int | None,
    link_a: LinkArg | None,
    link_b: LinkArg | None,
) -> tuple[ContactPoint, ...]:
    """The contact points of the last step (:meth:`simbridge.Sim.contact_points`).

    Args:
        s: the Sim's shared state.
        body_a, body_b, link_a, link_b: as :meth:`simbridge.Sim.contact_points`'s (None: any).

    Returns:
        :class:`~simbridge.types.ContactPoint` records, the asked body (and link) as A.

    Raises:
        UnknownBodyError, UnknownLinkError: a body or link that is not there.
        InvalidArgumentError: ``body_b`` without ``body_a``, or a link without its body.
    """
    if body_a is None and body_b is not None:
        raise InvalidArgumentError(
            "body_b",
            "give body_a too (PyBullet's getContactPoints filters by bodyB only "
            "together with bodyA); the points of one body are contact_points(body)",
        )
    if link_a is not None and body_a is None:
        raise InvalidArgumentError("link_a", "a link filter needs its body: give body_a")
    if link_b is not None and body_b is None:
        raise InvalidArgumentError("link_b", "a link filter needs its body: give body_b")
    la = lb = None
    if body_a is not None:
        body_table(s, body_a, "body_a")
        la = None if link_a is None else link_index(s, body_a, link_a)
    if body_b is not None:
        body_table(s, body_b, "body_b")
        lb = None if link_b is None else link_index(s, body_b, link_b)
    from simbridge.sim.contacts import select

    return select(s.backend.contact_points(), body_a, la, body_b, lb)


def external_forces(s: Shared, body: int) -> np.ndarray:
    """The contact wrench on each link of ``body`` (:meth:`simbridge.Sim.external_forces`).

    Args:
        s: the Sim's shared state.
        body: a body id.

    Returns:
        ``(links + 1, 6)`` float64, the base's row first: torque (N m) then force (N), world,
        about the body's centre of mass.

    Raises:
        UnknownBodyError: a body that is not there.
        BackendUnsupportedError: a backend without contact points.
    """
    body_table(s, body, "body")
    return s.backend.external_forces(body)


def get_state(s: Shared, exact: bool) -> WorldState:
    """The world's state (:meth:`simbridge.Sim.get_state`), bound commands sent first.

    Args:
        s: the Sim's shared state.
        exact: also keep the engine's own data (``WorldState.native``).

    Returns:
        The :class:`~simbridge.types.WorldState`, bodies in load order.

    Raises:
        InvalidArgumentError: a bound command holds a bad value (as ``step`` would), or
            ``exact`` is not a bool.
    """
    b = s.backend
    for command in s.commands:  # a bound command's values are the ones in force
        command.send()
    exact = flag(exact, "exact")
    with b.reading():  # one world: no step in another thread between its parts
        return _state(s, b, exact)


def _state(s: Shared, b: Backend, exact: bool) -> WorldState:
    native = b.snapshot() if exact else None
    bodies = []
    for body, info in s.bodies.items():
        base = b.base_state(body)
        js = b.joint_states(body, joint_indices(s, body, None, False))
        cmd = b.joint_commands(body)
        spherical = tuple(b.spherical_states(body)) if info.has_spherical else ()
        for e in spherical:  # the arrays hold a spherical joint's first coordinate and axis
            j = e.joint
            js.positions[j], js.velocities[j] = e.position[0], e.velocity[0]
            cmd.mode[j] = e.motor_mode
            cmd.target[j] = e.motor_target[0] if e.motor_mode == MotorMode.POSITION else 0.0
            cmd.max_force[j], cmd.kp[j], cmd.kd[j] = (
                e.motor_max_force[0],
                e.motor_kp[0],
                e.motor_kd[0],
            )
            cmd.pending_torque[j] = e.pending_torque[0]
        bodies.append(
            BodyState(
                body,
                info.name,
                tuple(info.joint_names),
                base.position,
                base.orientation,
                base.linear_velocity,
                base.angular_velocity,
                np.array(js.positions, dtype=np.float64),
                np.array(js.velocities, dtype=np.float64),
                cmd.mode,
                cmd.target,
                cmd.max_force,
                cmd.kp,
                cmd.kd,
                cmd.pending_torque,
                spherical,
            )
        )
    return WorldState(s.name, s.dt, b.time, tuple(bodies), native)


def set_state(s: Shared, state: WorldState) -> None:
    """Put the world in ``state`` (:meth:`simbridge.Sim.set_state`).

    Args:
        s: the Sim's shared state.
        state: a :class:`~simbridge.types.WorldState` of this Sim or another, on any backend,
            with the same robots loaded in the same order.

    Raises:
        InvalidArgumentError: not a WorldState, other robots or another load order, a bad
            value, a velocity for a fixed base.
        SimClosedError: the Sim is closed.
    """
    b = s.backend
    b.time  # noqa: B018 - raises SimClosedError after close()
    from simbridge.sim.state_check import check_state

    checked = check_state(state, s.bodies)
    s.end_commands("set_state replaced the commands in force")
    with b.reading():  # one world: no step in another thread between its parts
        exact = b.restore(state.native if state.backend == s.name else None)
        for c in checked:
            if not exact:
                pos, orn, lin, ang = c.base
                b.reset_base_state(c.body, pos, orn, lin, ang)  # type: ignore[arg-type]
                movable = joint_indices(s, c.body, None, True)
                if c.spherical:  # their own call below (a cached index array: backends
                    # key on it)
                    sph = {e.joint for e in c.spherical}
                    movable = joint_indices(
                        s, c.body, [j for j in movable.tolist() if j not in sph], True
                    )
                if len(movable):
                    b.reset_joint_state(
                        c.body,
                        movable,
                        c.positions[movable].tolist(),
                        c.velocities[movable].tolist(),
                    )
            b.set_joint_commands(c.body, c.commands)
            if c.spherical:
                b.set_spherical_states(c.body, c.spherical, not exact)
        b.set_time(float(state.time))
