"""Reading and setting the whole state of the world (``get_state``/``set_state``'s backend
half, the commands in force apart: commands.py): MuJoCo's own data for an exact restore.

* ``snapshot``/``restore``: ``mj_getState``/``mj_setState`` with ``mjSTATE_INTEGRATION``
  (time, qpos, qvel, act, the solver's warm start ``qacc_warmstart``, ctrl and applied
  forces), and the poses of fixed bases (``body_pos``/``body_quat``: a fixed base is moved in
  the model), valid in any world with the same compiled layout (the same robots loaded in the
  same order, so the same names and sizes). A restore without them starts the solver cold
  (``qacc_warmstart`` = 0, as a fresh ``MjData``), so that the portable state steps the same in
  any world.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import mujoco
import numpy as np

from simbridge.exceptions import EngineError, SimulationDivergedError

from ..locking import exclusive
from .robots import Compiled, Robot

__all__ = ["Snapshots"]

_STATE = mujoco.mjtState.mjSTATE_INTEGRATION


@dataclass(frozen=True, eq=False)
class _Native:
    """What ``snapshot`` keeps (opaque to the Sim)."""

    layout: tuple[Any, ...]
    state: np.ndarray  # mj_getState(..., mjSTATE_INTEGRATION)
    fixed_bases: tuple[tuple[int, np.ndarray, np.ndarray], ...]  # (body, body_pos, body_quat)
    steps: int


class Snapshots:
    """The state methods of the Backend contract (a part of :class:`MujocoBackend`)."""

    if TYPE_CHECKING:  # provided by MujocoBackend and simbridge.backend.Backend
        name: ClassVar[str]
        _robots: dict[int, Robot]
        _steps: int
        _dt: float
        _diverged: SimulationDivergedError | None
        _engine_error: str | None

        @property
        def _w(self) -> Compiled: ...

        @property
        def time(self) -> float: ...

        def _check_idle(self) -> None: ...

    _layout_cache: tuple[Compiled, tuple[Any, ...]] | None = None

    def _layout(self) -> tuple[Any, ...]:
        """What makes two compiled worlds' states interchangeable: sizes and every name."""
        c = self._w
        cached = self._layout_cache
        if cached is not None and cached[0] is c:
            return cached[1]
        m = c.m
        key = (
            m.nq,
            m.nv,
            m.na,
            m.nbody,
            m.ngeom,
            mujoco.mj_stateSize(m, _STATE),
            hashlib.sha256(bytes(m.names)).hexdigest(),
        )
        self._layout_cache = (c, key)
        return key

    def _refuse_broken(self) -> None:
        """A world that diverged or failed stays refused until reset(), set_state too."""
        if self._diverged is not None:
            raise self._diverged
        if self._engine_error is not None:
            raise EngineError(self.name, self.time, self._engine_error)

    @exclusive
    def snapshot(self) -> Any:
        """See Backend.snapshot.

        MuJoCo: ``mj_getState`` (``mjSTATE_INTEGRATION``) and the fixed bases.
        """
        self._check_idle()
        self._refuse_broken()
        c = self._w
        m, d = c.m, c.d
        state = np.empty(mujoco.mj_stateSize(m, _STATE))
        mujoco.mj_getState(m, d, state, _STATE)
        fixed = []
        for robot in self._robots.values():
            if robot.free_qadr < 0:
                bid = int(robot.body_ids[0])
                fixed.append((robot.id, m.body_pos[bid].copy(), m.body_quat[bid].copy()))
        return _Native(self._layout(), state, tuple(fixed), self._steps)

    @exclusive
    def restore(self, native: Any) -> bool:
        """See Backend.restore.

        MuJoCo: False for a snapshot of another compiled layout; the solver then starts cold
        (``qacc_warmstart`` = 0), as a fresh ``MjData``.
        """
        self._check_idle()
        self._refuse_broken()
        c = self._w
        m, d = c.m, c.d
        if not isinstance(native, _Native) or native.layout != self._layout():
            d.qacc_warmstart[:] = 0.0  # a cold start, as a fresh MjData's
            return False
        mujoco.mj_setState(m, d, native.state, _STATE)
        for body, pos, quat in native.fixed_bases:
            robot = self._robots[body]
            bid = int(robot.body_ids[0])
            if (m.body_pos[bid] != pos).any() or (m.body_quat[bid] != quat).any():
                m.body_pos[bid] = pos
                m.body_quat[bid] = quat
                robot.spec.root.pos = pos.tolist()  # kept across the next recompile
                robot.spec.root.quat = quat.tolist()
        self._steps = native.steps
        c.stale = True
        c.motor_force_valid = False
        return True

    @exclusive
    def set_time(self, time: float) -> None:
        """See Backend.set_time.

        MuJoCo: ``d.time`` set to the whole number of steps nearest ``time``.
        """
        self._check_idle()
        steps = round(time / self._dt)
        if steps != self._steps:
            self._steps = steps
            self._w.d.time = steps * self._dt
