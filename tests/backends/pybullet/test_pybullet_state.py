"""The PyBullet backend's bookkeeping for get_state/set_state (backends/pybullet/records.py and
world.py): its saveState snapshots are freed when their states are collected, never across a
reset, and a snapshot of another world is not restored."""

from __future__ import annotations

import gc

import numpy as np
import pybullet as p

import simbridge
from simbridge.backends.pybullet.inspect import backend_of, client_id


def _world() -> simbridge.Sim:
    sim = simbridge.Sim("pybullet")
    sim.load_urdf("plane.urdf")
    sim.load_urdf("r2d2.urdf", base_position=(0.0, 0.0, 0.475))
    sim.step(10)
    return sim


def test_snapshots_are_freed_when_their_states_go():
    with _world() as sim:
        first = sim.get_state().native.state_id  # dropped at once: its id is queued
        for _ in range(20):
            sim.get_state()  # frees the queue, then saves: dropped at once too
        gc.collect()
        kept = sim.get_state()
        assert backend_of(sim)._records.dead == []  # nothing left to free
        assert kept.native.state_id == first  # PyBullet numbers from the lowest free id


def test_a_reset_drops_the_queue_and_old_snapshots_do_not_fit():
    with _world() as sim:
        old = sim.get_state()
        sim.reset()
        sim.load_urdf("plane.urdf")
        sim.load_urdf("r2d2.urdf", base_position=(0.0, 0.0, 0.475))
        kept = sim.get_state()  # PyBullet numbers it 0 again, as the old one was
        assert kept.native.state_id == old.native.state_id == 0
        # a state of the world before the reset does not fit: its portable part is set
        assert backend_of(sim).restore(old.native) is False
        sim.set_state(old)
        assert sim.time == old.time
        del old
        gc.collect()
        sim.get_state()  # the old snapshot's id is not removed from the new world
        assert p.restoreState(kept.native.state_id, physicsClientId=client_id(sim)) is None


def test_a_snapshot_of_another_world_is_not_restored():
    with _world() as a, _world() as b:
        b.step(5)
        state = a.get_state()
        assert backend_of(b).restore(state.native) is False
        b.set_state(state)  # the portable part: the poses come back to float precision
        np.testing.assert_allclose(
            b.base_state(1).position, a.base_state(1).position, atol=1e-15, rtol=0
        )
