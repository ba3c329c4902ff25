"""Spherical joints (a part of :class:`PhysxBackend`).

SAPIEN 3.0.3 builds no spherical articulation joint, so model.py makes one of three revolute
joints about the child's inertial x, y and z axes at the joint origin (two links of 1e-6 kg
between them). Their coordinates (a, b, c) turn the child's inertial frame by
``Rx(a) Ry(b) Rz(c)``: PyBullet's joint quaternion is that turn, and its angular velocity in
the child's inertial frame is ``J(b, c) (a', b', c')``. Near b = +-pi/2 the three axes lose
one (gimbal lock): a joint turned there is held by PhysX's joints as well as it can, and a
velocity set there is solved in the least-squares sense (a departure).

PyBullet's spherical motor (``btMultiBodySphericalJointMotor``) asks per axis of the child's
inertial frame for ``w_new = (1 - kd) w - erp kp e / dt`` (e: Bullet's XYZ Euler angles of the
turn from the joint's quaternion to the target, erp 0.2), each axis's impulse within
``max_force dt``. Here that angular velocity becomes the three revolute drives' velocity
targets (``J^-1 w``) before each step, each drive's force limit the axis's max_force: the
axes of the drives are the child's axes only at the zero pose (a departure).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from simbridge.exceptions import SimulationDivergedError
from simbridge.profiles import Profile
from simbridge.spherical import motor_error
from simbridge.transforms import quat_multiply
from simbridge.types import (
    JointStateMultiDof,
    MotorMode,
    SphericalJointState,
)

from ..locking import exclusive
from .robots import SPHERICAL_BRAKE_IMPULSE, SPHERICAL_BRAKE_KP, Robot

__all__ = ["BallJoints", "angles_to_quat", "quat_to_angles", "rate_matrix", "spherical_error"]

SPHERICAL_ERP = 0.2  # Bullet's non-contact erp


def angles_to_quat(a: float, b: float, c: float) -> tuple[float, float, float, float]:
    """The turn Rx(a) Ry(b) Rz(c) as a quaternion.

    Args:
        a: The turn about x (rad).
        b: Then about y (rad).
        c: Then about z (rad).

    Returns:
        The unit quaternion (x, y, z, w).
    """
    qa = (math.sin(0.5 * a), 0.0, 0.0, math.cos(0.5 * a))
    qb = (0.0, math.sin(0.5 * b), 0.0, math.cos(0.5 * b))
    qc = (0.0, 0.0, math.sin(0.5 * c), math.cos(0.5 * c))
    return quat_multiply(quat_multiply(qa, qb), qc)


def quat_to_angles(q: tuple[float, ...]) -> tuple[float, float, float]:
    """The angles of a turn, the inverse of :func:`angles_to_quat`.

    Args:
        q: A unit quaternion (x, y, z, w).

    Returns:
        (a, b, c) in radians with Rx(a) Ry(b) Rz(c) the turn of ``q``; b within [-pi/2, pi/2].
    """
    x, y, z, w = q
    r01 = 2.0 * (x * y - w * z)
    r00 = 1.0 - 2.0 * (y * y + z * z)
    r02 = 2.0 * (x * z + w * y)
    r12 = 2.0 * (y * z - w * x)
    r22 = 1.0 - 2.0 * (x * x + y * y)
    b = math.asin(max(-1.0, min(1.0, r02)))
    return math.atan2(-r12, r22), b, math.atan2(-r01, r00)


def rate_matrix(b: float, c: float) -> np.ndarray:
    """The matrix J with w = J (a', b', c'), w in the child's (turned) frame.

    Args:
        b: The second angle (rad).
        c: The third angle (rad).

    Returns:
        The (3, 3) matrix.
    """
    cb, sb, cc, sc = math.cos(b), math.sin(b), math.cos(c), math.sin(c)
    return np.array([[cb * cc, sc, 0.0], [-cb * sc, cc, 0.0], [sb, 0.0, 1.0]])


def spherical_error(q: tuple[float, ...], t: tuple[float, ...]) -> tuple[float, float, float]:
    """Bullet's error of a spherical motor from q to t.

    The error is :func:`simbridge.spherical.motor_error`'s.

    Args:
        q: The joint's quaternion (x, y, z, w).
        t: The target quaternion (x, y, z, w).

    Returns:
        The error about the three axes (rad).
    """
    return motor_error(*q, *t)


def default_ball_motor(profile: Profile) -> dict[str, Any]:
    """PyBullet's spherical motor at load.

    It holds the identity (kp 0.2, 1000 N·m·s per step per axis), or under joint_brake
    "urdf_friction" does nothing (the file's friction is not a spherical joint's).

    Args:
        profile: The physics settings (joint brake, time step).

    Returns:
        The motor's record: ``mode``, ``target`` (x, y, z, w), and per axis ``max_force`` (N·m),
        ``kp``, ``kd`` and the pending ``torque``.
    """
    brake = profile.joint_brake == "pybullet"
    force = SPHERICAL_BRAKE_IMPULSE / profile.timestep if brake else 0.0
    return {
        "mode": int(MotorMode.POSITION),
        "target": (0.0, 0.0, 0.0, 1.0),
        "max_force": [force] * 3,
        "kp": [SPHERICAL_BRAKE_KP if brake else 0.0] * 3,
        "kd": [1.0] * 3,
        "torque": [0.0, 0.0, 0.0],
    }


class BallJoints:
    """The ``Backend`` methods of spherical joints."""

    if TYPE_CHECKING:
        name: ClassVar[str]
        profile: Profile
        _robots: dict[int, Robot]
        _dt: float
        _diverged: SimulationDivergedError | None

        def _check_idle(self) -> None: ...

        def _refresh_active(self) -> None: ...

        def _check_limits(self, robot: Robot) -> None: ...

    def _ball_state(self, robot: Robot, joint: int, q: Any, v: Any) -> tuple[Any, Any]:
        d0, d1, d2 = robot.ball_dofs[joint]
        a, b, c = float(q[d0]), float(q[d1]), float(q[d2])
        rates = np.array([v[d0], v[d1], v[d2]], dtype=float)
        w = rate_matrix(b, c) @ rates
        return angles_to_quat(a, b, c), (float(w[0]), float(w[1]), float(w[2]))

    @exclusive
    def joint_states_multi_dof(self, body: int, joints: np.ndarray) -> list[JointStateMultiDof]:
        """See Backend.joint_states_multi_dof.

        PhysX: a spherical joint read from its three revolutes (module docstring); no motor force is
        reported (zeros).
        """
        if self._diverged is not None:  # refused until reset, a body with no joints too
            raise self._diverged
        robot = self._robots[body]
        out: list[JointStateMultiDof] = []
        art = robot.built.articulation
        q = art.qpos if art is not None else np.zeros(0)
        v = art.qvel if art is not None else np.zeros(0)
        for j in joints.tolist():
            kind = robot.model.joints[j].type
            if kind == "fixed":
                out.append(JointStateMultiDof((), (), ()))
            elif kind == "spherical":
                pos, w = self._ball_state(robot, j, q, v)
                out.append(JointStateMultiDof(pos, w, (0.0, 0.0, 0.0)))
            else:
                d = robot.dof[j]
                out.append(JointStateMultiDof((float(q[d]),), (float(v[d]),), (0.0,)))
        return out

    def _set_ball(self, robot: Robot, joint: int, quat: Any, w: Any, q: Any, v: Any) -> None:
        a, b, c = quat_to_angles(tuple(quat))
        rates, *_ = np.linalg.lstsq(rate_matrix(b, c), np.asarray(w, dtype=float), rcond=None)
        for d, x, u in zip(robot.ball_dofs[joint], (a, b, c), rates, strict=True):
            q[d] = x
            v[d] = u

    @exclusive
    def reset_joint_state_multi_dof(
        self,
        body: int,
        joints: np.ndarray,
        positions: list[list[float]],
        velocities: list[list[float]],
    ) -> None:
        """See Backend.reset_joint_state_multi_dof.

        PhysX: a spherical joint written as its three revolutes' angles and rates (least squares
        near gimbal lock).
        """
        self._check_idle()
        robot = self._robots[body]
        art = robot.built.articulation
        q = art.qpos
        v = art.qvel
        for j, pos, vel in zip(joints.tolist(), positions, velocities, strict=True):
            if robot.model.joints[j].type == "spherical":
                self._set_ball(robot, j, pos, vel, q, v)
            else:
                d = robot.dof[j]
                q[d] = pos[0]
                v[d] = vel[0]
        art.qpos = q
        art.qvel = v
        robot.restored_velocities = None  # PhysX's, from the joint velocities written
        self._check_limits(robot)

    @exclusive
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

        PhysX: the motor becomes the three revolute drives' velocity targets before each step.
        """
        robot = self._robots[body]
        for j, t, f, p_, d_ in zip(joints.tolist(), targets, max_force, kp, kd, strict=True):
            motor = robot.balls[j]
            motor["mode"] = int(mode)
            if mode == MotorMode.POSITION:
                motor["target"] = tuple(t)
                motor["kp"] = list(p_)
                motor["kd"] = list(d_)
            else:  # a brake: target velocity 0
                motor["target"] = (0.0, 0.0, 0.0, 1.0)
                motor["kp"] = [0.0] * 3
                motor["kd"] = [1.0] * 3
            motor["max_force"] = list(f)
            self._ball_forces(robot, j)
        self._refresh_active()

    def _ball_forces(self, robot: Robot, joint: int) -> None:
        motor = robot.balls[joint]
        from .commands import DRIVE_DAMPING

        for d, f in zip(robot.ball_dofs[joint], motor["max_force"], strict=True):
            k = robot.dof_joint[d]
            if f > 0.0:
                k.set_drive_properties(0.0, DRIVE_DAMPING, float(f), "force")
            else:
                k.set_drive_properties(0.0, 0.0, 0.0, "force")

    @exclusive
    def set_joint_torque_multi_dof(
        self, body: int, joints: np.ndarray, torques: list[list[float]]
    ) -> None:
        """See Backend.set_joint_torque_multi_dof. PhysX: applied through the three revolutes."""
        robot = self._robots[body]
        for j, t in zip(joints.tolist(), torques, strict=True):
            motor = robot.balls[j]
            motor["torque"] = [a + b for a, b in zip(motor["torque"], t, strict=True)]
        robot.pending = True
        self._refresh_active()

    def _ball_before_step(self, robot: Robot, q: Any, v: Any, qf: np.ndarray | None) -> bool:
        """Set the ball joints' drive targets (PyBullet's motor law) and, into ``qf``, their
        pending torques as joint forces (``J^T tau``); True where a torque was written."""
        wrote = False
        inv_dt = 1.0 / self._dt
        for j, motor in robot.balls.items():
            quat, w = self._ball_state(robot, j, q, v)
            e = spherical_error(quat, motor["target"])
            kp, kd = motor["kp"], motor["kd"]
            want = np.array(
                [(1.0 - kd[i]) * w[i] - SPHERICAL_ERP * kp[i] * e[i] * inv_dt for i in range(3)]
            )
            d0, d1, d2 = robot.ball_dofs[j]
            jac = rate_matrix(float(q[d1]), float(q[d2]))
            rates, *_ = np.linalg.lstsq(jac, want, rcond=None)
            for d, r in zip((d0, d1, d2), rates.tolist(), strict=True):
                robot.dof_joint[d].set_drive_velocity_target(r)
            if qf is not None and any(motor["torque"]):
                qf[[d0, d1, d2]] += jac.T @ np.asarray(motor["torque"], dtype=float)
                wrote = True
        return wrote

    def _ball_after_step(self, robot: Robot) -> None:
        for motor in robot.balls.values():
            motor["torque"] = [0.0, 0.0, 0.0]

    @exclusive
    def spherical_states(self, body: int) -> list[SphericalJointState]:
        """See Backend.spherical_states.

        PhysX: read from the three revolutes and the motor's record.
        """
        robot = self._robots[body]
        art = robot.built.articulation
        q, v = art.qpos, art.qvel
        out = []
        for j, motor in robot.balls.items():
            pos, w = self._ball_state(robot, j, q, v)
            out.append(
                SphericalJointState(
                    j,
                    pos,
                    w,
                    motor["mode"],
                    tuple(motor["target"]),
                    tuple(motor["max_force"]),
                    tuple(motor["kp"]),
                    tuple(motor["kd"]),
                    tuple(motor["torque"]),
                )
            )
        return out

    @exclusive
    def set_spherical_states(
        self, body: int, states: list[SphericalJointState], positions: bool
    ) -> None:
        """See Backend.set_spherical_states.

        PhysX: written to the three revolutes and the motor's record.
        """
        robot = self._robots[body]
        art = robot.built.articulation
        q, v = art.qpos, art.qvel
        for st in states:
            motor = robot.balls[st.joint]
            motor["mode"] = int(st.motor_mode)
            motor["target"] = tuple(st.motor_target)
            motor["max_force"] = list(st.motor_max_force)
            motor["kp"] = list(st.motor_kp)
            motor["kd"] = list(st.motor_kd)
            motor["torque"] = list(st.pending_torque)
            self._ball_forces(robot, st.joint)
            if positions:
                self._set_ball(robot, st.joint, st.position, st.velocity, q, v)
        if positions:
            art.qpos = q
            art.qvel = v
            robot.restored_velocities = None  # PhysX's, from the joint velocities written
        robot.pending = robot.pending or any(any(m["torque"]) for m in robot.balls.values())
        self._refresh_active()
