"""Write a controller, run it on PyBullet and on MuJoCo, and compare what it achieves.

The controller below is plain Python against ``simbridge.Sim``: every control step it reads
r2d2's base pose and sets its four wheel speeds to turn towards a goal and drive there,
stopping within 5 cm. The scenario (written here as TOML) rests r2d2 on the plane and declares
the outcome: reach the goal within 5 cm. ``simbridge.compare`` runs it on both engines, each
``--ensemble`` times from spawn poses a nanometre apart (the controller is made afresh for every
run, in worker processes too), and writes the report: how many runs reached the goal on each
engine, how long they took, and where the trajectories part::

    python examples/controller_compare.py                        # goal (0.5, 1), 8 runs each
    python examples/controller_compare.py --goal -1 1 --ensemble 16 --out reports/goto
"""

from __future__ import annotations

import argparse
import math

from simbridge import compare
from simbridge.transforms import rpy_from_quat

WHEELS_RIGHT = ["right_front_wheel_joint", "right_back_wheel_joint"]
WHEELS_LEFT = ["left_front_wheel_joint", "left_back_wheel_joint"]


class GoToGoal:
    """Turn towards ``goal`` (x, y in m) and drive there; stop within ``stop`` m.

    Wheel speeds in rad/s: r2d2 drives towards its +y axis with negative wheel speeds, and turns
    left (counter-clockwise) with its right wheels backwards and its left wheels forwards."""

    def __init__(self, goal, speed=6.0, turn_gain=4.0, stop=0.05, max_force=10.0):
        self.goal = (float(goal[0]), float(goal[1]))
        self.speed, self.turn_gain, self.stop, self.max_force = speed, turn_gain, stop, max_force

    def start(self, sim, robots, time):
        self.robot = robots["r2d2"]  # the body id of the scenario's robot "r2d2"

    def step(self, sim, time):
        state = sim.base_state(self.robot)
        x, y, _ = state.position
        dx, dy = self.goal[0] - x, self.goal[1] - y
        distance = math.hypot(dx, dy)
        if distance < self.stop:
            forward = turn = 0.0
        else:
            facing = rpy_from_quat(state.orientation)[2] + math.pi / 2  # r2d2 faces +y
            error = (math.atan2(dy, dx) - facing + math.pi) % (2 * math.pi) - math.pi
            turn = max(-4.0, min(4.0, self.turn_gain * error))
            # full speed facing the goal, none when 60 degrees or more off (turn on the spot)
            forward = self.speed * max(0.0, 2.0 * math.cos(error) - 1.0)
            forward *= min(1.0, max(0.5, distance / 0.3))  # half speed over the last 15 cm
        sim.set_joint_velocity(
            self.robot, WHEELS_RIGHT, -(forward + turn), max_force=self.max_force
        )
        sim.set_joint_velocity(self.robot, WHEELS_LEFT, -(forward - turn), max_force=self.max_force)


SCENARIO = """\
name = "controller-example"
description = "r2d2 driven to a goal by the controller of examples/controller_compare.py"
timestep = "1/240"
subject = "r2d2"

[[robots]]
name = "plane"
urdf = "plane.urdf"

[[robots]]
name = "r2d2"
urdf = "r2d2.urdf"
position = [0.0, 0.0, 0.475]        # resting on its wheels

[[phases]]
name = "drive"
steps = {steps}

[[outcomes]]
name = "reaches the goal"
kind = "reach"
point = [{x}, {y}]
within = 0.05

[[outcomes]]
name = "stays upright"
kind = "upright"
max_tilt = 0.3
"""


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--goal", nargs=2, type=float, default=[0.5, 1.0], metavar=("X", "Y"))
    parser.add_argument("--seconds", type=float, default=10.0, help="how long to drive")
    parser.add_argument("--every", type=int, default=2, help="control period in steps")
    parser.add_argument("--ensemble", type=int, default=8, help="runs per engine")
    parser.add_argument("--out", default="reports/controller-example", help="report folder")
    args = parser.parse_args(argv)

    x, y = args.goal
    scenario = compare.loads_scenario(
        SCENARIO.format(steps=round(args.seconds * 240), x=x, y=y)
    ).with_controller(GoToGoal, {"goal": [x, y]}, every=args.every)
    result = compare.compare(scenario, ["pybullet", "mujoco"], ensemble=args.ensemble)
    path = compare.report(result, args.out)
    summary = compare.summary(result)
    for line in compare.headline(summary)[: len(scenario.outcomes) + 1]:
        print(line.replace("**", ""))
    print(f"report: {path}")
    return summary


if __name__ == "__main__":  # the ensemble's worker processes import this file again
    main()
