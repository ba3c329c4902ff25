"""Tutorial step 4: print R2D2's joint table, the 17 fields of getJointInfo per joint.

python examples/joint_table.py [--backend mujoco]
"""

import argparse

import simbridge


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--backend", default="pybullet", choices=simbridge.available_backends())
    args = parser.parse_args(argv)

    with simbridge.Sim(args.backend) as sim:
        robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.1))
        table = sim.joints(robot)
        for info in table:
            print(info._asdict())  # index, name, type, ..., parent_index: PyBullet's order
        return table


if __name__ == "__main__":
    main()
