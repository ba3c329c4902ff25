"""PyBullet's joint-limit row on PhysX for a joint past its limit (backends/physx/limits.py):
taken over after each write of the joint state that leaves a joint past its limit, handed back
to PhysX's own limit once the joint is in range, never in force otherwise."""

from __future__ import annotations

import numpy as np
import pytest

import simbridge

pytestmark = pytest.mark.needs_backend("physx")  # tests/_engines.py: skipped, or fails in CI

# a hinge whose range leaves out 0 (where it loads), its arm along x: gravity turns it
HINGE = """<robot name="h">
<link name="base"><inertial><mass value="1"/>
<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
<link name="arm"><inertial><origin xyz="0.3 0 0"/><mass value="0.5"/>
<inertia ixx="0.001" ixy="0" ixz="0" iyy="0.004" iyz="0" izz="0.004"/></inertial></link>
<joint name="j" type="revolute"><parent link="base"/><child link="arm"/>
<axis xyz="0 1 0"/><limit lower="{lower}" upper="{upper}" effort="10" velocity="5"/></joint>
</robot>"""


# two hinges about y, the first free, the second limited to +-0.4 rad
CHAIN = """<robot name="chain">
<link name="base"><inertial><mass value="1"/>
<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
<link name="upper"><inertial><origin xyz="0.2 0 0"/><mass value="1"/>
<inertia ixx="0.001" ixy="0" ixz="0" iyy="0.004" iyz="0" izz="0.004"/></inertial></link>
<link name="lower"><inertial><origin xyz="0.2 0 0"/><mass value="0.5"/>
<inertia ixx="0.001" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.002"/></inertial></link>
<joint name="shoulder" type="continuous"><parent link="base"/><child link="upper"/>
<axis xyz="0 1 0"/></joint>
<joint name="elbow" type="revolute"><parent link="upper"/><child link="lower"/>
<origin xyz="0.4 0 0"/><axis xyz="0 1 0"/><limit lower="-0.4" upper="0.4" effort="1" velocity="5"/>
</joint></robot>"""


def _limit(sim: simbridge.Sim, body: int) -> list[float]:
    from simbridge.backends.physx import inspect

    return inspect.robot(sim, body).joints[0].limit[0].tolist()


def _looked_at(sim: simbridge.Sim, body: int) -> bool:
    from simbridge.backends.physx import inspect

    robot = inspect.robot(sim, body)
    return robot.past_limit or robot in inspect.backend_of(sim)._active


def _slider(backend: str, start: float, speed: float, steps: int) -> np.ndarray:
    with simbridge.Sim(backend, profile="urdf") as sim:
        body = sim.load_urdf("slider.urdf", fixed_base=True)
        sim.set_joint_velocity(body, 0, 0.0, max_force=0.0)
        sim.reset_joint_state(body, 0, start, speed)
        out = np.empty((steps, 2))
        for k in range(steps):
            sim.step()
            js = sim.joint_states(body, [0])
            out[k] = js.positions[0], js.velocities[0]
        return out


def test_the_row_is_handed_back_to_physx_once_the_joint_is_in_range():
    """Reset 0.01 m past the slider's 0.4 m limit: PyBullet's row pushes it back at 0.48 m/s
    (PhysX's own limit: 1.92 m/s); while it is past, PhysX's limit on that side is moved to
    where the row lets the joint be after the step; at 0.398 m (step 6) the limit is PhysX's
    +-0.4 again and the robot is no longer looked at ("urdf" profile: nothing else is)."""
    ref = _slider("pybullet", 0.41, 0.0, 8)
    with simbridge.Sim("physx", profile="urdf") as sim:
        body = sim.load_urdf("slider.urdf", fixed_base=True)
        sim.set_joint_velocity(body, 0, 0.0, max_force=0.0)
        assert not _looked_at(sim, body)
        sim.reset_joint_state(body, 0, 0.41, 0.0)
        assert _looked_at(sim, body)
        sim.step()
        assert sim.joint_states(body, [0]).velocities[0] == pytest.approx(-0.48, abs=1e-6)
        assert _limit(sim, body)[1] == pytest.approx(0.41 - 0.48 / 240, abs=1e-7)  # 0.408
        for k in range(1, 8):
            sim.step()
            q = sim.joint_states(body, [0]).positions[0]
            assert q == pytest.approx(ref[k, 0], abs=1e-7)  # measured: 6e-8 (float32)
        assert q < 0.4
        assert _limit(sim, body) == pytest.approx([-0.4, 0.4], abs=1e-7)
        assert not _looked_at(sim, body)


def test_a_joint_reset_within_or_at_its_limit_is_left_to_physx():
    """A reset inside the range, or exactly at the limit, is never looked at: PhysX's limit
    and the step as they were (the conformance suite's same-results hashes hold the bits)."""
    with simbridge.Sim("physx", profile="urdf") as sim:
        body = sim.load_urdf("slider.urdf", fixed_base=True)
        for q in (0.0, 0.4, -0.4, 0.3999):
            sim.reset_joint_state(body, 0, q, 1.0)
            assert not _looked_at(sim, body)
            sim.step(3)
            assert _limit(sim, body) == pytest.approx([-0.4, 0.4], abs=1e-7)


def test_a_restore_past_a_limit_and_back():
    """set_state into a state past the limit (0.7: deep, PyBullet's row only stops outward
    motion: it stays) holds it there, as PyBullet; set_state back to one in range puts PhysX's
    limit back: the carriage at 0.35 m moving out at 1 m/s stops at 0.4 (with the moved limit
    left at 0.7 it would go on to 0.7). PyBullet's own row lets a joint that arrives at its
    limit at speed pass it by up to one step and pushes it back (0.4042, then in at -0.2 m/s):
    PhysX's limit stops it on the limit (a departure, "joint limits")."""
    held = {}
    for backend in ("pybullet", "physx"):
        with simbridge.Sim(backend, profile="urdf") as sim:
            body = sim.load_urdf("slider.urdf", fixed_base=True)
            sim.set_joint_velocity(body, 0, 0.0, max_force=0.0)
            sim.reset_joint_state(body, 0, 0.35, 1.0)
            inside = sim.get_state()
            sim.reset_joint_state(body, 0, 0.7, 0.0)
            past = sim.get_state()
            sim.set_state(inside)
            sim.set_state(past)
            sim.step(10)
            held[backend] = sim.joint_states(body, [0]).positions[0]
            if backend == "physx":
                assert _limit(sim, body)[1] == pytest.approx(0.7, abs=1e-7)
                sim.set_state(inside)
                sim.step(30)
                assert _limit(sim, body) == pytest.approx([-0.4, 0.4], abs=1e-7)
                assert sim.joint_states(body, [0]).positions[0] == pytest.approx(0.4, abs=1e-7)
                assert not _looked_at(sim, body)
    assert held["pybullet"] == pytest.approx(0.7, abs=1e-12)
    assert held["physx"] == pytest.approx(0.7, abs=1e-7)


@pytest.mark.parametrize(
    ("lower", "upper"),
    [(0.5, 3.0), (-1.0, -0.5), (0.02, 3.0), (-1.0, -0.02), (0.0029, 3.0), (0.002, 3.0)],
)
def test_a_hinge_loaded_outside_its_range_follows_pybullet(lower, upper):
    """A hinge whose range leaves out 0 loads at 0, past its limit; gravity turns it towards
    +q. PyBullet's row lets gravity swing it in (0.5 rad deep below 0.5), holds it where
    gravity pushes it out (0.5 rad above -0.5), or pushes it back at 0.2 depth/dt (0.02 rad
    past), with or against gravity. Before, PhysX threw it onto its limit at once. Measured
    over 60 steps: see the asserts (float32 state)."""
    urdf = HINGE.format(lower=lower, upper=upper)
    runs = []
    for backend in ("pybullet", "physx"):
        with simbridge.Sim(backend, profile="urdf") as sim:
            body = sim.load_urdf(urdf, fixed_base=True)
            sim.set_joint_velocity(body, 0, 0.0, max_force=0.0)
            out = np.empty((60, 2))
            for k in range(60):
                sim.step()
                js = sim.joint_states(body, [0])
                out[k] = js.positions[0], js.velocities[0]
            runs.append(out)
    ref, got = runs
    diff = np.abs(ref - got).max(axis=0)
    # measured: 2.1e-7 rad, 9.1e-7 rad/s (0 where held: -1 .. -0.5); PhysX's own limit threw
    # the 0.5 rad deep cases onto the limit within a step
    assert diff[0] < 1e-6 and diff[1] < 5e-6


@pytest.mark.parametrize("start", [0.41, 0.439, 0.7])
def test_the_push_back_moves_the_rest_of_the_chain_as_pybullet(start):
    """The elbow of a free two-hinge chain (no gravity) reset past its limit: PyBullet's row
    impulse turns the shoulder too. Measured over 60 steps (bench/physx_limit_reset.py):
    shoulder 1.3e-6 / 2.1e-5 rad, 5.1e-6 / 8.4e-5 rad/s, elbow 1.4e-7 rad, 7.2e-7 rad/s (0.41
    / 0.439); with the push written to the elbow alone the shoulder was 2.4e-2 rad off."""
    runs = []
    for backend in ("pybullet", "physx"):
        with simbridge.Sim(backend, profile="urdf", gravity=(0, 0, 0)) as sim:
            body = sim.load_urdf(CHAIN, fixed_base=True)
            sim.set_joint_velocity(body, [0, 1], 0.0, max_force=0.0)
            sim.reset_joint_state(body, 1, start, 0.0)
            out = np.empty((60, 4))
            for k in range(60):
                sim.step()
                js = sim.joint_states(body, [0, 1])
                out[k] = *js.positions, *js.velocities
            runs.append(out)
    diff = np.abs(runs[0] - runs[1]).max(axis=0)
    assert np.abs(runs[0][:, 0]).max() > (1e-3 if start < 0.44 else -1.0)  # it does turn
    assert diff[0] < 1e-4 and diff[2] < 4e-4  # shoulder: 5x the worst
    assert diff[1] < 1e-6 and diff[3] < 5e-6  # elbow
