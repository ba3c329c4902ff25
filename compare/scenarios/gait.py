"""An open-loop trot for pybullet_data's MJCF ant (the ant-gait scenario).

:class:`Trot` reads nothing but the time: every control step it sends the eight position
setpoints of a fixed trot, diagonal legs together, the pairs half a period apart: front left
with back right (legs 1 and 3 in ant.xml), back left with front right (2 and 4). Hip i (rad,
about the torso's z axis) follows ``direction_i * hip * sin(2 pi f t + phase_i)``, ankle i
``sign_i * (ankle + ankle_swing * cos(2 pi f t + phase_i))``: the ankles' signs follow their
ranges in ant.xml (legs 1 and 4 bend positive, 2 and 3 negative) and the hips' directions make
every leg sweep backwards (towards -x) while its foot is down, so the ant walks along +x.
:func:`forward_distance` is the scenario's outcome function.
"""

from __future__ import annotations

import math

HIPS = ("hip_1", "hip_2", "hip_3", "hip_4")
ANKLES = ("ankle_1", "ankle_2", "ankle_3", "ankle_4")
ANKLE_SIGN = (1.0, -1.0, -1.0, 1.0)  # ant.xml: ankle_1, ankle_4 in 30..100 deg; 2, 3 negative
HIP_DIRECTION = (1.0, 1.0, -1.0, -1.0)  # +: a leg's foot moves towards -x
PHASE = (0.0, math.pi, 0.0, math.pi)  # diagonal pairs (1, 3) and (2, 4)


class Trot:
    def __init__(
        self,
        frequency: float = 1.0,
        hip: float = 0.4,
        ankle: float = 1.0,
        ankle_swing: float = 0.3,
        max_force: float = 300.0,
        robot: str = "ant",
    ):
        self.frequency, self.hip = frequency, hip
        self.ankle, self.ankle_swing = ankle, ankle_swing
        self.max_force, self.robot = max_force, robot
        self.joints = [*HIPS, *ANKLES]

    def start(self, sim, robots, time):
        self.body = robots[self.robot]

    def targets(self, time: float) -> list[float]:
        """The eight setpoints (rad) at ``time`` (s): hips 1-4, then ankles 1-4."""
        w = 2.0 * math.pi * self.frequency * time
        hips = [d * self.hip * math.sin(w + p) for d, p in zip(HIP_DIRECTION, PHASE, strict=True)]
        ankles = [
            s * (self.ankle + self.ankle_swing * math.cos(w + p))
            for s, p in zip(ANKLE_SIGN, PHASE, strict=True)
        ]
        return hips + ankles

    def step(self, sim, time):
        sim.set_joint_position(self.body, self.joints, self.targets(time), max_force=self.max_force)


def forward_distance(trajectory, robot: str = "ant") -> float:
    """How far (m) the robot's base moved along +x from its start to the run's end."""
    x = trajectory.bodies[robot].base_position[:, 0]
    return float(x[-1] - x[0])
