"""A PD heading controller for r2d2 (the r2d2-goto scenario): drive each robot to its goal and
stop within ``stop_radius`` of it.

Every control step, for each robot: the heading error ``e`` (rad, wrapped to [-pi, pi]) between
where the robot faces and where its goal lies; a turn command ``kp * e - kd * yaw rate``
(wheel rad/s, clamped to ``turn_max``); a forward command ``speed`` (wheel rad/s), less near the
goal (``kv`` rad/s per metre of distance) and scaled by ``cos(e)`` but never below
``min_speed_factor``. r2d2 drives towards its +y axis with negative wheel speeds; its right
wheels are joints 2 and 3, its left wheels 6 and 7.

It reads ``sim.base_state`` and commands ``sim.set_joint_velocity`` alone: the same code on
every engine.
"""

from __future__ import annotations

import math

from simbridge.transforms import rpy_from_quat

RIGHT = ("right_front_wheel_joint", "right_back_wheel_joint")
LEFT = ("left_front_wheel_joint", "left_back_wheel_joint")


def wrap(angle: float) -> float:
    """``angle`` (rad) wrapped to [-pi, pi)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


class GoTo:
    """Drive robots to goals: ``goals`` maps a scenario robot name to its goal ``[x, y]`` (m,
    world)."""

    def __init__(
        self,
        goals: dict[str, list[float]],
        speed: float = 9.0,
        kv: float = 40.0,
        kp: float = 6.0,
        kd: float = 1.0,
        turn_max: float = 8.0,
        min_speed_factor: float = 0.5,
        stop_radius: float = 0.05,
        max_force: float = 10.0,
    ):
        self.goals = {name: (float(g[0]), float(g[1])) for name, g in goals.items()}
        self.speed, self.kv, self.kp, self.kd = speed, kv, kp, kd
        self.turn_max, self.min_speed_factor = turn_max, min_speed_factor
        self.stop_radius, self.max_force = stop_radius, max_force
        self.bodies: dict[str, int] = {}

    def start(self, sim, robots, time):
        missing = sorted(set(self.goals) - set(robots))
        if missing:
            raise KeyError(f"goals for robots that are not there: {missing}")
        self.bodies = {name: robots[name] for name in self.goals}

    def step(self, sim, time):
        for name, body in self.bodies.items():
            gx, gy = self.goals[name]
            state = sim.base_state(body)
            x, y, _ = state.position
            distance = math.hypot(gx - x, gy - y)
            if distance < self.stop_radius:
                forward = turn = 0.0
            else:
                heading = rpy_from_quat(state.orientation)[2] + math.pi / 2  # r2d2 faces +y
                error = wrap(math.atan2(gy - y, gx - x) - heading)
                turn = self.kp * error - self.kd * state.angular_velocity[2]
                turn = max(-self.turn_max, min(self.turn_max, turn))
                forward = min(self.speed, self.kv * distance)
                forward *= max(self.min_speed_factor, math.cos(error))
            right, left = -(forward + turn), -(forward - turn)
            sim.set_joint_velocity(body, RIGHT, right, max_force=self.max_force)
            sim.set_joint_velocity(body, LEFT, left, max_force=self.max_force)
