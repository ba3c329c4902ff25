"""The `Sim` under random sequences of calls: a stateful property test (Hypothesis's
``RuleBasedStateMachine``) on every registered backend, the net under the core's refactor.

A machine drives one Sim with random sequences of:

* loads (plane.urdf; r2d2.urdf, floating, on the ground or in the air; pendulum.urdf and
  kuka_iiwa/model.urdf with a fixed base; at most three bodies at a time, which may be loaded
  into each other), ``remove``, ``reset``;
* commands (``set_joint_velocity``, ``set_joint_position``, ``set_joint_torque``), their joints
  given as indices, names, arrays, one joint or None, their values as numbers, lists or arrays;
* bound commands (``velocity_command``, ``position_command``), their arrays written in place
  before a step, ``release``;
* steps (0 to 3), teleports (``reset_base_state``, ``reset_joint_state``);
* ``get_state`` (with and without the engine's data) and ``set_state`` of a state saved any
  time before, into the same world or a changed one;
* a round trip: ``get_state``, k steps (the truth), ``set_state``, the same k steps again;
* refused calls: an unknown joint (index or name), a fixed joint commanded, a NaN or infinite
  value, a negative force or gain, a removed body, a joint driven by a bound command commanded
  or bound again, a quaternion that is not unit, a velocity for a fixed base, a stale bound
  command, a bad value written into a bound command's arrays, a state from another world.

After each call it checks, against a model of what the world holds:

* the call succeeded or raised the typed error (a ``simbridge.exceptions`` class) its
  docstring names, never another exception; a refused call changed nothing (the portable
  state and the time are the same bits);
* every read is finite (base pose and velocities, joint positions, velocities and torques,
  contact points); the body ids and their load order; the time (steps x dt, or the state's);
  a load or a remove leaves the other bodies as they were, the same bits;
* the joint table (``joint_info`` of every joint: names, types, limits, indices...) of a body
  never changes while it is loaded, and is the same in every load of the same robot;
* a state set back reads back as it was saved: the commands in force the same bits; base and
  joint states the same bits from its engine data into the world it was taken from (a base
  pose within float32 rounding where the backend declares ``state_float32``), within float
  precision through the portable state; bound commands end there (StaleCommandError);
* the round trip steps on as the engine's documented state departure allows
  (:meth:`SimMachine._allowed`): without contacts, the same bits with fixed bases on every
  backend, ``state_continuation_floating_base`` with a floating one; with contacts, the same
  bits, or within ``state_continuation`` where the backend restarts its contacts, in contacts
  as calm as that size was measured in (finite beyond: bodies loaded into each other and
  thrown out at tens of m/s); finite where the backend declares the known bug
  ``restore_after_contacts_change`` and the contacts changed around the state.

Settings: two Hypothesis profiles, chosen by the environment variable ``SIMBRIDGE_HYPOTHESIS``:
``default`` (unset) runs 50 sequences of up to 40 calls per backend, derandomised (the same
sequences every run, so it cannot flake): 21 s of CPU for the three backends, 40-45 s of wall
time on the project's shared 2-core machine under load (MuJoCo half of it: each load and
remove recompiles its world); ``long``
(``SIMBRIDGE_HYPOTHESIS=long pytest tests/conformance/test_state_machine.py``) runs 300
sequences of up to 60 calls per backend, random unless ``CI`` is set (tests/_engines.py's rule:
there it is derandomised too). No deadline (the shared machine's timing noise), no example
database (nothing written beside the tests).
"""

from __future__ import annotations

import math
import os
from typing import Any, NamedTuple

import numpy as np
import pytest
from _engines import strict
from _gaps import gap, known_bug, tolerance
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import (
    RuleBasedStateMachine,
    initialize,
    invariant,
    precondition,
    rule,
    run_state_machine_as_test,
)

import simbridge
from simbridge import exceptions as exc
from simbridge.types import JointType, WorldState

# ---------------------------------------------------------------- settings

_COMMON: dict[str, Any] = {
    "deadline": None,
    "database": None,
    "suppress_health_check": [HealthCheck.too_slow, HealthCheck.filter_too_much],
}
settings.register_profile(
    "simbridge-state-machine",
    max_examples=50,
    stateful_step_count=40,
    derandomize=True,
    **_COMMON,
)
settings.register_profile(
    "simbridge-state-machine-long",
    max_examples=300,
    stateful_step_count=60,
    derandomize=strict(),  # random on a developer's machine, repeatable in CI
    **_COMMON,
)
_PROFILES = {"default": "simbridge-state-machine", "long": "simbridge-state-machine-long"}


def _settings() -> settings:
    chosen = os.environ.get("SIMBRIDGE_HYPOTHESIS", "default") or "default"
    if chosen not in _PROFILES:
        raise pytest.UsageError(
            f"SIMBRIDGE_HYPOTHESIS={chosen!r}: expected one of {sorted(_PROFILES)}"
        )
    return settings.get_profile(_PROFILES[chosen])


# ---------------------------------------------------------------- the robots


class Robot(NamedTuple):
    file: str
    fixed_base: bool  # the load's flag (plane.urdf's base has mass 0: static all the same)
    spawns: tuple[tuple[float, float, float], ...]  # base positions to load it at


ROBOTS = (
    Robot("plane.urdf", False, ((0.0, 0.0, 0.0),)),
    Robot("r2d2.urdf", False, ((0.0, 0.0, 0.47), (1.5, 0.0, 0.47), (0.0, 2.0, 3.0))),
    Robot("pendulum.urdf", True, ((0.0, -2.0, 1.0), (0.0, 0.0, 1.0))),
    Robot("kuka_iiwa/model.urdf", True, ((-1.5, 0.0, 0.0), (0.0, 0.0, 0.0))),
)

MAX_BODIES = 3
# The contacts a backend's ``state_continuation`` size was measured in (r2d2 driving on the
# plane: points within a few mm, speeds within 10): deeper points or faster bodies (teleported
# or loaded into each other, thrown out at tens of m/s) are held to finiteness.
CONTACT_DEPTH = 0.01  # m
CALM = 20.0  # the largest speed (m/s, rad/s)
SAVED = 3  # states kept for set_state (each may hold an engine snapshot)

# values a command or a teleport takes: moderate, so that no sequence blows a world up
VELOCITY = st.floats(-4.0, 4.0)
POSITION = st.floats(-2.0, 2.0)
FORCE = st.floats(0.0, 60.0)
GAIN = st.floats(0.0, 1.0)
DAMPING = st.floats(0.0, 2.0)
TORQUE = st.floats(-20.0, 20.0)
BAD = st.sampled_from([math.nan, math.inf, -math.inf])


class Body:
    """What the model knows of one loaded body."""

    def __init__(self, sim: simbridge.Sim, body: int, robot: Robot) -> None:
        self.id, self.robot = body, robot
        self.name = sim.body_name(body)
        self.table = tuple(sim.joint_info(body, j) for j in range(sim.num_joints(body)))
        self.movable = [j.index for j in self.table if j.type != JointType.FIXED]
        self.fixed_joints = [j.index for j in self.table if j.type == JointType.FIXED]
        # a fixed base: the load's flag, or a base of mass 0 (static, as in PyBullet)
        self.fixed = robot.fixed_base or sim.dynamics_info(body, -1).mass == 0.0


def _finite(what: str, values: Any) -> None:
    arr = np.asarray(values, dtype=np.float64)
    assert np.isfinite(arr).all(), f"{what} is not finite: {arr.tolist()}"


def _observe(sim: simbridge.Sim) -> np.ndarray:
    """Every body's base pose and velocities, joint positions and velocities, in load order."""
    parts: list[np.ndarray] = []
    for body in sim.bodies():
        base = sim.base_state(body)
        js = sim.joint_states(body)
        parts += [np.asarray(x, dtype=np.float64) for x in base]
        parts += [js.positions, js.velocities]
    return np.concatenate(parts) if parts else np.zeros(0)


BODY_FIELDS = ("base_position", "base_orientation", "base_linear_velocity", "base_angular_velocity")
JOINT_FIELDS = ("joint_positions", "joint_velocities")
COMMAND_FIELDS = (
    "motor_mode",
    "motor_target",
    "motor_max_force",
    "motor_kp",
    "motor_kd",
    "pending_torque",
)


def _assert_same_state(a: WorldState, b: WorldState) -> None:
    """Two states of one world the same bits: time, bodies, every value."""
    assert a.time == b.time
    assert [(x.body, x.name) for x in a.bodies] == [(y.body, y.name) for y in b.bodies]
    for x, y in zip(a.bodies, b.bodies, strict=True):
        for field in BODY_FIELDS + JOINT_FIELDS + COMMAND_FIELDS:
            np.testing.assert_array_equal(getattr(x, field), getattr(y, field), err_msg=field)


class SimMachine(RuleBasedStateMachine):
    """One Sim on ``backend`` and the model of its world (see the module docstring)."""

    def __init__(self, backend: str) -> None:
        super().__init__()
        self.backend = backend
        self.sim = simbridge.Sim(backend)
        self.dt = self.sim.timestep
        self.bodies: dict[int, Body] = {}  # load order
        self.removed: set[int] = set()  # ids once loaded, not in the world now
        self.tables: dict[str, tuple[Any, ...]] = {}  # robot file -> its joint table
        self.steps = 0  # the time in steps
        self.world = 0  # counts the world changes: load, remove, reset
        self.written = False  # the world written (a teleport, load...) since the last step
        self.saved: list[tuple[WorldState, int]] = []  # (state, the world it was taken in)
        self.live: list[simbridge.BoundCommand] = []
        self.stale: list[simbridge.BoundCommand] = []

    def teardown(self) -> None:
        self.sim.close()

    # ---------------------------------------------------------------- model helpers

    def _held(self, body: int) -> dict[int, simbridge.BoundCommand]:
        return {j: c for c in self.live if c.body == body for j in c.joints.tolist()}

    def _end_bound(self) -> None:
        """A world change or set_state ends every bound command."""
        for command in self.live:
            assert not command.bound
            with pytest.raises(exc.StaleCommandError):
                command.targets  # noqa: B018
        self.stale = (self.stale + self.live)[-4:]
        self.live = []

    def _world_changed(self) -> None:
        self.world += 1
        self.written = True
        self._end_bound()

    def _pick(self, data: st.DataObject) -> Body:
        return self.bodies[data.draw(st.sampled_from(list(self.bodies)), label="body")]

    def _joints(self, data: st.DataObject, body: Body, pool: list[int]) -> tuple[Any, list[int]]:
        """A joints argument over ``pool`` in one of the forms the commands take, and the
        indices it names."""
        form = data.draw(
            st.sampled_from(["indices", "names", "array", "one", "one name", "all"]), label="form"
        )
        if form == "all" and pool == body.movable:
            return None, list(pool)
        if form in ("one", "one name"):
            j = data.draw(st.sampled_from(pool), label="joint")
            return (j if form == "one" else body.table[j].name), [j]
        idx = data.draw(st.lists(st.sampled_from(pool), min_size=1, unique=True), label="joints")
        if form == "names":
            return [body.table[j].name for j in idx], idx
        if form == "array":
            return np.asarray(idx, dtype=np.intp), idx
        return idx, idx

    @staticmethod
    def _values(data: st.DataObject, values: st.SearchStrategy[float], n: int, what: str) -> Any:
        """A number, a list or a float64 array of n values (the hot path takes the array)."""
        form = data.draw(st.sampled_from(["number", "list", "array"]), label=f"{what} form")
        if form == "number":
            return data.draw(values, label=what)
        drawn = data.draw(st.lists(values, min_size=n, max_size=n), label=what)
        return drawn if form == "list" else np.asarray(drawn, dtype=np.float64)

    def _reads(self) -> dict[int, np.ndarray]:
        """Each body's base pose and velocities and joint states, by id."""
        out = {}
        for body in self.bodies:
            base = self.sim.base_state(body)
            js = self.sim.joint_states(body)
            out[body] = np.concatenate([*map(np.asarray, base), js.positions, js.velocities])
        return out

    def _others_kept(self, before: dict[int, np.ndarray]) -> None:
        """A load or a remove leaves every other body as it was, the same bits."""
        after = self._reads()
        for body, reads in before.items():
            if body in after:
                np.testing.assert_array_equal(after[body], reads, err_msg=f"body {body}")

    def _unchanged(self, before: WorldState) -> None:
        assert self.sim.time == before.time
        _assert_same_state(self.sim.get_state(exact=False), before)

    # ---------------------------------------------------------------- the world

    @initialize(data=st.data(), robots=st.lists(st.sampled_from(ROBOTS), min_size=1, max_size=3))
    def populate(self, data: st.DataObject, robots: list[Robot]) -> None:
        """A world to work on from the start (a load rule alone leaves most calls empty)."""
        for robot in robots:
            self.load(data, robot)

    @precondition(lambda self: len(self.bodies) < MAX_BODIES)
    @rule(data=st.data(), robot=st.sampled_from(ROBOTS))
    def load(self, data: st.DataObject, robot: Robot) -> None:
        spawn = data.draw(st.sampled_from(robot.spawns), label="spawn")
        before = self._reads()
        body = self.sim.load_urdf(robot.file, base_position=spawn, fixed_base=robot.fixed_base)
        self._others_kept(before)
        assert isinstance(body, int) and body not in self.bodies
        self.bodies[body] = Body(self.sim, body, robot)
        self.removed.discard(body)
        # the same file and options: the same table in every load
        assert self.tables.setdefault(robot.file, self.bodies[body].table) == (
            self.bodies[body].table
        )
        self._world_changed()

    @precondition(lambda self: self.bodies)
    @rule(data=st.data())
    def remove(self, data: st.DataObject) -> None:
        body = self._pick(data)
        before = self._reads()
        self.sim.remove(body.id)
        del self.bodies[body.id]
        self._others_kept(before)
        self.removed.add(body.id)
        self._world_changed()

    @precondition(lambda self: self.bodies)
    @rule()
    def reset(self) -> None:
        self.sim.reset()
        self.removed |= set(self.bodies)
        self.bodies.clear()
        self.steps = 0
        self._world_changed()

    @rule(data=st.data(), n=st.integers(0, 3))
    def step(self, data: st.DataObject, n: int) -> None:
        """A control loop's turn: the bound commands' arrays written in place (or not), then
        n steps."""
        for command in self.live:
            if data.draw(st.booleans(), label="write its arrays"):
                self._write(data, command)
        self.sim.step(n)
        self.steps += n
        self.written &= n == 0

    # ---------------------------------------------------------------- commands

    @precondition(lambda self: self.bodies)
    @rule(data=st.data(), mode=st.sampled_from(["velocity", "position", "torque"]))
    def command(self, data: st.DataObject, mode: str) -> None:
        body = self._pick(data)
        if not body.movable:  # a body with no movable joint takes a command on none
            joints, idx = None, []
        else:
            joints, idx = self._joints(data, body, body.movable)
        n = len(idx)
        held = mode != "torque" and bool(set(idx) & set(self._held(body.id)))
        before = self.sim.get_state(exact=False) if held else None
        try:
            if mode == "velocity":
                target = self._values(data, VELOCITY, n, "target")
                force = self._values(data, FORCE, n, "max_force")
                self.sim.set_joint_velocity(body.id, joints, target, max_force=force)
            elif mode == "position":
                target = self._values(data, POSITION, n, "target")
                force = self._values(data, FORCE, n, "max_force")
                kp = self._values(data, GAIN, n, "kp")
                kd = self._values(data, DAMPING, n, "kd")
                self.sim.set_joint_position(body.id, joints, target, max_force=force, kp=kp, kd=kd)
            else:
                torque = self._values(data, TORQUE, n, "torque")
                self.sim.set_joint_torque(body.id, joints, torque)
        except exc.InvalidArgumentError as e:
            assert held, f"refused: {e}"  # a joint a bound command drives, and nothing else
            assert "bound" in str(e)
            assert before is not None
            self._unchanged(before)
        else:
            assert not held, "a command on a joint driven by a bound command went through"

    @precondition(lambda self: any(b.movable for b in self.bodies.values()))
    @rule(data=st.data(), mode=st.sampled_from(["velocity", "position"]))
    def bind(self, data: st.DataObject, mode: str) -> None:
        body = self.bodies[
            data.draw(st.sampled_from([b for b, x in self.bodies.items() if x.movable]))
        ]
        joints, idx = self._joints(data, body, body.movable)
        n = len(idx)
        held = bool(set(idx) & set(self._held(body.id)))
        target = self._values(data, VELOCITY if mode == "velocity" else POSITION, n, "target")
        force = self._values(data, FORCE, n, "max_force")
        if held:
            with pytest.raises(exc.InvalidArgumentError, match="bound"):
                if mode == "velocity":
                    self.sim.velocity_command(body.id, joints, target, max_force=force)
                else:
                    self.sim.position_command(body.id, joints, target, max_force=force)
            return
        if mode == "velocity":
            command = self.sim.velocity_command(body.id, joints, target, max_force=force)
        else:
            kp = self._values(data, GAIN, n, "kp")
            kd = self._values(data, DAMPING, n, "kd")
            command = self.sim.position_command(
                body.id, joints, target, max_force=force, kp=kp, kd=kd
            )
        assert command.bound and command.mode == mode and command.body == body.id
        assert command.joints.tolist() == idx
        assert command.targets.shape == command.max_force.shape == (n,)
        self.live.append(command)

    @staticmethod
    def _write(data: st.DataObject, command: simbridge.BoundCommand) -> None:
        n = len(command.joints)
        values = VELOCITY if command.mode == "velocity" else POSITION
        if data.draw(st.booleans(), label="in place"):
            command.targets[:] = data.draw(st.lists(values, min_size=n, max_size=n))
        else:
            command.targets = data.draw(values)
        if data.draw(st.booleans(), label="force too"):
            command.max_force[:] = data.draw(st.lists(FORCE, min_size=n, max_size=n))

    @precondition(lambda self: self.live or self.stale)
    @rule(data=st.data())
    def release(self, data: st.DataObject) -> None:
        command = data.draw(st.sampled_from(self.live + self.stale), label="command")
        command.release()  # safe on a stale one too
        assert not command.bound
        if command in self.live:
            self.live.remove(command)
            self.stale = (self.stale + [command])[-4:]

    # ---------------------------------------------------------------- teleports

    @precondition(lambda self: self.bodies)
    @rule(
        data=st.data(),
        position=st.none() | st.tuples(st.floats(-2, 2), st.floats(-2, 2), st.floats(0.2, 3)),
        orientation=st.none()
        | st.tuples(*[st.floats(-1, 1)] * 4).filter(lambda q: sum(c * c for c in q) > 0.01),
        linear=st.none() | st.tuples(*[st.floats(-2, 2)] * 3),
        angular=st.none() | st.tuples(*[st.floats(-3, 3)] * 3),
    )
    def teleport_base(
        self,
        data: st.DataObject,
        position: tuple[float, ...] | None,
        orientation: tuple[float, ...] | None,
        linear: tuple[float, ...] | None,
        angular: tuple[float, ...] | None,
    ) -> None:
        body = self._pick(data)
        if orientation is not None:
            norm = math.sqrt(sum(c * c for c in orientation))
            orientation = tuple(c / norm for c in orientation)
        moving = any(v is not None and any(v) for v in (linear, angular))
        if body.fixed and moving:  # a fixed base takes a pose, but no velocity
            before = self.sim.get_state(exact=False)
            with pytest.raises(exc.InvalidArgumentError, match="fixed base"):
                self.sim.reset_base_state(body.id, position, orientation, linear, angular)
            self._unchanged(before)
            return
        self.sim.reset_base_state(body.id, position, orientation, linear, angular)
        self.written = True

    @precondition(lambda self: any(b.movable for b in self.bodies.values()))
    @rule(data=st.data())
    def teleport_joints(self, data: st.DataObject) -> None:
        body = self.bodies[
            data.draw(st.sampled_from([b for b, x in self.bodies.items() if x.movable]))
        ]
        joints, idx = self._joints(data, body, body.movable)
        n = len(idx)
        positions = self._values(data, POSITION, n, "positions")
        velocities = self._values(data, VELOCITY, n, "velocities")
        self.sim.reset_joint_state(body.id, joints, positions, velocities)  # bound or not
        self.written = True

    # ---------------------------------------------------------------- states

    @rule(exact=st.booleans())
    def save(self, exact: bool) -> None:
        state = self.sim.get_state(exact=exact)
        assert (state.native is not None) == exact
        assert state.time == self.sim.time and state.timestep == self.dt
        assert [(b.body, b.name) for b in state.bodies] == [
            (b.id, b.name) for b in self.bodies.values()
        ]
        for b in state.bodies:
            assert b.joint_names == tuple(j.name for j in self.bodies[b.body].table)
            for field in BODY_FIELDS + JOINT_FIELDS + COMMAND_FIELDS:
                _finite(f"get_state: body {b.body} {field}", getattr(b, field))
        self.saved = (self.saved + [(state, self.world)])[-SAVED:]

    def _matches(self, state: WorldState) -> bool:
        """set_state's rule: the same robots (name and joint names) in the same load order."""
        ours = [(b.name, tuple(j.name for j in b.table)) for b in self.bodies.values()]
        return [(b.name, b.joint_names) for b in state.bodies] == ours

    @precondition(lambda self: self.saved)
    @rule(data=st.data(), portable=st.booleans())
    def restore(self, data: st.DataObject, portable: bool) -> None:
        state, world = data.draw(st.sampled_from(self.saved), label="saved state")
        if portable:
            state = state.portable()
        if not self._matches(state):  # another world: refused, nothing set
            before = self.sim.get_state(exact=False)
            with pytest.raises(exc.InvalidArgumentError, match="another world|load order"):
                self.sim.set_state(state)
            self._unchanged(before)
            return
        self.sim.set_state(state)
        self.steps = round(state.time / self.dt)
        self.written = True
        self._end_bound()
        assert self.sim.time == state.time
        # into the world it was taken from, with its engine data: the same bits
        self._reads_back(state, exact=world == self.world and state.native is not None)

    def _reads_back(self, state: WorldState, exact: bool) -> None:
        """The world reads back as ``state`` holds it: the commands in force the same bits;
        the base poses and velocities and the joint states the same bits from the engine's data
        into the world it was taken from (``exact``; a backend whose state is float32, the
        ``state_float32`` gap, within its float32 rounding for the base pose, which it keeps
        as a root link pose), else within float precision (float32 where so declared)."""
        back = self.sim.get_state(exact=False)
        for x, y in zip(back.bodies, state.bodies, strict=True):
            for field in COMMAND_FIELDS:
                np.testing.assert_array_equal(getattr(x, field), getattr(y, field), field)
            for field in BODY_FIELDS + JOINT_FIELDS:
                got = np.asarray(getattr(x, field), dtype=np.float64)
                want = np.asarray(getattr(y, field), dtype=np.float64)
                scale = max(1.0, float(np.abs(want).max(initial=0.0)))
                if exact and field not in ("base_position", "base_orientation"):
                    np.testing.assert_array_equal(got, want, err_msg=field)
                    continue
                # a pose through the centre-of-mass frame: float precision, or float32's
                tol = tolerance(self.backend, 0.0 if exact else 1e-12 * scale, scale=scale)
                np.testing.assert_allclose(got, want, rtol=0, atol=tol, err_msg=field)

    def _contacts(self) -> tuple[set[frozenset[tuple[int, int]]], float]:
        """The pairs of links in contact at the last step, and the deepest point's distance
        (m, negative: into each other; 0 without contacts)."""
        points = self.sim.contact_points()
        pairs = {frozenset(((c.body_a, c.link_a), (c.body_b, c.link_b))) for c in points}
        return pairs, min((c.distance for c in points), default=0.0)

    def _run(self, k: int) -> tuple[np.ndarray, list[set[frozenset[tuple[int, int]]]], float]:
        """k steps one at a time: the world read after them, the pairs of links each step found
        in contact, and the deepest point."""
        pairs = []
        deepest = 0.0
        for _ in range(k):
            self.sim.step()
            found, depth = self._contacts()
            pairs.append(found)
            deepest = min(deepest, depth)
        return _observe(self.sim), pairs, deepest

    def _fastest(self) -> float:
        """The largest speed in the world: base and joint velocities (m/s, rad/s)."""
        fastest = 0.0
        for body in self.bodies:
            base = self.sim.base_state(body)
            speeds = [*base.linear_velocity, *base.angular_velocity]
            speeds += self.sim.joint_states(body).velocities.tolist()
            fastest = max(fastest, *map(abs, speeds))
        return fastest

    @rule(k=st.integers(1, 3))
    def round_trip(self, k: int) -> None:
        """get_state, k steps (the truth), set_state, k steps: against the truth as the
        engine's documented state departure allows (see _allowed)."""
        state = self.sim.get_state()
        at_save, deepest = self._contacts()
        written = self.written
        speed = self._fastest()
        truth, during, depth = self._run(k)
        speed = max(speed, self._fastest())
        self.sim.set_state(state)
        self._end_bound()
        assert self.sim.time == state.time
        self._reads_back(state, exact=True)
        got, again, depth_again = self._run(k)
        self.steps = round(state.time / self.dt) + k
        self.written = False
        _finite("the state after the round trip", got)
        allowed = self._allowed(
            at_save,
            during + again,
            written,
            min(deepest, depth, depth_again),
            speed,
            float(np.abs(truth).max(initial=0.0)),
        )
        if allowed == 0.0:
            np.testing.assert_array_equal(got, truth, err_msg=f"{k} steps after set_state")
        else:
            worst = float(np.abs(got - truth).max(initial=0.0))
            assert worst <= allowed, f"{k} steps after set_state off by {worst:.3g} > {allowed:.3g}"

    def _allowed(
        self,
        at_save: set[frozenset[tuple[int, int]]],
        steps: list[set[frozenset[tuple[int, int]]]],
        written: bool,
        deepest: float,
        speed: float,
        largest: float,
    ) -> float:
        """How far the round trip may step from the truth (0: the same bits; inf: finite).

        * No contact at the save nor at any step: the same bits where every base is fixed (on
          every backend), else within ``state_continuation_floating_base`` times the largest
          value read, at least 1 (float32 link poses derived afresh: an error that scales with
          the values; measured 7.6e-5 on r2d2 thrown out of kuka_iiwa at 92 m/s).
        * Contacts, on a backend that declares the known bug ``restore_after_contacts_change``
          (_gaps.py): finite where the pairs of links in contact were not the same at the save
          and after every step, where the world was written since the last step before the
          save, or where the contacts are not as calm as below (its restore leaves the
          broadphase pairs of now, which all three change: r2d2 thrown through kuka_iiwa at
          72 m/s, the same pairs in contact throughout, measured 188).
        * Contacts otherwise: the same bits, unless the backend declares
          ``state_continuation`` (its contacts restart at set_state): within it where the
          contacts are as it was measured in (no point deeper than CONTACT_DEPTH, no speed
          above CALM), else finite (bodies started deep in each other: measured up to 193).
        """
        if not at_save and not any(steps):
            if all(b.fixed for b in self.bodies.values()):
                return 0.0
            floating = gap(self.backend, "state_continuation_floating_base")
            return 0.0 if floating is None else floating * max(1.0, largest)
        calm = deepest >= -CONTACT_DEPTH and speed <= CALM
        changed = written or any(pairs != at_save for pairs in steps) or not calm
        if changed and known_bug(self.backend, "restore_after_contacts_change"):
            return math.inf
        continuation = gap(self.backend, "state_continuation")
        if continuation is None:
            return 0.0
        return continuation if calm else math.inf

    # ---------------------------------------------------------------- refused calls

    @precondition(lambda self: self.bodies)
    @rule(
        data=st.data(),
        kind=st.sampled_from(
            [
                "unknown joint index",
                "unknown joint name",
                "fixed joint",
                "non-finite value",
                "negative force",
                "bound joint",
                "not a unit quaternion",
            ]
        ),
    )
    def refused(self, data: st.DataObject, kind: str) -> None:
        body = self._pick(data)
        sim, b = self.sim, body.id
        before = sim.get_state(exact=False)
        n_joints = len(body.table)
        if kind in ("unknown joint index", "unknown joint name"):
            joint = (
                data.draw(st.sampled_from([-1, n_joints, n_joints + 7]))
                if kind == "unknown joint index"
                else "no_such_joint"
            )
            calls = {
                "velocity": lambda: sim.set_joint_velocity(b, joint, 0.0, max_force=1.0),
                "position": lambda: sim.set_joint_position(b, [joint], 0.0, max_force=1.0),
                "torque": lambda: sim.set_joint_torque(b, joint, 1.0),
                "reset": lambda: sim.reset_joint_state(b, joint, 0.0),
                "joint_info": lambda: sim.joint_info(b, joint),
                "bind": lambda: sim.velocity_command(b, [joint], 0.0, max_force=1.0),
            }
            error: type[Exception] = exc.UnknownJointError
        elif kind == "fixed joint":
            if not body.fixed_joints:
                return
            joint = data.draw(st.sampled_from(body.fixed_joints))
            calls = {
                "velocity": lambda: sim.set_joint_velocity(b, joint, 0.0, max_force=1.0),
                "position": lambda: sim.set_joint_position(b, joint, 0.0, max_force=1.0),
                "torque": lambda: sim.set_joint_torque(b, joint, 1.0),
                "reset": lambda: sim.reset_joint_state(b, joint, 0.0),
                "bind": lambda: sim.position_command(b, [joint], 0.0, max_force=1.0),
            }
            error = exc.InvalidArgumentError
        elif kind in ("non-finite value", "negative force"):
            if not body.movable:
                return
            joint = data.draw(st.sampled_from(body.movable))
            bad = data.draw(BAD) if kind == "non-finite value" else -1.0
            if kind == "non-finite value":
                calls = {
                    "velocity": lambda: sim.set_joint_velocity(b, joint, bad, max_force=1.0),
                    "position": lambda: sim.set_joint_position(b, joint, bad, max_force=1.0),
                    "torque": lambda: sim.set_joint_torque(b, [joint], [bad]),
                    "reset": lambda: sim.reset_joint_state(b, joint, 0.0, bad),
                    "bind": lambda: sim.velocity_command(b, joint, bad, max_force=1.0),
                    "gain": lambda: sim.set_joint_position(b, joint, 0.0, max_force=1.0, kd=bad),
                }
            else:
                calls = {
                    "velocity": lambda: sim.set_joint_velocity(b, joint, 0.0, max_force=bad),
                    "position": lambda: sim.set_joint_position(b, joint, 0.0, max_force=bad),
                    "bind": lambda: sim.position_command(b, joint, 0.0, max_force=bad),
                    "gain": lambda: sim.set_joint_position(b, joint, 0.0, max_force=1.0, kp=bad),
                }
            error = exc.InvalidArgumentError
        elif kind == "bound joint":
            held = self._held(b)
            if not held:
                return
            joint = data.draw(st.sampled_from(sorted(held)))
            calls = {
                "velocity": lambda: sim.set_joint_velocity(b, joint, 0.0, max_force=1.0),
                "position": lambda: sim.set_joint_position(b, [joint], [0.0], max_force=1.0),
                "bind": lambda: sim.velocity_command(b, joint, 0.0, max_force=1.0),
            }
            error = exc.InvalidArgumentError
        else:
            calls = {
                "teleport": lambda: sim.reset_base_state(b, orientation=(0.0, 0.0, 0.0, 2.0)),
                "zero": lambda: sim.reset_base_state(b, orientation=(0.0, 0.0, 0.0, 0.0)),
            }
            error = exc.InvalidArgumentError
        call = data.draw(st.sampled_from(sorted(calls)), label="call")
        with pytest.raises(error):
            calls[call]()
        self._unchanged(before)

    @precondition(lambda self: self.removed)
    @rule(
        data=st.data(),
        call=st.sampled_from(["remove", "velocity", "torque", "base_state", "bind", "teleport"]),
    )
    def removed_body(self, data: st.DataObject, call: str) -> None:
        b = data.draw(st.sampled_from(sorted(self.removed)), label="removed id")
        sim = self.sim
        calls = {
            "remove": lambda: sim.remove(b),
            "velocity": lambda: sim.set_joint_velocity(b, None, 0.0, max_force=1.0),
            "torque": lambda: sim.set_joint_torque(b, 0, 1.0),
            "base_state": lambda: sim.base_state(b),
            "bind": lambda: sim.velocity_command(b, 0, 0.0, max_force=1.0),
            "teleport": lambda: sim.reset_base_state(b, position=(0.0, 0.0, 1.0)),
        }
        before = sim.get_state(exact=False)
        with pytest.raises(exc.UnknownBodyError):
            calls[call]()
        self._unchanged(before)

    @precondition(lambda self: self.stale)
    @rule(data=st.data())
    def stale_command(self, data: st.DataObject) -> None:
        command = data.draw(st.sampled_from(self.stale), label="command")
        with pytest.raises(exc.StaleCommandError):
            command.targets[:] = 0.0
        with pytest.raises(exc.StaleCommandError):
            command.max_force = 1.0

    @precondition(lambda self: self.live)
    @rule(data=st.data(), bad=BAD, into=st.sampled_from(["targets", "max_force"]))
    def bound_bad_value(self, data: st.DataObject, bad: float, into: str) -> None:
        command = data.draw(st.sampled_from(self.live), label="command")
        before = self.sim.get_state(exact=False)
        arr = getattr(command, into)
        kept = arr.copy()
        arr[data.draw(st.integers(0, len(arr) - 1))] = bad
        with pytest.raises(exc.InvalidArgumentError):
            self.sim.step()  # no step is taken
        with pytest.raises(exc.InvalidArgumentError):
            self.sim.get_state()  # as step would
        arr[:] = kept
        self._unchanged(before)

    # ---------------------------------------------------------------- after every call

    @invariant()
    def the_world_is_as_modelled(self) -> None:
        sim = self.sim
        assert sim.bodies() == list(self.bodies)
        assert sim.time == self.steps * self.dt
        for body in self.bodies.values():
            assert sim.body_name(body.id) == body.name
            assert sim.num_joints(body.id) == len(body.table)
            table = tuple(sim.joint_info(body.id, j) for j in range(len(body.table)))
            assert table == body.table, f"body {body.id}'s joint table changed"
            base = sim.base_state(body.id)
            for name, value in zip(base._fields, base, strict=True):
                _finite(f"body {body.id} base {name}", value)
            js = sim.joint_states(body.id)
            for name, value in zip(js._fields, js, strict=True):
                _finite(f"body {body.id} joint {name}", value)
        for c in sim.contact_points():
            _finite("contact point", [*c.position_on_a, *c.position_on_b, *c.normal_on_b])
            _finite("contact forces", [c.distance, c.normal_force, c.lateral_friction_1])
        for command in self.live:
            assert command.bound


def test_random_sequences_keep_the_contract(backend: str) -> None:
    run_state_machine_as_test(lambda: SimMachine(backend), settings=_settings())
