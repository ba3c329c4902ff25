"""PyBullet's joint motors as PhysX joint drives (a part of :class:`PhysxBackend`).

PyBullet's VELOCITY_CONTROL (and its default brake) is a constraint row asking for the joint
velocity ``v*`` within one step, its impulse clamped to ``max_force dt``. A PhysX drive with
stiffness 0 and damping D pushes with ``D (v* - v)`` clamped to its force limit, implicitly: with
D large (:data:`DRIVE_DAMPING`) it is a velocity constraint that reaches ``v*`` within a step
when ``max_force`` allows, the same meaning. POSITION_CONTROL's law

    v_new = v_free + kd (v* - v_free) + kp (q* - q) / dt,      |impulse| <= max_force dt

is that velocity drive with the target ``kp (q* - q) / dt + (1 - kd) v``, set before every step
from the state at its start. TORQUE_CONTROL is the articulation's joint force (``qf``) for one
step, cleared after it; the drive stays (PyBullet's brake cancels small torques until released
with ``max_force=0``).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from simbridge.profiles import Profile
from simbridge.types import JointCommands, JointType, MotorMode

from ..locking import exclusive, wait_for_lock
from .robots import Robot

__all__ = ["MotorCommands", "DRIVE_DAMPING"]

# the damping (N·m·s/rad) of a drive standing for PyBullet's velocity row: large enough that the
# drive reaches its target within a step wherever its force limit allows. Measured: the default
# brake (240 N·m) against 0.95 of its force lets the joint creep at force / D (2.3e-5 rad/s at
# 1e7, 4.7e-10 at 1e9, 0 at 1e11); kuka position and velocity motors stay within 5e-4 rad of
# PyBullet's over 240 steps
DRIVE_DAMPING = 1e11
SPEED_UNCAPPED = 1e6  # rad/s, m/s: a joint speed PhysX never reaches
_POSITION = int(MotorMode.POSITION)  # as a plain int: an Enum member costs a lookup per use


def _set_drives(
    robot: Robot, slots: np.ndarray, max_force: list[float], target: list[float] | None = None
) -> None:
    """The drives of motor ``slots`` as ``_apply`` sets them: the force limit, the least of
    ``max_force`` and the joint's effort, set only where it changes (0: the drive off); a
    spherical joint's velocity target 0. With ``target`` (a velocity command), also the other
    joints' velocity targets, and the targets and force limits written to the motor table (a
    joint named twice: the last one holds, as in a numpy write). One loop of plain Python
    values: the commands' hot path (after a PhysX step a numpy fancy-index write costs more
    than the scalar writes of r2d2's four wheels)."""
    m = robot.motors
    calls = robot.slot_calls(slots, m["effort"], m["ball"])
    velocity = target is not None
    table_target, table_force = m["target"], m["max_force"]
    # a position motor's targets are set before each step: the slots stand in, unread
    targets = target if target is not None else calls[0]
    drive = robot.drive_force
    for s, joint, effort, ball, t, mf in zip(*calls, targets, max_force, strict=True):
        if velocity:
            table_target[s] = t
            table_force[s] = mf
        f = mf if mf < effort else effort
        if f <= 0.0:
            if drive[s] != 0.0:
                joint.set_drive_properties(0.0, 0.0, 0.0, "force")
                drive[s] = 0.0
            continue
        if drive[s] != f:
            joint.set_drive_properties(0.0, DRIVE_DAMPING, f, "force")
            drive[s] = f
        if ball:
            joint.set_drive_velocity_target(np.zeros(3, dtype=np.float32))
        elif velocity:
            joint.set_drive_velocity_target(t)


_INF_EFFORT = frozenset([float("inf")])  # the effort limits where torques need no clamp
_PLANS = 4  # the commands' shortcuts kept per robot and mode (joint groups commanded in turn)


def _drop_plans(robot: Robot, slots: list[int]) -> None:
    """Forget every shortcut that shares a motor slot with a command on ``slots`` (it changes
    their modes, gains, forces or drives)."""
    if robot.velocity_plans:
        plans = robot.velocity_plans
        for key in [k for k, v in plans.items() if not set(v[2]).isdisjoint(slots)]:
            del plans[key]
    if robot.position_plans:
        held = robot.position_plans
        for key in [k for k, p in held.items() if not set(p[4]).isdisjoint(slots)]:
            del held[key]


class MotorCommands:
    """The ``Backend`` motor methods (a part of :class:`PhysxBackend`)."""

    if TYPE_CHECKING:
        name: ClassVar[str]
        profile: Profile
        _robots: dict[int, Robot]
        _active: list[Robot]
        _clamped: list[Any]
        _generation: int
        _dt: float
        _stepping: threading.RLock

        def _check_idle(self) -> None: ...

        def _ball_forces(self, robot: Robot, joint: int) -> None: ...

        def _ball_before_step(
            self, robot: Robot, q: Any, v: Any, qf: np.ndarray | None
        ) -> bool: ...

        def _ball_after_step(self, robot: Robot) -> None: ...

        def _limit_rows(self, robot: Robot) -> None: ...

    # ---------------------------------------------------------------- set-up

    def _configure(self, robot: Robot) -> None:
        """A new robot's speed clamp, link damping and motors at load."""
        if robot.static:
            return
        p = self.profile
        cap = p.max_joint_velocity if p.max_joint_velocity is not None else SPEED_UNCAPPED
        for link in robot.built.links:  # PyBullet's damping is applied in _before_step
            link.linear_damping = 0.0
            link.angular_damping = 0.0
        if not robot.fixed and p.max_joint_velocity is not None:
            root = robot.built.links[0]
            root.max_linear_velocity = cap
            root.max_angular_velocity = cap
        for joint in robot.dof_joint.values():
            joint.max_velocity = cap
        lo = np.full(len(robot.movable), -np.inf)
        hi = np.full(len(robot.movable), np.inf)
        for s, j in enumerate(robot.movable):  # PyBullet's limited joints: lower <= upper
            info = robot.table[j]
            if info.type in (JointType.REVOLUTE, JointType.PRISMATIC) and (
                info.lower_limit <= info.upper_limit
            ):
                lo[s], hi[s] = info.lower_limit, info.upper_limit
        robot.target_lo, robot.target_hi = lo, hi
        if p.apply_joint_damping:
            damping = np.zeros(robot.ndof)
            for j in robot.movable:
                damping[robot.dof[j]] = robot.model.joints[j].damping
            robot.damping = damping if damping.any() else None
        for s in range(len(robot.movable)):
            if not robot.motors["ball"][s]:
                self._apply(robot, s)
        for j in robot.balls:
            self._ball_forces(robot, j)

    def _apply(self, robot: Robot, s: int) -> None:
        """Make slot ``s``'s motor PhysX's drive."""
        m = robot.motors
        joint = robot.joints[robot.movable[s]]
        force = min(float(m["max_force"][s]), float(m["effort"][s]))
        drive = robot.drive_force
        if force <= 0.0:
            if drive[s] != 0.0:
                joint.set_drive_properties(0.0, 0.0, 0.0, "force")
                drive[s] = 0.0
            return
        if drive[s] != force:  # PhysX's drive as it is set (NaN: not yet)
            joint.set_drive_properties(0.0, DRIVE_DAMPING, force, "force")
            drive[s] = force
        if m["ball"][s]:
            joint.set_drive_velocity_target(np.zeros(3, dtype=np.float32))
        elif m["mode"][s] == 0:  # MotorMode.VELOCITY
            joint.set_drive_velocity_target(float(m["target"][s]))

    def _refresh_active(self) -> None:
        """The robots that need work at every step (link damping, position motors, torques)."""
        damped = bool(self.profile.linear_damping or self.profile.angular_damping)
        for r in self._robots.values():
            r.has_position = bool((r.motors["mode"] == _POSITION).any())
        if getattr(self, "_clamped_for", None) != self._generation:  # robots loaded or removed
            self._clamped = (
                [r.built.articulation for r in self._robots.values() if not r.static and r.ndof > 0]
                if self.profile.max_joint_velocity is not None
                else []
            )
            self._clamped_for = self._generation
        self._active = [
            r
            for r in self._robots.values()
            if not r.static
            and (
                damped
                or r.pending
                or r.damping is not None
                or bool(r.balls)
                or r.has_position
                or r.past_limit
            )
        ]
        for r in self._active:
            if damped and r.damper is None:
                r.damper = self._damper(r)
            # the link damping alone: the step calls the damper, not _before_step
            r.damping_only = damped and not (
                r.pending or r.damping is not None or r.balls or r.has_position or r.past_limit
            )

    def _damper(self, robot: Robot) -> Callable[[], None]:
        """PyBullet's link damping on ``robot`` for the coming step, as one call made once per
        robot: f = -m k (1 + |v|) v, t = -I k (1 + |w|) w (principal axes), from the velocities
        at the start of the step; as accelerations the inertia drops out of both. Two reads and
        one write per link (SAPIEN's CPU articulation has no batched link velocities); the
        bound methods, the float32 factors -k_lin, -k_ang per row and the (2n, 3) buffer the
        velocities are read into (``add_force_torque`` takes views of its rows) are made here."""
        links = robot.moving_links
        getters = []
        for link in links:  # interleaved: v0, w0, v1, w1, ...
            getters += [link.get_linear_velocity, link.get_angular_velocity]
        p = self.profile
        k = np.tile(np.array([-p.linear_damping, -p.angular_damping], dtype=np.float32), len(links))
        buf = np.empty((2 * len(links), 3), dtype=np.float32)
        adds = [
            (link.add_force_torque, buf[2 * i], buf[2 * i + 1])  # views of buf's rows
            for i, link in enumerate(links)
        ]
        sqrt = np.sqrt

        def damp() -> None:
            nonlocal buf  # written in place: the views in ``adds`` stay on it
            restored = robot.restored_velocities
            if restored is None:
                buf[:] = [f() for f in getters]  # (2n, 3) float32
            else:  # the velocities the step before the snapshot left (the backend's restore)
                buf[:] = restored[robot.moving_rows].reshape(-1, 3)
            buf *= (k * (1.0 + sqrt((buf * buf).sum(axis=1))))[:, None]
            for add, a_lin, a_ang in adds:
                add(a_lin, a_ang, "acceleration")

        return damp

    def _before_step(self, robot: Robot) -> None:
        m = robot.motors
        art = robot.built.articulation
        if robot.damper is not None:
            robot.damper()
        if robot.has_position:
            position = np.flatnonzero((m["mode"] == _POSITION) & ~m["ball"])
            q = art.qpos
            v = art.qvel
            inv_dt = 1.0 / self._dt
            for s in position:
                if min(m["max_force"][s], m["effort"][s]) <= 0.0:
                    continue
                k = robot.dof[robot.movable[s]]
                # PyBullet moves to the target clamped into the joint's limits (the command
                # keeps the target as given: joint_commands reads it back unclamped)
                goal = min(max(m["target"][s], robot.target_lo[s]), robot.target_hi[s])
                target = m["kp"][s] * (goal - q[k]) * inv_dt + (1.0 - m["kd"][s]) * v[k]
                robot.joints[robot.movable[s]].set_drive_velocity_target(float(target))
        qf = None
        if robot.pending or robot.damping is not None:
            qf = np.zeros(robot.ndof)
            if robot.pending:
                for slot, j in enumerate(robot.movable):
                    if not m["ball"][slot]:
                        qf[robot.dof[j]] = m["torque"][slot]
            if robot.damping is not None:  # <dynamics damping>, explicit as PyBullet's server
                qf -= robot.damping * art.qvel
        if robot.balls:
            self._ball_before_step(robot, art.qpos, art.qvel, qf)
        if qf is not None:
            qf = qf.astype(np.float32)
            art.qf = qf
            robot.qf_set = True
        robot.step_qf = qf
        if robot.past_limit:  # after the motors and damping: they read the step's start
            self._limit_rows(robot)

    @staticmethod
    def _clamp_speeds(art: Any, v: np.ndarray, speeds: list[float], cap: float) -> None:
        """PyBullet's clamp of every joint speed after the step, where the step found one past
        ``cap`` in ``speeds`` (the joint velocities ``v`` as floats; the step reads them and
        compares their maximum, the common part, inline). PhysX's joint max velocity bounds
        the drives inside its solver, not what a joint force (a torque) adds: a wheel at 40
        rad/s kicked by a torque worth 150 rad/s read 189.7 after the step, unclamped."""
        # in plain floats (on a few joints a fraction of numpy's reduction and clip): without a
        # NaN the list's maximum is numpy's exactly; with one, numpy's is NaN and never clamps,
        # so numpy has the last word whenever the plain test would clamp
        if float(np.abs(v).max()) > cap:
            hi = float(np.float32(cap))  # np.clip's bound on float32 values: the cap in float32
            lo = -hi
            clipped = [lo if x < lo else hi if x > hi else x for x in speeds]
            art.qvel = np.array(clipped, dtype=np.float32)

    def _after_step(self, robot: Robot) -> None:
        if robot.qf_set:  # PhysX keeps joint forces until changed: they last this step only
            robot.built.articulation.qf = np.zeros(robot.ndof, dtype=np.float32)
            robot.qf_set = False
        if robot.pending:
            robot.motors["torque"][:] = 0.0
            if robot.balls:
                self._ball_after_step(robot)
            robot.pending = False
            self._refresh_active()

    # ---------------------------------------------------------------- commands

    def _slots(self, robot: Robot, joints: np.ndarray) -> np.ndarray:
        """The motor slots of ``joints`` (cached per joints array: the Sim hands the same
        array object for the same joints argument)."""
        key = id(joints)
        hit = robot.slot_cache.get(key)
        if hit is not None and hit[0] is joints:
            return hit[1]
        slots = np.array([robot.slot[int(j)] for j in joints], dtype=np.intp)
        robot.slot_cache[key] = (joints, slots)
        return slots

    def set_joint_velocity(
        self, body: int, joints: np.ndarray, target: list[float], max_force: list[float]
    ) -> None:
        # the lock inline (locking.exclusive's body): this is a control loop's hot path
        """See Backend.set_joint_velocity.

        PhysX: the joint's drive takes the target velocity, its force limit the max force; a
        repeated command on the same joints array only moves the targets.
        """
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            robot = self._robots[body]
            plan = robot.velocity_plans.get(id(joints))
            if plan is not None and plan[0] is joints and plan[1] == max_force:
                # these joints' plan, no motor of theirs changed since: the drives' force
                # limits and the table's forces stand, only the targets change
                table = robot.motors["target"]
                for s, joint, t in zip(plan[2], plan[3], target, strict=True):
                    table[s] = t
                    joint.set_drive_velocity_target(t)
                return
            self._velocity(robot, joints, target, max_force)
        finally:
            lock.release()

    def _velocity(
        self, robot: Robot, joints: np.ndarray, target: list[float], max_force: list[float]
    ) -> None:
        """A velocity command in full: the motor table's modes and gains, the drives, and the
        shortcut for the next command on the same joints with the same forces."""
        m = robot.motors
        slots = self._slots(robot, joints)
        if robot.velocity_slots is not slots:
            # POSITION is 2, VELOCITY 0: only a robot with a position motor can lose one here
            was_position = robot.has_position and bool(m["mode"][slots].any())
            m["mode"][slots] = 0
            m["kp"][slots] = 0.0
            m["kd"][slots] = 1.0
            robot.velocity_slots = slots
            _set_drives(robot, slots, max_force, target)
            if was_position:  # a position motor replaced: the step may have less to do
                self._refresh_active()
        else:  # these slots' last command, nothing else since
            _set_drives(robot, slots, max_force, target)
        slot_list, pjoints, _, ball = robot.slot_calls(slots, m["effort"], m["ball"])
        _drop_plans(robot, slot_list)
        drive = robot.drive_force
        if len(set(slot_list)) == len(slot_list) and all(
            not ball[i] and drive[s] > 0.0 for i, s in enumerate(slot_list)
        ):
            plans = robot.velocity_plans
            if len(plans) >= _PLANS:
                del plans[next(iter(plans))]  # the oldest
            plans[id(joints)] = (joints, list(max_force), slot_list, pjoints)

    @exclusive
    def set_joint_position(
        self,
        body: int,
        joints: np.ndarray,
        target: list[float],
        max_force: list[float],
        kp: list[float],
        kd: list[float],
    ) -> None:
        """See Backend.set_joint_position.

        PhysX: PyBullet's position law turned into a drive velocity target before each step.
        """
        robot = self._robots[body]
        plan = robot.position_plans.get(id(joints))
        if (
            plan is not None
            and plan[0] is joints
            and plan[1] == max_force
            and plan[2] == kp
            and plan[3] == kd
        ):
            # these joints' plan, no motor of theirs changed since: modes, gains, forces and
            # drives stand, only the targets change (read by the position law at each step)
            table = robot.motors["target"]
            for s, t in zip(plan[4], target, strict=True):
                table[s] = t
            return
        m = robot.motors
        slots = self._slots(robot, joints)
        robot.velocity_slots = None  # modes and gains change
        slot_list, _, _, ball = robot.slot_calls(slots, m["effort"], m["ball"])
        _drop_plans(robot, slot_list)
        if len(set(slot_list)) == len(slot_list) and not any(ball):
            plans = robot.position_plans
            if len(plans) >= _PLANS:
                del plans[next(iter(plans))]  # the oldest
            plans[id(joints)] = (joints, list(max_force), list(kp), list(kd), slot_list)
        if len(set(slots.tolist())) < len(slots):  # a joint named twice: the last one holds
            for s, t, f, p_, d_ in zip(slots, target, max_force, kp, kd, strict=True):
                m["mode"][s] = MotorMode.POSITION
                m["target"][s] = t
                m["max_force"][s] = f
                m["kp"][s] = p_
                m["kd"][s] = d_
                self._apply(robot, s)
            self._refresh_active()
            return
        m["mode"][slots] = _POSITION
        m["target"][slots] = target
        m["max_force"][slots] = max_force
        m["kp"][slots] = kp
        m["kd"][slots] = kd
        # the drives as _apply sets them for a position motor (its velocity target is set
        # before each step)
        _set_drives(robot, slots, max_force)
        if not robot.has_position:  # the robot's step gains the position law
            self._refresh_active()

    def set_joint_torque(self, body: int, joints: np.ndarray, torque: list[float]) -> None:
        # the lock inline (locking.exclusive's body): a control loop's hot path
        """See Backend.set_joint_torque. PhysX: a joint named twice adds its torque twice."""
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            robot = self._robots[body]
            m = robot.motors
            slots = self._slots(robot, joints)
            slot_list, _, efforts, _ = robot.slot_calls(slots, m["effort"], m["ball"])
            table = m["torque"]
            if _INF_EFFORT.issuperset(efforts):
                # no effort limit (the common case): the clamp below leaves every finite
                # torque as it is; added in order, as np.add.at (a joint named twice, twice)
                for s, t in zip(slot_list, torque, strict=True):
                    table[s] += t
            else:
                effort = m["effort"][slots]  # the profile enforces <limit effort>
                # each command clamped, as PyBullet; np.add.at: a joint named twice adds twice
                np.add.at(table, slots, np.minimum(np.maximum(torque, -effort), effort))
            if not robot.pending:
                robot.pending = True
                self._refresh_active()
        finally:
            lock.release()

    # ---------------------------------------------------------------- state of the motors

    @exclusive
    def joint_commands(self, body: int) -> JointCommands:
        """See Backend.joint_commands. PhysX: a spherical joint's row shows its first axis."""
        robot = self._robots[body]
        n = len(robot.table)
        mode = np.full(n, int(MotorMode.NONE), dtype=np.int8)
        target = np.zeros(n)
        max_force = np.zeros(n)
        kp = np.zeros(n)
        kd = np.zeros(n)
        torque = np.zeros(n)
        m = robot.motors
        for s, j in enumerate(robot.movable):
            if j in robot.balls:  # the first axis, as PyBullet's tables
                ball = robot.balls[j]
                mode[j] = ball["mode"]
                max_force[j] = ball["max_force"][0]
                kp[j] = ball["kp"][0]
                kd[j] = ball["kd"][0]
                torque[j] = ball["torque"][0]
                continue
            mode[j] = m["mode"][s]
            target[j] = m["target"][s]
            max_force[j] = m["max_force"][s]
            kp[j] = m["kp"][s]
            kd[j] = m["kd"][s]
            torque[j] = m["torque"][s]
        return JointCommands(mode, target, max_force, kp, kd, torque)

    @exclusive
    def set_joint_commands(self, body: int, commands: JointCommands) -> None:
        """See Backend.set_joint_commands.

        PhysX: spherical joints left to ``set_spherical_states``.
        """
        robot = self._robots[body]
        robot.velocity_slots = None  # modes and gains change
        robot.velocity_plans.clear()
        robot.position_plans.clear()
        m = robot.motors
        for s, j in enumerate(robot.movable):
            if robot.table[j].type == JointType.SPHERICAL:
                continue
            m["mode"][s] = int(commands.mode[j])
            m["target"][s] = float(commands.target[j])
            m["max_force"][s] = float(commands.max_force[j])
            m["kp"][s] = float(commands.kp[j])
            m["kd"][s] = float(commands.kd[j])
            m["torque"][s] = float(commands.pending_torque[j])
            self._apply(robot, s)
        robot.pending = bool(np.any(m["torque"] != 0.0))
        self._refresh_active()
