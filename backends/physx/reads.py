"""The world as the Sim reads and sets it (a part of :class:`PhysxBackend`): joint table, link
and base states, joint states, teleports. Frames and units are PyBullet's: a link's entity pose
is its URDF link frame, its centre-of-mass frame that pose times the link's ``cmass_local_pose``
(the inertial frame the model gave it); PhysX's velocities are those of the centre of mass.
PhysX keeps them in float32."""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, ClassVar, TypeVar

import numpy as np
import sapien

from simbridge.exceptions import SimulationDivergedError
from simbridge.profiles import Profile
from simbridge.transforms import transform_inverse, transform_multiply
from simbridge.types import (
    LINK_STATE_WIDTH,
    BaseState,
    DynamicsInfo,
    JointInfo,
    JointStates,
    LinkState,
    LinkStates,
    Quat,
    Vec3,
)

from ..locking import exclusive, wait_for_lock
from .model import _link_frame_in_base
from .robots import Robot

__all__ = ["StateReads"]


def _vec(v: Any) -> Vec3:
    return (float(v[0]), float(v[1]), float(v[2]))


def _frame(p: Any) -> tuple[Vec3, Quat]:
    """A SAPIEN pose as (position, (x, y, z, w))."""
    q = p.q
    return _vec(p.p), (float(q[1]), float(q[2]), float(q[3]), float(q[0]))


# a SAPIEN pose's (x, y, z, qw, qx, qy, qz) as Python floats, the float32 values as float64: the
# values of ``p.p.tolist()`` and ``p.q.tolist()`` in one call, without the two numpy arrays
# (1.0 µs with the entity_pose read, against 2.3)
_pose_floats = sapien.Pose.__getstate__
_T = TypeVar("_T", bound=tuple[Any, ...])
# a NamedTuple from a tuple, without the Python __new__ it is given
_new_tuple: Callable[[type[_T], tuple[Any, ...]], _T] = tuple.__new__


def _com_frame(
    x: float, y: float, z: float, qx: float, qy: float, qz: float, qw: float, local: Any
) -> tuple[Vec3, Quat]:
    """``transform_multiply(((x, y, z), (qx, qy, qz, qw)), local)`` with the very operations
    of simbridge.transforms (quat_rotate, then quat_multiply) in one call: the same bits (a
    link's centre-of-mass frame from its link frame, or the base's link frame from its new
    centre-of-mass frame)."""
    vx, vy, vz = local[0]
    bx, by, bz, bw = local[1]
    tx = 2.0 * (qy * vz - qz * vy)
    ty = 2.0 * (qz * vx - qx * vz)
    tz = 2.0 * (qx * vy - qy * vx)
    return (
        x + (vx + qw * tx + qy * tz - qz * ty),
        y + (vy + qw * ty + qz * tx - qx * tz),
        z + (vz + qw * tz + qx * ty - qy * tx),
    ), (
        qw * bx + qx * bw + qy * bz - qz * by,
        qw * by - qx * bz + qy * bw + qz * bx,
        qw * bz + qx * by - qy * bx + qz * bw,
        qw * bw - qx * bx - qy * by - qz * bz,
    )


class StateReads:
    """The ``Backend`` methods that read or set state."""

    if TYPE_CHECKING:
        name: ClassVar[str]
        profile: Profile
        _robots: dict[int, Robot]
        _diverged: SimulationDivergedError | None
        _stepping: threading.RLock
        _in_step: bool
        _steps: int
        _dt: float
        _contacts_cache: list[Any] | None

        @property
        def time(self) -> float: ...

        def _check_idle(self) -> None: ...

        def _refresh_active(self) -> None: ...

        def _ball_state(self, robot: Robot, joint: int, q: Any, v: Any) -> tuple[Any, Any]: ...

        def refuse_fixed_base_velocity(
            self, body: int, linear: Vec3 | None, angular: Vec3 | None
        ) -> None: ...

    # ---------------------------------------------------------------- tables

    def joint_info(self, body: int, joint: int) -> JointInfo:
        """See Backend.joint_info. PhysX: the row of the model's joint table, kept at load."""
        return self._robots[body].table[joint]

    def num_joints(self, body: int) -> int:
        """See Backend.num_joints. PhysX: the length of the model's joint table, kept at load."""
        return len(self._robots[body].table)

    def dynamics_info(self, body: int, link: int) -> DynamicsInfo:
        """See Backend.dynamics_info.

        PhysX: the build plan's values, which the links were built from.
        """
        plan = self._robots[body].built.plan
        assert plan is not None
        return plan.dynamics_info(link)

    # ---------------------------------------------------------------- reads

    def _readable(self, values: Any, body: int) -> None:
        if self._diverged is not None:
            raise self._diverged
        if not np.isfinite(values).all():
            self._diverged = SimulationDivergedError(self.name, self.time, f"body {body} state")
            raise self._diverged

    # The hot reads take the lock inline (as step does: the decorator's frame costs about as
    # much as the lock) and read each link through one pose call and its two velocity arrays.

    def link_state(self, body: int, link: int) -> LinkState:
        """See Backend.link_state. PhysX: float32 poses and velocities, returned as floats."""
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            robot = self._robots[body]
            ine = robot.built.inertials[link + 1]
            local = (ine.position, ine.orientation)
            if robot.static:
                return self._static_link_state(robot, link, local)
            x, y, z, qw, qx, qy, qz, lin, ang = self._link_read(robot, body, link + 1)
            com = _com_frame(x, y, z, qx, qy, qz, qw, local)
            return _new_tuple(
                LinkState, (com[0], com[1], *local, (x, y, z), (qx, qy, qz, qw), lin, ang)
            )
        finally:
            lock.release()

    def link_states(self, body: int, links: np.ndarray) -> LinkStates:
        """See Backend.link_states. PhysX: every link of ``links`` read in one loop under one
        lock (its pose and two velocity arrays, as :meth:`_link_read`), the floats of
        :meth:`link_state` row by row, checked finite once for all (SAPIEN's CPU articulation
        has no batched link read)."""
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            robot = self._robots[body]
            inertials = robot.built.inertials
            flat: list[float] = []
            add = flat.extend
            if robot.static:
                for link in links.tolist():
                    ine = inertials[link + 1]
                    st = self._static_link_state(robot, link, (ine.position, ine.orientation))
                    add((*st[0], *st[1], *st[2], *st[3], *st[4], *st[5], *st[6], *st[7]))
                return LinkStates.of(np.array(flat).reshape(len(links), LINK_STATE_WIDTH))
            comps = robot.built.links
            restored = robot.restored_velocities
            for link in links.tolist():
                ine = inertials[link + 1]
                local = (ine.position, ine.orientation)
                comp = comps[link + 1]
                x, y, z, qw, qx, qy, qz = _pose_floats(comp.entity_pose)
                com = _com_frame(x, y, z, qx, qy, qz, qw, local)
                add(com[0])
                add(com[1])
                add(local[0])
                add(local[1])
                add((x, y, z, qx, qy, qz, qw))
                if restored is None:
                    add(comp.linear_velocity.tolist())
                    add(comp.angular_velocity.tolist())
                else:  # set back by a restore (the backend's), until the next step or write
                    add(restored[link + 1].ravel().tolist())
            block = np.array(flat).reshape(len(links), LINK_STATE_WIDTH)
            if self._diverged is not None or not np.isfinite(block).all():
                self._readable(block, body)
        finally:
            lock.release()
        return LinkStates.of(block)

    def _static_link_state(self, robot: Robot, link: int, local: tuple[Vec3, Quat]) -> LinkState:
        base = _frame(robot.built.entities[0].pose)
        assert robot.built.plan is not None
        frame = transform_multiply(base, _link_frame_in_base(robot.built.plan, link))
        com = transform_multiply(frame, local)
        zero = (0.0, 0.0, 0.0)
        return LinkState(com[0], com[1], *local, frame[0], frame[1], zero, zero)

    def _link_read(self, robot: Robot, body: int, row: int) -> tuple[Any, ...]:
        """Link ``row`` of ``built.links`` (0: the base) of a moving body: its frame's x, y, z,
        qw, qx, qy, qz and its (linear, angular) velocity tuples; SimulationDivergedError
        when the world diverged or any of it is not finite."""
        comp = robot.built.links[row]
        x, y, z, qw, qx, qy, qz = _pose_floats(comp.entity_pose)
        if robot.restored_velocities is None:
            lin = tuple(comp.linear_velocity.tolist())
            ang = tuple(comp.angular_velocity.tolist())
        else:  # set back by a restore (the backend's), until the next step or write
            lin, ang = (tuple(v) for v in robot.restored_velocities[row].tolist())
        if self._diverged is not None or not math.isfinite(
            x + y + z + qw + qx + qy + qz + sum(lin) + sum(ang)  # a NaN or inf anywhere
        ):
            self._readable(np.array([x, y, z, qw, qx, qy, qz, *lin, *ang]), body)
        return x, y, z, qw, qx, qy, qz, lin, ang

    def base_state(self, body: int) -> BaseState:
        """See Backend.base_state. PhysX: float32 poses and velocities, returned as floats."""
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            robot = self._robots[body]
            ine = robot.built.inertials[0]
            local = (ine.position, ine.orientation)
            if robot.static:
                s = self._static_link_state(robot, -1, local)
                return BaseState(s[0], s[1], s[6], s[7])
            x, y, z, qw, qx, qy, qz, lin, ang = self._link_read(robot, body, 0)
            com = _com_frame(x, y, z, qx, qy, qz, qw, local)
            return _new_tuple(BaseState, (com[0], com[1], lin, ang))
        finally:
            lock.release()

    def joint_states(self, body: int, joints: np.ndarray) -> JointStates:
        """See Backend.joint_states.

        PhysX: the torque is the joint's incoming force along its axis less the joint forces
        the last step was given (a torque command, URDF damping): PhysX reports no drive force;
        a static body's joints read zeros.
        """
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            if self._diverged is not None:  # every read refused until reset, jointless too
                raise self._diverged
            robot = self._robots[body]
            n = len(joints)
            if robot.static or robot.ndof == 0:
                return JointStates(np.zeros(n), np.zeros(n), np.zeros(n))
            moving, dofs, links, cols, flat = self._reads_of(robot, joints)
            art = robot.built.articulation
            q = art.qpos
            v = art.qvel
            # float32 values summed in float64: finite exactly when every value is (as
            # backend._check_world; numpy's two reductions cost 2.6 µs, these 0.6)
            if not math.isfinite(sum(q.tolist()) + sum(v.tolist())):
                self._readable(np.concatenate([q, v]), body)
            # the motor force of the last step: PhysX reports no drive force, so the joint's
            # incoming force along its axis (in the child's joint frame, whose x axis is the
            # joint's; force first, then torque), less the joint forces the step was given (a
            # torque command, <dynamics damping>): PyBullet's appliedJointMotorTorque is the
            # motor's alone and reads 0 under a torque command
            forces = art.get_link_incoming_joint_forces()
            qf = robot.step_qf
            if moving is None and not robot.balls:  # every joint asked moves, none spherical
                tau = forces.take(flat).astype(float)
                if qf is not None:
                    tau -= qf[dofs]
                return _new_tuple(JointStates, (q[dofs].astype(float), v[dofs].astype(float), tau))
            if moving is None:
                moving = np.ones(n, dtype=bool)
            pos = np.zeros(n)
            vel = np.zeros(n)
            tau = np.zeros(n)
            pos[moving] = q[dofs]
            vel[moving] = v[dofs]
            tau[moving] = forces[links, cols]
            if qf is not None:
                tau[moving] -= qf[dofs]
            for k, j in enumerate(joints.tolist()):
                if j in robot.balls:  # the first coordinate, as p.getJointState
                    quat, w = self._ball_state(robot, j, q, v)
                    pos[k], vel[k], tau[k] = quat[0], w[0], 0.0
            return JointStates(pos, vel, tau)
        finally:
            lock.release()

    def _reads_of(
        self, robot: Robot, joints: np.ndarray
    ) -> tuple[np.ndarray | None, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """For ``joints``: which of them move (None: all), their dofs, PhysX link indices,
        force columns and those two as indices into the flattened forces array; cached per
        joints array (the Sim hands the same array object for the same joints argument)."""
        key = id(joints)
        hit = robot.read_cache.get(key)
        if hit is not None and hit[0] is joints:
            return hit[1]
        dof = robot.dof[joints]
        moving = dof >= 0
        joint_types = [robot.model.joints[int(j)].type for j in joints[moving]]
        links = np.array(
            [robot.built.links[int(j) + 1].index for j in joints[moving]], dtype=np.intp
        )
        cols = np.array([0 if t == "prismatic" else 3 for t in joint_types], dtype=np.intp)
        flat = links * 6 + cols  # get_link_incoming_joint_forces: (links, 6) per call
        out = (None if moving.all() else moving, dof[moving], links, cols, flat)
        robot.read_cache[key] = (joints, out)
        return out

    # ---------------------------------------------------------------- teleports

    @exclusive
    def reset_joint_state(
        self, body: int, joints: np.ndarray, positions: list[float], velocities: list[float]
    ) -> None:
        """See Backend.reset_joint_state.

        PhysX: a joint set past its limit gets PyBullet's limit row from the next step on.
        """
        self._check_idle()
        robot = self._robots[body]
        art = robot.built.articulation
        q = art.qpos
        v = art.qvel
        limits = robot.limit_of
        past = False
        for j, x, u in zip(joints, positions, velocities, strict=True):
            d = robot.dof[j]
            q[d] = x
            v[d] = u
            lo, hi = limits[j]
            if x < lo or x > hi:  # past its limit (x just past a float32 limit: let go at
                past = True  # the next step, as nothing is then past)
        art.qpos = q
        art.qvel = v
        robot.restored_velocities = None  # PhysX's, from the joint velocities written
        self._contacts_cache = None
        if past and not robot.past_limit:  # PyBullet's limit row from the next step on
            robot.past_limit = True
            self._refresh_active()

    def reset_base_state(
        self,
        body: int,
        position: Vec3 | None,
        orientation: Quat | None,
        linear_velocity: Vec3 | None,
        angular_velocity: Vec3 | None,
    ) -> None:
        """See Backend.reset_base_state. PhysX: the other links follow the root at once."""
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            self._check_idle()
            robot = self._robots[body]
            if robot.fixed and (linear_velocity is not None or angular_velocity is not None):
                self.refuse_fixed_base_velocity(body, linear_velocity, angular_velocity)
            if position is not None or orientation is not None:
                self._move_base(robot, position, orientation)
            if not robot.static:
                art = robot.built.articulation
                if linear_velocity is not None:
                    art.root_linear_velocity = np.asarray(linear_velocity, dtype=np.float32)
                if angular_velocity is not None:
                    art.root_angular_velocity = np.asarray(angular_velocity, dtype=np.float32)
                # the other links follow the root in PhysX only after a step or a write of the
                # joint state: one write now, so that reads see the teleport whole
                art.qpos = art.qpos
                art.qvel = art.qvel
            robot.restored_velocities = None  # PhysX's, from the state written
            self._contacts_cache = None
        finally:
            lock.release()

    def _move_base(self, robot: Robot, position: Vec3 | None, orientation: Quat | None) -> None:
        """The base's centre of mass to ``position`` and ``orientation`` (None: as it is), in
        float64 as PyBullet, then the root's link frame to SAPIEN (float32)."""
        ine = robot.built.inertials[0]
        local = (ine.position, ine.orientation)
        if position is None or orientation is None:  # the current one needed
            if robot.static:
                cur = _frame(robot.built.entities[0].pose)
            else:
                x, y, z, qw, qx, qy, qz = _pose_floats(robot.built.links[0].entity_pose)
                cur = ((x, y, z), (qx, qy, qz, qw))
            com = transform_multiply(cur, local)
            new_com = (
                position if position is not None else com[0],
                orientation if orientation is not None else com[1],
            )
        else:
            new_com = (position, orientation)
        if robot.base_inverse is None:  # fixed at load
            robot.base_inverse = transform_inverse(local)
        (x, y, z), (qx, qy, qz, qw) = new_com
        (x, y, z), (qx, qy, qz, qw) = _com_frame(x, y, z, qx, qy, qz, qw, robot.base_inverse)
        # a Pose from floats rounds them to float32 as np.asarray(..., np.float32) does (the
        # same bits over 20,000 random poses), without the two arrays
        frame = sapien.Pose((x, y, z), (qw, qx, qy, qz))
        if robot.static:
            robot.built.entities[0].pose = frame
        else:
            robot.built.articulation.root_pose = frame

    def set_time(self, time: float) -> None:
        """See Backend.set_time.

        PhysX: the step count set to the whole number nearest ``time / dt``.
        """
        self._steps = round(time / self._dt)
