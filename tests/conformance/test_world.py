"""The world's bookkeeping: body ids through load, remove and reset.

PyBullet hands out body ids from a pool: a new body takes the id freed last (the freed ids form
a stack), else the next unused one, and ``resetSimulation`` starts again from 0. Scripts keep
these ids, so every backend hands out the same ones (measured on raw PyBullet 3.2.7 with the
sequence below: [0..4], [3, 1, 5], [2, 4, 0, 6], [0, 1, 2])."""

from __future__ import annotations


def test_body_ids_follow_pybullets_pool(make_sim):
    sim = make_sim()

    def load(n: int, name: str = "cube.urdf") -> list[int]:
        return [sim.load_urdf(name, base_position=(3 * len(sim.bodies()), 0, 1)) for _ in range(n)]

    assert load(5) == [0, 1, 2, 3, 4]
    sim.remove(1)
    sim.remove(3)
    assert load(3, "r2d2.urdf") == [3, 1, 5]
    for body in (0, 4, 2):
        sim.remove(body)
    assert load(4) == [2, 4, 0, 6]
    assert sim.bodies() == [3, 1, 5, 2, 4, 0, 6]  # load order
    assert [sim.body_name(b) for b in (1, 3, 5)] == ["physics"] * 3  # r2d2.urdf's <robot name>
    sim.step(5)
    sim.reset()
    assert sim.bodies() == []
    assert load(3) == [0, 1, 2]


def test_a_reused_id_is_a_new_robot(make_sim):
    """The id freed by remove() names the next robot loaded, with its own joint table."""
    sim = make_sim()
    r2d2 = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 1))
    assert sim.num_joints(r2d2) == 15
    sim.remove(r2d2)
    cube = sim.load_urdf("cube.urdf", base_position=(0, 0, 1))
    assert cube == r2d2
    assert sim.num_joints(cube) == 0 and sim.body_name(cube) == "cube"
    sim.step(10)
    assert sim.base_state(cube).position[2] < 1.0  # it falls: a live body
