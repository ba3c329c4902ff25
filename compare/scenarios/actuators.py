"""A fixed actuator pattern for a model read as MuJoCo reads it (the ant-mujoco and
cheetah-mujoco scenarios), and their outcome functions.

:class:`Pattern` reads nothing but the time: every control step it writes every actuator's
control ``amplitude * sin(2 pi f t + i * phase_step)`` (actuator ``i`` in MuJoCo's order), the
same on every engine, through ``Sim.set_actuator_controls``: what a Gymnasium MuJoCo task's
action is.
"""

from __future__ import annotations

import math

import numpy as np


class Pattern:
    def __init__(self, frequency: float = 1.0, amplitude: float = 0.2, phase_step: float = 1.5708):
        self.frequency, self.amplitude, self.phase_step = frequency, amplitude, phase_step

    def start(self, sim, robots, time):
        self.count = len(sim.actuators())

    def controls(self, time: float) -> list[float]:
        """The controls at ``time`` (s), one per actuator in MuJoCo's order."""
        w = 2.0 * math.pi * self.frequency * time
        return [self.amplitude * math.sin(w + i * self.phase_step) for i in range(self.count)]

    def step(self, sim, time):
        sim.set_actuator_controls(self.controls(time))


def distance_travelled(trajectory, robot: str) -> float:
    """How far (m) the robot's base moved in the horizontal plane, start to end."""
    dx, dy = (
        trajectory.bodies[robot].base_position[-1, 0:2]
        - trajectory.bodies[robot].base_position[0, 0:2]
    )
    return math.sqrt(float(dx) * float(dx) + float(dy) * float(dy))  # no BLAS: portable.py


def joint_travel(trajectory, robot: str, joint: str) -> float:
    """How far the named joint moved, start to end (m for a slide, rad for a hinge)."""
    body = trajectory.bodies[robot]
    q = body.joint_positions[:, list(body.joint_names).index(joint)]
    return float(q[-1] - q[0])


def joint_peak(trajectory, robot: str, joint: str) -> float:
    """The largest magnitude the named joint reached over the run (m or rad)."""
    body = trajectory.bodies[robot]
    q = body.joint_positions[:, list(body.joint_names).index(joint)]
    return float(np.max(np.abs(q)))
