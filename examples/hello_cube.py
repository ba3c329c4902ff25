"""Tutorial step 2: a 0.5 m blue cube written as a URDF string, dropped from 1 m for one second.

python examples/hello_cube.py [--backend mujoco] [--gui]
"""

import argparse

import simbridge

CUBE_URDF = """<?xml version="1.0"?>
<robot name="cube">
  <link name="cube">
    <visual>
      <geometry><box size="0.5 0.5 0.5"/></geometry>
      <material name="blue"><color rgba="0 0 0.8 1"/></material>
    </visual>
    <collision><geometry><box size="0.5 0.5 0.5"/></geometry></collision>
    <inertial>
      <mass value="1.0"/>
      <inertia ixx="0.0001" ixy="0" ixz="0" iyy="0.0001" iyz="0" izz="0.0001"/>
    </inertial>
  </link>
</robot>
"""


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--backend", default="pybullet", choices=simbridge.available_backends())
    parser.add_argument("--gui", action="store_true", help="open the viewer, run in real time")
    args = parser.parse_args(argv)

    with simbridge.Sim(args.backend, gui=args.gui) as sim:
        cube = sim.load_urdf(CUBE_URDF, base_position=(0, 0, 1))  # no temp file to manage
        sim.step(240, realtime=args.gui)  # one second at 1/240 s
        state = sim.base_state(cube)
        print(f"[{args.backend}] after {sim.time:.3f} s the cube is at {state.position}")
        return state


if __name__ == "__main__":
    main()
