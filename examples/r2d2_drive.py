"""Tutorial step 7: the R2D2 drive. Change --backend and nothing else.

Plane plus r2d2 at z 0.1; 240 steps to settle; 240 steps turning on the spot (right wheels at
-100 rad/s, left at +100, force 50, set every step); 500 steps forward (all four at -100,
force 10).

    python examples/r2d2_drive.py --backend pybullet
    python examples/r2d2_drive.py --backend mujoco [--gui]
"""

import argparse

import simbridge

RIGHT_WHEELS = ["right_front_wheel_joint", "right_back_wheel_joint"]  # joints 2, 3
LEFT_WHEELS = ["left_front_wheel_joint", "left_back_wheel_joint"]  # joints 6, 7


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--backend", default="pybullet", choices=simbridge.available_backends())
    parser.add_argument("--gui", action="store_true", help="open the viewer, run in real time")
    args = parser.parse_args(argv)

    with simbridge.Sim(args.backend, gui=args.gui) as sim:
        sim.load_urdf("plane.urdf")
        robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.1))
        wheels = RIGHT_WHEELS + LEFT_WHEELS

        sim.step(240, realtime=args.gui)  # settle
        for _ in range(240):  # turn on the spot
            sim.set_joint_velocity(robot, wheels, [-100, -100, 100, 100], max_force=50)
            sim.step(realtime=args.gui)
        for _ in range(500):  # drive forward
            sim.set_joint_velocity(robot, wheels, -100, max_force=10)
            sim.step(realtime=args.gui)

        state = sim.base_state(robot)
        where = tuple(round(v, 4) for v in state.position)
        print(f"[{args.backend}] t = {sim.time:.3f} s  base at {where}")
        return state


if __name__ == "__main__":
    main()
