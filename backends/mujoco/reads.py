"""The world as the Sim reads and sets it: joint table, link and base states, joint states.

Poses and velocities are recomputed lazily on the first read after a step (``mj_kinematics``,
``mj_comPos``, ``mj_comVel``, or the compiled loop's ``body_state``), so the stepping loop pays
nothing for them. Frames and units are PyBullet's (see simbridge.types); the free base's body
frame is its centre-of-mass frame (model.py), turned back into the URDF link frame here.
"""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING, Any, ClassVar, NoReturn

import mujoco
import numpy as np

from simbridge.exceptions import SimBusyError, SimulationDivergedError
from simbridge.profiles import Profile
from simbridge.transforms import (
    quat_conjugate,
    quat_rotate,
    transform_inverse,
    transform_multiply,
    xyzw_to_wxyz,
)
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

from ..locking import exclusive, wait_for_lock
from .robots import Compiled, Robot

__all__ = ["StateReads"]

# as the compiled loop's busy error says it (_mjkernel.c refuse_if_busy)
_PY_BUSY = (
    "this Sim is stepping in another thread (or in a MuJoCo callback of its own step); a Sim "
    "takes one call at a time (give each thread its own Sim)"
)


def _local_inertials(robot: Robot) -> np.ndarray:
    """``(links + 1, 7)``: each link's inertial frame in its link frame (position, quaternion
    x, y, z, w), base first, kept in the robot's cache (under -1, which no ``id()`` is) for as
    long as its spec's inertials are the same list."""
    hit = robot.cache.get(-1)
    inertials = robot.spec.inertials
    if hit is None or hit[0] is not inertials:
        rows = np.array([(*i.position, *i.orientation) for i in inertials], dtype=np.float64)
        hit = (inertials, rows.reshape(len(inertials), 7))
        robot.cache[-1] = hit
    return hit[1]


class StateReads:
    """The ``Backend`` methods that read or set state (a part of :class:`MujocoBackend`)."""

    if TYPE_CHECKING:  # provided by MujocoBackend and simbridge.backend.Backend
        name: ClassVar[str]
        profile: Profile
        _robots: dict[int, Robot]
        _diverged: SimulationDivergedError | None

        @property
        def _w(self) -> Compiled: ...

        @property
        def time(self) -> float: ...

        def _engine_failed(self, detail: str) -> NoReturn: ...

        def _check_idle(self) -> None: ...

        def _py_mark(self) -> None: ...

        _stepping: threading.RLock
        _in_step: bool

        def refuse_fixed_base_velocity(
            self, body: int, linear: Vec3 | None, angular: Vec3 | None
        ) -> None: ...

    # ---------------------------------------------------------------- tables

    def joint_info(self, body: int, joint: int) -> JointInfo:
        """See Backend.joint_info. MuJoCo: the row of the model's joint table, kept at load."""
        return self._robots[body].table[joint]

    def num_joints(self, body: int) -> int:
        """See Backend.num_joints. MuJoCo: the length of the model's joint table, kept at load."""
        return len(self._robots[body].table)

    def dynamics_info(self, body: int, link: int) -> DynamicsInfo:
        """See Backend.dynamics_info.

        MuJoCo: the build plan's values, which the model was built from.
        """
        return self._robots[body].spec.plan.dynamics_info(link)

    # ---------------------------------------------------------------- state

    def _fresh(self) -> None:
        c = self._w
        if c.stale:
            m, d = c.m, c.d
            mujoco.mj_kinematics(m, d)
            mujoco.mj_comPos(m, d)
            mujoco.mj_comVel(m, d)
            c.stale = False

    def _com_pose_velocity(self, bid: int) -> tuple[Vec3, Quat, Vec3, Vec3]:
        d = self._w.d
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, d.ximat[bid])
        vel = np.empty(6)
        mujoco.mj_objectVelocity(self._w.m, d, mujoco.mjtObj.mjOBJ_BODY, bid, vel, 0)
        pos = d.xipos[bid]
        return (
            (float(pos[0]), float(pos[1]), float(pos[2])),
            (float(quat[1]), float(quat[2]), float(quat[3]), float(quat[0])),
            (float(vel[3]), float(vel[4]), float(vel[5])),
            (float(vel[0]), float(vel[1]), float(vel[2])),
        )

    def _state_of(self, bid: int, body: int) -> list[float]:
        """Centre-of-mass pose and velocity, then link-frame pose, of MuJoCo body ``bid``
        (20 floats, quaternions x, y, z, w), after the lazy refresh (under the Sim's lock)."""
        c = self._w
        kernel = c.kernel
        if kernel is not None:
            finite = kernel.body_state(bid, c.stale, c.state_out)
            if finite is None:
                self._engine_failed(kernel.last_error())
            c.stale = False
            if not finite:
                raise SimulationDivergedError(self.name, self.time, f"body {body} pose")
            return c.state_out.tolist()
        if self._diverged is not None:
            raise self._diverged
        self._py_mark()  # refused from a MuJoCo callback inside the Python loop's step
        self._fresh()
        d = c.d
        self._check_finite(d.xipos[bid], body)
        com_pos, com_orn, lin, ang = self._com_pose_velocity(bid)
        fp = d.xpos[bid]
        fq = d.xquat[bid]
        return [
            *com_pos,
            *com_orn,
            *lin,
            *ang,
            float(fp[0]),
            float(fp[1]),
            float(fp[2]),
            float(fq[1]),
            float(fq[2]),
            float(fq[3]),
            float(fq[0]),
        ]

    def link_state(self, body: int, link: int) -> LinkState:
        """See Backend.link_state.

        MuJoCo: read from the body's pose and velocity after the lazy forward kinematics, the body
        frame turned back into the URDF link frame where model.py turned it.
        """
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            robot = self._robots[body]
            v = self._state_of(int(robot.body_ids[link + 1]), body)
        finally:
            lock.release()
        ine = robot.spec.inertials[link + 1]
        frame = ((v[13], v[14], v[15]), (v[16], v[17], v[18], v[19]))
        if link == -1 and robot.spec.base_offset is not None:  # body frame = the COM frame
            frame = transform_multiply(frame, robot.spec.base_offset)
        elif robot.spec.link_offsets and link in robot.spec.link_offsets:  # a turned body frame
            frame = transform_multiply(frame, robot.spec.link_offsets[link])
        return LinkState(
            (v[0], v[1], v[2]),
            (v[3], v[4], v[5], v[6]),
            ine.position,
            ine.orientation,
            frame[0],
            frame[1],
            (v[7], v[8], v[9]),
            (v[10], v[11], v[12]),
        )

    def _states_of(self, bids: np.ndarray, body: int) -> np.ndarray:
        """:meth:`_state_of` of each MuJoCo body of ``bids`` (``np.intp``), row by row: ``(n,
        20)`` float64, in one kernel call where the compiled loop has one (under the Sim's
        lock)."""
        c = self._w
        out = np.empty((len(bids), 20))
        kernel = c.kernel
        batch = getattr(kernel, "bodies_state", None)  # a loop built before it: body by body
        if batch is not None:
            finite = batch(bids, c.stale, out)
            if finite is None:
                self._engine_failed(kernel.last_error())
            c.stale = False
            if not finite:
                raise SimulationDivergedError(self.name, self.time, f"body {body} pose")
            return out
        for k, bid in enumerate(bids.tolist()):
            out[k] = self._state_of(bid, body)
        return out

    def link_states(self, body: int, links: np.ndarray) -> LinkStates:
        """See Backend.link_states.

        MuJoCo: every body's pose and velocity in one pass after the lazy forward kinematics
        (one call of the compiled loop), the body frames turned back into URDF link frames
        where model.py turned them, as :meth:`link_state`.
        """
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            robot = self._robots[body]
            rows = links + 1
            v = self._states_of(robot.body_ids.take(rows), body)
        finally:
            lock.release()
        block = np.empty((len(links), LINK_STATE_WIDTH))
        block[:, 0:7] = v[:, 0:7]  # centre of mass: position, orientation
        block[:, 7:14] = _local_inertials(robot).take(rows, axis=0)
        block[:, 14:21] = v[:, 13:20]  # link frame
        block[:, 21:27] = v[:, 7:13]  # velocities
        spec = robot.spec
        if spec.base_offset is not None or spec.link_offsets:
            for k, link in enumerate(links.tolist()):
                if link == -1:
                    turn = spec.base_offset
                else:
                    turn = spec.link_offsets.get(link) if spec.link_offsets else None
                if turn is not None:  # as link_state: the same floats, the same operations
                    f = v[k, 13:20].tolist()
                    frame = transform_multiply(((f[0], f[1], f[2]), (f[3], f[4], f[5], f[6])), turn)
                    block[k, 14:21] = (*frame[0], *frame[1])
        return LinkStates.of(block)

    def base_state(self, body: int) -> BaseState:
        """See Backend.base_state.

        MuJoCo: the free base's body frame is its centre-of-mass frame.
        """
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            return self._base_state(body)
        finally:
            lock.release()

    def _base_state(self, body: int) -> BaseState:
        """base_state under the Sim's lock."""
        v = self._state_of(int(self._robots[body].body_ids[0]), body)
        return BaseState(
            (v[0], v[1], v[2]), (v[3], v[4], v[5], v[6]), (v[7], v[8], v[9]), (v[10], v[11], v[12])
        )

    def _check_finite(self, values: np.ndarray, body: int) -> None:
        if not np.isfinite(values).all():
            raise SimulationDivergedError(self.name, self.time, f"body {body} pose")

    def _joint_cache(self, robot: Robot, joints: np.ndarray) -> tuple[Any, ...]:
        key = id(joints)
        hit = robot.cache.get(key)
        if hit is not None and hit[0] is joints:
            return hit
        movable = robot.qadr[joints] >= 0
        qadr = robot.qadr[joints][movable]
        dof = robot.dofadr[joints][movable]
        pos_of = np.full(len(robot.table), -1, np.intp)
        pos_of[robot.movable] = robot.motor_index
        motor = pos_of[joints][movable]
        entry = (joints, movable, qadr, dof, motor, bool(movable.all()))
        robot.cache[key] = entry
        return entry

    def _torque_rows(self, joints: np.ndarray, movable: np.ndarray, motor: np.ndarray) -> tuple:
        """Motor rows of ``joints`` under the current motor set (cached per motor epoch):
        (rows, positions in the answer, every joint has a row)."""
        t = self._w.motors
        hit = self._w.torque_map.get(id(joints))
        if hit is not None and hit[0] is joints and hit[1] == t.epoch:
            return hit[2:]
        rows = t.row_of[motor]
        on = rows >= 0
        rows = rows[on]
        entry = (joints, t.epoch, rows, np.flatnonzero(movable)[on], len(rows) == len(joints))
        self._w.torque_map[id(joints)] = entry
        return entry[2:]

    def joint_states(self, body: int, joints: np.ndarray) -> JointStates:
        """See Backend.joint_states.

        MuJoCo: the torque is the motor row's ``efc_force`` of the last step (0 after a teleport or
        a restore, until the next step). Refused (``SimBusyError``) from a MuJoCo callback inside
        this thread's own step.
        """
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            if self._in_step:  # a MuJoCo callback inside this thread's own step
                raise SimBusyError(_PY_BUSY)
            c = self._w
            if c.kernel is None and self._diverged is not None:
                raise self._diverged
            robot = self._robots[body]
            _, movable, qadr, dof, motor, all_movable = self._joint_cache(robot, joints)
            d = c.d
            n = len(joints)
            if c.motor_force_valid and c.motor_rows_valid:
                rows, where, full = self._torque_rows(joints, movable, motor)
                torque = d.efc_force[rows] if full else np.zeros(n)
                if not full:
                    torque[where] = d.efc_force[rows]
            else:
                torque = np.zeros(n)
            if all_movable:
                pos, vel = d.qpos[qadr], d.qvel[dof]
            else:
                pos = np.zeros(n)
                vel = np.zeros(n)
                pos[movable] = d.qpos[qadr]
                vel[movable] = d.qvel[dof]
            return JointStates(pos, vel, torque)
        finally:
            lock.release()

    def reset_joint_state(
        self, body: int, joints: np.ndarray, positions: list[float], velocities: list[float]
    ) -> None:
        """See Backend.reset_joint_state.

        MuJoCo: writes ``qpos``/``qvel``; the poses follow lazily.
        """
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            self._check_idle()
            robot = self._robots[body]
            _, _, qadr, dof, _, _ = self._joint_cache(robot, joints)
            c = self._w
            c.d.qpos[qadr] = positions
            c.d.qvel[dof] = velocities
            c.stale = True
            c.motor_force_valid = False
        finally:
            lock.release()

    @exclusive
    def joint_states_multi_dof(self, body: int, joints: np.ndarray) -> list[JointStateMultiDof]:
        """See Backend.joint_states_multi_dof.

        MuJoCo: a ball joint's ``qpos`` (w, x, y, z) is turned into (x, y, z, w); its torques are
        its three motor rows' forces.
        """
        c = self._w
        kernel = c.kernel
        if kernel is not None:
            kernel.check_idle()  # as joint_states
        elif self._diverged is not None:
            raise self._diverged
        else:
            self._py_mark()
        robot = self._robots[body]
        d = c.d
        rows = c.motors.row_of
        forces = c.motor_force_valid and c.motor_rows_valid
        slot_of = dict(zip(robot.movable, robot.motor_index.tolist(), strict=True))
        out = []
        for j in joints.tolist():
            jtype = robot.table[j].type
            if jtype == JointType.FIXED:
                out.append(JointStateMultiDof((), (), ()))
                continue
            a, v, s = int(robot.qadr[j]), int(robot.dofadr[j]), slot_of[j]
            n = 3 if jtype == JointType.SPHERICAL else 1
            torque = tuple(
                float(d.efc_force[rows[s + i]]) if forces and rows[s + i] >= 0 else 0.0
                for i in range(n)
            )
            if n == 3:  # MuJoCo's ball: w, x, y, z; a is x's address
                q = d.qpos[a - 1 : a + 3].tolist()
                position: tuple[float, ...] = (q[1], q[2], q[3], q[0])
            else:
                position = (float(d.qpos[a]),)
            velocity = tuple(d.qvel[v : v + n].tolist())
            out.append(JointStateMultiDof(position, velocity, torque))
        return out

    @exclusive
    def reset_joint_state_multi_dof(
        self,
        body: int,
        joints: np.ndarray,
        positions: list[list[float]],
        velocities: list[list[float]],
    ) -> None:
        """See Backend.reset_joint_state_multi_dof.

        MuJoCo: a ball's (x, y, z, w) written as (w, x, y, z).
        """
        self._check_idle()
        robot = self._robots[body]
        c = self._w
        for j, q, v in zip(joints.tolist(), positions, velocities, strict=True):
            a, dof = int(robot.qadr[j]), int(robot.dofadr[j])
            if len(q) == 4:  # (x, y, z, w) into MuJoCo's (w, x, y, z); a is x's address
                c.d.qpos[a - 1 : a + 3] = (q[3], q[0], q[1], q[2])
            else:
                c.d.qpos[a] = q[0]
            c.d.qvel[dof : dof + len(v)] = v
        c.stale = True
        c.motor_force_valid = False

    def reset_base_state(
        self,
        body: int,
        position: Vec3 | None,
        orientation: Quat | None,
        linear_velocity: Vec3 | None,
        angular_velocity: Vec3 | None,
    ) -> None:
        """See Backend.reset_base_state.

        MuJoCo: a free base writes its free joint's ``qpos``/``qvel``; a fixed base moves the base
        body in the model.
        """
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            self._reset_base_state(body, position, orientation, linear_velocity, angular_velocity)
        finally:
            lock.release()

    def _reset_base_state(
        self,
        body: int,
        position: Vec3 | None,
        orientation: Quat | None,
        linear_velocity: Vec3 | None,
        angular_velocity: Vec3 | None,
    ) -> None:
        """reset_base_state under the Sim's lock."""
        robot = self._robots[body]
        if robot.free_qadr < 0:
            self.refuse_fixed_base_velocity(body, linear_velocity, angular_velocity)
        cur = self._base_state(body)
        pos = cur.position if position is None else position
        orn = cur.orientation if orientation is None else orientation
        lin = cur.linear_velocity if linear_velocity is None else linear_velocity
        ang = cur.angular_velocity if angular_velocity is None else angular_velocity
        ine = robot.spec.inertials[0]
        # link frame = COM frame * inverse(inertial frame)
        fpos, forn = transform_multiply(
            (pos, orn), transform_inverse((ine.position, ine.orientation))
        )
        d, m = self._w.d, self._w.m
        if robot.free_qadr >= 0:
            # the free base's body frame: its centre-of-mass frame, or the link frame when the
            # two coincide (base_offset None)
            bpos, born = (pos, orn) if robot.spec.base_offset is not None else (fpos, forn)
            a = robot.free_qadr
            d.qpos[a : a + 3] = bpos
            d.qpos[a + 3 : a + 7] = xyzw_to_wxyz(born)
            # MuJoCo: linear velocity of the frame origin (world), angular in the body frame:
            # lin + ang x (bpos - pos), in floats (np.cross's own arithmetic, 20 us faster)
            r0, r1, r2 = bpos[0] - pos[0], bpos[1] - pos[1], bpos[2] - pos[2]
            v = robot.free_dofadr
            d.qvel[v : v + 6] = (
                lin[0] + (ang[1] * r2 - ang[2] * r1),
                lin[1] + (ang[2] * r0 - ang[0] * r2),
                lin[2] + (ang[0] * r1 - ang[1] * r0),
                *quat_rotate(quat_conjugate(born), ang),
            )
        else:
            bid = int(robot.body_ids[0])
            m.body_pos[bid] = fpos
            m.body_quat[bid] = xyzw_to_wxyz(forn)
            robot.spec.root.pos = list(fpos)
            robot.spec.root.quat = list(xyzw_to_wxyz(forn))
        self._w.stale = True
