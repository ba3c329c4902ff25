"""Reproducibility: one scenario run twice is bitwise identical, and two Sims in one process do
not interfere (interleaved stepping equals separate stepping, bit for bit)."""

from __future__ import annotations

import numpy as np

WHEELS = [
    "right_front_wheel_joint",
    "right_back_wheel_joint",
    "left_front_wheel_joint",
    "left_back_wheel_joint",
]


def _start(make_sim, profile):
    sim = make_sim(profile=profile)
    sim.load_urdf("plane.urdf")
    robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
    return sim, robot


def _advance(sim, robot, step: int) -> bytes:
    """One step of a drive that turns, then drives; returns the state after it as bytes."""
    target = [-10.0, -10.0, 10.0, 10.0] if step < 120 else -10.0
    sim.set_joint_velocity(robot, WHEELS, target, max_force=20)
    sim.step()
    base = sim.base_state(robot)
    joints = sim.joint_states(robot)
    link = sim.link_state(robot, "head")
    return np.concatenate(
        [
            np.ravel(base.position),
            base.orientation,
            base.linear_velocity,
            base.angular_velocity,
            joints.positions,
            joints.velocities,
            joints.applied_torques,
            link.link_frame_position,
            link.link_frame_orientation,
        ]
    ).tobytes()


STEPS = 240


def test_two_runs_are_bitwise_identical(make_sim, profile):
    runs = []
    for _ in range(2):
        sim, robot = _start(make_sim, profile)
        runs.append([_advance(sim, robot, i) for i in range(STEPS)])
        sim.close()
    assert runs[0] == runs[1]


def test_two_sims_do_not_interfere(make_sim, profile):
    sim, robot = _start(make_sim, profile)
    alone = [_advance(sim, robot, i) for i in range(STEPS)]
    sim.close()
    a, ra = _start(make_sim, profile)
    b, rb = _start(make_sim, profile)
    b.step(7)  # b runs ahead: a different state in the same process
    together_a, together_b = [], []
    for i in range(STEPS):
        together_a.append(_advance(a, ra, i))
        together_b.append(_advance(b, rb, i))
    assert together_a == alone
    assert together_b != alone  # b is really a different world
    assert a.time == STEPS * a.timestep and b.time == (STEPS + 7) * b.timestep
