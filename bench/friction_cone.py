"""The shape of each engine's friction limit: a cone (the same friction in every direction) or a
per-direction one (a box or a pyramid: another friction along the diagonal).

A 20 cm, 1 kg box settles on plane.urdf (pair friction 0.5 x 1.0 = 0.5), is set sliding at 2 m/s
along x, then along the diagonal x = y, and slides 0.1 s: the deceleration over g is printed for
each (the profile's link damping adds about 0.02 to every figure). A cone decelerates alike both
ways; PyBullet's enableConeFriction = False (two friction rows, each bounded by mu N) gives the
diagonal sqrt(2) times more; MuJoCo's pyramidal cone (its edges along the two axes) about
1 / sqrt(2) of it. ``simbridge explain`` reasons from these figures (compare/study/candidates.py).

Measured (SAPIEN 3.0.3, MuJoCo and PyBullet as pinned, this machine)::

    engine    settings                        along x   diagonal
    pybullet  (profile)                        0.520     0.520     a cone
    pybullet  enableConeFriction = False       0.520     0.725     a box
    mujoco    (profile: pyramidal)             0.456     0.270     a pyramid
    mujoco    cone = elliptic                  0.449     0.449     a cone
    physx     (profile)                        0.520     0.520     a cone

::

    .venv/bin/python bench/friction_cone.py
"""

from __future__ import annotations

import numpy as np

import simbridge

BOX = """<?xml version="1.0"?>
<robot name="box"><link name="box">
  <collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision>
  <inertial><mass value="1"/>
    <inertia ixx="0.00667" ixy="0" ixz="0" iyy="0.00667" iyz="0" izz="0.00667"/></inertial>
</link></robot>"""

SPEED = 2.0  # m/s
SLIDE = 24  # steps of 1/240 s: 0.1 s
G = 9.8  # Sim's default gravity

CASES: tuple[tuple[str, dict[str, object]], ...] = (
    ("pybullet", {}),
    ("pybullet", {"enableConeFriction": False}),
    ("mujoco", {}),
    ("mujoco", {"cone": "elliptic"}),
    ("physx", {}),
)


def deceleration(
    backend: str, settings: dict[str, object], direction: tuple[float, float]
) -> float:
    """The box's deceleration over g while it slides along ``direction``."""
    with simbridge.Sim(backend, engine_settings=settings) as sim:
        sim.load_urdf("plane.urdf")
        box = sim.load_urdf(BOX, base_position=(0, 0, 0.1011))
        sim.step(120)  # settle
        v0 = SPEED * np.asarray(direction) / np.linalg.norm(direction)
        sim.reset_base_state(box, linear_velocity=(float(v0[0]), float(v0[1]), 0.0))
        sim.step(SLIDE)
        v = np.asarray(sim.base_state(box).linear_velocity)[:2]
        return float((SPEED - np.linalg.norm(v)) / (SLIDE / 240) / G)


def main() -> None:
    print(f"{'engine':9s} {'settings':34s} {'along x':>8s} {'diagonal':>9s}")
    for backend, settings in CASES:
        if backend not in simbridge.available_backends():
            continue
        ax = deceleration(backend, settings, (1.0, 0.0))
        diag = deceleration(backend, settings, (1.0, 1.0))
        print(f"{backend:9s} {settings!s:34s} {ax:8.3f} {diag:9.3f}")


if __name__ == "__main__":
    main()
