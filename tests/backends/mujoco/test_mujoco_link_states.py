"""The MuJoCo backend's batched link read (``Sim.link_states``) on each of its paths: the
compiled loop's ``bodies_state`` (one call for every body), the Python loop, and a compiled
loop built before ``bodies_state`` existed (body by body through ``body_state``). Each gives
the floats of ``link_state`` link by link, bit for bit, on robots whose body frames the
backend turns back into URDF link frames (r2d2's free base, laikago's rotated inertials)."""

from __future__ import annotations

import numpy as np
import pytest

import simbridge
from simbridge.backends.mujoco import kernel as mujoco_kernel
from simbridge.backends.mujoco.inspect import compiled

requires_kernel = pytest.mark.skipif(
    mujoco_kernel.reason() != "", reason=f"no compiled loop: {mujoco_kernel.reason()}"
)
ROBOTS = [("r2d2.urdf", (0.0, 0.0, 0.5)), ("laikago/laikago_toes.urdf", (0.0, 0.0, 0.6))]


def _single(sim: simbridge.Sim, body: int) -> np.ndarray:
    rows = [sim.link_state(body, k) for k in range(-1, sim.num_joints(body))]
    return np.array([[x for field in s for x in field] for s in rows])


def _batched(sim: simbridge.Sim, body: int) -> np.ndarray:
    return np.concatenate(list(sim.link_states(body)), axis=1)


def _drive(sim: simbridge.Sim, path: str, position: tuple[float, float, float]) -> int:
    sim.load_urdf("plane.urdf")
    body = sim.load_urdf(path, base_position=position)
    movable = [j.index for j in sim.joints(body) if j.type != 4]  # 4: fixed
    sim.set_joint_velocity(body, movable, np.linspace(-3, 3, len(movable)), max_force=20.0)
    return body


class _OlderKernel:
    """A compiled loop as built before ``bodies_state``: every other call goes to the real one."""

    def __init__(self, kernel: object) -> None:
        self._kernel = kernel

    def __getattr__(self, name: str) -> object:
        if name == "bodies_state":
            raise AttributeError(name)
        return getattr(self._kernel, name)


@pytest.mark.parametrize("loop", ["kernel", "python"])
@pytest.mark.parametrize("path, position", ROBOTS)
def test_link_states_equal_link_state_on_each_loop(monkeypatch, loop, path, position):
    if loop == "python":
        monkeypatch.setenv(mujoco_kernel.ENV, "python")
    elif mujoco_kernel.reason():
        pytest.skip(f"no compiled loop: {mujoco_kernel.reason()}")
    else:
        monkeypatch.delenv(mujoco_kernel.ENV, raising=False)
    with simbridge.Sim("mujoco") as sim:
        assert (compiled(sim).kernel is None) == (loop == "python")
        body = _drive(sim, path, position)
        for k in range(4):
            sim.step(15)
            if k % 2:  # the batched read does the lazy refresh, or the single reads do
                batched, single = _batched(sim, body), _single(sim, body)
            else:
                single, batched = _single(sim, body), _batched(sim, body)
            np.testing.assert_array_equal(batched, single)
        assert np.abs(batched[:, 21:24]).max() > 1e-3  # moving: not a rest pose's rows


@requires_kernel
def test_a_loop_built_before_bodies_state_reads_body_by_body():
    with simbridge.Sim("mujoco") as sim:
        body = _drive(sim, *ROBOTS[1])
        sim.step(30)
        c = compiled(sim)
        real = c.kernel
        c.kernel = _OlderKernel(real)
        try:
            older = _batched(sim, body)
            sim.step(1)
            older_fresh = _batched(sim, body)  # the lazy refresh through body_state
        finally:
            c.kernel = real
        single = _single(sim, body)
        np.testing.assert_array_equal(older_fresh, single)
        assert not np.array_equal(older, older_fresh)  # a step later: other rows


@requires_kernel
def test_bodies_state_checks_its_arguments():
    with simbridge.Sim("mujoco") as sim:
        sim.load_urdf("r2d2.urdf")
        kernel = compiled(sim).kernel
        nbody = compiled(sim).m.nbody
        ids = np.arange(2, dtype=np.intp)
        with pytest.raises(ValueError, match="a float64 array of len\\(body_ids\\) x 20"):
            kernel.bodies_state(ids, True, np.empty((3, 20)))
        with pytest.raises(ValueError, match="an array of C longs"):
            kernel.bodies_state(ids.astype(np.int32), True, np.empty((2, 20)))
        with pytest.raises(ValueError, match=f"body id {nbody} outside 0..{nbody - 1}"):
            kernel.bodies_state(np.array([0, nbody], dtype=np.intp), True, np.empty((2, 20)))
        with pytest.raises(TypeError, match="bodies_state\\(body_ids, fresh, out\\)"):
            kernel.bodies_state(ids, True)
        out = np.empty((2, 20))
        assert kernel.bodies_state(ids, True, out) is True
        one = np.empty(20)
        assert kernel.body_state(1, False, one) is True
        np.testing.assert_array_equal(out[1], one)
