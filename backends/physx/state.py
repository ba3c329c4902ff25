"""The world as the Sim reads and sets it (a part of :class:`PhysxBackend`): joint table, link
and base states, joint states, teleports. Frames and units are PyBullet's: a link's entity pose
is its URDF link frame, its centre-of-mass frame that pose times the link's ``cmass_local_pose``
(the inertial frame the model gave it); PhysX's velocities are those of the centre of mass.
PhysX keeps them in float32."""

from __future__ import annotations

import math
import threading
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from simbridge.exceptions import SimulationDivergedError
from simbridge.profiles import Profile
from simbridge.transforms import transform_inverse, transform_multiply
from simbridge.types import (
    BaseState,
    DynamicsInfo,
    JointInfo,
    JointStates,
    LinkState,
    Quat,
    Vec3,
)

from ..locking import exclusive
from .model import _link_frame_in_base, pose
from .world import Robot

__all__ = ["StateAccess"]


def _vec(v: Any) -> Vec3:
    return (float(v[0]), float(v[1]), float(v[2]))


def _frame(p: Any) -> tuple[Vec3, Quat]:
    """A SAPIEN pose as (position, (x, y, z, w))."""
    q = p.q
    return _vec(p.p), (float(q[1]), float(q[2]), float(q[3]), float(q[0]))


class StateAccess:
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

        def _check_limits(self, robot: Robot) -> None: ...

        def _ball_state(self, robot: Robot, joint: int, q: Any, v: Any) -> tuple[Any, Any]: ...

        def refuse_fixed_base_velocity(
            self, body: int, linear: Vec3 | None, angular: Vec3 | None
        ) -> None: ...

    # ---------------------------------------------------------------- tables

    def joint_info(self, body: int, joint: int) -> JointInfo:
        return self._robots[body].table[joint]

    def num_joints(self, body: int) -> int:
        return len(self._robots[body].table)

    def dynamics_info(self, body: int, link: int) -> DynamicsInfo:
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

    @exclusive
    def link_state(self, body: int, link: int) -> LinkState:
        robot = self._robots[body]
        ine = robot.built.inertials[link + 1]
        local = (ine.position, ine.orientation)
        if robot.static:
            base = _frame(robot.built.entities[0].pose)
            assert robot.built.plan is not None
            frame = transform_multiply(base, _link_frame_in_base(robot.built.plan, link))
            com = transform_multiply(frame, local)
            zero = (0.0, 0.0, 0.0)
            return LinkState(com[0], com[1], *local, frame[0], frame[1], zero, zero)
        comp = robot.built.links[link + 1]
        p = comp.entity_pose
        x, y, z = p.p.tolist()
        qw, qx, qy, qz = p.q.tolist()
        if robot.restored_velocities is None:
            lin = tuple(comp.linear_velocity.tolist())
            ang = tuple(comp.angular_velocity.tolist())
        else:  # set back by a restore (the backend's), until the next step or write
            lin, ang = (tuple(v) for v in robot.restored_velocities[link + 1].tolist())
        if self._diverged is not None or not math.isfinite(
            x + y + z + qw + qx + qy + qz + sum(lin) + sum(ang)  # a NaN or inf anywhere
        ):
            self._readable(np.array([x, y, z, qw, qx, qy, qz, *lin, *ang]), body)
        frame = ((x, y, z), (qx, qy, qz, qw))
        com = transform_multiply(frame, local)
        return LinkState(com[0], com[1], *local, frame[0], frame[1], lin, ang)

    @exclusive
    def base_state(self, body: int) -> BaseState:
        s = self.link_state(body, -1)
        return BaseState(s[0], s[1], s[6], s[7])

    @exclusive
    def joint_states(self, body: int, joints: np.ndarray) -> JointStates:
        if self._diverged is not None:  # every read refused until reset, jointless bodies too
            raise self._diverged
        robot = self._robots[body]
        n = len(joints)
        if robot.static or robot.ndof == 0:
            return JointStates(np.zeros(n), np.zeros(n), np.zeros(n))
        moving, dofs, links, cols = self._reads_of(robot, joints)
        art = robot.built.articulation
        q = art.qpos
        v = art.qvel
        if self._diverged is not None or not math.isfinite(float(q.sum() + v.sum())):
            self._readable(np.concatenate([q, v]), body)
        # the motor force of the last step: PhysX reports no drive force, so the joint's
        # incoming force along its axis (in the child's joint frame, whose x axis is the
        # joint's; force first, then torque)
        forces = art.get_link_incoming_joint_forces()
        if moving is None and not robot.balls:  # every joint asked moves, none spherical
            return JointStates(
                q[dofs].astype(float), v[dofs].astype(float), forces[links, cols].astype(float)
            )
        if moving is None:
            moving = np.ones(n, dtype=bool)
        pos = np.zeros(n)
        vel = np.zeros(n)
        tau = np.zeros(n)
        pos[moving] = q[dofs]
        vel[moving] = v[dofs]
        tau[moving] = forces[links, cols]
        for k, j in enumerate(joints.tolist()):
            if j in robot.balls:  # the first coordinate, as p.getJointState
                quat, w = self._ball_state(robot, j, q, v)
                pos[k], vel[k], tau[k] = quat[0], w[0], 0.0
        return JointStates(pos, vel, tau)

    def _reads_of(
        self, robot: Robot, joints: np.ndarray
    ) -> tuple[np.ndarray | None, np.ndarray, np.ndarray, np.ndarray]:
        """For ``joints``: which of them move (None: all), their dofs, PhysX link indices and
        force columns; cached per joints array (the Sim hands the same array object for the
        same joints argument)."""
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
        out = (None if moving.all() else moving, dof[moving], links, cols)
        robot.read_cache[key] = (joints, out)
        return out

    # ---------------------------------------------------------------- teleports

    @exclusive
    def reset_joint_state(
        self, body: int, joints: np.ndarray, positions: list[float], velocities: list[float]
    ) -> None:
        self._check_idle()
        robot = self._robots[body]
        art = robot.built.articulation
        q = art.qpos
        v = art.qvel
        for j, x, u in zip(joints, positions, velocities, strict=True):
            d = robot.dof[j]
            q[d] = x
            v[d] = u
        art.qpos = q
        art.qvel = v
        robot.restored_velocities = None  # PhysX's, from the joint velocities written
        self._contacts_cache = None
        self._check_limits(robot)

    @exclusive
    def reset_base_state(
        self,
        body: int,
        position: Vec3 | None,
        orientation: Quat | None,
        linear_velocity: Vec3 | None,
        angular_velocity: Vec3 | None,
    ) -> None:
        self._check_idle()
        robot = self._robots[body]
        if robot.fixed:
            self.refuse_fixed_base_velocity(body, linear_velocity, angular_velocity)
        ine = robot.built.inertials[0]
        local = (ine.position, ine.orientation)
        if position is not None or orientation is not None:
            if robot.static:
                cur = _frame(robot.built.entities[0].pose)
            else:
                cur = _frame(robot.built.links[0].entity_pose)
            com = transform_multiply(cur, local)
            new_com = (
                position if position is not None else com[0],
                orientation if orientation is not None else com[1],
            )
            frame = transform_multiply(new_com, transform_inverse(local))
            if robot.static:
                robot.built.entities[0].pose = pose(*frame)
            else:
                robot.built.articulation.root_pose = pose(*frame)
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

    def set_time(self, time: float) -> None:
        self._steps = round(time / self._dt)
