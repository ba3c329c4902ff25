"""``JointStates.applied_torques`` is the joint motor's force of the last step, PyBullet's
``appliedJointMotorTorque``, under each control mode: a saturated velocity or position motor
reads its max_force; a torque command is no motor force, so a torque alone reads 0 and a torque
held by the default brake (a velocity motor at 0) reads the brake's force, minus the command.

kuka_iiwa's joint 0 (a vertical axis), fixed base, no gravity, no link damping; 50 N m is far
below the 300 N m effort limit. The answers are PyBullet's documented semantics, not a reading
of any backend; a backend that reads the joint's force instead of the motor's is held to its
``applied_torque_from_joint_force`` gap, relative to the force.
"""

from __future__ import annotations

import pytest
from _gaps import tolerance

TORQUE = 50.0  # N m
# PyBullet's brake (a velocity motor at 0 whose max force the profile sets) cancels a torque
# within its solver's convergence: measured -49.9963 N m on the first step (7.4e-5 relative),
# then -49.9999 and -50.0; MuJoCo -50 exactly
BRAKE_REL = 1e-4


def _kuka(make_sim):
    from simbridge import Profile

    prof = Profile(name="applied", linear_damping=0.0, angular_damping=0.0)
    sim = make_sim(profile=prof, gravity=(0.0, 0.0, 0.0))
    return sim, sim.load_urdf("kuka_iiwa/model.urdf", fixed_base=True)


def _applied(sim, body) -> float:
    return float(sim.joint_states(body, 0).applied_torques[0])


def test_a_torque_command_alone_reads_no_motor_force(make_sim):
    sim, body = _kuka(make_sim)
    sim.set_joint_velocity(body, 0, 0.0, max_force=0.0)  # the brake off: no motor at all
    tol = tolerance(sim.backend, 1e-9, "applied_torque_from_joint_force", scale=TORQUE)
    speeds = []
    for _ in range(5):
        sim.set_joint_torque(body, 0, TORQUE)
        sim.step()
        assert _applied(sim, body) == pytest.approx(0.0, abs=tol)
        speeds.append(sim.joint_states(body, 0).velocities[0])
    assert speeds[0] > 0.0 and speeds[-1] > speeds[0]  # the torque did move the joint
    sim.step()  # the command lasts one step: still no motor force after it
    assert _applied(sim, body) == pytest.approx(0.0, abs=tol)


def test_a_torque_held_by_the_brake_reads_the_brake_s_force(make_sim):
    sim, body = _kuka(make_sim)
    tol = tolerance(sim.backend, 0.0, "applied_torque_from_joint_force", scale=TORQUE)
    for _ in range(3):
        sim.set_joint_torque(body, 0, TORQUE)
        sim.step()
        assert _applied(sim, body) == pytest.approx(-TORQUE, rel=BRAKE_REL, abs=tol)


@pytest.mark.parametrize("mode", ["velocity", "position"])
def test_a_saturated_motor_reads_its_max_force(make_sim, mode):
    sim, body = _kuka(make_sim)
    force = 150.0
    if mode == "velocity":
        sim.set_joint_velocity(body, 0, 100.0, max_force=force)
    else:
        sim.set_joint_position(body, 0, 1.0, max_force=force)
    sim.step()
    rel = tolerance(sim.backend, 1e-6, "applied_torque_from_joint_force")
    assert _applied(sim, body) == pytest.approx(force, rel=rel)
