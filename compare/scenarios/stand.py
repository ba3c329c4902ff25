"""A quadruped holding its height under feedback (the laikago-stand scenario).

:class:`HoldHeight` bends all four legs by one angle ``a`` (rad): hip 0, upper leg
``-0.7 - a / 2``, lower leg ``0.7 + a`` (laikago's standing pose at ``a = 0``, from PyBullet's
laikago example; a larger ``a`` folds the legs and lowers the body). Every control step it
reads the base height (its URDF link frame's z) and rate and sets ``a`` by a PID law on the
height error, then sends the twelve position setpoints (force up to ``max_force`` N·m).
:func:`height_error` is the scenario's outcome function: the RMS of the base height against
the target over the run's last seconds.
"""

from __future__ import annotations

import numpy as np

LEGS = ("FR", "FL", "RR", "RL")


def leg_joints() -> list[str]:
    out = []
    for leg in LEGS:
        out += [
            f"{leg}_hip_motor_2_chassis_joint",
            f"{leg}_upper_leg_2_hip_motor_joint",
            f"{leg}_lower_leg_2_upper_leg_joint",
        ]
    return out


class HoldHeight:
    def __init__(
        self,
        height: float,
        robot: str = "laikago",
        kp: float = 8.0,
        ki: float = 20.0,
        kd: float = 0.5,
        max_bend: float = 1.2,
        max_force: float = 40.0,
    ):
        self.height, self.robot = height, robot
        self.kp, self.ki, self.kd = kp, ki, kd
        self.max_bend, self.max_force = max_bend, max_force
        self.joints = leg_joints()
        self.integral = 0.0
        self.last = None

    def start(self, sim, robots, time):
        self.body = robots[self.robot]
        self.last = time

    def step(self, sim, time):
        state = sim.link_state(self.body, -1)  # the base: its URDF link frame, as recorded
        error = state.link_frame_position[2] - self.height  # > 0: too high, fold the legs
        self.integral += error * (time - self.last)
        self.last = time
        bend = self.kp * error + self.ki * self.integral + self.kd * state.linear_velocity[2]
        bend = min(max(bend, 0.0), self.max_bend)
        pose = [0.0, -0.7 - bend / 2, 0.7 + bend] * 4
        sim.set_joint_position(self.body, self.joints, pose, max_force=self.max_force)


def height_error(trajectory, height: float, robot: str = "laikago", after: float = 0.0):
    """RMS (m) of the robot's base height (URDF root link frame) against ``height`` from
    ``after`` seconds on."""
    body = trajectory.bodies[robot]
    keep = trajectory.time >= after
    if not keep.any():  # a run cut short (--duration) ends before: nothing to measure
        raise ValueError(
            f"no instant from {after:g} s on: the run ends at {trajectory.time[-1]:g} s"
        )
    z = body.base_position[keep, 2]
    return float(np.sqrt(np.mean((z - height) ** 2)))
