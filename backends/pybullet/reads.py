"""The PyBullet backend's state reads and resets (a part of
:class:`~simbridge.backends.pybullet.backend.PyBulletBackend`): joint tables, link, base
and joint states (multi-DoF ones too), contact points, snapshots and the time. Every read
checks the values it returns: none hands out a NaN or an infinity."""

from __future__ import annotations

import math
import threading
from contextlib import AbstractContextManager
from itertools import chain
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from simbridge.exceptions import SimulationDivergedError
from simbridge.types import (
    LINK_STATE_WIDTH,
    BaseState,
    DynamicsInfo,
    JointInfo,
    JointStateMultiDof,
    JointStates,
    JointType,
    LinkState,
    LinkStates,
    Quat,
    Vec3,
)

from .common import _all_finite, _Body, _exclusive, _finite_base, wait_for_lock
from .output import p  # pybullet, imported with its banner captured
from .records import Records

__all__ = ["StateReads"]

_flat = chain.from_iterable


class StateReads:
    """The ``Backend`` methods that read or reset state (a part of PyBulletBackend)."""

    if TYPE_CHECKING:  # provided by PyBulletBackend and simbridge.backend.Backend
        name: ClassVar[str]
        _c: int
        _stepping: threading.RLock
        _bodies: dict[int, _Body]
        _records: Records
        _diverged: SimulationDivergedError | None
        _steps: int
        _dt: float
        _next_check: int

        def _diverge(self, where: str) -> None: ...

        def _idle(self) -> AbstractContextManager[None]: ...

        def refuse_fixed_base_velocity(
            self, body: int, linear: Vec3 | None, angular: Vec3 | None
        ) -> None: ...

    # ---------------------------------------------------------------- tables

    def _read_joint_info(self, body: int, joint: int) -> JointInfo:
        r = p.getJointInfo(body, joint, physicsClientId=self._c)
        return JointInfo(
            r[0],
            r[1].decode("utf-8"),
            JointType(r[2]),
            r[3],
            r[4],
            r[5],
            r[6],
            r[7],
            r[8],
            r[9],
            r[10],
            r[11],
            r[12].decode("utf-8"),
            r[13],
            r[14],
            r[15],
            r[16],
        )

    def joint_info(self, body: int, joint: int) -> JointInfo:
        """See Backend.joint_info. PyBullet: ``p.getJointInfo``'s row, read once at load."""
        return self._bodies[body].table[joint]

    def num_joints(self, body: int) -> int:
        """See Backend.num_joints. PyBullet: ``p.getNumJoints``, read once at load."""
        return self._bodies[body].n

    @_exclusive
    def dynamics_info(self, body: int, link: int) -> DynamicsInfo:
        """See Backend.dynamics_info. PyBullet: ``p.getDynamicsInfo``."""
        r = p.getDynamicsInfo(body, link, physicsClientId=self._c)
        return DynamicsInfo(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7])

    # ---------------------------------------------------------------- state

    def link_state(self, body: int, link: int) -> LinkState:
        """See Backend.link_state.

        PyBullet: ``p.getLinkState`` with velocity and forward kinematics (the base from its base
        reads); a non-finite value raises ``SimulationDivergedError``.
        """
        if self._diverged is not None:
            raise self._diverged
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            c = self._c
            if link >= 0:
                r = p.getLinkState(
                    body, link, computeLinkVelocity=1, computeForwardKinematics=1, physicsClientId=c
                )
                p0, o0, p4, o5, v6, w7 = r[0], r[1], r[4], r[5], r[6], r[7]
                if not math.isfinite(  # explicit sums: 0.2 µs (sum() 0.4)
                    p0[0] + p0[1] + p0[2] + o0[0] + o0[1] + o0[2] + o0[3]
                    + p4[0] + p4[1] + p4[2] + o5[0] + o5[1] + o5[2] + o5[3]
                    + v6[0] + v6[1] + v6[2] + w7[0] + w7[1] + w7[2]
                ) and not _all_finite(p0, o0, p4, o5, v6, w7):  # fmt: skip
                    self._diverge(f"body {body} link {link} state")
                return LinkState(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7])
            pos, orn = p.getBasePositionAndOrientation(body, physicsClientId=c)
            lin, ang = p.getBaseVelocity(body, physicsClientId=c)
        finally:
            lock.release()
        return self._base_link_state(body, pos, orn, lin, ang)

    def _base_link_state(self, body: int, pos: Vec3, orn: Quat, lin: Vec3, ang: Vec3) -> LinkState:
        """The base as a link, from its base reads (checked finite here): its URDF link frame
        is the centre-of-mass frame times the inverse of its inertial frame."""
        if not _finite_base(pos, orn, lin, ang) and not _all_finite(pos, orn, lin, ang):
            self._diverge(f"body {body} base state")
        lp, lo = self._bodies[body].base_inertial
        inv_pos, inv_orn = p.invertTransform(lp, lo)
        fpos, forn = p.multiplyTransforms(pos, orn, inv_pos, inv_orn)
        return LinkState(pos, orn, lp, lo, fpos, forn, lin, ang)

    def link_states(self, body: int, links: np.ndarray) -> LinkStates:
        """See Backend.link_states.

        PyBullet: one ``p.getLinkStates`` of every link asked for, with velocity and forward
        kinematics (the base, if asked for, from its base reads, as ``link_state``); a
        non-finite value raises ``SimulationDivergedError``.
        """
        if self._diverged is not None:
            raise self._diverged
        idx = links.tolist()
        moving = [k for k in idx if k >= 0]
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            c = self._c
            rows = (
                p.getLinkStates(
                    body,
                    moving,
                    computeLinkVelocity=1,
                    computeForwardKinematics=1,
                    physicsClientId=c,
                )
                if moving
                else []
            )
            if len(moving) != len(idx):
                pos, orn = p.getBasePositionAndOrientation(body, physicsClientId=c)
                lin, ang = p.getBaseVelocity(body, physicsClientId=c)
        finally:
            lock.release()
        if len(moving) != len(idx):  # the base, where it stands among the links
            rows = list(rows)
            rows.insert(idx.index(-1), self._base_link_state(body, pos, orn, lin, ang))
        n = len(idx)  # each row 8 tuples, LinkState's fields: 27 floats
        block = np.fromiter(_flat(_flat(rows)), np.float64, n * LINK_STATE_WIDTH).reshape(
            n, LINK_STATE_WIDTH
        )
        if not np.isfinite(block).all():
            self._diverge(f"body {body} link states")
        return LinkStates.of(block)

    def base_state(self, body: int) -> BaseState:
        """See Backend.base_state.

        PyBullet: ``p.getBasePositionAndOrientation`` and ``p.getBaseVelocity``; a non-finite value
        raises ``SimulationDivergedError``.
        """
        if self._diverged is not None:
            raise self._diverged
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            c = self._c
            pos, orn = p.getBasePositionAndOrientation(body, physicsClientId=c)
            lin, ang = p.getBaseVelocity(body, physicsClientId=c)
        finally:
            lock.release()
        if not _finite_base(pos, orn, lin, ang) and not _all_finite(pos, orn, lin, ang):
            self._diverge(f"body {body} base state")
        return BaseState(pos, orn, lin, ang)

    def joint_states(self, body: int, joints: np.ndarray) -> JointStates:
        """See Backend.joint_states.

        PyBullet: ``p.getJointStates``; a non-finite value raises ``SimulationDivergedError``.
        """
        if self._diverged is not None:
            raise self._diverged
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            rows = p.getJointStates(body, joints.tolist(), physicsClientId=self._c)
        finally:
            lock.release()
        if not rows:
            return JointStates(np.zeros(0), np.zeros(0), np.zeros(0))
        pos, vel, _, torque = zip(*rows, strict=True)  # position, velocity, reaction, torque
        if not math.isfinite(sum(pos) + sum(vel) + sum(torque)) and not _all_finite(
            pos, vel, torque
        ):
            self._diverge(f"body {body} joint states")
        return JointStates(np.array(pos), np.array(vel), np.array(torque))

    @_exclusive
    def reset_joint_state(
        self, body: int, joints: np.ndarray, positions: list[float], velocities: list[float]
    ) -> None:
        """See Backend.reset_joint_state.

        PyBullet: ``p.resetJointState``, probed after the next step.
        """
        c = self._c
        for j, q, v in zip(joints.tolist(), positions, velocities, strict=True):
            p.resetJointState(body, j, q, v, physicsClientId=c)
        self._next_check = self._steps + 1  # a teleport: probed after the next step

    @_exclusive
    def reset_base_state(
        self,
        body: int,
        position: Vec3 | None,
        orientation: Quat | None,
        linear_velocity: Vec3 | None,
        angular_velocity: Vec3 | None,
    ) -> None:
        """See Backend.reset_base_state.

        PyBullet: ``p.resetBasePositionAndOrientation`` (which zeroes the velocity: the current one
        is written back unless given) and ``p.resetBaseVelocity``.
        """
        if self._diverged is not None:  # it reads the state it keeps
            raise self._diverged
        self._next_check = self._steps + 1  # a teleport: probed after the next step
        c = self._c
        if not self._bodies[body].free:
            self.refuse_fixed_base_velocity(body, linear_velocity, angular_velocity)
        cur_lin, cur_ang = p.getBaseVelocity(body, physicsClientId=c)
        if position is not None or orientation is not None:
            cur_pos, cur_orn = p.getBasePositionAndOrientation(body, physicsClientId=c)
            p.resetBasePositionAndOrientation(
                body,
                cur_pos if position is None else position,
                cur_orn if orientation is None else orientation,
                physicsClientId=c,
            )
            # PyBullet's pose reset also zeroes the base velocity; the contract keeps it
            if linear_velocity is None:
                linear_velocity = cur_lin
            if angular_velocity is None:
                angular_velocity = cur_ang
        if linear_velocity is not None or angular_velocity is not None:
            p.resetBaseVelocity(
                body,
                cur_lin if linear_velocity is None else linear_velocity,
                cur_ang if angular_velocity is None else angular_velocity,
                physicsClientId=c,
            )

    # ---------------------------------------------------------------- spherical joints

    def joint_states_multi_dof(self, body: int, joints: np.ndarray) -> list[JointStateMultiDof]:
        """See Backend.joint_states_multi_dof. PyBullet: ``p.getJointStatesMultiDof``."""
        if self._diverged is not None:
            raise self._diverged
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            rows = p.getJointStatesMultiDof(body, joints.tolist(), physicsClientId=self._c)
        finally:
            lock.release()
        out = [JointStateMultiDof(tuple(r[0]), tuple(r[1]), tuple(r[3])) for r in rows]
        if not _all_finite(*(x for r in out for x in r)):
            self._diverge(f"body {body} joint states")
        return out

    @_exclusive
    def reset_joint_state_multi_dof(
        self,
        body: int,
        joints: np.ndarray,
        positions: list[list[float]],
        velocities: list[list[float]],
    ) -> None:
        """See Backend.reset_joint_state_multi_dof. PyBullet: ``p.resetJointStateMultiDof``."""
        c = self._c
        for j, q, v in zip(joints.tolist(), positions, velocities, strict=True):
            p.resetJointStateMultiDof(body, j, q, v, physicsClientId=c)
        self._next_check = self._steps + 1  # a teleport: probed after the next step
