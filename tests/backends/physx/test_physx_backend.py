"""The PhysX backend's own tests: what it builds and how it maps PyBullet's meaning onto PhysX,
each against raw PyBullet (through the PyBullet backend, bit for bit raw PyBullet's) where
there is a PyBullet figure. PhysX keeps its state in float32: positions are compared at a few
float32 spacings (1.2e-7 m at 1 m)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import simbridge
from simbridge.exceptions import (
    BackendNotInstalledError,
    BackendUnsupportedError,
    SimulationDivergedError,
)
from simbridge.transforms import rpy_from_quat
from simbridge.types import JointType

needs_sapien = pytest.mark.needs_backend("physx")  # tests/_engines.py: skipped, or fails in CI

WHEELS = [
    "right_front_wheel_joint",
    "right_back_wheel_joint",
    "left_front_wheel_joint",
    "left_back_wheel_joint",
]
# float32 state: a link frame read back within this of PyBullet's (measured worst 3.1e-7 m on
# kuka_iiwa at 1.3 m from the origin, 2.6 float32 spacings)
F32_POSITION = 1e-6
F32_ANGLE = 5e-7


def test_physx_is_registered_and_says_how_to_install_it(monkeypatch):
    from simbridge import registry

    assert "physx" in simbridge.available_backends()
    monkeypatch.setitem(sys.modules, "sapien", None)  # import sapien raises ImportError
    monkeypatch.delitem(registry._LOADED, "physx", raising=False)
    with pytest.raises(BackendNotInstalledError) as info:
        registry.load_backend("physx")
    assert "simbridge[physx]" in str(info.value)
    # the line a report's "left out" note gives: from PyPI, and from a clone
    both = "pip install 'simbridge[physx]' (from a clone: pip install -e '.[physx]')"
    assert both in str(info.value)
    monkeypatch.delitem(registry._LOADED, "physx", raising=False)


def _frames_after_resets(backend: str, urdf: str, fixed: bool):
    with simbridge.Sim(backend) as sim:
        body = sim.load_urdf(
            urdf,
            base_position=(0.1, 0.2, 1.0),
            base_orientation=(0.0, 0.0, np.sin(0.2), np.cos(0.2)),
            fixed_base=fixed,
        )
        rng = np.random.default_rng(3)
        table = [sim.joint_info(body, j) for j in range(sim.num_joints(body))]
        movable = [j.index for j in table if j.type != JointType.FIXED]
        sim.reset_joint_state(
            body, movable, rng.uniform(-0.5, 0.5, len(movable)), rng.uniform(-1, 1, len(movable))
        )
        links = [sim.link_state(body, k) for k in range(-1, len(table))]
        dyn = [sim.dynamics_info(body, k) for k in range(-1, len(table))]
        return table, links, dyn, sim.joint_states(body, movable)


@needs_sapien
@pytest.mark.parametrize(
    "urdf, fixed", [("r2d2.urdf", False), ("kuka_iiwa/model.urdf", True), ("cartpole.urdf", True)]
)
def test_joint_table_dynamics_and_link_frames_are_pybullets(urdf, fixed):
    ta, la, da, ja = _frames_after_resets("pybullet", urdf, fixed)
    tb, lb, db, jb = _frames_after_resets("physx", urdf, fixed)
    assert len(ta) == len(tb)
    for a, b in zip(ta, tb, strict=True):  # the core's table on both (PyBullet's own for one)
        assert a.name == b.name and a.type == b.type and a.link_name == b.link_name
        assert a[3:6] == b[3:6] and a.parent_index == b.parent_index
        np.testing.assert_allclose(a.axis, b.axis, atol=1e-15)
        np.testing.assert_allclose(a.parent_frame_position, b.parent_frame_position, atol=1e-15)
        np.testing.assert_allclose(
            a.parent_frame_orientation, b.parent_frame_orientation, atol=1e-15
        )
    for a, b in zip(da, db, strict=True):
        assert a.mass == b.mass and a.lateral_friction == b.lateral_friction
        # PyBullet reads its own inertia back 4e-8 off the core's figure (float32 inside)
        np.testing.assert_allclose(a.local_inertia_diagonal, b.local_inertia_diagonal, rtol=1e-7)
    for k, (a, b) in enumerate(zip(la, lb, strict=True)):
        where = f"{urdf} link {k - 1}"
        for field in ("com_position", "link_frame_position"):
            np.testing.assert_allclose(
                getattr(b, field), getattr(a, field), atol=F32_POSITION, err_msg=where
            )
        for field in ("com_orientation", "link_frame_orientation"):
            qa, qb = np.asarray(getattr(a, field)), np.asarray(getattr(b, field))
            assert min(np.abs(qa - qb).max(), np.abs(qa + qb).max()) < F32_ANGLE, where
        np.testing.assert_allclose(b.linear_velocity, a.linear_velocity, atol=F32_POSITION)
        np.testing.assert_allclose(b.angular_velocity, a.angular_velocity, atol=F32_POSITION)
    np.testing.assert_allclose(jb.positions, ja.positions, atol=F32_ANGLE)
    np.testing.assert_allclose(jb.velocities, ja.velocities, atol=F32_ANGLE)


@needs_sapien
def test_links_are_in_place_right_after_a_load_and_a_teleport():
    """PhysX moves an articulation's links only at a step or a joint-state write: read before
    either, every link but the root was at the origin (measured before the fix)."""
    frames = {}
    for backend in ("pybullet", "physx"):
        with simbridge.Sim(backend) as sim:
            r2d2 = sim.load_urdf("r2d2.urdf", base_position=(0.2, -0.1, 0.6))
            loaded = [sim.link_state(r2d2, k).link_frame_position for k in range(15)]
            sim.reset_base_state(r2d2, (1.0, 2.0, 3.0), angular_velocity=(0.5, -0.2, 0.1))
            moved = [sim.link_state(r2d2, k) for k in range(15)]
            frames[backend] = (loaded, moved)
    (la, ma), (lb, mb) = frames["pybullet"], frames["physx"]
    np.testing.assert_allclose(lb, la, atol=F32_POSITION)
    for a, b in zip(ma, mb, strict=True):
        np.testing.assert_allclose(b.link_frame_position, a.link_frame_position, atol=F32_POSITION)
        np.testing.assert_allclose(b.linear_velocity, a.linear_velocity, atol=F32_POSITION)


@needs_sapien
def test_r2d2_rests_where_pybullets_does():
    """PyBullet's 1 mm collision margin as PhysX's rest offset: PyBullet 0.470990, PhysX at its
    own rest offset 0 would rest 1 mm lower."""
    rest = {}
    for backend in ("pybullet", "physx"):
        with simbridge.Sim(backend) as sim:
            sim.load_urdf("plane.urdf")
            r2d2 = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
            sim.step(240)
            rest[backend] = sim.base_state(r2d2).position[2]
    assert rest["physx"] == pytest.approx(rest["pybullet"], abs=3e-5)


@needs_sapien
def test_the_plane_is_one_static_actor_and_r2d2_one_articulation():
    from simbridge.backends.physx.inspect import articulation, robot

    with simbridge.Sim("physx") as sim:
        plane = sim.load_urdf("plane.urdf")
        r2d2 = sim.load_urdf("r2d2.urdf")
        assert robot(sim, plane).static and articulation(sim, plane) is None
        art = articulation(sim, r2d2)
        built = robot(sim, r2d2).built.links  # PyBullet's order (PhysX keeps its own)
        assert sorted(link.name for link in built) == sorted(link.name for link in art.links)
        assert [link.name for link in built] == ["base_link"] + [
            sim.joint_info(r2d2, j).link_name for j in range(sim.num_joints(r2d2))
        ]
        # PhysX's defaults that would bite: 50 rad/s and 10 m/s link caps, joint friction 0.05
        # (the base's are the profile's 100 rad/s and m/s clamp, PyBullet's on its 6 coordinates)
        assert built[0].max_angular_velocity == built[0].max_linear_velocity == 100.0
        assert all(link.max_angular_velocity > 1e3 for link in built[1:])
        assert all(link.max_linear_velocity > 1e3 for link in built[1:])
        assert all(j.friction == 0.0 for j in art.active_joints)
        assert art.solver_position_iterations == sim.profile.solver_iterations


@needs_sapien
def test_a_wheel_runs_past_physx_default_cap_up_to_the_profiles_clamp():
    """PhysX caps a link at 50 rad/s by default; PyBullet's clamp is 100 ("pybullet") or none
    ("urdf")."""
    for profile, expected in (("pybullet", 100.0), ("urdf", 150.0)):
        with simbridge.Sim("physx", profile=profile) as sim:
            wheel = sim.load_urdf("wheel.urdf", fixed_base=True)
            sim.set_joint_velocity(wheel, "axle", 150.0, max_force=1000.0)
            sim.step(10)
            assert sim.joint_states(wheel, "axle").velocities[0] == pytest.approx(
                expected, rel=1e-5
            )


@needs_sapien
def test_velocity_motor_is_pybullets_on_the_kuka():
    """Coupled velocity motors with a force limit, one solve with gravity: PhysX at the profile's
    50 solver iterations gives PyBullet's velocities at the first step within 1.8e-4 rad/s
    (measured; PyBullet's own 50 iterations leave joints 3 and 7 that far short of the 1 rad/s
    PhysX reaches; at PhysX's own 10 iterations it is 0.012 short)."""
    v = {}
    for backend in ("pybullet", "physx"):
        with simbridge.Sim(backend) as sim:
            kuka = sim.load_urdf("kuka_iiwa/model.urdf", fixed_base=True)
            joints = list(range(7))
            sim.set_joint_velocity(kuka, joints, [1.0] * 7, max_force=[500.0] * 7)
            sim.step()
            v[backend] = sim.joint_states(kuka, joints).velocities
    assert v["pybullet"][1] < 0.95  # joint 2 is held back by its force limit against gravity
    np.testing.assert_allclose(v["physx"], v["pybullet"], atol=3e-4)


@needs_sapien
def test_position_motor_follows_pybullets_law():
    """kp (q* - q) / dt per step, force-limited: over 240 steps of the kuka moving to 0.5 rad
    the joint positions stay within 2e-3 rad of PyBullet's (measured 1.7e-3, at the start of the
    move, where the force limit binds)."""
    out = {}
    for backend in ("pybullet", "physx"):
        with simbridge.Sim(backend) as sim:
            kuka = sim.load_urdf("kuka_iiwa/model.urdf", fixed_base=True)
            joints = list(range(7))
            sim.set_joint_position(kuka, joints, [0.5] * 7, max_force=[500.0] * 7, kp=0.1, kd=1)
            trace = []
            for _ in range(240):
                sim.step()
                trace.append(sim.joint_states(kuka, joints).positions)
            out[backend] = np.array(trace)
    assert np.abs(out["pybullet"][-1] - 0.5).max() < 1e-3  # the move is done on both
    assert np.abs(out["physx"] - out["pybullet"]).max() < 2e-3


@needs_sapien
def test_a_torque_lasts_one_step_and_the_brake_holds_until_released():
    with simbridge.Sim("physx", gravity=(0.0, 0.0, 0.0)) as sim:
        wheel = sim.load_urdf("wheel.urdf", fixed_base=True)
        inertia = sim.dynamics_info(wheel, "wheel").local_inertia_diagonal[2]
        sim.set_joint_torque(wheel, "axle", 0.5)  # the brake (1/dt N·m) cancels it
        sim.step()
        assert abs(sim.joint_states(wheel, "axle").velocities[0]) < 1e-6
        sim.set_joint_velocity(wheel, "axle", 0.0, max_force=0.0)
        sim.set_joint_torque(wheel, "axle", 0.5)
        sim.step()
        w1 = sim.joint_states(wheel, "axle").velocities[0]
        assert w1 == pytest.approx(0.5 / inertia * sim.timestep, rel=1e-5)
        sim.step()  # no torque any more: only PyBullet's link damping slows the wheel
        k = sim.profile.angular_damping
        w2 = w1 - sim.timestep * k * (1.0 + abs(w1)) * w1
        assert sim.joint_states(wheel, "axle").velocities[0] == pytest.approx(w2, rel=1e-6)


@needs_sapien
def test_the_tutorial_drive_turns_and_drives_on_pybullets_motors():
    """The tutorial's R2D2 drive (README), from 0.5 m: the wheels hold the commanded +-100 rad/s
    after most steps of the turn, as on PyBullet (within 0.01 rad/s after 80 % of the 240 steps,
    measured; PyBullet 91 %: on both a wheel that hits the ground edge-first loses speed for a
    step), and the robot turns (measured about 1 rad; PyBullet -2.15 rad: skid steering is the
    engines' contact models' business)."""
    with simbridge.Sim("physx") as sim:
        sim.load_urdf("plane.urdf")
        r2d2 = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
        sim.step(240)
        start = sim.base_state(r2d2)
        held = []
        for _ in range(240):
            sim.set_joint_velocity(r2d2, WHEELS, [-100, -100, 100, 100], max_force=50)
            sim.step()
            speeds = np.abs(sim.joint_states(r2d2, WHEELS).velocities)
            held.append(np.abs(speeds - 100.0).max() < 0.01)
        assert np.mean(held) > 0.7
        turned = sim.base_state(r2d2)
        yaw = [rpy_from_quat(s.orientation)[2] for s in (start, turned)]
        assert abs(yaw[1] - yaw[0]) > 0.2
        for _ in range(500):
            sim.set_joint_velocity(r2d2, WHEELS, -100, max_force=10)
            sim.step()
        assert np.isfinite(sim.base_state(r2d2).position).all()
        assert sim.contact_points(r2d2)  # it stands (or lies) on the plane


@needs_sapien
def test_contacts_hold_a_resting_robot_up():
    """r2d2 at rest: PhysX's impulses over dt hold its weight (measured 651.3 of 652.5 N at
    PhysX's defaults; within 1 % here)."""
    with simbridge.Sim("physx") as sim:
        plane = sim.load_urdf("plane.urdf")
        r2d2 = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
        sim.step(480)
        weight = -sim.profile.gravity[2] * sum(
            sim.dynamics_info(r2d2, k).mass for k in range(-1, sim.num_joints(r2d2))
        )
        points = sim.contact_points(r2d2, plane)
        assert points and all(p.body_a == r2d2 and p.body_b == plane for p in points)
        assert all(p.normal_on_b[2] > 0.99 for p in points)
        total = sum(p.normal_force for p in points)
        assert total == pytest.approx(weight, rel=0.01)


def _neck(backend: str):
    with simbridge.Sim(backend) as sim:
        h = sim.load_urdf("humanoid/humanoid.urdf", base_position=(0, 0, 3), fixed_base=True)
        table = [sim.joint_info(h, j) for j in range(sim.num_joints(h))]
        q0 = (0.1, 0.2, 0.0, float(np.sqrt(0.95)))
        sim.reset_joint_state_multi_dof(h, "neck", q0, [0.5, -0.3, 0.2])
        links = [sim.link_state(h, k) for k in range(-1, len(table))]
        reset = sim.joint_states_multi_dof(h, "neck")[0]
        sim.step(120)  # PyBullet's default spherical motor pulls the neck back to the identity
        held = sim.joint_states_multi_dof(h, "neck")[0]
        return table, links, reset, held


@needs_sapien
def test_spherical_joints_are_pybullets():
    """A spherical joint as three revolute joints (ball.py): humanoid.urdf's joint table and
    link frames are PyBullet's, a reset reads back, and PyBullet's default motor brings the
    neck back as PyBullet's does (after 120 steps within 1e-5 of PyBullet's quaternion,
    measured 1e-6)."""
    ta, la, ra, ha = _neck("pybullet")
    tb, lb, rb, hb = _neck("physx")
    assert [tuple(r) for r in ta] == [tuple(r) for r in tb]
    for a, b in zip(la, lb, strict=True):
        np.testing.assert_allclose(b.link_frame_position, a.link_frame_position, atol=F32_POSITION)
        np.testing.assert_allclose(b.com_position, a.com_position, atol=F32_POSITION)
    np.testing.assert_allclose(rb.position, ra.position, atol=1e-7)
    np.testing.assert_allclose(rb.velocity, ra.velocity, atol=1e-6)
    np.testing.assert_allclose(hb.position, ha.position, atol=1e-5)
    assert abs(ha.position[3]) > 0.9999  # back at the identity


@needs_sapien
def test_a_non_finite_state_raises_diverged():
    with simbridge.Sim("physx", profile="urdf") as sim:
        wheel = sim.load_urdf("wheel.urdf", fixed_base=True)
        sim.set_joint_velocity(wheel, "axle", 0.0, max_force=0.0)
        sim.set_joint_torque(wheel, "axle", 1e38)
        with pytest.raises(SimulationDivergedError):
            sim.step(8)
        with pytest.raises(SimulationDivergedError):
            sim.step()


@needs_sapien
def test_reads_of_a_jointless_body_are_refused_after_a_divergence():
    """After the step that diverged every read raises until reset(), a body with no movable
    joint (the plane) too (before: the plane's empty joint states were returned)."""
    with simbridge.Sim("physx", gravity=(0.0, 0.0, -1e300), divergence_check="every_step") as sim:
        plane = sim.load_urdf("plane.urdf")
        sim.load_urdf("free_box.urdf", base_position=(0.0, 0.0, 2.0))
        with pytest.raises(SimulationDivergedError):
            sim.step(32)
        with pytest.raises(SimulationDivergedError):
            sim.joint_states(plane)
        with pytest.raises(SimulationDivergedError):
            sim.joint_states_multi_dof(plane)
        sim.reset()
        assert sim.num_joints(sim.load_urdf("plane.urdf")) == 0


@needs_sapien
def test_manifest_lists_what_physx_cannot_match():
    with simbridge.Sim("physx") as sim:
        m = sim.manifest()
    assert m["backend"] == "physx"
    for key in ("precision", "snapshot", "motors", "contact"):
        assert key in m["departures"]
    assert "friction combine" not in m["departures"]  # the product is reached (combine.py)


@needs_sapien
def test_the_speed_clamp_and_motor_departures_say_what_the_backend_does():
    from simbridge.backends.physx.commands import DRIVE_DAMPING

    with simbridge.Sim("physx") as sim:
        dep = sim.manifest()["departures"]
        cap = sim.profile.max_joint_velocity
    # the backend clamps joint speeds after each step (motors.py _clamp_speeds)
    assert "after each step" in dep["speed clamp"]
    assert f"{cap:g} rad/s" in dep["speed clamp"]
    assert "joint max velocity (inside its solver);" not in dep["speed clamp"]
    # the drive's damping as a value, not a constant's name
    assert "DRIVE_DAMPING" not in dep["motors"]
    assert f"damping {DRIVE_DAMPING:g} " in dep["motors"]


@needs_sapien
def test_friction_is_the_product_of_the_two_materials():
    """A box (friction 0.5, the profile's) sliding on plane.urdf (friction 1): PyBullet's product
    0.5 slows it by 0.5 g per second; PhysX's own rule, the average, would give 0.75 g."""
    from simbridge.backends.physx.combine import product_combine_available

    assert product_combine_available()
    box = """<robot name="box"><link name="b"><inertial><mass value="1"/>
      <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
      <collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision></link></robot>"""
    decel = {}
    for backend in ("pybullet", "physx"):
        with simbridge.Sim(backend, profile="urdf") as sim:
            sim.load_urdf("plane.urdf")
            body = sim.load_urdf(box, base_position=(0, 0, 0.101))
            sim.step(120)  # at rest on the plane
            sim.reset_base_state(body, linear_velocity=(2.0, 0.0, 0.0))
            sim.step(24)
            v = sim.base_state(body).linear_velocity[0]
            decel[backend] = (2.0 - v) / (24 * sim.timestep) / -sim.profile.gravity[2]
    assert decel["pybullet"] == pytest.approx(0.5, abs=0.01)
    assert decel["physx"] == pytest.approx(0.5, abs=0.01)


@needs_sapien
def test_a_waiting_call_is_refused_once_the_sim_is_closed():
    sys.path.insert(0, str(__import__("pathlib").Path(__file__).parents[2]))
    from _closing_race import check_waiting_call_refused_after_close

    from simbridge.backends.physx.inspect import backend_of

    sim = simbridge.Sim("physx")
    check_waiting_call_refused_after_close(sim, backend_of(sim)._stepping)


@needs_sapien
def test_a_position_target_past_a_limit_is_clamped_to_it():
    """PyBullet clamps a POSITION_CONTROL target into the joint's limits: 0.6 on the slider
    (limits +-0.4 m) moves the carriage as 0.4 does (unclamped: 8.1e-4 m apart after 30
    steps on PhysX; clamped: float32 spacings)."""

    def run(backend: str, target: float) -> float:
        with simbridge.Sim(backend) as sim:
            body = sim.load_urdf("slider.urdf", fixed_base=True)
            sim.reset_joint_state(body, 0, 0.399, 0.0)
            sim.set_joint_position(body, 0, target, max_force=20.0)
            sim.step(30)
            assert sim.get_state().bodies[body].motor_target[0] == target  # read back as given
            return float(sim.joint_states(body, [0]).positions[0])

    ref = run("pybullet", 0.6)
    assert abs(run("physx", 0.6) - ref) < 4e-7
    assert abs(run("physx", 0.6) - run("physx", 0.4)) == 0.0


@needs_sapien
def test_a_torque_kick_is_clamped_at_the_profiles_speed_as_pybullet():
    """PyBullet clamps every joint speed after the step, what a torque added too: a wheel at
    40 rad/s kicked by a torque worth 150 rad/s more reads 100 (the "pybullet" profile's
    clamp) on raw PyBullet; PhysX's joint max velocity alone left it at 189.7."""

    def kick(backend: str) -> float:
        with simbridge.Sim(backend) as sim:
            body = sim.load_urdf("wheel.urdf", fixed_base=True)
            sim.reset_joint_state(body, "axle", 0.0, 40.0)
            sim.set_joint_velocity(body, "axle", 0.0, max_force=0.0)
            inertia = max(sim.dynamics_info(body, "wheel").local_inertia_diagonal)
            sim.set_joint_torque(body, "axle", 150.0 * inertia / sim.timestep)
            sim.step()
            return float(sim.joint_states(body, "axle").velocities[0])

    assert kick("pybullet") == 100.0
    assert kick("physx") == 100.0


@needs_sapien
def test_an_unenforced_spherical_limit_is_warned_and_listed(caplog):
    """spherical_joint_limit.urdf's neck has PyBullet's swing/twist limit, which the three
    revolute stand-in does not hold: said at load and under the body's departures."""
    import logging

    caplog.set_level(logging.WARNING, logger="simbridge")
    with simbridge.Sim("physx") as sim:
        body = sim.load_urdf("spherical_joint_limit.urdf", fixed_base=True)
        assert f"body {body} spherical joint limits" in sim.manifest()["departures"]
        assert "spherical joints ['neck'] have PyBullet's swing/twist limit" in caplog.text
        free = sim.load_urdf("humanoid/humanoid.urdf", fixed_base=True)
        assert f"body {free} spherical joint limits" not in sim.manifest()["departures"]


@needs_sapien
def test_a_body_past_physx_articulation_size_is_refused_at_load():
    """255 links (root included) step; 256 crashed the process at the first step: refused at
    load naming the count, and the Sim goes on."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "conformance"))
    from _generated import arms_urdf, chain_urdf

    with simbridge.Sim("physx") as sim:
        for urdf in (chain_urdf(2000), arms_urdf(255, 1)):
            with pytest.raises(BackendUnsupportedError, match=r"no more than 255 links"):
                sim.load_urdf(urdf, fixed_base=True)
        assert sim.bodies() == []
        body = sim.load_urdf(chain_urdf(254), fixed_base=True)
        sim.step()
        assert np.isfinite(sim.joint_states(body).positions).all()


@needs_sapien
def test_restored_link_velocities_last_until_a_step_or_a_write():
    """set_state puts back the link velocities PhysX reported when the state was taken (unpack
    recomputes them from the joint velocities): a state taken right after set_state carries
    them on, bit for bit; a write of the joint state hands the reads back to PhysX."""
    with simbridge.Sim("physx") as sim:
        arm = sim.load_urdf("kuka_iiwa/model.urdf", fixed_base=True)
        n = sim.num_joints(arm)
        sim.set_joint_velocity(arm, None, 0.0, max_force=0.0)  # brake off: it swings
        sim.reset_joint_state(arm, None, [0.3] * n)
        sim.step(20)
        first = sim.get_state()
        kept = np.array([sim.link_state(arm, k)[6:8] for k in range(n)])
        sim.step(10)
        sim.set_state(first)
        again = sim.get_state()  # taken from the restored world: the kept velocities again
        sim.step(10)
        truth = sim.joint_states(arm)
        sim.set_state(again)
        sim.step(10)
        np.testing.assert_array_equal(sim.joint_states(arm).positions, truth.positions)
        np.testing.assert_array_equal(sim.joint_states(arm).velocities, truth.velocities)
        # a write of the same joint state: PhysX's link velocities from the joint velocities,
        # measured 0.25 rad/s (last link) away from those its step left on this arm
        sim.set_state(first)
        js = sim.joint_states(arm)
        sim.reset_joint_state(arm, None, js.positions, js.velocities)
        recomputed = np.array([sim.link_state(arm, k)[6:8] for k in range(n)])
        assert float(np.abs(recomputed - kept).max()) > 1e-3


@needs_sapien
def test_a_repeated_velocity_command_takes_the_shortcut_bit_for_bit():
    """A velocity or position command on the joints and with the forces (and gains) of an
    earlier one, with no motor of those joints changed since, only writes the targets
    (motors.py's shortcuts, a few joint groups per robot). Two r2d2 drives through the same
    commands, one taking the shortcuts wherever it may and one never (every shortcut forgotten
    before every command), give the same motor table, drives and state, bit for bit, at every
    step: through target changes, a force change, a joint released (force 0), one wheel under
    a position command, a one-step torque, the same joints as a new list, a subset, two joint
    groups in turn, a command on a joint of each group between them, position commands on two
    groups in turn, a velocity command and a force change on one of them."""
    from simbridge.backends.physx import inspect

    wheels = np.array([2, 3, 6, 7])
    left, right = np.array([2, 3]), np.array([6, 7])
    schedule = []
    for k in range(110):
        targets = np.array([-1.0, -1.0, 1.0, 1.0]) * (10.0 + k)
        side = left if k % 2 else right
        if k < 10:
            schedule.append(("v", wheels, targets, 50.0))
        elif k < 20:
            schedule.append(("v", wheels, -targets, 10.0))
        elif k == 20:
            schedule.append(("v", wheels, targets, np.array([10.0, 0.0, 10.0, 10.0])))
        elif k < 30:
            schedule.append(("v", wheels, targets, 10.0))
        elif k == 30:
            schedule.append(("p", np.array([3]), np.array([0.5]), 20.0))
        elif k == 35:
            schedule.append(("t", np.array([6]), np.array([3.0]), None))
        elif k < 45:
            schedule.append(("v", wheels, targets, 10.0))
        elif k < 50:
            schedule.append(("v", [2, 3, 6, 7], targets, 10.0))
        elif k < 60:
            schedule.append(("v", wheels[:2], targets[:2], 10.0))
        elif k == 70:  # a joint of each group: both groups' forces change
            schedule.append(("v", np.array([3, 6]), targets[:2], 20.0))
        elif k < 80:  # two groups in turn, each with its own force
            schedule.append(("v", side, targets[:2], 10.0 if k % 2 else 30.0))
        elif k == 90:
            schedule.append(("v", left, targets[:2], 10.0))
        elif k == 95:
            schedule.append(("p", right, targets[:2] * 0.01, 40.0))
        else:  # position commands on two groups in turn
            schedule.append(("p", side, targets[:2] * 0.01, 20.0))
    sims = [simbridge.Sim("physx"), simbridge.Sim("physx")]
    try:
        bodies = []
        for sim in sims:
            sim.load_urdf("plane.urdf")
            bodies.append(sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5)))
            sim.step(50)
        shortcuts = {"v": 0, "p": 0, "t": 0}
        for kind, joints, values, force in schedule:
            for i, (sim, body) in enumerate(zip(sims, bodies, strict=True)):
                robot = inspect.robot(sim, body)
                if i == 1:  # the full path every time
                    robot.velocity_plans.clear()
                    robot.position_plans.clear()
                elif kind != "t":
                    plans = robot.velocity_plans if kind == "v" else robot.position_plans
                    shortcuts[kind] += id(sim._joints(body, joints, True)) in plans
                if kind == "v":
                    sim.set_joint_velocity(body, joints, values, max_force=force)
                elif kind == "p":
                    sim.set_joint_position(body, joints, values, max_force=force)
                else:
                    sim.set_joint_torque(body, joints, values)
                sim.step()
            a, b = (sim.joint_states(body) for sim, body in zip(sims, bodies, strict=True))
            assert np.array_equal(a.positions, b.positions)
            assert np.array_equal(a.velocities, b.velocities)
            ca, cb = (
                inspect.backend_of(sim).joint_commands(body)
                for sim, body in zip(sims, bodies, strict=True)
            )
            for x, y in zip(ca, cb, strict=True):
                assert np.array_equal(x, y)
            da, db = (
                inspect.robot(sim, body).drive_force for sim, body in zip(sims, bodies, strict=True)
            )
            assert da == db
        # shortcuts ready for the joints: measured 69 of 79 velocity commands and 26 of 30
        # position commands
        assert shortcuts["v"] > 50 and shortcuts["p"] > 10
        last = inspect.backend_of(sims[0]).joint_commands(bodies[0])
        assert list(last.target[[2, 3]]) == list(schedule[-1][2])
    finally:
        for sim in sims:
            sim.close()


def test_reads_are_sapiens_arrays_and_pybullets_frame_maths_bit_for_bit():
    """The reads' hot path (one pose call per link, the centre-of-mass frame in plain floats,
    the joints gathered by flat index) gives exactly what SAPIEN's pose and velocity arrays
    and simbridge.transforms give: r2d2 tumbling in the air, the KUKA swinging, every link."""
    from simbridge.backends.physx.inspect import robot
    from simbridge.transforms import transform_multiply

    with simbridge.Sim("physx") as sim:
        r2d2 = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 2))
        arm = sim.load_urdf("kuka_iiwa/model.urdf", base_position=(3, 0, 0), fixed_base=True)
        sim.reset_base_state(r2d2, None, (0.1, 0.7, 0.1, 0.7), (0.3, -0.2, 1.0), (1.0, 2.0, 3.0))
        sim.set_joint_velocity(arm, None, 0.0, max_force=0.0)
        sim.reset_joint_state(arm, None, [0.4] * 7, [0.5] * 7)
        sim.step(7)
        for body in (r2d2, arm):
            r = robot(sim, body)
            for k in range(-1, sim.num_joints(body)):
                link = r.built.links[k + 1]
                pose = link.entity_pose
                qw, qx, qy, qz = pose.q.tolist()
                frame = (tuple(pose.p.tolist()), (qx, qy, qz, qw))
                ine = r.built.inertials[k + 1]
                com = transform_multiply(frame, (ine.position, ine.orientation))
                lin = tuple(link.linear_velocity.tolist())
                ang = tuple(link.angular_velocity.tolist())
                # it moves (but the welded base): the test compares something
                assert lin != (0.0, 0.0, 0.0) or (body, k) == (arm, -1)
                want = (*com, ine.position, ine.orientation, *frame, lin, ang)
                assert tuple(sim.link_state(body, k)) == want
                if k == -1:
                    assert tuple(sim.base_state(body)) == (*com, lin, ang)
            art = r.built.articulation
            movable = [j for j in range(sim.num_joints(body)) if r.dof[j] >= 0]
            dofs = r.dof[movable]
            forces = art.get_link_incoming_joint_forces()
            axis = [0 if r.model.joints[j].type == "prismatic" else 3 for j in movable]
            rows = [r.built.links[j + 1].index for j in movable]
            for joints in (movable, movable[::-1]):
                order = [movable.index(j) for j in joints]
                js = sim.joint_states(body, joints)
                assert js.positions.dtype == js.applied_torques.dtype == np.float64
                np.testing.assert_array_equal(js.positions, art.qpos[dofs[order]])
                np.testing.assert_array_equal(js.velocities, art.qvel[dofs[order]])
                # the incoming joint force less the joint forces the step was given (here the
                # arm's <dynamics damping>): the motor's force alone
                qf = r.step_qf if r.step_qf is not None else np.zeros(r.ndof, dtype=np.float32)
                torques = [float(forces[rows[i], axis[i]]) - float(qf[dofs[i]]) for i in order]
                np.testing.assert_array_equal(js.applied_torques, torques)
