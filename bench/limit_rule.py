"""The joint-limit rule (engine setting ``limit_rule``): a joint arriving at its limit, per engine
and rule, against PyBullet's.

    python bench/limit_rule.py

PyBullet's limit row exists only once a step starts at or past the limit: a joint arriving from
inside passes by up to one step's travel, then is pushed back at 0.2 of the depth per step.
PhysX's own limit (``physx.limit_rule = "hard"``, its default) stops it on the limit within the
step; ``"pybullet"`` gives PhysX PyBullet's rule (backends/physx/limits.py). MuJoCo's backend
has PyBullet's rule (``mujoco.limit_rule = "pybullet"``, its default); ``"hard"`` gives it PhysX's
(backends/mujoco/motor_rows.py).

Cases, 1/240 s, "pybullet" profile, each 240 steps:

- ``slider``: slider.urdf's carriage reset at 0.38 m, moving at 1 m/s toward its 0.4 m limit,
  its motor off;
- ``kuka falls``: kuka_iiwa's joint 2 (limits +-2.0944 rad) released 0.3 rad from upright, the
  other joints held by position motors at 0 (PyBullet's default gains): gravity swings it into
  its upper limit (a pendulum with a limit);
- ``kuka driven``: kuka_iiwa's joint 2 driven by a velocity motor at 1 rad/s (max_force 300 N m)
  from 1.9 rad into its upper limit, pressing on it;
- ``kuka position``: kuka_iiwa under position control (kp 0.3, max_force 200 N m), joint 1 from
  2.5 rad to a target of 3.2 rad, past its 2.9671 rad upper limit (PyBullet's motor aims at the
  limit itself: the target is clamped into the range), the other joints held where they start.

Per run: how far past the upper limit the joint went (largest, and at the step it first reached
the limit, within 1e-6), where it is 10 steps after, and the largest difference from PyBullet's
position of that joint over the run.
"""

from __future__ import annotations

import numpy as np

import simbridge

STEPS = 240
RUNS = [
    ("pybullet", None),
    ("physx", "hard"),
    ("physx", "pybullet"),
    ("mujoco", "pybullet"),
    ("mujoco", "hard"),
]


def slider(sim: simbridge.Sim) -> tuple[int, int, float]:
    body = sim.load_urdf("slider.urdf", fixed_base=True)
    sim.set_joint_velocity(body, 0, 0.0, max_force=0.0)
    sim.reset_joint_state(body, 0, 0.38, 1.0)
    return body, 0, 0.4


def kuka_falls(sim: simbridge.Sim) -> tuple[int, int, float]:
    body = sim.load_urdf("kuka_iiwa/model.urdf", fixed_base=True)
    others = [0, 2, 3, 4, 5, 6]
    sim.set_joint_position(body, others, [0.0] * len(others), max_force=300.0)
    sim.set_joint_velocity(body, 1, 0.0, max_force=0.0)
    sim.reset_joint_state(body, 1, 0.3, 0.0)
    return body, 1, sim.joint_info(body, 1).upper_limit


def kuka_driven(sim: simbridge.Sim) -> tuple[int, int, float]:
    body = sim.load_urdf("kuka_iiwa/model.urdf", fixed_base=True)
    others = [0, 2, 3, 4, 5, 6]
    sim.set_joint_position(body, others, [0.0] * len(others), max_force=300.0)
    sim.reset_joint_state(body, 1, 1.9, 1.0)
    sim.set_joint_velocity(body, 1, 1.0, max_force=300.0)
    return body, 1, sim.joint_info(body, 1).upper_limit


def kuka_position(sim: simbridge.Sim) -> tuple[int, int, float]:
    body = sim.load_urdf("kuka_iiwa/model.urdf", fixed_base=True)
    joints = list(range(7))
    sim.reset_joint_state(body, joints, [2.5, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])
    target = [3.2, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0]
    sim.set_joint_position(body, joints, target, max_force=200.0, kp=0.3)
    return body, 0, sim.joint_info(body, 0).upper_limit


CASES = {
    "slider": slider,
    "kuka falls": kuka_falls,
    "kuka driven": kuka_driven,
    "kuka position": kuka_position,
}


def run(case: str, backend: str, rule: str | None) -> tuple[np.ndarray, float]:
    """The joint's position after each step, and its upper limit."""
    profile = simbridge.get_profile("pybullet")
    if rule is not None:
        profile = profile.with_engine(backend, limit_rule=rule)
    with simbridge.Sim(backend, profile=profile) as sim:
        body, joint, upper = CASES[case](sim)
        q = np.empty(STEPS)
        for k in range(STEPS):
            sim.step()
            q[k] = sim.joint_states(body, [joint]).positions[0]
    return q, upper


def figures(q: np.ndarray, upper: float, ref: np.ndarray) -> str:
    past = q - upper
    reached = np.flatnonzero(past >= -1e-6)  # PhysX holds its state in float32
    if not len(reached):
        return f"never reached (closest {past.max():+.3g}); vs pybullet {np.abs(q - ref).max():.3g}"
    k = int(reached[0])
    after = min(k + 10, len(q) - 1)
    return (
        f"largest past {past.max():+.3e}, at arrival (step {k + 1}) {past[k]:+.3e}, "
        f"10 steps on {past[after]:+.3e}; largest |q - pybullet| {np.abs(q - ref).max():.3e}"
    )


def main() -> None:
    for case in CASES:
        print(f"{case}:")
        ref, _ = run(case, "pybullet", None)
        for backend, rule in RUNS:
            q, upper = run(case, backend, rule)
            name = backend + (f" limit_rule={rule}" if rule else "")
            print(f"  {name:28s} {figures(q, upper, ref)}")


if __name__ == "__main__":
    main()
