"""The `Sim`'s contacts and whole-world state: ``contact_points``, ``get_state`` and
``set_state`` (a part of :class:`simbridge.Sim`; the state records are
:mod:`simbridge.types`, their checks :mod:`simbridge.sim.state_check`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from simbridge.exceptions import InvalidArgumentError
from simbridge.sim.arguments import JointsArg, LinkArg, flag
from simbridge.types import BodyState, ContactPoint, MotorMode, WorldState

if TYPE_CHECKING:
    from simbridge.backend import Backend
    from simbridge.bound import BoundCommand
    from simbridge.sim.lookups import _Body

__all__ = ["WorldStates"]


class WorldStates:
    """Contacts, and the world's state saved and restored (a part of :class:`Sim`)."""

    if TYPE_CHECKING:  # provided by simbridge.sim.Sim and its other parts
        backend: str
        _b: Backend
        _bodies: dict[int, _Body]
        _commands: list[BoundCommand]
        _dt: float
        _wall_start: float | None

        def _body(self, body: int, argument: str = "body") -> _Body: ...

        def link_index(self, body: int, link: LinkArg) -> int: ...

        def _joints(self, body: int, joints: JointsArg | None, movable: bool) -> np.ndarray: ...

        def _end_commands(self, why: str) -> None: ...

    def contact_points(
        self,
        body_a: int | None = None,
        body_b: int | None = None,
        *,
        link_a: LinkArg | None = None,
        link_b: LinkArg | None = None,
    ) -> tuple[ContactPoint, ...]:
        """The contact points of the last step (``p.getContactPoints``): all of them, those of
        ``body_a`` (as A), or those between ``body_a`` and ``body_b``; ``link_a``/``link_b``
        (index or name, -1 = base) narrow to one link of each. See
        :class:`~simbridge.types.ContactPoint` for the frames, signs and units.

        The contacts are those found at the start of the last step, with the forces that step
        applied; a teleport or ``set_state`` changes them only at the next step.

        Raises:
            UnknownBodyError, UnknownLinkError: a body or link that is not there.
            InvalidArgumentError: ``body_b`` without ``body_a`` (PyBullet answers that with
                nothing), or a link without its body.
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
            self._body(body_a, "body_a")
            la = None if link_a is None else self.link_index(body_a, link_a)
        if body_b is not None:
            self._body(body_b, "body_b")
            lb = None if link_b is None else self.link_index(body_b, link_b)
        from simbridge.sim.contacts import select

        return select(self._b.contact_points(), body_a, la, body_b, lb)

    def get_state(self, *, exact: bool = True) -> WorldState:
        """Everything :meth:`set_state` needs to put this world back: per body (load order)
        the base's centre-of-mass pose and velocities, every joint's position and velocity,
        the commands in force (motor mode, target, max force, gains) and the torques pending
        for the next step (a spherical joint's in full in ``BodyState.spherical``); the time.

        Args:
            exact: also keep the engine's own data (``WorldState.native``: MuJoCo's solver warm
                start, PyBullet's ``saveState`` with its contact caches, which costs about 2.6
                ms on r2d2), so that a restore into this same world steps bit for bit as the
                uninterrupted run. Without it the state is the portable one alone.

        Bound commands are sent first (as a step would), so the state holds their values.

        Raises:
            InvalidArgumentError: a bound command holds a bad value (as ``step`` would).
        """
        b = self._b
        for command in self._commands:  # a bound command's values are the ones in force
            command.send()
        exact = flag(exact, "exact")
        with b.reading():  # one world: no step in another thread between its parts
            return self._state(b, exact)

    def _state(self, b: Backend, exact: bool) -> WorldState:
        native = b.snapshot() if exact else None
        bodies = []
        for body, info in self._bodies.items():
            base = b.base_state(body)
            js = b.joint_states(body, self._joints(body, None, False))
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
        return WorldState(self.backend, self._dt, b.time, tuple(bodies), native)

    def set_state(self, state: WorldState) -> None:
        """Put the world in ``state`` (from :meth:`get_state` of this Sim, or of another Sim,
        on any backend, with the same robots loaded in the same order): base poses and
        velocities, joint positions and velocities, the commands in force, pending torques and
        the time (to the nearest whole step of this Sim's time step).

        Into the world it was taken from (no load, remove or reset since) a state with its
        engine data restores bit-exactly; anywhere else, or after ``state.portable()``, what
        the engine keeps of its past (contact caches, solver warm start) stays out: see
        docs/state_and_contacts.md for each engine's one-step error after such a restore.
        ``joint_states(...).applied_torques`` describe the last step until the next one.
        Bound commands (:meth:`velocity_command`) end here, as at a world change: the state's
        commands replace them.

        Raises:
            InvalidArgumentError: not a WorldState; other robots or another load order (the
                message lists both); a value of the wrong shape, non-finite, a motor mode on a
                fixed joint; a velocity for a fixed base. Nothing is set then, but for the last,
                which the backend refuses when it reaches that body.
            SimClosedError: the Sim is closed.
        """
        b = self._b
        b.time  # noqa: B018 - raises SimClosedError after close()
        from simbridge.sim.state_check import check_state

        checked = check_state(state, self._bodies)
        self._end_commands("set_state replaced the commands in force")
        with b.reading():  # one world: no step in another thread between its parts
            exact = b.restore(state.native if state.backend == self.backend else None)
            for c in checked:
                if not exact:
                    pos, orn, lin, ang = c.base
                    b.reset_base_state(c.body, pos, orn, lin, ang)  # type: ignore[arg-type]
                    movable = self._joints(c.body, None, True)
                    if c.spherical:  # their own call below (a cached index array: backends
                        # key on it)
                        sph = {e.joint for e in c.spherical}
                        movable = self._joints(
                            c.body, [j for j in movable.tolist() if j not in sph], True
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
