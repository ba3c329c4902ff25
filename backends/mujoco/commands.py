"""Joint commands: PyBullet's velocity, position and torque control on the motor table.

A velocity or position command rewrites the commanded joints' columns of the motor table and
pushes them into the model (``Compiled.refresh_motors``); a repeated velocity command on the
same joints takes a hot path that writes the targets in place (in C when the compiled loop
runs). Torques add up until the next step, as in PyBullet.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from simbridge.profiles import Profile

from .world import Compiled, Robot

__all__ = ["MotorCommands"]


class MotorCommands:
    """The ``Backend`` command methods (a part of :class:`MujocoBackend`)."""

    if TYPE_CHECKING:  # provided by MujocoBackend
        profile: Profile
        _robots: dict[int, Robot]

        @property
        def _w(self) -> Compiled: ...

        def _joint_cache(self, robot: Robot, joints: np.ndarray) -> tuple[Any, ...]: ...

    # ---------------------------------------------------------------- control

    def _motor_slots(self, body: int, joints: np.ndarray) -> np.ndarray:
        return self._joint_cache(self._robots[body], joints)[4]

    def set_joint_velocity(
        self, body: int, joints: np.ndarray, target: list[float], max_force: list[float]
    ) -> None:
        c = self._w
        t = c.motors
        fast = c.fast.get(id(joints))
        if fast is not None and fast[0] is joints and fast[1] == t.epoch and fast[2] == body:
            # Hot path: the same joints, still velocity motors with kd 1, all rows present.
            if target == fast[6] and max_force == fast[7]:
                return  # the command in force already
            if min(max_force) > 0.0:
                kernel = c.kernel
                if kernel is not None:  # the same writes in C (_mjkernel.c set_velocity)
                    kernel.set_velocity(fast[8], target, max_force)
                else:
                    rows, inv_dt = fast[4], c.inv_dt
                    t.target_velocity[fast[3]] = target
                    t.max_force[fast[3]] = max_force
                    c.m.dof_frictionloss[fast[5]] = max_force
                    t.offset_rows[rows] = [v * inv_dt for v in target]
                    t.force_rows_slack[rows] = [f * (1.0 - 1e-9) for f in max_force]
                t.has_offset = True
                c.fast[id(joints)] = (*fast[:6], target, max_force, fast[8])
                return
        idx = self._motor_slots(body, joints)
        t.target_velocity[idx] = target
        t.max_force[idx] = max_force
        t.kp[idx] = 0.0
        t.kd[idx] = 1.0
        c.refresh_motors()
        rows = t.row_of[idx]
        if t.n_special == 0 and not self.profile.enforce_effort_limit and (rows >= 0).all():
            dofs = t.dof[idx]
            c.fast[id(joints)] = (
                joints,
                t.epoch,
                body,
                idx,
                rows,
                dofs,
                list(target),
                list(max_force),
                np.ascontiguousarray(np.stack([idx, rows, dofs]), dtype=np.intp),
            )

    def set_joint_position(
        self,
        body: int,
        joints: np.ndarray,
        target: list[float],
        max_force: list[float],
        kp: list[float],
        kd: list[float],
    ) -> None:
        idx = self._motor_slots(body, joints)
        c = self._w
        t = c.motors
        model = self._robots[body].model
        target = [  # PyBullet clamps a position target to the joint's limits (measured)
            min(max(q, model.joints[j].lower), model.joints[j].upper)
            if model.joints[j].has_limit
            else q
            for q, j in zip(target, joints.tolist(), strict=True)
        ]
        t.target_velocity[idx] = 0.0
        t.target_position[idx] = target
        t.max_force[idx] = max_force
        t.kp[idx] = kp
        t.kd[idx] = kd
        c.refresh_motors()

    def set_joint_torque(self, body: int, joints: np.ndarray, torque: list[float]) -> None:
        idx = self._motor_slots(body, joints)
        c = self._w
        t = c.motors
        if self.profile.enforce_effort_limit:
            c.torque[idx] += np.clip(torque, -t.effort[idx], t.effort[idx])  # each command
        else:
            c.torque[idx] += torque  # commands before one step add up, as in PyBullet
        c.pending_torque = True
