"""Tutorial step 5: for every link, its name, mass, friction, position and orientation.

python examples/link_table.py [--backend mujoco]
"""

import argparse

import simbridge


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--backend", default="pybullet", choices=simbridge.available_backends())
    args = parser.parse_args(argv)

    rows = []
    with simbridge.Sim(args.backend) as sim:
        robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.1))
        for i in range(sim.num_joints(robot)):
            name = sim.joint_info(robot, i)[12]  # field 12: the link name
            mass, friction, *_ = sim.dynamics_info(robot, i)
            pos, orn, *_ = sim.link_state(robot, i)  # centre-of-mass pose, as getLinkState
            rows.append((i, name, mass, friction, pos, orn))
            print(
                f"{i:2d} {name:20s} mass {mass:5.2f} kg  friction {friction:.2f}  "
                f"pos {tuple(round(v, 3) for v in pos)}  orn {tuple(round(v, 3) for v in orn)}"
            )
    return rows


if __name__ == "__main__":
    main()
