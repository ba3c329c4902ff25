"""The largest models, every backend: what each engine takes, and a typed error up front, before
the engine spends its time, for what it cannot take (measured sizes and times: bench/limits.py,
docs/limits.md)."""

from __future__ import annotations

import numpy as np
import pytest
from _gaps import as_stored, gap
from _generated import arms_urdf, chain_urdf

from simbridge import exceptions as exc


@pytest.mark.known_bug("long_chain_velocity_motors")
def test_a_robot_with_128_joints(make_sim, backend, within):
    """128 revolute joints (8 arms of 16): MuJoCo loads, steps and reads all of them; PyBullet
    refuses it when loading, naming the count and its limits (raw PyBullet loads it, then
    getJointState, getLinkState and getBasePositionAndOrientation fail for every joint:
    joint_states raised a raw pybullet.error), and takes 121, every one read, reset and
    driven (a 122nd reads 0 and takes no reset or motor in raw PyBullet)."""
    sim = make_sim()
    urdf = arms_urdf(8, 16)
    most = gap(backend, "most_joints")  # None: no limit of its own
    limit = None if most is None else int(most)
    if limit is not None and limit < 128:
        with pytest.raises(
            exc.BackendUnsupportedError,
            match=rf"a body with 128 joints \(128 movable\): .* no more than {limit} movable",
        ):
            sim.load_urdf(urdf, fixed_base=True)
        assert sim.bodies() == []
        urdf = arms_urdf(limit, 1)  # the most it takes (uncoupled: its solver converges)
    body = sim.load_urdf(urdf, fixed_base=True)
    n = sim.num_joints(body)
    every = list(range(n))
    targets = np.linspace(-0.5, 0.5, n)
    sim.reset_joint_state(body, every, targets, 0.25)  # every joint takes its reset
    states = sim.joint_states(body)
    assert states.positions.tolist() == as_stored(backend, targets).tolist()  # type: ignore[union-attr]
    assert states.velocities.tolist() == [0.25] * n
    sim.set_joint_velocity(body, every, 0.5, max_force=10.0)  # and its motor
    sim.step(2)
    states = sim.joint_states(body)
    within("motors after 2 steps (rad/s)", np.abs(states.velocities - 0.5).max(), 1e-3)
    assert np.isfinite(sim.link_state(body, n - 1).link_frame_position).all()


def test_joints_nested_past_the_engines_depth_are_refused_up_front(make_sim, backend):
    """A chain one joint deeper than the backend takes is refused by load_urdf before the
    engine sees it (MuJoCo's compiler refused a 2000-link chain itself, after 40 s: "depth limit
    exceeded in signature computation"; PyBullet loaded it in 0.5 s, and its first step took
    220 s). A backend with no depth limit of its own (no ``deepest_chain`` gap) loads and
    steps a 200-joint chain, deeper than PyBullet takes."""
    sim = make_sim()
    limit = gap(backend, "deepest_chain")
    if limit is None:
        body = sim.load_urdf(chain_urdf(200), fixed_base=True)
        sim.step()
        assert sim.num_joints(body) == 200
        assert np.isfinite(sim.joint_states(body).positions).all()
        return
    deepest = int(limit)
    with pytest.raises(exc.BackendUnsupportedError, match=rf"{deepest + 1}"):
        sim.load_urdf(chain_urdf(deepest + 1), fixed_base=True)
    assert sim.bodies() == []
    with pytest.raises(exc.BackendUnsupportedError, match=r"2000"):
        sim.load_urdf(chain_urdf(2000), fixed_base=True)
    body = sim.load_urdf(chain_urdf(60), fixed_base=True)  # the Sim goes on
    sim.step()
    assert sim.num_joints(body) == 60
