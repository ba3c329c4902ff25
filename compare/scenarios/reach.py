"""Joint-space moves under position control (the kuka-reach scenario).

:class:`JointMove` takes a robot's joints from wherever they are when its phase starts to
``target`` (rad) along a minimum-jerk path lasting ``duration`` seconds, then holds the
target: every control step it sends ``sim.set_joint_position`` with the path's point for that
time (PyBullet's position law, gains ``kp`` and ``kd``, force up to ``max_force`` N·m).
"""

from __future__ import annotations

import numpy as np


class JointMove:
    def __init__(
        self,
        target: list[float],
        robot: str = "kuka",
        joints: list[str] | None = None,
        duration: float = 1.0,
        max_force: float = 300.0,
        kp: float = 0.1,
        kd: float = 1.0,
    ):
        self.target = np.asarray(target, dtype=np.float64)
        self.robot, self.joints = robot, joints
        self.duration, self.max_force, self.kp, self.kd = duration, max_force, kp, kd

    def start(self, sim, robots, time):
        self.body = robots[self.robot]
        if self.joints is None:  # every movable joint, in index order
            self.joints = [j.index for j in sim.joints(self.body) if j.type.name != "FIXED"]
        if len(self.joints) != len(self.target):
            raise ValueError(f"{len(self.target)} targets for {len(self.joints)} joints")
        self.start_q = sim.joint_states(self.body, self.joints).positions.copy()
        self.t0 = time

    def setpoint(self, time: float) -> np.ndarray:
        """The minimum-jerk path's point at ``time`` (s): 10 s^3 - 15 s^4 + 6 s^5 of the way."""
        s = min(max((time - self.t0) / self.duration, 0.0), 1.0)
        h = s**3 * (10 - 15 * s + 6 * s * s)
        return self.start_q + (self.target - self.start_q) * h

    def step(self, sim, time):
        sim.set_joint_position(
            self.body,
            self.joints,
            self.setpoint(time),
            max_force=self.max_force,
            kp=self.kp,
            kd=self.kd,
        )
