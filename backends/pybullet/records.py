"""What the PyBullet backend keeps to answer ``joint_commands`` (PyBullet has no getter for the
commands in force) and to tell a snapshot's world: :class:`Records`, the velocity and position
commands given per body since it was loaded (or since the last ``set_joint_commands``), in
order, and the torque commands of the current step, with the generation of saved states. The
default motor is derived from the joint table and the profile: PyBullet's brake (VELOCITY,
target 0, 1 N·s per step = 1/dt N·m) or, under ``joint_brake="urdf_friction"``, the joint's
``<dynamics friction>``.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

from simbridge.types import JointCommands, JointInfo, JointType, MotorMode

__all__ = ["Records"]


class Records:
    """The commands given to each body (see the module docstring)."""

    def __init__(self) -> None:
        # body -> id(joints) -> (order, joints, mode, target, max_force, kp, kd); the joints
        # array is kept, so its id is not reused while it is here
        self.motors: dict[int, dict[int, tuple[Any, ...]]] = {}
        self.baseline: dict[int, JointCommands] = {}  # set by set_joint_commands
        self.order = itertools.count()
        # torque commands: (step, body, joints, torques); only those of the current step count
        self.torques: list[tuple[int, int, np.ndarray, list[float]]] = []
        # spherical joints: body -> joint -> (mode, target, max_force, kp, kd), the last motor
        # command (absent: the motor PyBullet gave it at load); torques (step, body, joint, 3)
        self.spherical: dict[int, dict[int, tuple[Any, ...]]] = {}
        self.spherical_torques: list[tuple[int, int, int, list[float]]] = []
        self.generation = 0  # bumped by every reset (saved states die with it)
        self.dead: list[tuple[int, int]] = []  # (generation, state id) of collected snapshots

    def loaded(self, body: int) -> None:
        """A body was loaded: it starts with no command recorded (PyBullet's default motors).

        Args:
            body: The new body's id.
        """
        self.motors[body] = {}
        self.baseline.pop(body, None)
        self.spherical[body] = {}

    def removed(self, body: int) -> None:
        """A body was removed: its commands and pending torques go.

        Args:
            body: The removed body's id.
        """
        self.motors.pop(body, None)
        self.baseline.pop(body, None)
        self.torques = [t for t in self.torques if t[1] != body]
        self.spherical.pop(body, None)
        self.spherical_torques = [t for t in self.spherical_torques if t[1] != body]

    def reset(self) -> None:
        """The world was reset: every record goes, and the saved states' generation moves on."""
        self.motors.clear()
        self.baseline.clear()
        self.torques.clear()
        self.spherical.clear()
        self.spherical_torques.clear()
        self.generation += 1
        self.dead.clear()

    def motor(
        self,
        body: int,
        joints: np.ndarray,
        mode: int,
        target: list[float],
        max_force: list[float],
        kp: list[float] | None,
        kd: list[float] | None,
    ) -> None:
        """A velocity (kp, kd None) or position command given.

        Args:
            body: The body's id.
            joints: (n,) ``np.intp`` joint indices (kept: the next command on the same array
                replaces this one).
            mode: The ``MotorMode``.
            target: n target velocities (rad/s or m/s) or positions (rad or m).
            max_force: n force limits (N·m or N).
            kp: n position gains, or None for a velocity command.
            kd: n velocity gains, or None for a velocity command.
        """
        # keyed by joints array, replaced by the next command on it; read back in ``order``
        self.motors[body][id(joints)] = (next(self.order), joints, mode, target, max_force, kp, kd)

    def torque(self, step: int, body: int, joints: np.ndarray, torque: list[float]) -> None:
        """A torque command given before step ``step`` (as applied: after any effort clamp).

        Args:
            step: The step count when it was given.
            body: The body's id.
            joints: (n,) ``np.intp`` joint indices.
            torque: n torques or forces (N·m or N).
        """
        log = self.torques
        if log and log[0][0] != step:
            log.clear()  # those of an earlier step acted and are gone
        log.append((step, body, joints, torque))

    def commands(
        self, body: int, table: list[JointInfo], brake: str, dt: float, step: int
    ) -> JointCommands:
        """The commands in force on ``body`` and its torques pending before step ``step``.

        Args:
            body: The body's id.
            table: Its joint table.
            brake: The profile's ``joint_brake`` (the default motor: ``"pybullet"`` or
                ``"urdf_friction"``).
            dt: The time step (s), for the brake's force (1 N·s per step).
            step: The step count now.

        Returns:
            The commands, one row per joint.
        """
        n = len(table)
        base = self.baseline.get(body)
        if base is not None:
            mode, target, max_force, kp, kd = (a.copy() for a in base[:5])
        else:
            movable = np.array([j.type != JointType.FIXED for j in table], dtype=bool)
            mode = np.where(movable, MotorMode.VELOCITY, MotorMode.NONE).astype(np.int8)
            target = np.zeros(n)
            if brake == "pybullet":
                max_force = np.where(movable, 1.0 / dt, 0.0)
            else:
                max_force = np.array(
                    [j.friction if m else 0.0 for j, m in zip(table, movable, strict=True)]
                )
            kp = np.zeros(n)
            kd = np.where(movable, 1.0, 0.0)
        for _, joints, m, t, f, p, d in sorted(self.motors.get(body, {}).values(), key=_first):
            mode[joints] = m
            target[joints] = t
            max_force[joints] = f
            kp[joints] = 0.0 if p is None else p
            kd[joints] = 1.0 if d is None else d
        pending = np.zeros(n)
        for s, b, joints, torque in self.torques:
            if s == step and b == body:
                pending[joints] += torque
        return JointCommands(mode, target, max_force, kp, kd, pending)

    def set(self, body: int, commands: JointCommands, step: int, movable: np.ndarray) -> None:
        """``commands`` are now in force on ``body`` (the log starts again from them).

        Args:
            body: The body's id.
            commands: The commands, one row per joint.
            step: The step count now (the pending torques are this step's).
            movable: ``np.intp`` indices of the body's movable joints.
        """
        self.baseline[body] = JointCommands(*(np.array(a) for a in commands))
        self.motors[body] = {}
        self.torques = [t for t in self.torques if not (t[0] == step and t[1] == body)]
        self.torques.append((step, body, movable, commands.pending_torque[movable].tolist()))

    def restamp(self, old: int, new: int) -> None:
        """The step counter moved from ``old`` to ``new`` (set_time): pending torques follow.

        Args:
            old: The step count before.
            new: The step count after.
        """
        self.torques = [(new, *t[1:]) for t in self.torques if t[0] == old]
        self.spherical_torques = [(new, *t[1:]) for t in self.spherical_torques if t[0] == old]

    def spherical_motor(self, body: int, joint: int, motor: tuple[Any, ...]) -> None:
        """A spherical joint's motor command.

        Args:
            body: The body's id.
            joint: The joint's index.
            motor: (mode, target, max_force, kp, kd).
        """
        self.spherical.setdefault(body, {})[joint] = motor

    def spherical_torque(self, step: int, body: int, joint: int, torque: list[float]) -> None:
        """Torques on a spherical joint given before step ``step`` (as applied).

        Args:
            step: The step count when they were given.
            body: The body's id.
            joint: The joint's index.
            torque: The three torques (N·m).
        """
        log = self.spherical_torques
        if log and log[0][0] != step:
            log.clear()  # those of an earlier step acted and are gone
        log.append((step, body, joint, torque))

    def spherical_pending(self, step: int, body: int, joint: int) -> list[float]:
        """The torques pending on a spherical joint before step ``step`` (their sum).

        Args:
            step: The step count now.
            body: The body's id.
            joint: The joint's index.

        Returns:
            The three torques (N·m).
        """
        out = [0.0, 0.0, 0.0]
        for s, b, j, torque in self.spherical_torques:
            if s == step and b == body and j == joint:
                out = [x + y for x, y in zip(out, torque, strict=True)]
        return out

    def spherical_set_pending(self, step: int, body: int, joint: int, torque: list[float]) -> None:
        """``torque`` is now what is pending on the joint before step ``step``.

        Args:
            step: The step count now.
            body: The body's id.
            joint: The joint's index.
            torque: The three torques (N·m).
        """
        self.spherical_torques = [
            t for t in self.spherical_torques if (t[0], t[1], t[2]) != (step, body, joint)
        ]
        self.spherical_torque(step, body, joint, torque)


def _first(entry: tuple[Any, ...]) -> Any:
    return entry[0]
