"""The world's bookkeeping: body ids through load, remove and reset.

PyBullet hands out body ids from a pool: a new body takes the id freed last (the freed ids form
a stack), else the next unused one, and ``resetSimulation`` starts again from 0. Scripts keep
these ids, so every backend hands out the same ones (measured on raw PyBullet 3.2.7 with the
sequence below: [0..4], [3, 1, 5], [2, 4, 0, 6], [0, 1, 2])."""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Callable

import pytest
from _gaps import gap

import simbridge

HOURS = 10**9
"""A step(n) that would run for hours on any machine: the tests below stop it with a Ctrl-C."""


def _stopped_step(
    sim: simbridge.Sim,
    probe: Callable[[], object],
    during: Callable[[], object] = lambda: None,
    *,
    after_a_step: bool = False,
) -> tuple[object, int, float]:
    """This (the main) thread steps ``sim`` for :data:`HOURS` while another thread waits until
    the step is seen running (``probe()``, a read, is refused with SimBusyError; and, with
    ``after_a_step``, sim.time has moved: a step is done), runs ``during()``, then stops the
    step with a Ctrl-C. The step thus lasts as long as what the test does in it, on a fast
    machine as on a slow or loaded one (a step count timed to last 0.3 s could end before the
    test was done: then it failed). Returns ``during()``'s result, the steps that ran and the
    seconds from the Ctrl-C to the end of the step."""
    from simbridge.exceptions import SimBusyError

    start = sim.time
    got: list[object] = []
    errors: list[BaseException] = []
    sent: list[float] = []
    stepping = False

    def helper() -> None:
        try:
            deadline = time.monotonic() + 60  # bounds a hang only: the step starts at once
            while True:
                try:
                    probe()
                except SimBusyError:
                    if not after_a_step or sim.time > start:
                        break
                assert time.monotonic() < deadline, "the step was never seen running"
            got.append(during())
        except BaseException as error:  # noqa: BLE001 - raised by the caller
            errors.append(error)
        finally:
            sent.append(time.monotonic())
            os.kill(os.getpid(), signal.SIGINT)

    def ctrl_c(signum: int, frame: object) -> None:
        if stepping:  # else the step ended otherwise (its error is raised): nothing to stop
            signal.default_int_handler(signum, frame)

    previous = signal.signal(signal.SIGINT, ctrl_c)
    worker = threading.Thread(target=helper)
    try:
        try:
            stepping = True
            worker.start()
            sim.step(HOURS)
            raise AssertionError("a step of hours ended by itself")
        except KeyboardInterrupt:
            stopped = time.monotonic()
        finally:
            stepping = False
        worker.join()
    finally:
        signal.signal(signal.SIGINT, previous)
    if errors:
        raise errors[0]
    steps = (sim.time - start) / sim.timestep
    assert steps == pytest.approx(round(steps), abs=1e-6)  # whole steps counted
    return got[0], round(steps), stopped - sent[0]


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


def test_a_body_without_movable_joints_takes_commands_on_none_again_and_again(make_sim):
    """Every command on all movable joints (None) of plane.urdf, which has none, is taken, the
    second time too (found by test_state_machine.py: the MuJoCo backend kept a shortcut for the
    empty joint list, whose min(max_force) raised ValueError on the second position command)."""
    sim = make_sim()
    plane = sim.load_urdf("plane.urdf")
    for _ in range(3):
        sim.set_joint_position(plane, None, 0.0, max_force=1.0)
        sim.set_joint_position(plane, None, [], max_force=[], kp=[], kd=0.5)
        sim.set_joint_velocity(plane, None, 0.0, max_force=1.0)
        sim.set_joint_torque(plane, None, 0.0)
        sim.step()
    assert sim.time == 3 * sim.timestep


def test_ctrl_c_stops_a_long_step_and_the_time_counts_the_steps_done(make_sim):
    """A KeyboardInterrupt (Ctrl-C) during step(n) stops it within a moment (MuJoCo's compiled
    loop runs in chunks of 1000 steps for this), sim.time counts exactly the steps that ran,
    and the Sim goes on stepping afterwards. The Ctrl-C comes once the step is seen running
    (a timer of 0.2 s could fire before the step began)."""
    sim = make_sim()
    body = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
    _, steps, took = _stopped_step(sim, lambda: sim.base_state(body), after_a_step=True)
    assert steps > 0
    assert took < 5.0  # measured: a few ms; the bound only says "not an hour of stepping"
    before = sim.time
    sim.step(10)
    assert sim.time == pytest.approx(before + 10 / 240)
    assert sim.num_joints(body) == 15


def test_changing_the_world_while_another_thread_steps_it_is_refused(make_sim):
    """load, remove, reset, close and step from another thread while step(n) runs raise
    SimBusyError (the stepping thread would otherwise die mid-loop or race the engine); the
    world is left as it was and the stepping call goes on until stopped (by a Ctrl-C, its
    steps counted whole), then the Sim steps on."""
    from simbridge.exceptions import SimBusyError

    sim = make_sim()
    robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
    sim.load_urdf("plane.urdf")
    for change in (
        lambda: sim.load_urdf("cube_small.urdf"),
        lambda: sim.remove(robot),
        sim.reset,
        sim.close,
        lambda: sim.step(5),  # a second stepper, too
    ):

        def refused(change=change) -> None:
            with pytest.raises(SimBusyError, match="another thread"):
                change()

        # until the step is seen running: a read is refused then, and a step that begins
        # while the read holds the Sim waits for it (a step(0) probe, a step itself, could
        # refuse the stepping thread's step in that moment)
        _stopped_step(sim, lambda: sim.base_state(robot), refused)
    assert sim.bodies() == [robot, 1] and sim.num_joints(robot) == 15
    before = sim.time
    sim.step(5)
    assert sim.time == pytest.approx(before + 5 / 240)


def test_a_urdf_file_edited_between_two_loads_loads_as_it_is_now(make_sim, tmp_path):
    """The second load of a file reads what the file says now (PyBullet caches a file's
    contents by name for the life of its connection: the old robot came back)."""
    path = tmp_path / "edited.urdf"
    text = (
        '<robot name="edited"><link name="a"/><link name="b"/>'
        '<joint name="{}" type="continuous"><parent link="a"/><child link="b"/>'
        '<axis xyz="0 0 1"/></joint></robot>'
    )
    path.write_text(text.format("first"))
    sim = make_sim()
    one = sim.load_urdf(path, fixed_base=True)
    path.write_text(text.format("second"))
    two = sim.load_urdf(path, fixed_base=True)
    assert sim.joint_info(one, 0).name == "first"
    assert sim.joint_info(two, 0).name == "second"
    assert sim.joint_index(two, "second") == 0
    three = sim.load_urdf(path, fixed_base=True)  # unchanged since: the file itself
    assert sim.joint_info(three, 0).name == "second"


def test_every_call_that_touches_the_world_is_refused_while_another_thread_steps(make_sim):
    """Commands, teleports and state reads from a second thread during a step(n) raise
    SimBusyError and change nothing: on PyBullet, whose step(n) loops in Python between
    stepSimulation calls, set_joint_velocity and reset_base_state went through (195 calls in
    one step(60000), measured) instead of being refused as on MuJoCo."""
    from simbridge.exceptions import SimBusyError

    sim = make_sim()
    robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
    sim.load_urdf("plane.urdf")
    state = sim.get_state(exact=False)
    calls = {
        "set_joint_velocity": lambda: sim.set_joint_velocity(robot, 2, 1.0, max_force=10),
        "set_joint_position": lambda: sim.set_joint_position(robot, 2, 1.0, max_force=10),
        "set_joint_torque": lambda: sim.set_joint_torque(robot, 2, 1.0),
        "reset_joint_state": lambda: sim.reset_joint_state(robot, 2, 0.5),
        "reset_base_state": lambda: sim.reset_base_state(robot, position=(1, 2, 3)),
        "base_state": lambda: sim.base_state(robot),
        "link_state": lambda: sim.link_state(robot, 2),
        "link_states": lambda: sim.link_states(robot),
        "joint_states": lambda: sim.joint_states(robot),
        "contact_points": lambda: sim.contact_points(),
        "get_state": lambda: sim.get_state(),
        "set_state": lambda: sim.set_state(state),
        "velocity_command": lambda: sim.velocity_command(robot, 3, 0.0, max_force=1),
    }

    def attempt() -> list[str]:  # each call while the step runs: the ones not refused
        slipped = []
        for name, call in calls.items():
            try:
                call()
            except SimBusyError:
                continue
            slipped.append(name)
        return slipped

    slipped, steps, _ = _stopped_step(sim, lambda: sim.base_state(robot), attempt)
    assert slipped == []
    assert sim.time == pytest.approx(steps / 240)
    sim.step()  # the Sim goes on, nothing was changed
    assert sim.base_state(robot).position[0] != 1.0


def test_reads_from_several_threads_at_once_are_not_refused(make_sim):
    """Four threads reading one Sim that nobody steps all get their answers, equal to the
    single-threaded ones (PyBullet refused 8,456 of them with SimBusyError, naming a step
    that was not there: each read held the Sim's lock and another read found it taken; a wait
    of 1 ms for the lock still refused some across the GIL's 5 ms switch interval, hence
    backends/locking.py's WAIT_SLICE_S of 5 ms)."""
    import threading

    sim = make_sim()
    sim.load_urdf("plane.urdf")
    robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
    sim.step(50)
    expected = (sim.base_state(robot), sim.joint_states(robot).positions.tolist())
    errors: list[BaseException] = []
    answers: list[object] = []

    def reader() -> None:
        try:
            for _ in range(2000):
                got = (sim.base_state(robot), sim.joint_states(robot).positions.tolist())
                if got != expected:
                    answers.append(got)
        except BaseException as error:  # noqa: BLE001 - reported below
            errors.append(error)

    threads = [threading.Thread(target=reader) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == [] and answers == []


@pytest.mark.parametrize("read", ["joint_states", "get_state"])
def test_a_read_racing_a_step_in_another_thread_is_whole_or_refused(make_sim, read):
    """A read while another thread steps one step at a time answers with the state after some
    whole step, or raises SimBusyError; never positions of one step with speeds of the next
    (MuJoCo's compiled loop runs without the GIL: a read in parts could straddle a step that
    began between them; get_state, a read of several calls, mixed two steps 20 times in
    2,980 on PyBullet)."""
    import sys
    import threading
    import time

    from simbridge.exceptions import SimBusyError

    def world() -> tuple[simbridge.Sim, int]:  # falling and swinging: every number moves
        sim = make_sim(profile="urdf")
        body = sim.load_urdf("double_pendulum.urdf", base_position=(0, 0, 100))
        sim.reset_joint_state(body, [0, 1], [1.0, -0.5])
        return sim, body

    def of(base: object, positions: object, velocities: object) -> tuple[float, ...]:
        if read == "joint_states":  # joint_states is one read: its own numbers
            return (*positions.tolist(), *velocities.tolist())  # type: ignore[attr-defined]
        return (*base, *positions.tolist(), *velocities.tolist())  # type: ignore[attr-defined]

    n = 3000
    sim, body = world()
    whole = set()
    for _ in range(n + 1):
        js = sim.joint_states(body)
        whole.add(of(sim.base_state(body).position, js.positions, js.velocities))
        sim.step()
    sim, body = world()
    done = threading.Event()
    seen: list[tuple[float, ...]] = []
    refused = 0
    deadline = time.monotonic() + 1.5  # a reader in a tight loop may hold the stepper back:
    # the race is run for this long (or n steps), not to a step count

    def stepper() -> None:
        for k in range(n):
            if time.monotonic() > deadline:
                break
            try:
                sim.step()
            except SimBusyError:  # a step waits for a read, 10 s at most
                continue
            if k % 2:
                time.sleep(0)  # the reader gets in between steps too
        done.set()

    switch = sys.getswitchinterval()
    sys.setswitchinterval(1e-5)  # threads take turns often: more reads land near a step
    try:
        worker = threading.Thread(target=stepper)
        worker.start()
        while not done.is_set():
            try:
                if read == "get_state":
                    b = sim.get_state().bodies[0]
                    seen.append(of(b.base_position, b.joint_positions, b.joint_velocities))
                else:
                    js = sim.joint_states(body)
                    seen.append(of(None, js.positions, js.velocities))
            except SimBusyError:
                refused += 1
        worker.join()
    finally:
        sys.setswitchinterval(switch)
    torn = [s for s in seen if s not in whole]
    assert seen and not torn, f"{len(torn)} of {len(seen)} reads were not of a whole step"


RACE_STEPS, RACE_CALLS = 150, 100


def test_commands_and_teleports_racing_a_stepping_thread_land_whole(make_sim):
    """One thread steps r2d2 (fixed base, in the air) one step at a time while three others
    command and teleport it as fast as they can: every call lands whole between two steps or
    is refused (SimBusyError), never inside one. Each step is checked in the stepping thread:

    - a wheel alternately under a velocity motor (target +1000, 1e-3 N m) and a position
      motor (target -1000, 2e-3 N m), both held at their force limit: each step changes its
      speed by one of the two motors' pulls, never by one motor's force in the other's
      direction (a command torn across its writes: the model's force limit written, the
      rows not yet);
    - a free wheel given 1e-3 N m torques: each step adds a whole number of torques' worth of
      speed, and at the end exactly as many as were accepted (none lost);
    - a free wheel and the cube teleported to position 0 with speed 2 or 3: the position is
      always a whole number of steps at the speed read (a teleport torn between its position
      and its speed: a step of the old speed from the new position).

    The race runs to RACE_STEPS steps with every kind of call accepted RACE_CALLS times at least
    (about 1 s here: 150 to 750 steps and thousands of calls of each kind a second), not for a
    fixed time, whose steps and calls depend on the machine and its load.

    Without the MuJoCo backend's lock (it checked that no step ran, then acted holding
    nothing) every run tore commands (tens to hundreds a second) and most tore teleports."""
    import sys
    import threading
    import time

    from simbridge.exceptions import SimBusyError

    sim = make_sim(profile="urdf")  # no brakes, no damping: each pull and torque adds up
    robot = sim.load_urdf("r2d2.urdf", fixed_base=True, base_position=(0, 0, 1))
    cube = sim.load_urdf("cube_small.urdf", base_position=(0, 5, 5))
    motor, spun, torqued = 2, 3, 6  # wheels: each a leaf of the fixed base, alone on its dof
    wheels = [motor, spun, torqued]
    vel_cmd, pos_cmd = (1000.0, 1e-3), (-1000.0, 2e-3)  # (target, force): never reached
    dt = sim.timestep

    def speeds() -> list[float]:
        return sim.joint_states(robot, wheels).velocities.tolist()  # type: ignore[no-any-return]

    # each motor's pull and one torque's worth of speed, measured alone
    sim.set_joint_velocity(robot, motor, vel_cmd[0], max_force=vel_cmd[1])
    sim.set_joint_torque(robot, torqued, 1e-3)
    before = speeds()
    sim.step()
    after = speeds()
    pull_vel, per_torque = after[0] - before[0], after[2] - before[2]
    sim.set_joint_position(robot, motor, pos_cmd[0], max_force=pos_cmd[1])
    sim.step()
    pull_pos = speeds()[0] - after[0]
    assert pull_vel > 0 > pull_pos and per_torque > 0
    sim.reset_joint_state(robot, wheels, [0.0] * 3, [0.0, 2.0, 0.0])
    sim.reset_base_state(cube, (0, 5, 5), (0, 0, 0, 1), (2, 0, 0), (0, 0, 0))

    stop = threading.Event()
    errors: list[BaseException] = []
    torn: list[str] = []
    accepted = {"commands": 0, "torques": 0, "teleports": 0, "steps": 0}

    def forever(name: str, calls: list) -> None:  # type: ignore[type-arg]
        k = 0
        while not stop.is_set():
            try:
                calls[k % len(calls)](k)
            except SimBusyError:
                continue  # a step was running: refused, nothing changed
            accepted[name] += 1
            k += 1

    f32 = gap(sim.backend, "state_float32") or 0.0

    def whole_steps(position: float, speed: float) -> bool:
        # a float32 position (_gaps "state_float32") gathers a rounding of up to 2^-24 of itself
        # at each of its n steps: n^2 2^-24 steps' worth at most, bounded by f32 n^2
        n = position / (speed * dt)
        return speed in (2.0, 3.0) and abs(n - round(n)) < 1e-6 + f32 * n * n

    def raced() -> bool:  # run to counts, not for a time: the same race on any machine
        calls = min(accepted[k] for k in ("commands", "torques", "teleports"))
        return accepted["steps"] >= RACE_STEPS and calls >= RACE_CALLS

    def stepper() -> None:
        deadline = time.monotonic() + 60  # bounds a hang only (measured: 0.3-2 s here)
        last = speeds()
        while not raced():
            assert time.monotonic() < deadline, f"the race got too few calls in 60 s: {accepted}"
            sim.step()
            accepted["steps"] += 1
            now = speeds()
            pull = now[0] - last[0]
            # a float32 state (_gaps "state_float32"): the speeds read are rounded, so a pull or
            # a count of torques is whole to a few roundings of the speeds it is taken from
            round_v = 4 * f32 * (abs(now[0]) + abs(last[0]) + abs(pull))
            round_t = 4 * f32 * (abs(now[2]) + abs(last[2]) + abs(now[2] - last[2])) / per_torque
            if (
                abs(pull - pull_vel) > 1e-9 * pull_vel + round_v
                and abs(pull - pull_pos) > -1e-9 * pull_pos + round_v
            ):
                torn.append(f"command: a pull of {pull / pull_vel:.3f} velocity pulls")
            torques = (now[2] - last[2]) / per_torque
            if abs(torques - round(torques)) > 1e-6 + round_t:
                torn.append(f"torque: {torques:.6f} torques' worth in one step")
            if not whole_steps(sim.joint_states(robot, [spun]).positions[0], now[1]):
                torn.append("teleport: reset_joint_state")
            base = sim.base_state(cube)
            if not whole_steps(base.position[0], base.linear_velocity[0]):
                torn.append("teleport: reset_base_state")
            last = now
            time.sleep(0)  # the others get in between steps too

    def run(target, *args) -> None:  # type: ignore[no-untyped-def]
        try:
            target(*args)
        except BaseException as error:  # noqa: BLE001 - reported below
            errors.append(error)
        finally:
            stop.set()

    commands = [
        lambda k: sim.set_joint_velocity(robot, motor, vel_cmd[0], max_force=vel_cmd[1]),
        lambda k: sim.set_joint_position(robot, motor, pos_cmd[0], max_force=pos_cmd[1]),
    ]
    torques = [lambda k: sim.set_joint_torque(robot, torqued, 1e-3)]
    teleports = [
        lambda k: sim.reset_base_state(cube, (0, 5, 5), (0, 0, 0, 1), (2 + k % 2, 0, 0), (0, 0, 0)),
        lambda k: sim.reset_joint_state(robot, spun, 0.0, 2.0 + k % 2),
    ]
    threads = [threading.Thread(target=run, args=(stepper,))] + [
        threading.Thread(target=run, args=(forever, name, calls))
        for name, calls in (("commands", commands), ("torques", torques), ("teleports", teleports))
    ]
    switch = sys.getswitchinterval()
    sys.setswitchinterval(1e-5)  # threads take turns often: calls land near and in steps
    try:
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(switch)
    assert errors == []
    sim.step()  # the torques still pending
    total = (speeds()[2] - 0.0) / per_torque
    assert torn == [], f"{len(torn)} of {accepted['steps']} steps: {sorted(set(torn))}"
    # whole to the float32 rounding of the speed and of one torque's worth (measured 1.1e-4 of
    # 2430 on PhysX: 4.3e-8 relative), a lost torque being 1
    rounding = 4 * f32 * (abs(total) + 1.0)
    assert total == pytest.approx(accepted["torques"], abs=1e-6 + rounding), "torques lost"
    assert raced(), accepted  # every kind of call raced the steps


def test_body_ids_follow_pybullets_pool_through_many_removals(make_sim):
    """Hundreds of loads and removals (the PyBullet backend renews its engine's world when
    remove() empties it and the next ids would be a new world's: see RECYCLE_AFTER_REMOVALS)
    hand out the ids raw PyBullet hands out, in both removal orders (measured on raw
    PyBullet 3.2.7: removing 0 then 1 leaves 1 next, then 0)."""
    import pybullet as p
    import pybullet_data

    cube = f"{pybullet_data.getDataPath()}/cube_small.urdf"
    raw = p.connect(p.DIRECT)
    sim = make_sim()
    try:
        for k in range(80):
            order = (0, 1) if k % 3 else (1, 0)  # which of the two loaded goes first
            ids = [sim.load_urdf("cube_small.urdf", base_position=(i, 0, 1)) for i in range(2)]
            raw_ids = [p.loadURDF(cube, (i, 0, 1), physicsClientId=raw) for i in range(2)]
            assert ids == raw_ids, f"cycle {k}"
            sim.step()
            for i in order:
                sim.remove(ids[i])
                p.removeBody(raw_ids[i], physicsClientId=raw)
    finally:
        p.disconnect(raw)
    assert sim.time == pytest.approx(80 / 240)


def test_a_world_emptied_by_many_removals_simulates_as_a_new_one(make_sim):
    """r2d2 loaded, stepped and removed 40 times in one Sim, then loaded again: its drive is
    bit for bit the one in a new Sim (PyBullet's world, renewed after 32 removals, kept its
    gravity, time step and solver settings), and time went on."""

    def drive(sim):
        robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
        sim.set_joint_velocity(robot, [2, 3, 6, 7], -5.0, max_force=10.0)
        sim.step(60)
        return robot, sim.base_state(robot), sim.joint_states(robot).velocities.tolist()

    fresh = make_sim()
    _, expected_base, expected_joints = drive(fresh)
    sim = make_sim()
    for _ in range(40):
        robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
        sim.step(2)
        sim.remove(robot)
    robot, base, joints = drive(sim)
    assert robot == 0
    assert base == expected_base and joints == expected_joints
    assert sim.time == pytest.approx(140 / 240)
