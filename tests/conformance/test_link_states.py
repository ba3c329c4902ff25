"""``Sim.link_states``: several links read in one pass equal ``Sim.link_state`` of each, bit for
bit, on every backend (both read the same engine values; the batched read only saves the calls).

Checked on robots with a free base resting on the ground (r2d2: contacts, a base whose link
frame is not its centre of mass), a fixed base (the KUKA), rotated inertial frames
(laikago_toes) and many fixed joints (minitaur), each driven for a few steps so that poses and
velocities are non-trivial; read first after a step (the lazy refresh done by the batched read)
and second (done by the single reads before it). The arguments: a subset in any order, names,
the base by -1 or by name, and the errors of a bad ``links``.
"""

from __future__ import annotations

import numpy as np
import pytest

from simbridge import exceptions as exc
from simbridge.types import LinkState, LinkStates

ROBOTS = {
    "r2d2": ("r2d2.urdf", (0.0, 0.0, 0.5), False),
    "kuka": ("kuka_iiwa/model.urdf", (0.0, 0.0, 0.0), True),
    "laikago": ("laikago/laikago_toes.urdf", (0.0, 0.0, 0.6), False),
    "minitaur": ("quadruped/minitaur.urdf", (0.0, 0.0, 0.3), False),
}
KUKA_ROOT = "lbr_iiwa_link_0"  # kuka_iiwa/model.urdf's root link


def _rows(sim, body, links) -> np.ndarray:
    """The per-link reads, laid out as a LinkStates block."""
    out = []
    for link in links:
        s: LinkState = sim.link_state(body, link)
        out.append([x for field in s for x in field])
    return np.array(out, dtype=np.float64)


def _block(ls: LinkStates) -> np.ndarray:
    return np.concatenate([np.asarray(f) for f in ls], axis=1)


def _world(make_sim, robot: str):
    path, position, fixed = ROBOTS[robot]
    sim = make_sim()
    sim.load_urdf("plane.urdf")
    body = sim.load_urdf(path, base_position=position, fixed_base=fixed)
    movable = [j.index for j in sim.joints(body) if j.type != 4]  # 4: fixed
    speeds = np.linspace(-2.0, 2.0, len(movable))
    sim.set_joint_velocity(body, movable, speeds, max_force=20.0)
    return sim, body


@pytest.mark.parametrize("robot", sorted(ROBOTS))
def test_link_states_equal_link_state_of_every_link(make_sim, robot):
    sim, body = _world(make_sim, robot)
    n = sim.num_joints(body)
    every = list(range(-1, n))
    moved = 0.0
    for k in range(6):
        sim.step(10)
        if k % 2:  # the batched read first after the step, then the single ones
            ls = sim.link_states(body)
            single = _rows(sim, body, every)
        else:
            single = _rows(sim, body, every)
            ls = sim.link_states(body)
        assert isinstance(ls, LinkStates)
        shapes = [np.shape(f) for f in ls]
        assert shapes == [(n + 1, 3), (n + 1, 4)] * 3 + [(n + 1, 3), (n + 1, 3)]
        assert all(np.asarray(f).dtype == np.float64 for f in ls)
        np.testing.assert_array_equal(_block(ls), single)  # bit for bit
        moved = max(moved, float(np.abs(ls.linear_velocity).max()))
    assert moved > 1e-3  # the robot moved: the rows compared are not a rest pose's


def test_link_states_of_chosen_links_in_the_order_given(make_sim):
    sim, body = _world(make_sim, "kuka")
    sim.step(20)
    names = [j.link_name for j in sim.joints(body)]
    chosen = [5, -1, names[2], 0]
    ls = sim.link_states(body, chosen)
    np.testing.assert_array_equal(_block(ls), _rows(sim, body, [5, -1, 2, 0]))
    np.testing.assert_array_equal(
        _block(sim.link_states(body, np.array([3, 6]))), _rows(sim, body, [3, 6])
    )
    one = sim.link_states(body, 4)
    np.testing.assert_array_equal(_block(one), _rows(sim, body, [4]))
    none = sim.link_states(body, [])
    assert [np.shape(f) for f in none] == [(0, 3), (0, 4)] * 3 + [(0, 3), (0, 3)]
    root = sim.link_states(body, [KUKA_ROOT, 1])  # the base by its URDF link name
    np.testing.assert_array_equal(_block(root), _rows(sim, body, [-1, 1]))


def test_link_states_refuses_bad_links(make_sim):
    sim, body = _world(make_sim, "kuka")
    n = sim.num_joints(body)
    with pytest.raises(exc.UnknownLinkError, match="no_such_link"):
        sim.link_states(body, [0, "no_such_link"])
    with pytest.raises(exc.UnknownLinkError):
        sim.link_states(body, [n])
    with pytest.raises(exc.InvalidArgumentError, match="links.*given twice"):
        sim.link_states(body, [1, 2, 1])
    with pytest.raises(exc.InvalidArgumentError, match="links.*ordered sequence"):
        sim.link_states(body, {1, 2})
    with pytest.raises(exc.UnknownBodyError):
        sim.link_states(body + 100)


def test_link_states_after_set_state_and_a_teleport(make_sim):
    """Right after ``set_state`` (an engine may hand back the velocities it restored until the
    next step) and after a teleport, the batched read still equals the single reads."""
    sim, body = _world(make_sim, "r2d2")
    every = list(range(-1, sim.num_joints(body)))
    sim.step(30)
    state = sim.get_state()
    sim.step(30)
    sim.set_state(state)
    np.testing.assert_array_equal(_block(sim.link_states(body)), _rows(sim, body, every))
    sim.reset_base_state(body, (0.2, -0.1, 0.8), linear_velocity=(0.5, 0.0, 0.0))
    np.testing.assert_array_equal(_block(sim.link_states(body)), _rows(sim, body, every))
    sim.step()
    np.testing.assert_array_equal(_block(sim.link_states(body)), _rows(sim, body, every))


CHAIN = """<mujoco><worldbody><body name="upper" pos="0 0 1">
<joint name="shoulder" type="hinge" axis="0 1 0"/>
<geom type="capsule" size="0.04" fromto="0 0 0 0.3 0 0"/>
<body name="lower" pos="0.3 0 0"><joint name="elbow" type="hinge" axis="0 1 0"/>
<geom type="capsule" size="0.04" fromto="0 0 0 0.3 0 0"/></body></body></worldbody></mujoco>"""


def test_link_states_of_an_mjcf_read_as_mujoco_reads_it(make_sim):
    """A world of MuJoCo's reading, whose reads each engine makes its own way: the same rule."""
    sim = make_sim()
    (body,) = sim.load_mjcf(CHAIN, semantics="mujoco")
    every = list(range(-1, sim.num_joints(body)))
    sim.step(120)  # the chain swings down under gravity
    ls = sim.link_states(body)
    np.testing.assert_array_equal(_block(ls), _rows(sim, body, every))
    assert float(np.abs(ls.angular_velocity).max()) > 1e-3
