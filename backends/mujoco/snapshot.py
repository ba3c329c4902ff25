"""Reading and setting the whole state of the world (``get_state``/``set_state``'s backend
half): the commands in force from the motor table, and MuJoCo's own data for an exact restore.

* ``joint_commands``: the motor table's columns of a body (motors.py) in PyBullet's terms: a
  motor with kp 0 and kd 1 is a VELOCITY motor towards ``target_velocity``, any other a
  POSITION motor towards ``target_position`` (a position command sets ``target_velocity`` to
  0); the torques pending for the next step.
* ``set_joint_commands``: writes those columns back (a position target clamped to the
  joint's limits, as ``set_joint_position`` does) and the pending torques; spherical joints
  apart: ``spherical_states``/``set_spherical_states`` read and write their three slots, target
  quaternion, coordinates and torques.
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
from simbridge.types import JointCommands, JointType, MotorMode, SphericalJointState

from ..locking import exclusive
from .world import Compiled, Robot

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
    def joint_commands(self, body: int) -> JointCommands:
        robot = self._robots[body]
        c = self._w
        t = c.motors
        n = len(robot.table)
        mv = np.asarray(robot.movable, dtype=np.intp)
        slots = robot.motor_index
        kp = t.kp[slots]
        kd = t.kd[slots]
        position = (kp != 0.0) | (kd != 1.0)
        mode = np.full(n, MotorMode.NONE, dtype=np.int8)
        mode[mv] = np.where(position, MotorMode.POSITION, MotorMode.VELOCITY)
        out = [np.zeros(n) for _ in range(5)]
        out[0][mv] = np.where(position, t.target_position[slots], t.target_velocity[slots])
        out[1][mv] = t.max_force[slots]
        out[2][mv] = kp
        out[3][mv] = kd
        out[4][mv] = c.torque[slots]
        return JointCommands(mode, *out)

    @exclusive
    def set_joint_commands(self, body: int, commands: JointCommands) -> None:
        self._check_idle()
        robot = self._robots[body]
        c = self._w
        t = c.motors
        keep = [k for k, j in enumerate(robot.movable) if j not in robot.balls]  # not spherical
        mv = np.asarray(robot.movable, dtype=np.intp)[keep]
        slots = robot.motor_index[keep]
        position = commands.mode[mv] == MotorMode.POSITION
        target = commands.target[mv]
        joints = robot.model.joints
        for k in np.flatnonzero(position).tolist():  # as set_joint_position: within the limits
            j = joints[int(mv[k])]
            if j.has_limit:
                target[k] = min(max(target[k], j.lower), j.upper)
        t.target_velocity[slots] = np.where(position, 0.0, target)
        t.target_position[slots] = np.where(position, target, t.target_position[slots])
        t.kp[slots] = np.where(position, commands.kp[mv], 0.0)
        t.kd[slots] = np.where(position, commands.kd[mv], 1.0)
        t.max_force[slots] = commands.max_force[mv]
        c.refresh_motors()
        c.torque[slots] = commands.pending_torque[mv]  # in place: the step loops hold it
        c.pending_torque = bool(c.torque.any())

    @exclusive
    def spherical_states(self, body: int) -> list[SphericalJointState]:
        robot = self._robots[body]
        c = self._w
        t = c.motors
        d = c.d
        first = dict(zip(robot.movable, robot.motor_index.tolist(), strict=True))
        out = []
        for j in robot.balls:
            s = first[j]
            axes = slice(s, s + 3)
            kp, kd = tuple(t.kp[axes].tolist()), tuple(t.kd[axes].tolist())
            position = any(kp) or kd != (1.0, 1.0, 1.0)
            a, v = int(robot.qadr[j]), int(robot.dofadr[j])  # a: x's address, after w
            q = d.qpos[a - 1 : a + 3].tolist()
            out.append(
                SphericalJointState(
                    j,
                    (q[1], q[2], q[3], q[0]),
                    tuple(d.qvel[v : v + 3].tolist()),
                    int(MotorMode.POSITION if position else MotorMode.VELOCITY),
                    tuple(t.ball_target[t.ball_of[s]].tolist()),
                    tuple(t.max_force[axes].tolist()),
                    kp,
                    kd,
                    tuple(c.torque[axes].tolist()),
                )
            )
        return out

    @exclusive
    def set_spherical_states(
        self, body: int, states: list[SphericalJointState], positions: bool
    ) -> None:
        self._check_idle()
        robot = self._robots[body]
        c = self._w
        t = c.motors
        first = dict(zip(robot.movable, robot.motor_index.tolist(), strict=True))
        for e in states:
            assert robot.table[e.joint].type == JointType.SPHERICAL
            s = first[e.joint]
            axes = slice(s, s + 3)
            t.target_velocity[axes] = 0.0
            t.target_position[axes] = 0.0
            t.kp[axes] = e.motor_kp
            t.kd[axes] = e.motor_kd
            t.max_force[axes] = e.motor_max_force
            t.ball_target[t.ball_of[s]] = e.motor_target
            c.torque[axes] = e.pending_torque  # in place: the step loops hold it
            if positions:
                a, v = int(robot.qadr[e.joint]), int(robot.dofadr[e.joint])
                x, y, z, w = e.position
                c.d.qpos[a - 1 : a + 3] = (w, x, y, z)
                c.d.qvel[v : v + 3] = e.velocity
        c.refresh_motors()
        c.pending_torque = bool(c.torque.any())
        if positions:
            c.stale = True
            c.motor_force_valid = False

    @exclusive
    def snapshot(self) -> Any:
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
        self._check_idle()
        steps = round(time / self._dt)
        if steps != self._steps:
            self._steps = steps
            self._w.d.time = steps * self._dt
