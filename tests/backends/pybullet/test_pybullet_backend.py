"""PyBullet-backend specifics: the layer adds nothing to raw PyBullet under the "pybullet" profile.

These tests import pybullet directly because they compare against raw PyBullet code, and look
inside the backend only through ``simbridge.backends.pybullet.inspect``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile

import numpy as np
import pybullet as p
import pybullet_data
import pytest

import simbridge
from simbridge.backends.pybullet.inspect import client_id, set_check_every
from simbridge.exceptions import DisplayError

WHEELS_RIGHT, WHEELS_LEFT = (2, 3), (6, 7)


def _raw_drive() -> tuple[list, list]:
    """The tutorial drive in raw PyBullet, the way the tutorial writes it."""
    c = p.connect(p.DIRECT)
    try:
        p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=c)
        p.setGravity(0, 0, -9.8, physicsClientId=c)
        p.loadURDF("plane.urdf", physicsClientId=c)
        r = p.loadURDF("r2d2.urdf", [0, 0, 0.1], physicsClientId=c)
        base, joints = [], []

        def record() -> None:
            base.append(p.getBasePositionAndOrientation(r, physicsClientId=c))
            joints.append([s[:2] for s in p.getJointStates(r, range(15), physicsClientId=c)])

        for _ in range(240):
            p.stepSimulation(physicsClientId=c)
            record()
        for _ in range(240):
            for j in WHEELS_RIGHT:
                p.setJointMotorControl2(
                    r, j, p.VELOCITY_CONTROL, targetVelocity=-100, force=50, physicsClientId=c
                )
            for j in WHEELS_LEFT:
                p.setJointMotorControl2(
                    r, j, p.VELOCITY_CONTROL, targetVelocity=100, force=50, physicsClientId=c
                )
            p.stepSimulation(physicsClientId=c)
            record()
        for _ in range(500):
            for j in WHEELS_RIGHT + WHEELS_LEFT:
                p.setJointMotorControl2(
                    r, j, p.VELOCITY_CONTROL, targetVelocity=-100, force=10, physicsClientId=c
                )
            p.stepSimulation(physicsClientId=c)
            record()
        return base, joints
    finally:
        p.disconnect(c)


def _layer_drive() -> tuple[list, list]:
    with simbridge.Sim("pybullet") as sim:
        sim.load_urdf("plane.urdf")
        r = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.1))
        base, joints = [], []

        def record() -> None:
            s = sim.base_state(r)
            base.append((s.position, s.orientation))
            js = sim.joint_states(r)
            joints.append(list(zip(js.positions.tolist(), js.velocities.tolist(), strict=True)))

        for _ in range(240):
            sim.step()
            record()
        for _ in range(240):
            sim.set_joint_velocity(r, [2, 3, 6, 7], [-100, -100, 100, 100], max_force=50)
            sim.step()
            record()
        wheels = np.array([2, 3, 6, 7])
        for _ in range(500):
            sim.set_joint_velocity(r, wheels, np.full(4, -100.0), max_force=10)
            sim.step()
            record()
        return base, joints


def test_r2d2_drive_is_bitwise_the_raw_drive():
    raw_base, raw_joints = _raw_drive()
    base, joints = _layer_drive()
    assert len(base) == 980
    for k in range(980):
        assert base[k] == raw_base[k], f"base pose differs at step {k}"
        assert joints[k] == raw_joints[k], f"joint states differ at step {k}"
    # The tutorial drive moves the robot: the comparison is not between two resting robots.
    assert np.linalg.norm(np.subtract(base[-1][0][:2], base[239][0][:2])) > 0.5


def _temp_leftovers() -> set[str]:
    return {f for f in os.listdir(tempfile.gettempdir()) if f.startswith("simbridge_")}


@pytest.fixture
def private_tmp(tmp_path, monkeypatch):
    """Every ``tempfile`` call of this process writes under a folder of this test's own: the
    shared temporary folder holds other processes' ``simbridge_`` files (another pytest worker
    loading URDF text at the same moment), which the before/after comparison would count."""
    folder = tmp_path / "tmp"
    folder.mkdir()
    monkeypatch.setenv("TMPDIR", str(folder))
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    return folder


CUBE = """<robot name="cube"><link name="box">
  <inertial><mass value="{mass}"/>
    <inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial>
  <collision><geometry><box size="0.5 0.5 0.5"/></geometry></collision>
</link></robot>"""


def test_urdf_text_goes_through_a_unique_temp_file_that_is_removed(private_tmp):
    before = _temp_leftovers()
    with simbridge.Sim("pybullet") as sim:
        a = sim.load_urdf(CUBE.format(mass=1.0), base_position=(0, 0, 1))
        b = sim.load_urdf(CUBE.format(mass=3.0), base_position=(2, 0, 1))
        # No stale model from PyBullet's file-name cache: each text gives its own mass.
        assert sim.dynamics_info(a).mass == 1.0
        assert sim.dynamics_info(b).mass == 3.0
        sim.reset()
        c = sim.load_urdf(CUBE.format(mass=7.0))
        assert sim.dynamics_info(c).mass == 7.0
    assert _temp_leftovers() == before


def test_failed_text_load_leaves_no_temp_file_and_sim_stays_usable(private_tmp):
    before = _temp_leftovers()
    with simbridge.Sim("pybullet") as sim:
        with pytest.raises(simbridge.exceptions.UrdfParseError, match="<urdf text>: malformed"):
            sim.load_urdf("<robot name='x'><link name='a'></robot>")
        assert sim.load_urdf(CUBE.format(mass=2.0)) >= 0
    assert _temp_leftovers() == before


def test_each_sim_owns_and_releases_its_client():
    sim = simbridge.Sim("pybullet")
    client = client_id(sim)
    assert p.getConnectionInfo(client)["isConnected"] == 1
    sim.close()
    assert p.getConnectionInfo(client)["isConnected"] == 0
    sim.close()  # twice is fine
    with pytest.raises(simbridge.exceptions.SimClosedError, match="closed"):
        sim.step()


def test_inspect_gives_the_client_of_this_sim_and_refuses_others():
    with simbridge.Sim("pybullet") as a, simbridge.Sim("pybullet") as b:
        a.load_urdf("plane")
        robot = a.load_urdf("r2d2", base_position=(0, 0, 0.5))
        c = client_id(a)
        assert c != client_id(b)
        assert p.getNumBodies(physicsClientId=c) == 2
        assert p.getNumBodies(physicsClientId=client_id(b)) == 0
        pos, _ = p.getBasePositionAndOrientation(robot, physicsClientId=c)
        assert pos == a.base_state(robot).position
    with pytest.raises(simbridge.exceptions.InvalidArgumentError, match="got _Closed"):
        client_id(a)
    with (
        simbridge.Sim("mujoco") as m,
        pytest.raises(simbridge.exceptions.InvalidArgumentError, match="MujocoBackend"),
    ):
        client_id(m)


def test_the_probe_cadence_is_set_through_inspect_and_changes_no_state():
    def drive(every: int) -> np.ndarray:
        with simbridge.Sim("pybullet") as sim:
            sim.load_urdf("plane")
            robot = sim.load_urdf("r2d2", base_position=(0, 0, 0.5))
            set_check_every(sim, every)
            sim.set_joint_velocity(robot, list(WHEELS_RIGHT + WHEELS_LEFT), -5.0, max_force=10.0)
            sim.step(60)
            state = [*sim.base_state(robot), *sim.joint_states(robot)]
            return np.concatenate([np.ravel(np.asarray(x, dtype=float)) for x in state])

    every_step = drive(1)
    assert np.abs(every_step).max() > 0.1  # it moved
    np.testing.assert_array_equal(every_step, drive(1000))
    with simbridge.Sim("pybullet") as sim:
        for bad in (0, -3, 2.5, True, "8"):
            with pytest.raises(simbridge.exceptions.InvalidArgumentError, match="'every'"):
                set_check_every(sim, bad)  # type: ignore[arg-type]


def test_gui_without_display_is_a_clear_error(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    with pytest.raises(DisplayError, match="backend 'pybullet' cannot open a window: DISPLAY"):
        simbridge.Sim("pybullet", gui=True)


def test_gui_with_an_unreachable_display_is_a_clear_error_not_an_exit():
    """PyBullet's GUI ends the process when the X server cannot be reached (exit code 1, no
    exception); the backend tries the display first. Run in a child process: if the check
    failed, the test process itself would end."""
    code = (
        "import simbridge\n"
        "try:\n"
        "    simbridge.Sim('pybullet', gui=True)\n"
        "except simbridge.exceptions.DisplayError as exc:\n"
        "    print('refused:', exc)\n"
    )
    env = dict(os.environ, DISPLAY=":77")  # no X server listens there
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60
    )
    assert out.returncode == 0, out.stderr[-2000:]
    assert "refused: backend 'pybullet' cannot open a window:" in out.stdout
    assert "DISPLAY=':77'" in out.stdout or "libX11" in out.stdout


def test_urdf_profile_uses_file_inertia_and_no_brake():
    with simbridge.Sim("pybullet", profile="urdf") as sim:
        r = sim.load_urdf("r2d2.urdf", fixed_base=True)
        # r2d2's links declare ixx = iyy = izz = 1 in the file.
        assert sim.dynamics_info(r, 2).local_inertia_diagonal == (1.0, 1.0, 1.0)
    with simbridge.Sim("pybullet", profile="pybullet") as sim:
        r = sim.load_urdf("r2d2.urdf", fixed_base=True)
        assert sim.dynamics_info(r, 2).local_inertia_diagonal != (1.0, 1.0, 1.0)


def test_a_name_pybullet_cannot_hold_is_refused_before_it_reads_the_file():
    """Raw PyBullet 3.2.7 ends the process (SIGSEGV) on a joint name over 1263 bytes: the
    backend refuses names over 1023 bytes (PyBullet's buffer) with the element and its line."""
    from simbridge.exceptions import UrdfStructureError

    inertial = (
        '<inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>'
        "</inertial>"
    )
    name = "j" * 1300
    text = (
        f'<robot name="r">\n<link name="a">{inertial}</link>\n<link name="b">{inertial}</link>\n'
        f'<joint name="{name}" type="fixed"><parent link="a"/><child link="b"/></joint>\n'
        "</robot>"
    )
    with simbridge.Sim("pybullet") as sim:
        with pytest.raises(UrdfStructureError, match=r":4: <joint name='j.*PyBullet holds at most"):
            sim.load_urdf(text)
        assert sim.load_urdf(text.replace(name, "j" * 1023)) == 0  # the longest it holds


def test_a_call_waiting_for_the_sim_when_another_thread_closes_it_is_refused():
    import sys
    from pathlib import Path

    from simbridge.backends.pybullet.inspect import backend_of

    sys.path.insert(0, str(Path(__file__).parents[2]))
    from _closing_race import check_waiting_call_refused_after_close

    sim = simbridge.Sim("pybullet")
    check_waiting_call_refused_after_close(sim, backend_of(sim)._stepping)
