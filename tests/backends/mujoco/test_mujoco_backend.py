"""MuJoCo-backend specifics: the model it builds, the world edits, and the behaviours only this
backend has to construct (PyBullet's motor, brake, damping and contact rules on MuJoCo).

These tests look inside the backend (through ``simbridge.backends.mujoco.inspect``) and import
mujoco/pybullet on purpose.
"""

from __future__ import annotations

import glob
import logging
import os
from pathlib import Path

import mujoco
import numpy as np
import pybullet_data
import pytest

import simbridge
from simbridge.backends.mujoco.inspect import compiled
from simbridge.exceptions import DisplayError, SimulationDivergedError, UrdfStructureError

WHEELS = [2, 3, 6, 7]


@pytest.fixture
def sim():
    s = simbridge.Sim("mujoco")
    yield s
    s.close()


def _names(m: mujoco.MjModel, obj: mujoco.mjtObj, n: int) -> list[str]:
    return [mujoco.mj_id2name(m, obj, i) for i in range(n)]


def test_one_body_per_link_visuals_kept_and_plane_is_a_plane(sim):
    plane = sim.load_urdf("plane.urdf")
    r2d2 = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
    m = compiled(sim).m
    bodies = _names(m, mujoco.mjtObj.mjOBJ_BODY, m.nbody)
    links = ["base_link"] + [sim.joint_info(r2d2, i).link_name for i in range(15)]
    assert bodies == ["world", "b0/planeLink"] + [f"b1/{n}" for n in links]  # fixed links too
    assert m.njnt == 1 + 8  # a free joint and the 8 movable joints
    visual = m.geom_group == 1
    assert visual.sum() == 17  # r2d2's 16 visuals and the plane's mesh, none of them colliding
    assert (m.geom_contype[visual] == 0).all() and (m.geom_conaffinity[visual] == 0).all()
    planes = np.flatnonzero(m.geom_type == mujoco.mjtGeom.mjGEOM_PLANE)
    assert len(planes) == 1 and m.geom_pos[planes[0]][2] == 0.0  # the box's top face
    # contacts only through pairs, each with PyBullet's product friction (0.5 x 1.0)
    assert m.npair == 16 and np.allclose(m.pair_friction[:, :2], 0.5)
    assert sim.body_name(plane) == "plane"


def test_r2d2_rests_where_pybullet_rests(sim):
    sim.load_urdf("plane.urdf")
    r = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
    sim.step(240)
    # PyBullet: 0.47099 (1 mm collision margin); measured here 0.47100 with the pairs' 1 mm
    # margin and solref (2 dt, 1)
    assert sim.base_state(r).position[2] == pytest.approx(0.4710, abs=3e-4)


def test_loading_a_second_robot_keeps_the_first_ones_state_and_commands(sim):
    a = sim.load_urdf("wheel.urdf", fixed_base=True)
    sim.set_joint_velocity(a, "axle", 5.0, max_force=2.0)
    sim.step(120)
    before = sim.joint_states(a)
    t = sim.time
    b = sim.load_urdf("pendulum.urdf", fixed_base=True, base_position=(2, 0, 1))
    after = sim.joint_states(a)
    assert sim.time == t
    assert after.positions.tolist() == before.positions.tolist()
    assert after.velocities.tolist() == before.velocities.tolist()
    sim.step(120)
    assert sim.joint_states(a).velocities[0] == pytest.approx(5.0, abs=1e-9)  # command kept
    assert sim.joint_states(b).velocities[0] == 0.0  # the new pendulum has its brake
    sim.remove(b)
    assert sim.bodies() == [a]
    sim.step(10)
    assert sim.joint_states(a).velocities[0] == pytest.approx(5.0, abs=1e-9)


def test_torque_lasts_one_step_and_leaves_the_brake(sim):
    body = sim.load_urdf("wheel.urdf", fixed_base=True)
    sim.set_joint_torque(body, "axle", 100.0)  # below the 240 N m brake: held
    sim.step()
    assert sim.joint_states(body).velocities[0] == 0.0
    applied = sim.joint_states(body).applied_torques[0]
    assert applied == pytest.approx(-100.0, rel=1e-9)  # the brake's force, not the command
    sim.set_joint_velocity(body, "axle", 0.0, max_force=0.0)
    sim.set_joint_torque(body, "axle", 1.0)
    sim.step()
    w1 = sim.joint_states(body).velocities[0]
    sim.step()
    assert sim.joint_states(body).velocities[0] < w1  # gone after one step (damping only)
    assert sim.joint_states(body).applied_torques[0] == 0.0


def test_link_state_is_current_after_a_step(sim):
    body = sim.load_urdf("double_pendulum.urdf", fixed_base=True)
    sim.set_joint_velocity(body, [0, 1], 0.0, max_force=0.0)
    sim.reset_joint_state(body, [0, 1], [0.7, -0.4])
    sim.step(37)
    got = sim.link_state(body, 1)
    m, d = compiled(sim).m, compiled(sim).d
    fresh = mujoco.MjData(m)
    fresh.qpos[:], fresh.qvel[:] = d.qpos, d.qvel
    mujoco.mj_forward(m, fresh)
    bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "b0/lower")
    assert got.com_position == pytest.approx(fresh.xipos[bid], abs=1e-15)
    assert got.link_frame_position == pytest.approx(fresh.xpos[bid], abs=1e-15)


def test_reset_base_state_takes_the_centre_of_mass_frame(sim):
    body = sim.load_urdf("free_box.urdf")
    pose = ((0.3, -0.2, 1.5), (0.0, 0.0, np.sin(0.4), np.cos(0.4)))
    sim.reset_base_state(body, *pose, linear_velocity=(1, 2, 3), angular_velocity=(0.1, 0.2, 0.3))
    s = sim.base_state(body)
    assert s.position == pytest.approx(pose[0], abs=1e-12)
    assert s.orientation == pytest.approx(pose[1], abs=1e-12)
    assert s.linear_velocity == pytest.approx((1, 2, 3), abs=1e-12)
    assert s.angular_velocity == pytest.approx((0.1, 0.2, 0.3), abs=1e-12)


def test_divergence_is_reported_and_leaves_no_log_file(tmp_path, monkeypatch, caplog):
    monkeypatch.chdir(tmp_path)  # MuJoCo's default handler writes MUJOCO_LOG.TXT here
    sim = simbridge.Sim("mujoco", profile="urdf")  # no speed clamp to hold the wheel back
    body = sim.load_urdf("wheel.urdf", fixed_base=True)
    sim.set_joint_velocity(body, "axle", 0.0, max_force=0.0)
    sim.set_joint_torque(body, "axle", 1e300)
    # the warning is asked for at its level, whatever level an earlier test left behind
    with (
        caplog.at_level(logging.WARNING, logger="simbridge.mujoco"),
        pytest.raises(SimulationDivergedError, match="mujoco"),
    ):
        sim.step(3)
    sim.close()
    assert list(tmp_path.iterdir()) == []
    assert any("MuJoCo: Nan, Inf or huge value" in r.getMessage() for r in caplog.records)


def test_gui_without_display_raises(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(DisplayError, match="mujoco"):
        simbridge.Sim("mujoco", gui=True)


def test_gui_with_an_unreachable_display_is_a_clear_error(monkeypatch, tmp_path):
    """The window process cannot open its window: DisplayError with GLFW's reason, at once
    (the window process is gone; nothing is left running), and no file left behind: MuJoCo
    writes MUJOCO_LOG.TXT into the window process's working folder, which is its own."""
    import tempfile

    monkeypatch.setenv("DISPLAY", ":77")  # no X server there
    monkeypatch.chdir(tmp_path)
    before = set(os.listdir(tempfile.gettempdir()))
    with pytest.raises(DisplayError, match="mujoco.*(display|GLFW)"):
        simbridge.Sim("mujoco", gui=True)
    assert list(tmp_path.iterdir()) == []
    left = set(os.listdir(tempfile.gettempdir())) - before
    assert not [x for x in left if x.startswith("simbridge-mujoco-")], left


class _Window:
    """Stands in for the backend's viewer (viewer.Viewer, MuJoCo's passive viewer in a window
    process of its own; the real one is tested under Xvfb in test_gui.py): records what the
    backend asks of it."""

    log: list[str] = []

    def __init__(self, backend, m, d) -> None:
        self.m, self.d = m, d
        _Window.log.append(f"open nbody={m.nbody}")

    def sync(self) -> None:
        _Window.log.append(f"sync t={self.d.time:.4f}")

    def close(self) -> None:
        _Window.log.append("close")


def test_gui_opens_the_viewer_and_keeps_it_on_the_current_world(monkeypatch):
    """gui=True opens MuJoCo's passive viewer at once, syncs it every step, reopens it on the
    model of every load, remove and reset, and closes it with the Sim."""
    from simbridge.backends.mujoco import backend as mujoco_backend

    monkeypatch.setenv("DISPLAY", ":0")
    monkeypatch.setattr(mujoco_backend, "Viewer", _Window)
    _Window.log = []
    with simbridge.Sim("mujoco", gui=True) as sim:
        assert _Window.log == ["open nbody=1"]
        body = sim.load_urdf("r2d2.urdf")
        assert _Window.log[-2:] == ["close", f"open nbody={1 + 15 + 1}"]
        sim.step(2)
        assert _Window.log[-2:] == ["sync t=0.0042", "sync t=0.0083"]
        sim.remove(body)
        assert _Window.log[-1] == "open nbody=1"
        sim.load_urdf("cube.urdf")
        sim.reset()
        assert _Window.log[-2:] == ["close", "open nbody=1"]
    assert _Window.log[-1] == "close"


def test_manifest_names_engine_and_departures(sim):
    sim.load_urdf("r2d2.urdf")
    man = sim.manifest()
    assert man["backend"] == "mujoco" and man["engine_version"] == mujoco.__version__
    assert man["native_defaults"]["friction_combine"] == "max"
    assert isinstance(man["departures"], dict) and man["departures"]
    sim.close()
    sim.close()  # twice is fine


def test_dae_meshes_are_converted():
    daes = sorted(
        glob.glob(os.path.join(pybullet_data.getDataPath(), "**", "*.dae"), recursive=True)
    )
    if not daes:
        pytest.skip("no .dae mesh in this pybullet_data")
    urdf = f"""<robot name="dae"><link name="a">
      <inertial><mass value="1"/>
        <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
      <visual><geometry><mesh filename="{daes[0]}"/></geometry></visual></link></robot>"""
    with simbridge.Sim("mujoco") as s:
        s.load_urdf(urdf)
        assert compiled(s).m.nmesh == 1


def test_brake_threshold_is_one_newton_second_per_step(sim):
    """PyBullet's default motor: impulse 1 N s per step (240 N m at 1/240 s): 228 N m held,
    252 N m slips by (252/240 - 1) / I in one step."""
    body = sim.load_urdf("wheel.urdf", fixed_base=True)
    inertia = sim.dynamics_info(body, "wheel").local_inertia_diagonal[2]
    sim.set_joint_torque(body, "axle", 228.0)
    sim.step()
    assert sim.joint_states(body).velocities[0] == 0.0
    sim.set_joint_torque(body, "axle", 252.0)
    sim.step()
    assert sim.joint_states(body).velocities[0] == pytest.approx((252 / 240 - 1) / inertia)


def _exact_against_solver(monkeypatch, profile: str, scenario) -> tuple[float, int]:
    """Run ``scenario`` twice on the Python step loop: with the exact motor-only solve, and
    with it switched off (MuJoCo's solver, then the polish). Returns the largest gap in qpos,
    qvel and motor impulses over the run, and how many steps took the exact solve."""
    from simbridge.backends.mujoco import kernel as mujoco_kernel
    from simbridge.backends.mujoco import solve as mujoco_solve

    monkeypatch.setenv(mujoco_kernel.ENV, "python")
    exact = mujoco_solve.exact_motors
    taken = [0]

    def counted(m, d, t, k):  # type: ignore[no-untyped-def]
        ok = exact(m, d, t, k)
        taken[0] += ok
        return ok

    runs = []
    for solve in (counted, lambda m, d, t, k: False):
        monkeypatch.setattr(mujoco_solve, "exact_motors", solve)
        states: list[np.ndarray] = []
        with simbridge.Sim("mujoco", profile=profile) as s:

            def record(s=s, states=states) -> None:
                d, t = compiled(s).d, compiled(s).motors
                impulses = np.zeros(t.n)  # the motor rows' impulses (fewer rows once released)
                impulses[: t.n_rows] = d.efc_force[: t.n_rows] * compiled(s).dt
                states.append(np.concatenate([d.qpos, d.qvel, impulses]))

            scenario(s, record)
        runs.append(np.array(states))
    return float(np.abs(runs[0] - runs[1]).max()), taken[0]


def _arm_with_saturated_motors(s, record) -> None:
    arm = s.load_urdf("kuka_iiwa/model.urdf", fixed_base=True)
    limits = [200, 200, 100, 100, 50, 5, 1]  # the last two saturate on the way
    targets = [0.5, -0.4, 0.3, 1.0, -0.2, 0.6, 0.1]
    s.set_joint_position(arm, list(range(7)), targets, max_force=limits, kp=0.2, kd=0.7)
    saturated = 0
    for _ in range(300):
        s.step()
        record()
        torque = np.abs(s.joint_states(arm, [5, 6]).applied_torques)
        saturated += bool(np.isclose(torque, [5, 1], rtol=1e-9).any())
    assert saturated >= 5  # motors at their limit for part of the run (7 steps at least)


def _coupled_pendulum_motors(s, record) -> None:
    dp = s.load_urdf("double_pendulum.urdf", fixed_base=True)
    s.set_joint_velocity(dp, [0, 1], [1.0, -2.0], max_force=[5.0, 1.0])
    for k in range(480):
        if k == 240:  # one strong and one weak, saturated motor
            s.set_joint_velocity(dp, [0, 1], [-3.0, 2.0], max_force=[500.0, 0.2])
        s.step()
        record()


def _joints_driven_into_their_limits(s, record) -> None:
    slider = s.load_urdf("slider.urdf", fixed_base=True)
    s.set_joint_velocity(slider, 0, 1.0, max_force=5.0)  # into +0.4 m, then pressing on it
    dp = s.load_urdf("double_pendulum.urdf", fixed_base=True, base_position=(3, 0, 2))
    s.set_joint_velocity(dp, [0, 1], [2.0, 6.0], max_force=[50.0, 50.0])  # elbow into +2.5
    for k in range(360):
        if k == 180:  # released, reset just past (pushed back) and deep past (held) the limits
            s.set_joint_velocity(slider, 0, 0.0, max_force=0.0)
            s.reset_joint_state(slider, 0, 0.42, 0.0)
            s.set_joint_velocity(dp, 1, 0.0, max_force=0.0)
            s.reset_joint_state(dp, 1, 2.7, 0.0)
        s.step()
        record()
    assert s.joint_states(slider, 0).positions[0] < 0.42
    assert s.joint_states(dp, 1).positions[0] > 2.5


@pytest.mark.parametrize("profile", ["pybullet", "urdf"])
def test_exact_solve_with_limit_rows_matches_the_solver(monkeypatch, profile):
    """Joint-limit rows join the exact solve (a joint at or past its limit, no contact): it
    must be the same law as MuJoCo's solver on the hardened limit rows, which keep 1e-6 of
    MuJoCo's regulariser (the polish makes only motor rows exact). Measured (2026-11-23), both
    profiles: 3.5e-5 rad/s at the step the elbow hits its limit at 6 rad/s, 1e-6 rad/s after,
    6.9e-7 rad in positions. Tolerance ~3x. The exact solve takes 358-360 of the 360 steps
    (a motor pressing a joint into its limit goes to its force bound)."""
    gap, taken = _exact_against_solver(monkeypatch, profile, _joints_driven_into_their_limits)
    assert taken >= 350
    assert gap < 1e-4, gap


@pytest.mark.parametrize("profile", ["pybullet", "urdf"])
@pytest.mark.parametrize("scenario", [_arm_with_saturated_motors, _coupled_pendulum_motors])
def test_exact_motor_solve_matches_the_solver_and_polish(monkeypatch, profile, scenario):
    """With no contact and no limit in force, the backend solves the motor rows itself (an
    active set on the box-constrained rows) instead of calling MuJoCo's solver and polishing
    the result. Both must be the same motor: measured (2026-11-23) 1.2e-11 and 3.4e-11 for the
    arm, 1.8e-15 and 3.6e-15 for the pendulum (the two profiles), over every step. The
    tolerance, 1e-9, is far below what a wrong active set does (a saturated motor left free, or
    one freed too early, moves a joint by 1e-3 within a step)."""
    gap, taken = _exact_against_solver(monkeypatch, profile, scenario)
    assert taken > 200  # the exact solve was the one in use
    assert gap < 1e-9, gap


def test_a_load_that_fails_to_compile_leaves_the_world_as_it_was(tmp_path):
    """A mesh MuJoCo cannot compile (scale 0: no surface) fails the load with the file named;
    the mesh asset it added is rolled back with the robot's bodies, so the robots already there
    stay (the world used to be rebuilt empty, their ids left dangling)."""
    mesh = Path(pybullet_data.getDataPath()) / "cube.obj"
    urdf = tmp_path / "flat.urdf"
    urdf.write_text(
        f'<robot name="flat"><link name="a"><collision><geometry><mesh filename="{mesh}" '
        'scale="0 0 0"/></geometry></collision></link></robot>'
    )
    with simbridge.Sim("mujoco") as sim:
        r2d2 = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
        sim.step(10)
        before = sim.base_state(r2d2).position
        with pytest.raises(UrdfStructureError, match=r"flat\.urdf: <robot>: MuJoCo cannot compile"):
            sim.load_urdf(urdf)
        assert sim.bodies() == [r2d2]
        assert sim.base_state(r2d2).position == before
        cube = sim.load_urdf("cube.urdf", base_position=(3, 0, 1))
        sim.step(10)
        assert sim.bodies() == [r2d2, cube]


def test_a_call_waiting_for_the_sim_when_another_thread_closes_it_is_refused():
    import sys
    from pathlib import Path

    from simbridge.backends.mujoco.inspect import backend_of

    sys.path.insert(0, str(Path(__file__).parents[2]))
    from _closing_race import check_waiting_call_refused_after_close

    sim = simbridge.Sim("mujoco")
    check_waiting_call_refused_after_close(sim, backend_of(sim)._stepping)
