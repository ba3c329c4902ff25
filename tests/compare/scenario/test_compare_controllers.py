"""Controllers in scenarios: from files and modules, their params, their control period, a fresh
one per run and phase, from Python, in ensemble workers, and every way a controller can fail.

Real engines on a real URDF: the shipped pendulum (robots/pendulum.urdf, one continuous joint
``hinge``, fixed base, no contact), a few dozen steps per run."""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np
import pytest

from simbridge.compare import (
    ControllerError,
    ControllerSpec,
    Phase,
    load_scenario,
    loads_scenario,
    run,
)
from simbridge.compare.errors import ScenarioError
from simbridge.compare.run.ensemble import run_ensembles
from simbridge.compare.scenario import dumps_scenario
from simbridge.exceptions import InvalidArgumentError

DT = 1 / 240

CONTROLLER = '''\
"""Test controllers: each sets the hinge's velocity target from what it was given."""

import math

made = []  # every instance, in the order made (this process)


class Echo:
    """Sets the hinge's velocity target to the time of each call (so the recording shows
    when it was called) plus `offset`."""

    def __init__(self, offset=0.0, max_force=5.0):
        self.offset, self.max_force = offset, max_force
        self.calls = []
        self.robots = None
        made.append(self)

    def start(self, sim, robots, time):
        self.robots = dict(robots)
        self.body = robots["pendulum"]
        self.started = time

    def step(self, sim, time):
        self.calls.append(time)
        sim.set_joint_velocity(self.body, "hinge", time + self.offset, max_force=self.max_force)


class Raises:
    def __init__(self, when=0.05):
        self.when = when

    def start(self, sim, robots, time):
        self.body = robots["pendulum"]

    def step(self, sim, time):
        if time >= self.when:
            raise ZeroDivisionError("the gain was zero")
        sim.set_joint_velocity(self.body, "hinge", 1.0, max_force=5.0)


class Returns:
    def step(self, sim, time):
        return [1.0, 2.0]


class WrongJoint:
    def start(self, sim, robots, time):
        self.body = robots["pendulum"]

    def step(self, sim, time):
        sim.set_joint_velocity(self.body, "elbow", 1.0, max_force=5.0)


class SetsNaN:
    def start(self, sim, robots, time):
        self.body = robots["pendulum"]

    def step(self, sim, time):
        target = math.nan if time > 0.02 else 0.5
        sim.set_joint_position(self.body, "hinge", target, max_force=5.0)


class Steps:
    def step(self, sim, time):
        sim.step()


class NoStep:
    def control(self, sim, time):
        pass


class Torque:
    """A constant torque, released brake first: held by the run between control steps."""

    def __init__(self, torque=0.2):
        self.torque = torque

    def start(self, sim, robots, time):
        self.body = robots["pendulum"]
        sim.set_joint_velocity(self.body, "hinge", 0.0, max_force=0.0)

    def step(self, sim, time):
        sim.set_joint_torque(self.body, "hinge", self.torque)


def not_a_class_attribute():
    pass
'''

SCENARIO = """\
name = "ctl"
timestep = "1/240"

[[robots]]
name = "pendulum"
urdf = "pendulum.urdf"
fixed_base = true
position = [0.0, 0.0, 1.0]

[[phases]]
name = "first"
steps = {steps}
[phases.controller]
class = "{ref}"
every = {every}
[phases.controller.params]
{params}
"""


def write(
    tmp_path: Path,
    ref: str = "ctrl.py:Echo",
    every: int = 1,
    steps: int = 24,
    params: str = "offset = 0.0",
    extra: str = "",
) -> Path:
    (tmp_path / "ctrl.py").write_text(CONTROLLER)
    path = tmp_path / "scenario.toml"
    path.write_text(SCENARIO.format(steps=steps, ref=ref, every=every, params=params) + extra)
    return path


def made(tmp_path: Path) -> list:
    from simbridge.compare.scenario.controllers import load_object

    return load_object(f"{tmp_path / 'ctrl.py'}:made")


# ---------------------------------------------------------------- from files and modules


@pytest.mark.parametrize("backend", ["pybullet", "mujoco"])
def test_a_controller_from_a_file_beside_the_scenario_drives_the_run(tmp_path, backend):
    sc = load_scenario(write(tmp_path, params="offset = 2.0"))
    assert sc.closed_loop and sc.phases[0].controller.ref == f"{tmp_path / 'ctrl.py'}:Echo"
    tr = run(sc, backend)
    # every step: the target held during step k (row k + 1) is the time of its start + offset
    targets = tr.body.joint_targets[1:, 0]
    assert targets == pytest.approx(np.arange(24) * DT + 2.0, abs=0)
    assert (tr.body.joint_modes[1:, 0] == 1).all() and math.isnan(tr.body.joint_targets[0, 0])
    assert (tr.body.joint_max_forces[1:, 0] == 5.0).all()  # the controller's max_force
    # the motor follows (5 N·m against the bob's weight: 1.92 rad/s on both engines)
    assert 1.8 < tr.body.joint_velocities[-1, 0] < targets[-1]


def test_a_controller_from_a_module_on_sys_path(tmp_path, monkeypatch):
    pkg = tmp_path / "lib" / "mycontrol"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "hinge.py").write_text(CONTROLLER)
    monkeypatch.syspath_prepend(str(tmp_path / "lib"))
    (tmp_path / "sc").mkdir()
    path = write(tmp_path / "sc", ref="mycontrol.hinge:Echo", params="offset = -1.5")
    sc = load_scenario(path)
    assert sc.phases[0].controller.ref == "mycontrol.hinge:Echo"
    tr = run(sc, "pybullet")
    assert tr.body.joint_targets[1:, 0] == pytest.approx(np.arange(24) * DT - 1.5, abs=0)


def test_params_reach_the_controller_and_it_is_told_the_robots(tmp_path):
    sc = load_scenario(write(tmp_path, params="offset = 0.25\nmax_force = 0.5"))
    before = len(made(tmp_path))
    run(sc, "pybullet")
    (ctl,) = made(tmp_path)[before:]
    assert (ctl.offset, ctl.max_force) == (0.25, 0.5)
    assert ctl.robots == {"pendulum": 0}  # by scenario name: the body id
    assert ctl.started == 0.0


def test_the_control_period_is_honoured(tmp_path):
    sc = load_scenario(write(tmp_path, every=5, steps=23))
    before = len(made(tmp_path))
    tr = run(sc, "pybullet")
    (ctl,) = made(tmp_path)[before:]
    # called before steps 0, 5, 10, 15, 20 of the phase, with the time of each
    assert ctl.calls == pytest.approx([k * DT for k in (0, 5, 10, 15, 20)], abs=0)
    # a velocity command persists: step k holds the last call's target
    held = tr.body.joint_targets[1:, 0]
    assert held == pytest.approx([5 * (k // 5) * DT for k in range(23)], abs=0)


def test_a_torque_is_held_until_the_next_control_step(tmp_path):
    held = load_scenario(write(tmp_path, ref="ctrl.py:Torque", every=4, params="torque = 0.2"))
    every = load_scenario(write(tmp_path, ref="ctrl.py:Torque", every=1, params="torque = 0.2"))
    a, b = run(held, "pybullet"), run(every, "pybullet")
    assert (a.body.joint_modes[1:, 0] == 3).all()
    assert a.body.joint_targets[1:, 0] == pytest.approx(0.2, abs=0)
    # the same torque every step, whether sent by the controller or held by the run
    assert a.body.joint_positions == pytest.approx(b.body.joint_positions, abs=0)
    assert abs(a.body.joint_velocities[-1, 0]) > 0.01  # it moved


def test_a_fresh_controller_per_phase_and_per_run(tmp_path):
    extra = textwrap.dedent(
        """
        [[phases]]
        name = "second"
        steps = 10
        [phases.controller]
        class = "ctrl.py:Echo"
        [phases.controller.params]
        offset = 7.0
        """
    )
    sc = load_scenario(write(tmp_path, steps=12, extra=extra))
    before = len(made(tmp_path))
    run(sc, "pybullet")
    run(sc, "pybullet")
    fresh = made(tmp_path)[before:]
    assert len(fresh) == 4 and len({id(c) for c in fresh}) == 4
    first, second = fresh[0], fresh[1]
    assert len(first.calls) == 12 and first.calls[0] == 0.0
    assert second.started == pytest.approx(12 * DT, abs=0) and second.offset == 7.0
    assert second.calls == pytest.approx([(12 + k) * DT for k in range(10)], abs=0)


class PyHold:
    """A controller defined in this test module (found again by its module's file)."""

    def __init__(self, target=0.3):
        self.target = target

    def start(self, sim, robots, time):
        self.body = robots["pendulum"]

    def step(self, sim, time):
        sim.set_joint_position(self.body, "hinge", self.target, max_force=20.0)


class SpinAt:
    """Drives the hinge at 1 rad/s (a velocity motor)."""

    def start(self, sim, robots, time):
        self.body = robots["pendulum"]

    def step(self, sim, time):
        sim.set_joint_velocity(self.body, "hinge", 1.0, max_force=5.0)


def test_a_controller_holds_its_command_against_the_phases_own_between_calls():
    # the shipped pendulum's phase re-sends "hinge: velocity 0, max_force 0" (released) before
    # every step; the controller, called every 4 steps, must still drive the hinge throughout
    tr = run("pendulum", "pybullet", controller=ControllerSpec.of(SpinAt, every=4), duration=0.5)
    assert tr.body.joint_targets[1:, 0] == pytest.approx(1.0, abs=0)
    assert tr.body.joint_velocities[-1, 0] == pytest.approx(1.0, abs=1e-3)
    free = run("pendulum", "pybullet", duration=0.5)  # released: it swings down from 0.5 rad
    assert free.body.joint_velocities[-1, 0] < -1.0


def test_from_python_run_takes_a_class_or_a_spec_and_a_scenario_object(tmp_path):
    sc = load_scenario(write(tmp_path))
    a = run(sc, "mujoco", controller=ControllerSpec.of(PyHold, {"target": 0.3}, 2))
    assert (a.body.joint_modes[1:, 0] == 2).all()
    assert a.body.joint_targets[1:, 0] == pytest.approx(0.3, abs=0)
    # the same from a Scenario object made in Python
    spec = ControllerSpec.of(PyHold, {"target": 0.3}, 2)
    made_here = sc.__class__(
        name="py",
        robots=sc.robots,
        phases=(Phase("hold", 24, controller=spec),),
        subject="pendulum",
    )
    b = run(made_here, "mujoco")
    assert b.body.joint_positions == pytest.approx(a.body.joint_positions, abs=0)
    # a class alone: params default, every step
    c = run(sc, "mujoco", controller=PyHold)
    assert c.body.joint_targets[1:, 0] == pytest.approx(0.3, abs=0)


def test_an_instance_or_a_local_class_is_refused():
    class Local:
        def step(self, sim, time):
            pass

    with pytest.raises(InvalidArgumentError, match="made fresh for every run"):
        ControllerSpec.of(PyHold())
    with pytest.raises(InvalidArgumentError, match="inside a function"):
        ControllerSpec.of(Local)
    with pytest.raises(InvalidArgumentError, match="every"):
        ControllerSpec.of(PyHold, every=0)


def test_ensemble_workers_make_the_controller_from_its_file(tmp_path):
    extra = textwrap.dedent(
        """
        [[outcomes]]
        name = "spins up"
        kind = "track"
        joints = ["hinge"]
        quantity = "velocity"
        max = 0.5
        """
    )
    sc = load_scenario(write(tmp_path, params="offset = 1.0", extra=extra))
    (ens,) = run_ensembles(sc, [("pybullet", "pybullet")], "joint_velocity_rms", size=3, workers=2)
    assert len(ens.outcomes) == 3
    nominal = run(sc, "pybullet").outcomes["spins up"]
    for member in ens.outcomes:  # measured in each worker on its own run
        record = member["spins up"]
        assert record.figures.samples == 24 and record.success is True
        assert record.value == pytest.approx(nominal.value, rel=1e-6)


def test_with_timestep_keeps_the_control_period_in_seconds(tmp_path):
    sc = load_scenario(write(tmp_path, every=3, steps=24))
    assert sc.with_timestep(DT / 2).phases[0].controller.every == 6
    with pytest.raises(ScenarioError, match=r"controller\.every.*not a whole number"):
        sc.with_timestep(DT * 2)


def test_round_trip_keeps_controllers(tmp_path):
    sc = load_scenario(write(tmp_path, every=3, params='offset = 0.5\nname = "x"\nlist = [1, 2]'))
    again = loads_scenario(dumps_scenario(sc))
    assert again == sc
    assert again.phases[0].controller.params == {"offset": 0.5, "name": "x", "list": [1, 2]}


# ---------------------------------------------------------------- bad controllers


FIRST_AFTER_50_MS = next(k for k in range(100) if k * DT >= 0.05)  # a step's start time


def _fails(tmp_path, ref: str, params: str = "", steps: int = 24) -> ControllerError:
    sc = load_scenario(write(tmp_path, ref=ref, params=params, steps=steps))
    with pytest.raises(ControllerError) as info:
        run(sc, "pybullet")
    err = info.value
    assert isinstance(err, ScenarioError)
    assert err.file == str(tmp_path / "scenario.toml") and err.key == "phases[0].controller"
    assert err.phase == "first" and "ctrl.py:" in err.controller
    assert f"controller {err.controller} in phase 'first' at t = " in str(err)
    return err


def test_a_controller_that_raises_names_itself_the_phase_and_the_time(tmp_path):
    err = _fails(tmp_path, "ctrl.py:Raises", "when = 0.05")
    first = FIRST_AFTER_50_MS  # the first step whose start time reaches 0.05 s
    assert err.time == pytest.approx(first * DT, abs=0)
    assert "step() raised ZeroDivisionError: the gain was zero" in str(err)
    assert isinstance(err.__cause__, ZeroDivisionError)
    # the run recorded up to there: the initial state and the steps taken before the failure
    tr = err.trajectory
    assert tr is not None and len(tr.time) == first + 1 and tr.time[-1] == err.time
    assert tr.phases == [("first", 0, first)]
    assert tr.body.joint_targets[1:, 0] == pytest.approx(1.0, abs=0)
    assert np.isfinite(tr.body.joint_positions).all()


def test_a_controller_that_returns_something(tmp_path):
    err = _fails(tmp_path, "ctrl.py:Returns")
    assert err.time == 0.0 and "step() returned [1.0, 2.0]" in str(err)
    assert "returns None" in str(err)
    assert len(err.trajectory.time) == 1  # stopped before the first step


def test_a_controller_that_commands_a_joint_that_does_not_exist(tmp_path):
    err = _fails(tmp_path, "ctrl.py:WrongJoint")
    assert "UnknownJointError" in str(err) and "'elbow'" in str(err) and "hinge" in str(err)


def test_a_controller_that_sends_nan(tmp_path):
    err = _fails(tmp_path, "ctrl.py:SetsNaN")
    assert err.time == pytest.approx(5 * DT, abs=0)  # the first call after 0.02 s
    assert "InvalidArgumentError" in str(err) and "nan" in str(err).lower()
    assert len(err.trajectory.time) == 6
    assert np.isfinite(err.trajectory.body.joint_positions).all()


def test_a_controller_that_steps_the_world_or_has_no_step(tmp_path):
    err = _fails(tmp_path, "ctrl.py:Steps")
    assert "sim.step()" in str(err) and "commands joints only" in str(err)
    err = _fails(tmp_path, "ctrl.py:NoStep")
    assert "has no step(sim, time) method" in str(err)


def test_params_it_does_not_take(tmp_path):
    err = _fails(tmp_path, "ctrl.py:Echo", "gain = 3.0")
    assert "making it with params {'gain': 3.0} raised TypeError" in str(err)


def test_a_file_or_module_that_cannot_be_found_names_the_path_and_the_rule(tmp_path):
    with pytest.raises(ScenarioError) as info:
        load_scenario(write(tmp_path, ref="missing.py:GoTo"))
    msg = str(info.value)
    assert info.value.key == "phases[0].controller.class" and info.value.line == 14
    assert f"no such file {str(tmp_path / 'missing.py')!r}" in msg
    assert "relative to the scenario's folder" in msg
    with pytest.raises(ScenarioError) as info:
        load_scenario(write(tmp_path, ref="no_such_package.control:GoTo"))
    msg = str(info.value)
    assert "no module named 'no_such_package'" in msg and "imported from sys.path" in msg
    with pytest.raises(ScenarioError, match="has no 'Nope'; it defines: .*Echo"):
        load_scenario(write(tmp_path, ref="ctrl.py:Nope"))
    with pytest.raises(ScenarioError, match="expected 'file.py:Name'"):
        load_scenario(write(tmp_path, ref="ctrl.py"))


def test_a_file_that_fails_to_import(tmp_path):
    path = write(tmp_path, ref="broken.py:X")
    (tmp_path / "broken.py").write_text("raise RuntimeError('half written')\n")
    with pytest.raises(ScenarioError, match="importing .*broken.py' failed: RuntimeError"):
        load_scenario(path)


def test_a_bad_controller_leaves_no_report_behind(tmp_path, capsys):
    from simbridge.cli import main

    path = write(tmp_path, ref="ctrl.py:Raises", params="when = 0.05")
    out = tmp_path / "report"
    code = main(["compare", str(path), "--out", str(out), "--ensemble", "1", "--no-plots"])
    assert code == 1
    err = capsys.readouterr().err
    assert (
        f"controller ctrl.py:Raises in phase 'first' at t = {FIRST_AFTER_50_MS * DT:.6g} s" in err
    )
    assert not out.exists() or list(out.iterdir()) == []


def test_compare_takes_a_controller_for_every_run():
    from simbridge.compare import compare

    c = compare("pendulum", ["pybullet", "mujoco"], ensemble=1, duration=0.1, controller=SpinAt)
    assert c.scenario.closed_loop
    for tr in c.runs.values():  # both engines, at dt and dt/2
        assert tr.body.joint_targets[1:, 0] == pytest.approx(1.0, abs=0)


def test_a_controller_error_pickles_with_its_fields(tmp_path):
    import pickle

    err = _fails(tmp_path, "ctrl.py:Returns")
    again = pickle.loads(pickle.dumps(err))
    assert isinstance(again, ControllerError) and str(again) == str(err)
    assert (again.controller, again.phase, again.time) == (err.controller, "first", 0.0)
    assert again.trajectory is None  # the recording stays with the original
