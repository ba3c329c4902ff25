"""The MuJoCo backend's compiled step loop (backends/_mjkernel.c) against its Python reference.

Both loops do the same arithmetic in the same order; they may differ only in round-off (the
kernel sums the 3x3 rotations and solves the motor rows' small linear systems in its own order;
numpy uses einsum and LAPACK). Each scenario runs on both and compares every coordinate of the
state (qpos, qvel, motor impulses) at every step. Measured (2026-11-23, `pytest -s` prints it):
0 to 2e-11 in the trajectories, 1e-14 step by step in r2d2's tutorial drive. The tolerance,
1e-9, is far above round-off and far below what a wrong term does (a damping sign, a missed
offset, a torque kept for two steps moves the state by 1e-4 or more within 10 steps). The
tutorial drive is chaotic and is compared step by step from the same state instead
(test_r2d2_drive_step_by_step).
"""

from __future__ import annotations

import os
import shutil
import sys
import sysconfig
from pathlib import Path

import mujoco
import numpy as np
import pytest

import simbridge
from simbridge.backends.mujoco import kernel as mujoco_kernel
from simbridge.backends.mujoco.inspect import compiled
from simbridge.exceptions import SimBusyError, SimulationDivergedError
from simbridge.profiles import get_profile

WHEELS = [2, 3, 6, 7]
requires_kernel = pytest.mark.skipif(
    mujoco_kernel.reason() != "", reason=f"no compiled loop: {mujoco_kernel.reason()}"
)
TOL = 0.0  # the loops do the same arithmetic in the same order (solve.py): bit for bit


def _compiler() -> str | None:
    cc = (sysconfig.get_config_var("CC") or "cc").split()[0]
    return shutil.which(cc) or shutil.which("cc") or shutil.which("gcc")


def test_kernel_is_built_and_used_where_a_compiler_exists():
    if _compiler() is None:  # pragma: no cover - machines without a C compiler
        pytest.skip("no C compiler: the package installs with the Python step loop")
    if os.environ.get(mujoco_kernel.ENV) == "python":
        pytest.skip(f"{mujoco_kernel.ENV}=python chooses the Python loop for this run")
    assert mujoco_kernel.reason() == "", mujoco_kernel.reason()
    with simbridge.Sim("mujoco") as sim:
        assert compiled(sim).kernel is not None
        assert sim.manifest()["step_loop"].startswith("compiled")


def test_the_loop_records_the_mujoco_it_was_built_against():
    assert mujoco_kernel._version(4000000) == "4.0.0"  # MuJoCo 4's header number (mujoco.h)
    assert mujoco_kernel._version(331) == "3.3.1"  # MuJoCo 3's: one digit each
    if _compiler() is None:  # pragma: no cover - machines without a C compiler
        pytest.skip("no C compiler: no compiled loop to ask")
    # setup.py compiles the build environment's mujoco release in (MUJOCO_RELEASE)
    running = mujoco.__version__
    assert mujoco_kernel.built_against() == running
    assert mujoco_kernel.describe() == (
        f"step loop: compiled (C), built against MuJoCo {running} (running {running})"
    )


def test_environment_variable_selects_the_python_loop(monkeypatch):
    monkeypatch.setenv(mujoco_kernel.ENV, "python")
    with simbridge.Sim("mujoco") as sim:
        assert compiled(sim).kernel is None
        assert sim.manifest()["step_loop"] == f"Python ({mujoco_kernel.ENV}=python)"


def _select_loop(monkeypatch, loop: str) -> None:
    if loop == "python":
        monkeypatch.setenv(mujoco_kernel.ENV, "python")
    else:
        monkeypatch.delenv(mujoco_kernel.ENV, raising=False)


def _trajectory(monkeypatch, loop: str, scenario, profile: str = "pybullet") -> list[np.ndarray]:
    _select_loop(monkeypatch, loop)
    states: list[np.ndarray] = []
    with simbridge.Sim("mujoco", profile=profile) as sim:
        assert (compiled(sim).kernel is None) == (loop == "python")

        def record() -> None:
            d = compiled(sim).d
            motor_forces = d.efc_force[: compiled(sim).motors.n_rows]
            states.append(np.concatenate([d.qpos, d.qvel, motor_forces * compiled(sim).dt]))

        scenario(sim, record)
    return states


def _agree(monkeypatch, scenario, profile: str = "pybullet", tol: float = TOL) -> float:
    if mujoco_kernel.reason():
        pytest.skip(f"no compiled loop: {mujoco_kernel.reason()}")
    a = _trajectory(monkeypatch, "kernel", scenario, profile)
    b = _trajectory(monkeypatch, "python", scenario, profile)
    assert len(a) == len(b) and len(a) > 10
    assert [x.shape for x in a] == [x.shape for x in b]
    gap = max(float(np.abs(x - y).max()) for x, y in zip(a, b, strict=True))
    print(f"kernel against Python loop: largest gap {gap:.3g}")
    assert gap <= tol, gap
    return gap


def _tutorial_sim(profile: str) -> tuple:
    sim = simbridge.Sim("mujoco", profile=profile)
    sim.load_urdf("plane.urdf")
    return sim, sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.1))


@requires_kernel
@pytest.mark.parametrize("profile", ["pybullet", "urdf"])
def test_r2d2_drive_step_by_step(monkeypatch, profile):
    """The tutorial drive is chaotic (r2d2 thrown up from 0.37 m into the ground, then hopping):
    a 1e-13 difference flips a grazing contact some hundred steps later and grows to 1e-6 by
    the end (measured) when the loops' arithmetic differs at all. So the two loops are compared
    step by step: before every step the Python loop's world is set to the compiled loop's
    (mj_copyData: positions, velocities, warm start, contacts), both take the same step, and
    the states and motor impulses after it must agree to TOL."""
    import mujoco

    _select_loop(monkeypatch, "kernel")
    a, ra = _tutorial_sim(profile)
    _select_loop(monkeypatch, "python")
    b, rb = _tutorial_sim(profile)
    try:
        assert compiled(a).kernel is not None and compiled(b).kernel is None
        worst = 0.0
        for k in range(980):
            for sim, robot in ((a, ra), (b, rb)):
                if k >= 240:
                    if k < 480:
                        sim.set_joint_velocity(robot, WHEELS, [-100, -100, 100, 100], max_force=50)
                    else:
                        sim.set_joint_velocity(robot, WHEELS, -100.0, max_force=10)
            mujoco.mj_copyData(compiled(b).d, compiled(b).m, compiled(a).d)
            a.step()
            b.step()
            da, db = compiled(a).d, compiled(b).d
            n = compiled(a).motors.n_rows
            gap = max(
                float(np.abs(da.qpos - db.qpos).max()),
                float(np.abs(da.qvel - db.qvel).max()),
                float(np.abs(da.efc_force[:n] - db.efc_force[:n]).max(initial=0.0))
                * compiled(a).dt,
            )
            worst = max(worst, gap)
        print(f"kernel against Python loop, step by step: largest gap {worst:.3g}")
        assert worst <= TOL, worst
    finally:
        a.close()
        b.close()


def _new_target_every_step(sim, record) -> None:
    # a policy's loop: a new velocity target and force on the wheels at every step (the
    # command's hot path, in C on the compiled loop and in numpy on the Python one)
    sim.load_urdf("plane.urdf")
    r = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
    wheels = np.array(WHEELS)
    for k in range(400):
        phase = 0.05 * k
        target = np.array([np.sin(phase), np.cos(phase), -np.sin(phase), 0.5]) * 20.0
        sim.set_joint_velocity(r, wheels, target, max_force=[5.0 + k % 7, 5.0, 8.0, 3.0])
        sim.step()
        record()
    assert compiled(sim).fast  # the hot path was the one taken


def test_new_target_every_step(monkeypatch):
    _agree(monkeypatch, _new_target_every_step)


def _kuka_position_torque_damping(sim, record) -> None:
    # position motors with kd != 1 (the split step's qacc_smooth term), joint damping from the
    # file, one-step torques, link damping on a fixed base
    arm = sim.load_urdf("kuka_iiwa/model.urdf", fixed_base=True)
    joints = list(range(7))
    sim.set_joint_position(
        arm, joints, [0.5, -0.4, 0.3, 1.0, -0.2, 0.6, 0.1], max_force=200, kp=0.2, kd=0.7
    )
    for k in range(300):
        if k == 150:
            sim.set_joint_velocity(arm, [0, 1], 0.0, max_force=0.0)  # release two joints
        if k % 7 == 0:
            sim.set_joint_torque(arm, [0, 1, 5], [3.0, -2.0, 0.5])
        sim.step()
        record()


@pytest.mark.parametrize("profile", ["pybullet", "urdf"])
def test_kuka_position_motors_torques_and_damping(monkeypatch, profile):
    _agree(monkeypatch, _kuka_position_torque_damping, profile)


def _spherical_motors(sim, record) -> None:
    # spherical joints: PyBullet's motor at load (kp 0.2 to the identity) on a humanoid's eight,
    # position motors with gains and forces per axis, a brake, torques, and a free swing
    h = sim.load_urdf("humanoid/humanoid.urdf", base_position=(0, 0, 3), fixed_base=True)
    b = sim.load_urdf("spherical_pendulum.urdf", base_position=(2, 0, 1), fixed_base=True)
    tilt = (0.29, -0.21, 0.12, 0.9253)
    sim.reset_joint_state_multi_dof(b, "ball", tilt, (1.5, -0.7, 2.0))
    sim.set_joint_position(
        h,
        ["neck", "left_hip"],
        [(0.2, 0.0, 0.0, 0.98), (0.0, 0.4, 0.1, 0.91)],
        max_force=[50.0, 20.0, 10.0],
        kp=[0.3, 0.2, 0.1],
        kd=0.8,
    )
    sim.set_joint_position(b, "ball", (0.0, 0.0, 0.0, 1.0), max_force=0.5, kp=0.4)
    for k in range(30):
        sim.set_joint_torque(h, "chest", [1.0, -2.0, 0.5 * k])
        sim.step()
        record()
    sim.set_joint_velocity(b, "ball", 0.0, max_force=[0.05, 0.03, 0.0])
    sim.set_joint_velocity(h, "right_shoulder", 0.0, max_force=0.0)
    for _ in range(30):
        sim.step()
        record()


@pytest.mark.parametrize("profile", ["pybullet", "urdf"])
def test_spherical_motors_and_torques(monkeypatch, profile):
    _agree(monkeypatch, _spherical_motors, profile)


def _speed_clamp(sim, record) -> None:
    # a motor asking 150 rad/s is held to PyBullet's 100 by the clamp in the split step
    wheel = sim.load_urdf("wheel.urdf", fixed_base=True)
    sim.set_joint_velocity(wheel, "axle", 150.0, max_force=1000.0)
    for _ in range(60):
        sim.step()
        record()
    assert abs(sim.joint_states(wheel, "axle").velocities[0]) == pytest.approx(100.0, rel=1e-9)


def test_speed_clamp(monkeypatch):
    _agree(monkeypatch, _speed_clamp)


def _robots_added_and_removed(sim, record) -> None:
    # each compile binds the kernel afresh: a robot added and one removed mid-run
    sim.load_urdf("plane.urdf")
    a = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
    sim.set_joint_velocity(a, WHEELS, 5.0, max_force=20)
    for _ in range(40):
        sim.step(2)
        record()
    b = sim.load_urdf("pendulum.urdf", base_position=(2, 0, 1), fixed_base=True)
    for _ in range(40):
        sim.step()
        record()
    sim.remove(a)
    sim.set_joint_velocity(b, 0, 1.0, max_force=5)
    for _ in range(40):
        sim.step()
        record()


def test_robots_added_and_removed(monkeypatch):
    _agree(monkeypatch, _robots_added_and_removed)


def test_torque_of_a_multi_step_call_acts_in_the_first_step_only(monkeypatch):
    def scenario(sim, record) -> None:
        body = sim.load_urdf("wheel.urdf", fixed_base=True)
        sim.set_joint_velocity(body, "axle", 0.0, max_force=0.0)
        sim.set_joint_torque(body, "axle", 2.0)
        sim.step(5)
        record()
        sim.step(5)
        record()
        for _ in range(9):
            sim.step()
            record()

    _agree(monkeypatch, scenario)


@pytest.mark.parametrize("n", [1, 300])
@pytest.mark.parametrize("loop", ["kernel", "python"])
def test_divergence_is_reported_by_either_loop_at_its_step(monkeypatch, loop, n):
    """MuJoCo's warning (a bad speed: it puts the state back to the reference pose) stops
    either loop after that step: the time is that step's, not the end of the call; a
    divergence in the last step of a call is reported too (the Python loop let step(1) pass
    it, and a control loop of step(1) calls never heard of it)."""
    if loop == "kernel" and mujoco_kernel.reason():
        pytest.skip(f"no compiled loop: {mujoco_kernel.reason()}")
    _select_loop(monkeypatch, loop)
    with simbridge.Sim("mujoco") as sim:
        body = sim.load_urdf("wheel.urdf", fixed_base=True)
        sim.set_joint_velocity(body, "axle", 0.0, max_force=0.0)
        sim.step(2)
        # a state no command can make: only the loop's check sees it
        compiled(sim).d.qvel[:] = np.inf
        with pytest.raises(SimulationDivergedError, match=r"t=0\.012500 s: .*velocities"):
            sim.step(n)
        assert sim.time == pytest.approx(3 * sim.timestep, abs=1e-12)
        with pytest.raises(SimulationDivergedError, match="velocities"):
            sim.joint_states(body)


@requires_kernel
def test_bad_bindings_raise_instead_of_crashing():
    with simbridge.Sim("mujoco") as sim:
        sim.load_urdf("wheel.urdf", fixed_base=True)
        k = compiled(sim).kernel
        ints = np.zeros(1, np.intp)
        floats = np.zeros(1)
        none = np.zeros(0, np.intp)
        nonef = np.zeros(0)
        with pytest.raises(TypeError, match="dof_rows"):
            k.bind_motors(floats, none, none, nonef, none, none, nonef, floats, floats)
        with pytest.raises(ValueError, match="out of range"):
            k.bind_motors(floats, none, none, nonef, none, none, nonef, ints + 99, floats)
        with pytest.raises(ValueError, match="expected 1 elements"):
            k.bind_motors(nonef, none, none, nonef, none, none, nonef, ints, floats)
        k.bind_motors(floats, none, none, nonef, none, none, nonef, ints, floats)
        index = np.zeros(3, np.intp)  # motor slot 0, row 0, dof 0
        with pytest.raises(ValueError, match="out of range"):
            k.set_velocity(index + 5, [1.0], [1.0])
        with pytest.raises(ValueError, match="lists of n floats"):
            k.set_velocity(index, (1.0,), [1.0])
        with pytest.raises(TypeError):
            k.set_velocity(index, ["fast"], [1.0])
        k.set_velocity(index, [2.0], [3.0])
        c = compiled(sim)
        assert c.motors.max_force[0] == 3.0 and c.m.dof_frictionloss[0] == 3.0
        with pytest.raises(ValueError, match="out of the model's range"):
            k.bind_world(0, nonef, nonef, ints + 50, floats, none, nonef, None, 1.0, 0.0, 1.0)
        with pytest.raises(ValueError, match="15 addresses"):
            type(k)(None, None, 1, 1, (), 0.01)
        with pytest.raises(ValueError, match="null"):
            type(k)(None, None, 0, 0, (1,) * 15, 0.01)


def _link_states(monkeypatch, loop: str) -> list:
    _select_loop(monkeypatch, loop)
    with simbridge.Sim("mujoco") as sim:
        sim.load_urdf("plane.urdf")
        r = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
        sim.set_joint_velocity(r, WHEELS, [-5, -5, 5, 5], max_force=20)
        out = []
        for _ in range(5):
            sim.step(7)
            out.append(sim.base_state(r))
            out.extend(sim.link_state(r, j) for j in range(-1, sim.num_joints(r)))
        return out


@requires_kernel
def test_link_and_base_state_read_through_the_kernel_as_in_python(monkeypatch):
    a = _link_states(monkeypatch, "kernel")
    b = _link_states(monkeypatch, "python")
    assert len(a) == len(b) == 5 * (1 + 16)  # base_state, then links -1 .. 15
    for x, y in zip(a, b, strict=True):
        assert type(x) is type(y)
        np.testing.assert_allclose(
            np.concatenate([np.ravel(f) for f in x]),
            np.concatenate([np.ravel(f) for f in y]),
            rtol=0,
            atol=1e-12,
        )


@requires_kernel
def test_body_state_checks_its_arguments():
    with simbridge.Sim("mujoco") as sim:
        sim.load_urdf("wheel.urdf", fixed_base=True)
        k = compiled(sim).kernel
        with pytest.raises(ValueError, match="float64 array of 20"):
            k.body_state(1, True, np.zeros(13))
        with pytest.raises(ValueError, match="body id 99"):
            k.body_state(99, True, np.zeros(20))
        out = np.zeros(20)
        assert k.body_state(1, True, out) is True
        assert np.linalg.norm(out[3:7]) == pytest.approx(1.0)


# ---------------------------------------------------------------- engine errors, threads

_ENGINE_ERROR_SCRIPT = """
import simbridge
from simbridge.exceptions import EngineError
sim = simbridge.Sim("mujoco")
sim.load_urdf("plane.urdf")
from simbridge.backends.mujoco.inspect import world_spec
world_spec(sim).memory = 60_000  # a world too large for its memory: MuJoCo's stack overflows
for i in range(30):
    sim.load_urdf("cube_small.urdf", base_position=(0, 0, 0.05 + 0.03 * i))
print(sim.manifest()["step_loop"])
try:
    sim.step(1000)
except EngineError as exc:
    print("first", exc)
try:
    sim.step(1)
except EngineError:
    print("refused")
sim.reset()
sim.load_urdf("plane.urdf")
sim.step(10)
print("after reset", sim.time)
sim.close()
"""


@pytest.mark.parametrize("loop", ["kernel", "python"])
def test_an_engine_error_raises_instead_of_ending_the_process(tmp_path, loop):
    """MuJoCo's own error handler prints and calls exit(); inside the compiled loop a MuJoCo
    error (here a stack overflow) must come back as EngineError, on both loops alike, the
    world must refuse to go on until reset(), and no MUJOCO_LOG.TXT may be left behind. Run in
    a child process: a regression would end the process, not fail a test."""
    import subprocess

    if loop == "kernel" and mujoco_kernel.reason():
        pytest.skip(f"no compiled loop: {mujoco_kernel.reason()}")
    env = dict(os.environ)
    env.pop(mujoco_kernel.ENV, None)
    if loop == "python":
        env[mujoco_kernel.ENV] = "python"
    run = subprocess.run(
        [sys.executable, "-c", _ENGINE_ERROR_SCRIPT],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    out = run.stdout
    assert out.startswith("compiled" if loop == "kernel" else "Python")
    # the same step fails on both loops (17 steps ran: t = 17/240 s), with MuJoCo's message
    first = out[out.index("first ") : out.index("refused")]
    assert first.startswith("first backend 'mujoco' stopped with an engine error at t=0.070833")
    assert "mj_stackAlloc: out of memory" in first and "reset() or close" in first
    assert out.endswith(f"refused\nafter reset {10 / 240}\n")
    assert os.listdir(tmp_path) == []


def _drive_in_thread(sims, n: int = 300) -> None:
    for sim, robot in sims:
        sim.set_joint_velocity(robot, WHEELS, [-5, -5, 5, 5], max_force=20)
        sim.step(n)


def _r2d2() -> tuple:
    sim = simbridge.Sim("mujoco")
    sim.load_urdf("plane.urdf")
    return sim, sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))


@requires_kernel
def test_sims_in_threads_step_as_they_do_alone():
    """The compiled loop runs without the GIL: Sims in two threads step at once and end in
    exactly the state they reach one after the other."""
    import threading

    alone = [_r2d2() for _ in range(2)]
    together = [_r2d2() for _ in range(2)]
    try:
        _drive_in_thread(alone)
        threads = [threading.Thread(target=_drive_in_thread, args=([w],)) for w in together]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        for (a, _), (b, _) in zip(alone, together, strict=True):
            assert a.time == b.time
            assert np.array_equal(compiled(a).d.qpos, compiled(b).d.qpos)
            assert np.array_equal(compiled(a).d.qvel, compiled(b).d.qvel)
    finally:
        for sim, _ in alone + together:
            sim.close()


class _HeldStep:
    """A step(n) run in another thread and held inside its first step until the block ends: a
    MuJoCo control callback (``mjcb_control``, called by MuJoCo in every step, on both loops)
    waits there in the stepping thread. The Sim is then known to be stepping for as long as
    the test needs, on a fast machine as on a slow or loaded one (20,000 steps had to outlast
    the test's calls: about 0.25 s here, less on a faster machine)."""

    def __init__(self, sim, n: int) -> None:
        import threading

        self.sim, self.n = sim, n
        self.holding, self.go = threading.Event(), threading.Event()
        self.stepper = 0
        self.errors: list[BaseException] = []
        self.thread = threading.Thread(target=self._step)

    def _step(self) -> None:
        import threading

        self.stepper = threading.get_ident()
        try:
            self.sim.step(self.n)
        except BaseException as error:  # noqa: BLE001 - raised by the block
            self.errors.append(error)

    def _control(self, m, d) -> None:  # type: ignore[no-untyped-def]
        import threading

        if threading.get_ident() == self.stepper and not self.go.is_set():
            self.holding.set()
            self.go.wait(60)  # bounds a hang only: the block lets it go

    def __enter__(self) -> _HeldStep:
        import mujoco

        mujoco.set_mjcb_control(self._control)
        self.thread.start()
        assert self.holding.wait(60), "the step never began"
        return self

    def __exit__(self, *exc: object) -> None:
        import mujoco

        self.go.set()
        self.thread.join(60)
        mujoco.set_mjcb_control(None)
        assert not self.thread.is_alive()
        if self.errors:
            raise self.errors[0]


@requires_kernel
def test_a_sim_stepping_in_another_thread_refuses_calls():
    """While one thread steps a Sim (without the GIL), a call that needs its compiled loop
    from another thread raises SimBusyError instead of racing it; the step runs to its end."""
    sim, robot = _r2d2()
    try:
        sim.step(1)
        kernel = compiled(sim).kernel
        with _HeldStep(sim, 200):
            with pytest.raises(SimBusyError, match="another thread"):
                sim.link_state(robot, 2)
            with pytest.raises(SimBusyError):
                kernel.check_idle()  # the compiled loop itself says it is busy
        assert sim.time == pytest.approx(201 / 240)
        sim.link_state(robot, 2)  # free again
        # changing the world (load, remove, reset, close) is refused while it steps too
        for change in (
            lambda: sim.load_urdf("cube_small.urdf"),
            lambda: sim.remove(robot),
            sim.reset,
            sim.close,
        ):
            with _HeldStep(sim, 200), pytest.raises(SimBusyError):
                change()
        assert sim.time == pytest.approx(1001 / 240)
        assert sim.num_joints(robot) == 15  # r2d2 is still there, the world unchanged
    finally:
        sim.close()


@pytest.mark.parametrize("loop", ["kernel", "python"])
def test_a_raising_mujoco_callback_reaches_the_caller_and_stops_the_world(monkeypatch, loop):
    """A user's MuJoCo callback (here mjcb_control) that raises mid-step: its exception reaches
    the caller of Sim.step on both loops (not a SystemError), the steps before it count, and
    the half-computed world refuses to step until reset()."""
    import mujoco

    from simbridge.exceptions import EngineError

    if loop == "kernel" and mujoco_kernel.reason():
        pytest.skip(f"no compiled loop: {mujoco_kernel.reason()}")
    _select_loop(monkeypatch, loop)
    sim, robot = _r2d2()
    calls = [0]

    def control(m, d) -> None:  # type: ignore[no-untyped-def]
        calls[0] += 1
        if calls[0] == 5:
            raise ValueError("policy failed")

    try:
        sim.step(3)
        mujoco.set_mjcb_control(control)
        try:
            with pytest.raises(ValueError, match="policy failed"):
                sim.step(10)
        finally:
            mujoco.set_mjcb_control(None)
        assert calls[0] == 5
        assert sim.time == pytest.approx(7 / 240)  # 3 + the 4 steps before the failing one
        with pytest.raises(EngineError, match="a MuJoCo callback raised ValueError"):
            sim.step()
        sim.reset()
        sim.load_urdf("plane.urdf")
        sim.step(5)
        assert sim.time == pytest.approx(5 / 240)
    finally:
        sim.close()


def _arms_pressing_on_their_limits(sim, record) -> None:
    # five arms, every joint reset at a limit with its motor pushing outward (30 N m, which
    # the limit holds): the exact solve with motor and limit rows on the same dofs, a block of
    # 70 rows whose degenerate pairs the active set must never free together (numpy's solver
    # let a near-singular block through where the C one did not: 1e-4 rad/s apart)
    arms = [
        sim.load_urdf("kuka_iiwa/model.urdf", fixed_base=True, base_position=(2 * i, 0, 0))
        for i in range(5)
    ]
    joints = list(range(7))
    for arm in arms:
        table = [sim.joint_info(arm, j) for j in joints]
        at = [t.upper_limit if j % 2 == 0 else t.lower_limit for j, t in enumerate(table)]
        sim.reset_joint_state(arm, joints, at)
        sim.set_joint_velocity(
            arm, joints, [1.0 if j % 2 == 0 else -1.0 for j in joints], max_force=30.0
        )
    for k in range(60):
        if k == 30:  # and then pulled back off the limits
            sim.set_joint_velocity(
                arms[0], joints, [-0.5 if j % 2 == 0 else 0.5 for j in joints], max_force=30.0
            )
        sim.step()
        record()
    alone = sim.joint_states(arms[1], joints).positions
    assert np.allclose(alone, sim.joint_states(arms[4], joints).positions, atol=1e-12)


def test_arms_pressing_on_their_limits(monkeypatch):
    _agree(monkeypatch, _arms_pressing_on_their_limits)


def _arms_driven_to_their_limits(sim, record) -> None:
    # a KUKA and a Panda with every joint driven to a limit (targets past it, which the motor
    # clamps to it; 100 N m), gravity driving some joints into theirs while their motors brake:
    # the exact solve's active set cycled there (a motor sent to the bound its free force
    # pointed to, or freed, and back) and fell back to MuJoCo's solver in 146 (KUKA alone) and
    # 140 (Panda alone) of 240 steps
    arms = [
        sim.load_urdf("kuka_iiwa/model.urdf", fixed_base=True),
        sim.load_urdf("franka_panda/panda.urdf", fixed_base=True, base_position=(2, 0, 0)),
    ]
    moved = []
    for arm in arms:
        table = [t for t in sim.joints(arm) if t.type in (0, 1) and t.upper_limit > t.lower_limit]
        joints = [t.index for t in table]
        past = [
            t.upper_limit + 0.2 if i % 2 == 0 else t.lower_limit - 0.2 for i, t in enumerate(table)
        ]
        inside = [0.5 * (t.lower_limit + t.upper_limit) for t in table]
        sim.set_joint_position(arm, joints, past, max_force=100.0)
        moved.append((arm, joints, inside))
    d = compiled(sim).d
    d.solver_niter[:] = 0
    for k in range(240):
        if k == 180:  # and then driven back off the limits
            for arm, joints, inside in moved:
                sim.set_joint_position(arm, joints, inside, max_force=100.0)
        sim.step()
        record()
    assert d.solver_niter.max() == 0  # MuJoCo's solver never ran: the exact solve took every step


def test_arms_driven_to_their_limits(monkeypatch):
    _agree(monkeypatch, _arms_driven_to_their_limits)


def _arms_falling_into_their_limits(sim, record) -> None:
    # limit_rule "hard" (every limited joint's rows at every step, a gain inside the range): a
    # KUKA whose joint 2 falls into its limit while the others are held, and one pressing on its
    # limits as in _arms_pressing_on_their_limits, its motors released after 30 steps
    falls = sim.load_urdf("kuka_iiwa/model.urdf", fixed_base=True)
    sim.set_joint_position(falls, [0, 2, 3, 4, 5, 6], [0.0] * 6, max_force=300.0)
    sim.set_joint_velocity(falls, 1, 0.0, max_force=0.0)
    sim.reset_joint_state(falls, 1, 1.9, 0.0)
    presses = sim.load_urdf("kuka_iiwa/model.urdf", fixed_base=True, base_position=(2, 0, 0))
    joints = list(range(7))
    table = [sim.joint_info(presses, j) for j in joints]
    sim.reset_joint_state(presses, joints, [t.upper_limit - 0.01 for t in table])
    sim.set_joint_velocity(presses, joints, [1.0] * 7, max_force=30.0)
    for k in range(90):
        if k == 30:
            sim.set_joint_velocity(presses, joints, [0.0] * 7, max_force=0.0)
        sim.step()
        record()


def test_the_hard_limit_rule(monkeypatch):
    profile = get_profile("pybullet").with_engine("mujoco", limit_rule="hard")
    _agree(monkeypatch, _arms_falling_into_their_limits, profile)


def test_a_lost_compiled_loop_warns_once_naming_both_versions(monkeypatch):
    """A compiled loop built against another MuJoCo is not used (kernel.reason() says so): the
    first MuJoCo Sim of the process warns once, naming both versions and what to run, and the
    manifest says which loop runs."""
    import mujoco

    from simbridge.exceptions import SlowStepWarning

    monkeypatch.delenv(mujoco_kernel.ENV, raising=False)
    monkeypatch.setattr(mujoco_kernel, "_state", {})
    mujoco_kernel._load()  # the real checks first, then the other build's answer on top
    monkeypatch.setitem(mujoco_kernel._state, "class", None)
    monkeypatch.setitem(
        mujoco_kernel._state,
        "reason",
        f"the compiled step loop was built for MuJoCo {mujoco_kernel._version(399)}, this is "
        f"MuJoCo {mujoco.__version__}: {mujoco_kernel._REBUILD}",
    )
    with pytest.warns(SlowStepWarning) as caught, simbridge.Sim("mujoco") as sim:
        assert sim.manifest()["step_loop"].startswith("Python (the compiled step loop was built")
    assert len(caught) == 1
    text = str(caught[0].message)
    assert "3.9.9" in text and mujoco.__version__ in text and "--no-build-isolation" in text
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a second Sim does not warn again
        simbridge.Sim("mujoco").close()


def test_choosing_the_python_loop_does_not_warn(monkeypatch):
    import warnings

    monkeypatch.setenv(mujoco_kernel.ENV, "python")
    monkeypatch.setattr(mujoco_kernel, "_state", {})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        simbridge.Sim("mujoco").close()


_FIRST_SIMS_IN_THREADS = """
import json, threading, warnings
import simbridge
from simbridge.backends.mujoco import kernel
from simbridge.registry import load_backend

load_backend("mujoco")  # the backend imported: the threads meet at the loop's loader
barrier = threading.Barrier(4)
loops = [None] * 4

def first_sim(i):
    barrier.wait()
    try:
        with simbridge.Sim("mujoco") as sim:
            loops[i] = sim.manifest()["step_loop"]
    except Exception as exc:
        loops[i] = f"{type(exc).__name__}: {exc}"

with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    threads = [threading.Thread(target=first_sim, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
slow = [w for w in caught if w.category.__name__ == "SlowStepWarning"]
print(json.dumps({"loops": loops, "reason": kernel.reason(), "warnings": len(slow)}))
"""


def test_first_sims_made_at_once_in_threads_all_get_the_loop(tmp_path):
    """The first MuJoCo Sims of a process, made at once in four threads, each get the step loop
    one Sim alone gets, and at most one warning. Before the loader took a lock, the threads that
    came in while the first imported the compiled loop read a half-made answer: a raw
    KeyError('reason') in 5 runs of 5 (or, a moment later, a Sim on the Python loop). In a
    child process: the loader's answer is made once per process."""
    import json
    import subprocess

    env = dict(os.environ)
    env.pop(mujoco_kernel.ENV, None)
    run = subprocess.run(
        [sys.executable, "-c", _FIRST_SIMS_IN_THREADS],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    out = json.loads(run.stdout.strip().splitlines()[-1])
    alone = "compiled (" if out["reason"] == "" else f"Python ({out['reason']})"
    assert all(str(loop).startswith(alone) for loop in out["loops"]), out
    assert out["warnings"] == (0 if out["reason"] == "" else 1), out


@requires_kernel
def test_a_step_begun_since_a_reads_mark_refuses_the_read():
    """The mark a read takes (check_idle) and checks at its end (check_since): a step begun
    in between, as in another thread while the compiled loop runs without the GIL, makes it
    SimBusyError (measured without it: 1 read in 2.7 million straddled a step and mixed two
    steps' positions and speeds)."""
    with simbridge.Sim("mujoco") as sim:
        sim.load_urdf("wheel.urdf", fixed_base=True)
        kernel = compiled(sim).kernel
        mark = kernel.check_idle()
        kernel.check_since(mark)  # no step since: passes
        sim.step()
        with pytest.raises(SimBusyError, match="stepped in another thread while it was being read"):
            kernel.check_since(mark)
        kernel.check_since(kernel.check_idle())


def test_the_python_loop_refuses_calls_from_another_thread_while_it_steps(monkeypatch):
    """MuJoCo's functions release the GIL, so the Python loop is raced as the compiled one
    would be: the conformance suite's check (commands, teleports, reads, a second step from
    another thread during a step(n) raise SimBusyError and change nothing) on the Python
    loop, where they went through (a set_joint_velocity, a reset_base_state...)."""
    monkeypatch.syspath_prepend(str(Path(__file__).parents[2] / "conformance"))
    from test_world import (
        test_every_call_that_touches_the_world_is_refused_while_another_thread_steps as check,
    )

    _run_on_the_python_loop(monkeypatch, check)


def test_the_python_loop_takes_racing_commands_and_teleports_whole(monkeypatch):
    """The conformance suite's race (one thread stepping, three commanding, giving torques and
    teleporting) on the Python loop, whose MuJoCo calls release the GIL mid-step: every call
    lands between two steps or is refused, no torque is lost."""
    monkeypatch.syspath_prepend(str(Path(__file__).parents[2] / "conformance"))
    from test_world import (
        test_commands_and_teleports_racing_a_stepping_thread_land_whole as check,
    )

    _run_on_the_python_loop(monkeypatch, check)


def _run_on_the_python_loop(monkeypatch, check) -> None:
    """Run a conformance check (which takes a ``make_sim``) on Sims stepping in Python."""
    _select_loop(monkeypatch, "python")
    sims: list[simbridge.Sim] = []

    def make(**kwargs: object) -> simbridge.Sim:
        sims.append(simbridge.Sim("mujoco", **kwargs))  # type: ignore[arg-type]
        assert compiled(sims[-1]).kernel is None
        return sims[-1]

    try:
        check(make)
    finally:
        for sim in sims:
            sim.close()
