"""The PyBullet backend's motor commands (a part of
:class:`~simbridge.backends.pybullet.backend.PyBulletBackend`): velocity, position and
torque, per joint and per spherical joint, within <limit effort> when the profile
enforces it; and the commands in force, read and set (``joint_commands``, the spherical
joints' states with their motors)."""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING, Any

import numpy as np

from simbridge.profiles import Profile
from simbridge.types import JointCommands, JointType, MotorMode, SphericalJointState

from .common import _Body, _exclusive, wait_for_lock
from .output import p  # pybullet, imported with its banner captured
from .records import Records

__all__ = ["MotorCommands", "SPHERICAL_BRAKE_IMPULSE", "SPHERICAL_BRAKE_KP"]

# PyBullet's spherical joint motor at load (PhysicsServerCommandProcessor::createJointMotors): a
# btMultiBodySphericalJointMotor holding the identity with kp 0.2 and an impulse of 1000 N·m·s
# per step per axis (the MuJoCo backend's motors.py reproduces it)
SPHERICAL_BRAKE_KP = 0.2
SPHERICAL_BRAKE_IMPULSE = 1000.0


class MotorCommands:
    """The ``Backend`` methods that command the motors (a part of PyBulletBackend)."""

    if TYPE_CHECKING:  # provided by PyBulletBackend and simbridge.backend.Backend
        profile: Profile
        _c: int
        _stepping: threading.RLock
        _bodies: dict[int, _Body]
        _records: Records
        _steps: int
        _dt: float
        _next_check: int
        _last_velocity: tuple[Any, ...] | None

    # ---------------------------------------------------------------- control

    def set_joint_velocity(
        self, body: int, joints: np.ndarray, target: list[float], max_force: list[float]
    ) -> None:
        """See Backend.set_joint_velocity.

        PyBullet: ``p.setJointMotorControlArray`` with VELOCITY_CONTROL; the command in force
        already is not sent again.
        """
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            last = self._last_velocity
            # joints: Sim's cached read-only index array: the same object, the same joints
            if (
                last is not None
                and last[0] is joints
                and last[1] == body
                and last[2] == target
                and last[3] == max_force
            ):
                return  # the command in force already
            p.setJointMotorControlArray(
                body,
                joints.tolist(),
                p.VELOCITY_CONTROL,
                targetVelocities=target,
                forces=self._within_effort(body, joints, max_force),
                physicsClientId=self._c,
            )
            self._last_velocity = (joints, body, target, max_force)
            self._records.motor(body, joints, 0, target, max_force, None, None)
        finally:
            lock.release()

    @_exclusive
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

        PyBullet: ``p.setJointMotorControlArray``, POSITION_CONTROL.
        """
        self._last_velocity = None
        p.setJointMotorControlArray(
            body,
            joints.tolist(),
            p.POSITION_CONTROL,
            targetPositions=target,
            forces=self._within_effort(body, joints, max_force),
            positionGains=kp,
            velocityGains=kd,
            physicsClientId=self._c,
        )
        self._records.motor(body, joints, 2, target, max_force, kp, kd)

    @_exclusive
    def set_joint_torque(self, body: int, joints: np.ndarray, torque: list[float]) -> None:
        """See Backend.set_joint_torque.

        PyBullet: ``p.setJointMotorControlArray`` with TORQUE_CONTROL, each command within the
        effort limit where the profile enforces it.
        """
        self._last_velocity = None
        effort = self._bodies[body].effort
        if effort is not None:  # each command within the effort, as on MuJoCo
            torque = [
                max(-effort[i], min(t, effort[i]))
                for t, i in zip(torque, joints.tolist(), strict=True)
            ]
        p.setJointMotorControlArray(
            body, joints.tolist(), p.TORQUE_CONTROL, forces=torque, physicsClientId=self._c
        )
        self._records.torque(self._steps, body, joints, torque)

    def _within_effort(self, body: int, joints: np.ndarray, force: list[float]) -> list[float]:
        effort = self._bodies[body].effort
        if effort is None:
            return force
        return [min(f, effort[i]) for f, i in zip(force, joints.tolist(), strict=True)]

    # ---------------------------------------------------------------- spherical joints

    @_exclusive
    def set_joint_motor_multi_dof(
        self,
        body: int,
        joints: np.ndarray,
        mode: MotorMode,
        targets: list[list[float]],
        max_force: list[list[float]],
        kp: list[list[float]],
        kd: list[list[float]],
    ) -> None:
        """See Backend.set_joint_motor_multi_dof.

        PyBullet: ``p.setJointMotorControlMultiDof``, POSITION_CONTROL.
        """
        self._last_velocity = None
        self._spherical_motor(body, joints.tolist(), targets, max_force, kp, kd)
        for j, q, f, a, b in zip(joints.tolist(), targets, max_force, kp, kd, strict=True):
            self._records.spherical_motor(body, j, (int(mode), q, f, a, b))

    def _spherical_motor(
        self,
        body: int,
        joints: list[int],
        targets: list[list[float]],
        max_force: list[list[float]],
        kp: list[list[float]],
        kd: list[list[float]],
    ) -> None:
        """setJointMotorControlMultiDof's POSITION_CONTROL with every gain and force a list of
        3 (PyBullet takes them per axis only then: a single kp makes force[0] every axis's);
        ``damping`` is the velocity term the motor reads (velocityGain is read by nothing)."""
        info = self._bodies.get(body)  # None while loading (the profile's brake)
        effort = info.effort if info is not None else None
        for j, q, f, a, b in zip(joints, targets, max_force, kp, kd, strict=True):
            if effort is not None:
                f = [min(x, effort[j]) for x in f]
            p.setJointMotorControlMultiDof(
                body,
                j,
                p.POSITION_CONTROL,
                targetPosition=q,
                positionGain=a,
                velocityGain=[1.0, 1.0, 1.0],
                force=f,
                damping=b,
                physicsClientId=self._c,
            )

    @_exclusive
    def set_joint_torque_multi_dof(
        self, body: int, joints: np.ndarray, torques: list[list[float]]
    ) -> None:
        """See Backend.set_joint_torque_multi_dof.

        PyBullet: ``p.setJointMotorControlMultiDof`` with TORQUE_CONTROL, within the effort limit
        where the profile enforces it.
        """
        self._last_velocity = None
        effort = self._bodies[body].effort
        for j, t in zip(joints.tolist(), torques, strict=True):
            if effort is not None:  # each command within the effort, as on MuJoCo
                t = [max(-effort[j], min(x, effort[j])) for x in t]
            p.setJointMotorControlMultiDof(
                body, j, p.TORQUE_CONTROL, force=t, physicsClientId=self._c
            )
            self._records.spherical_torque(self._steps, body, j, t)

    def _spherical_default(self, body: int, joint: int) -> tuple[Any, ...]:
        """The motor PyBullet gives a spherical joint at load, under this profile: (mode,
        target, max_force, kp, kd), the force as asked (before an effort limit)."""
        if self.profile.joint_brake == "pybullet":
            force = SPHERICAL_BRAKE_IMPULSE / self._dt
            return (MotorMode.POSITION, (0.0, 0.0, 0.0, 1.0), [force] * 3, [0.2] * 3, [1.0] * 3)
        friction = self._bodies[body].table[joint].friction
        return (MotorMode.VELOCITY, (0.0, 0.0, 0.0, 1.0), [friction] * 3, [0.0] * 3, [1.0] * 3)

    @_exclusive
    def spherical_states(self, body: int) -> list[SphericalJointState]:
        """See Backend.spherical_states.

        PyBullet: the motors from the records (PyBullet has no getter), the state from
        ``p.getJointStatesMultiDof``.
        """
        info = self._bodies[body]
        balls = [i for i in info.movable if info.table[i].type == JointType.SPHERICAL]
        rows = p.getJointStatesMultiDof(body, balls, physicsClientId=self._c)
        records = self._records.spherical.get(body, {})
        out = []
        for j, r in zip(balls, rows, strict=True):
            mode, target, force, kp, kd = records.get(j) or self._spherical_default(body, j)
            out.append(
                SphericalJointState(
                    j,
                    tuple(r[0]),
                    tuple(r[1]),
                    int(mode),
                    tuple(target),
                    tuple(force),
                    tuple(kp),
                    tuple(kd),
                    tuple(self._records.spherical_pending(self._steps, body, j)),  # type: ignore[arg-type]
                )
            )
        return out

    @_exclusive
    def set_spherical_states(
        self, body: int, states: list[SphericalJointState], positions: bool
    ) -> None:
        """See Backend.set_spherical_states.

        PyBullet: the positions (unless a bit-exact restore put them back), the motors, and the
        pending torques: those in force cancelled exactly (x + (-x) is 0), the new ones given.
        """
        self._last_velocity = None
        c = self._c
        records = self._records
        for e in states:
            if positions:
                p.resetJointStateMultiDof(body, e.joint, e.position, e.velocity, physicsClientId=c)
            motor = (e.motor_mode, e.motor_target, e.motor_max_force, e.motor_kp, e.motor_kd)
            self._spherical_motor(
                body,
                [e.joint],
                [list(e.motor_target)],
                [list(e.motor_max_force)],
                [list(e.motor_kp)],
                [list(e.motor_kd)],
            )
            records.spherical_motor(body, e.joint, motor)
            now = records.spherical_pending(self._steps, body, e.joint)
            for torque in ([-x for x in now], list(e.pending_torque)):
                if any(torque):
                    p.setJointMotorControlMultiDof(
                        body, e.joint, p.TORQUE_CONTROL, force=torque, physicsClientId=c
                    )
            records.spherical_set_pending(self._steps, body, e.joint, list(e.pending_torque))
        if positions:
            self._next_check = self._steps + 1  # a teleport: probed after the next step

    # ---------------------------------------------------------------- commands in force

    @_exclusive
    def joint_commands(self, body: int) -> JointCommands:
        """See Backend.joint_commands.

        PyBullet: from the records of the commands given (no getter).
        """
        return self._records.commands(
            body, self._bodies[body].table, self.profile.joint_brake, self._dt, self._steps
        )

    @_exclusive
    def set_joint_commands(self, body: int, commands: JointCommands) -> None:
        """See Backend.set_joint_commands.

        PyBullet: re-issues the motors that differ from those in force (a restore into the same
        world sends none), then cancels the pending torques and gives the new ones.
        """
        c = self._c
        now = self.joint_commands(body)
        info = self._bodies[body]
        movable = np.asarray(  # spherical joints: set_spherical_states
            [i for i in info.movable if info.table[i].type != JointType.SPHERICAL], dtype=np.intp
        )
        differ = np.zeros(len(now.mode), dtype=bool)
        for field in range(5):
            differ |= now[field] != commands[field]
        for mode in (MotorMode.VELOCITY, MotorMode.POSITION):
            joints = movable[differ[movable] & (commands.mode[movable] == mode)]
            if not len(joints):
                continue
            force = self._within_effort(body, joints, commands.max_force[joints].tolist())
            target = commands.target[joints].tolist()
            if mode == MotorMode.VELOCITY:
                p.setJointMotorControlArray(
                    body,
                    joints.tolist(),
                    p.VELOCITY_CONTROL,
                    targetVelocities=target,
                    forces=force,
                    physicsClientId=c,
                )
            else:
                p.setJointMotorControlArray(
                    body,
                    joints.tolist(),
                    p.POSITION_CONTROL,
                    targetPositions=target,
                    forces=force,
                    positionGains=commands.kp[joints].tolist(),
                    velocityGains=commands.kd[joints].tolist(),
                    physicsClientId=c,
                )
        self._last_velocity = None
        if (now.pending_torque != commands.pending_torque).any():
            for torque in (-now.pending_torque[movable], commands.pending_torque[movable]):
                if torque.any():  # x + (-x) is exactly 0: the engine's sum starts afresh
                    p.setJointMotorControlArray(
                        body,
                        movable.tolist(),
                        p.TORQUE_CONTROL,
                        forces=torque.tolist(),
                        physicsClientId=c,
                    )
        self._records.set(body, commands, self._steps, movable)
