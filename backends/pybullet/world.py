"""The whole world's state, PyBullet's half of ``get_state``/``set_state`` (a part of
:class:`~simbridge.backends.pybullet.backend.PyBulletBackend`; the commands in force:
commands.py): ``snapshot``/``restore`` through PyBullet's ``saveState``/``restoreState``, and
the time.

:class:`Saved` is one ``p.saveState`` snapshot (positions, velocities and the contact caches
with their warm-started impulses, kept in the physics client's memory; its cost:
docs/state_and_contacts.md).
It fits only the world it was taken in: the same client, no load, remove or reset since. When
it is garbage-collected its id is queued and removed by the backend on its next snapshot or
restore, in the backend's own thread; a reset drops the queue (resetSimulation frees every
saved state, and PyBullet numbers new ones from 0 again).
"""

from __future__ import annotations

import weakref
from contextlib import AbstractContextManager
from typing import TYPE_CHECKING, Any, ClassVar

from simbridge.engine_output import captured
from simbridge.exceptions import SimulationDivergedError

from .common import _Body, _exclusive
from .output import p  # pybullet, imported with its banner captured
from .records import Records

__all__ = ["Saved", "Snapshots"]


class Saved:
    """One ``p.saveState`` snapshot and what it fits (see the module docstring).

    Args:
        client: The PyBullet client id it was saved in.
        records: The backend's records (their generation; a collected snapshot is listed in
            ``records.dead`` for its state to be freed).
        world: ``((body id, its _Body object), ...)`` of the world it was saved in.
        state_id: ``p.saveState``'s id.
        steps: The step count when it was saved.
    """

    __slots__ = ("client", "generation", "world", "state_id", "steps", "__weakref__")

    def __init__(
        self, client: int, records: Records, world: tuple[Any, ...], state_id: int, steps: int
    ) -> None:
        self.client = client
        self.generation = records.generation
        self.world = world  # ((body id, its _Body object), ...): the very objects, not copies
        self.state_id = state_id
        self.steps = steps
        done = weakref.finalize(self, records.dead.append, (records.generation, state_id))
        done.atexit = False

    def fits(self, client: int, records: Records, world: tuple[Any, ...]) -> bool:
        """Whether this snapshot can be restored into the world as it is now.

        Args:
            client: The PyBullet client id now.
            records: The backend's records now.
            world: ``((body id, its _Body object), ...)`` now.

        Returns:
            True for the same client, generation and bodies (the very objects).
        """
        return (
            self.client == client
            and self.generation == records.generation
            and len(self.world) == len(world)
            and all(a[0] == b[0] and a[1] is b[1] for a, b in zip(self.world, world, strict=True))
        )


class Snapshots:
    """``snapshot``, ``restore`` and ``set_time`` (a part of PyBulletBackend)."""

    if TYPE_CHECKING:  # provided by PyBulletBackend and simbridge.backend.Backend
        name: ClassVar[str]
        _c: int
        _bodies: dict[int, _Body]
        _records: Records
        _diverged: SimulationDivergedError | None
        _steps: int
        _dt: float
        _next_check: int

        def _idle(self) -> AbstractContextManager[None]: ...

    def _world_key(self) -> tuple[Any, ...]:
        return tuple(self._bodies.items())

    def _free_dead_states(self) -> None:
        records = self._records
        while records.dead:
            generation, state_id = records.dead.pop()
            if generation == records.generation:
                p.removeState(state_id, physicsClientId=self._c)

    def snapshot(self) -> Any:
        """See Backend.snapshot. PyBullet: ``p.saveState``, kept with what world it fits."""
        if self._diverged is not None:
            raise self._diverged
        with self._idle():
            self._free_dead_states()
            state_id = p.saveState(physicsClientId=self._c)
            return Saved(self._c, self._records, self._world_key(), state_id, self._steps)

    def restore(self, native: Any) -> bool:
        """See Backend.restore.

        PyBullet: ``p.restoreState`` when the snapshot fits this world (False otherwise: PyBullet's
        contact caches cannot be dropped, they stay).
        """
        if self._diverged is not None:
            raise self._diverged
        with self._idle():
            self._free_dead_states()
            if not (
                isinstance(native, Saved) and native.fits(self._c, self._records, self._world_key())
            ):
                return False  # PyBullet's contact caches cannot be dropped: they stay
            with captured(self.name, "restoring a state"):
                p.restoreState(native.state_id, physicsClientId=self._c)
            self.set_time(native.steps * self._dt)
            return True

    @_exclusive
    def set_time(self, time: float) -> None:
        """See Backend.set_time.

        PyBullet: the step count moves; the pending torques' records follow.
        """
        steps = round(time / self._dt)
        if steps != self._steps:
            self._records.restamp(self._steps, steps)
            self._steps = steps
            self._next_check = steps + 1  # a restored state: probed after the next step
