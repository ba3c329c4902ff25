"""Each backend against PyBullet, the reference, on the same URDF, where no contact is involved.

Without contacts the engines integrate the same equations (semi-implicit Euler, the same joint
table and inertias, PyBullet's motor rows, link damping and brake reproduced), so what is left
is floating-point order and, for coupled motors, PyBullet's iterative solver. Every tolerance
below carries the largest difference measured over the whole trajectory between PyBullet and
MuJoCo (pybullet 3.2.7, mujoco 4.0.0, this project's machines: the tightest any backend met)
and why it is not zero; a backend that cannot meet one has a gap in _gaps.py.

The reference is not compared with itself: PyBullet beside PyBullet compares a run with its own
repeat, every difference 0 unless PyBullet stopped being deterministic (test_determinism.py's
subject, bit for bit), so those cases could not fail for what this file checks. What this file
states of the reference's own behaviour (the asserts on its trajectory ``a``: the wheel's 20
rad/s, the pendulum held at 0.5, PyBullet's limit rule...) runs in every other backend's case.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from _gaps import REFERENCE, against_reference, gap, tolerance

import simbridge

PROFILES = ("pybullet", "urdf")

# every test here takes the ``backend`` fixture (conftest.py: it fails or skips a backend that
# is not available) for each registered backend but the reference; the decorator nearest each
# test, so that the backend leads the case's id, as everywhere in the suite
each_backend = pytest.mark.parametrize("backend", against_reference(), indirect=True)


Setup = Callable[[simbridge.Sim, int], None]


def _trajectory(
    backend: str, profile: str, urdf: str, steps: int, setup: Setup, joints: list[int]
) -> np.ndarray:
    """(steps, 3 n) array: positions, velocities, motor torques after every step."""
    with simbridge.Sim(backend, profile=profile) as sim:
        body = sim.load_urdf(urdf, fixed_base=True)
        setup(sim, body)
        out = np.empty((steps, 3 * len(joints)))
        for k in range(steps):
            sim.step()
            js = sim.joint_states(body, joints)
            out[k] = np.concatenate([js.positions, js.velocities, js.applied_torques])
        return out


def _both(backend: str, profile: str, urdf: str, steps: int, setup: Setup, joints: list[int]):
    """The reference's trajectory (a), the backend's (b), and their largest differences."""
    a = _trajectory(REFERENCE, profile, urdf, steps, setup, joints)
    b = _trajectory(backend, profile, urdf, steps, setup, joints)
    n = len(joints)
    diff = np.abs(a - b).max(axis=0)
    return a, b, diff[:n].max(), diff[n : 2 * n].max(), diff[2 * n :].max()


def _release_and_tilt(q0: list[float]) -> Setup:
    def setup(sim: simbridge.Sim, body: int) -> None:
        joints = list(range(len(q0)))
        sim.set_joint_velocity(body, joints, 0.0, max_force=0.0)  # no brake: a free swing
        sim.reset_joint_state(body, joints, q0)

    return setup


@pytest.mark.parametrize("profile", PROFILES)
@each_backend
def test_pendulum_swings_freely_for_2_s(backend, profile):
    _, _, dq, dv, _ = _both(backend, profile, "pendulum.urdf", 480, _release_and_tilt([1.0]), [0])
    # measured: "urdf" 1.4e-15 rad, 8.9e-15 rad/s (same arithmetic up to rounding);
    # "pybullet" 1.9e-9 rad, 9.6e-9 rad/s (PyBullet's link damping, |v| (1 + |v|) k, is
    # summed in another order and grows with the swing). Tolerances: 50x the worst.
    assert dq < tolerance(backend, 1e-7, "trajectory_float32")
    assert dv < tolerance(backend, 5e-7, "trajectory_float32")


@pytest.mark.parametrize("profile", PROFILES)
@each_backend
def test_double_pendulum_for_half_a_second(backend, profile):
    setup = _release_and_tilt([1.0, -0.5])
    a, _, dq, dv, _ = _both(backend, profile, "double_pendulum.urdf", 120, setup, [0, 1])
    assert np.abs(a[:, 3]).max() > 5.0  # the elbow really whips (8.7 rad/s at the end)
    # measured: "urdf" 7.0e-16 rad, 6.2e-15 rad/s; "pybullet" 8.5e-10 rad, 8.9e-9 rad/s (link
    # damping rounding, as above). Chaos has not set in by 0.5 s. Tolerances: ~100x.
    assert dq < tolerance(backend, 1e-7, "trajectory_float32")
    assert dv < tolerance(backend, 1e-6, "trajectory_float32")


@pytest.mark.parametrize("profile", PROFILES)
@each_backend
def test_wheel_in_the_air_reaches_and_holds_its_velocity(backend, profile):
    def setup(sim: simbridge.Sim, body: int) -> None:
        sim.set_joint_velocity(body, "axle", 20.0, max_force=1.0)

    a, b, dq, dv, dtau = _both(backend, profile, "wheel.urdf", 480, setup, [0])
    # both ramp at F/I (0.44 s for the "pybullet" profile's box inertia) and then hold 20
    assert a[-1, 1] == pytest.approx(20.0, abs=1e-9)
    assert b[-1, 1] == pytest.approx(20.0, abs=tolerance(backend, 1e-9, scale=20.0))
    # measured: "urdf" 0 rad, 0 rad/s, 3.7e-15 N m (MuJoCo's row made exact after its solve);
    # "pybullet" 1.3e-7 rad, 7.7e-7 rad/s, 2.6e-6 N m (the step where the motor stops
    # saturating, under link damping: the two engines cross the target a few 1e-7 rad/s
    # apart). Tolerances: ~10x.
    assert dq < tolerance(backend, 2e-6, "trajectory_float32")
    assert dv < tolerance(backend, 1e-5, "trajectory_float32")
    assert dtau < tolerance(backend, 3e-5, "trajectory_float32")


@pytest.mark.parametrize("profile", PROFILES)
@each_backend
def test_pendulum_position_control_settles_the_same_way(backend, profile):
    def setup(sim: simbridge.Sim, body: int) -> None:
        sim.set_joint_position(body, "hinge", 0.5, max_force=100.0)

    a, b, dq, dv, dtau = _both(backend, profile, "pendulum.urdf", 480, setup, [0])
    assert a[-1, 0] == pytest.approx(0.5, abs=1e-6)
    # measured (MuJoCo): "urdf" 5.6e-17 rad, 2.3e-15 rad/s, 1.9e-13 N m; "pybullet" 1.6e-12 rad,
    # 2.2e-10 rad/s, 2.5e-8 N m (link damping rounding), the same two digits on the machines
    # this was first measured on and on an AVX-512 one. Tolerances: 6x and 4.5x for a compiler
    # or summation order of another build; N m 400x (the rule every engine's torque shares).
    # A float32 state comes to rest a few float32 steps off the target: its gap, in rad, and x25
    # in rad/s (PhysX measured 1.19e-7 rad and 2.86e-6 rad/s, _gaps.py).
    assert dq < tolerance(backend, 1e-11, "held_position_float32")
    assert dv < tolerance(backend, 1e-9, "held_position_float32", scale=25.0)
    assert dtau < tolerance(backend, 1e-5, "applied_torque_from_joint_force", scale=100.0)


@pytest.mark.parametrize("profile", PROFILES)
@each_backend
def test_coupled_position_motors_settle_the_same_way(backend, profile):
    def setup(sim: simbridge.Sim, body: int) -> None:
        sim.set_joint_position(body, [0, 1], [0.5, -0.3], max_force=[50, 20], kp=0.05, kd=0.5)

    a, b, dq, dv, dtau = _both(backend, profile, "double_pendulum.urdf", 480, setup, [0, 1])
    assert np.abs(a[-1, :2] - b[-1, :2]).max() < tolerance(backend, 2e-4, "position_motor_law")
    # measured: 5.5e-5 rad, 2.1e-3 rad/s, 2.1e-2 N m, both profiles. The two motor rows are
    # coupled through the mass matrix; MuJoCo solves them exactly, PyBullet's sequential
    # impulse solver stops short (50 iterations: the elbow's rows converge to within 1e-4
    # of their target velocity per step, measured on its velocity motors). Tolerances: ~4x.
    assert dq < tolerance(backend, 2e-4, "position_motor_law")
    # the gap's size is in rad; its rad/s and N m counterparts scale with it (x30, x100)
    assert dv < tolerance(backend, 1e-2, "position_motor_law", scale=30.0)
    assert dtau < tolerance(backend, 0.1, "position_motor_law", scale=100.0)


@pytest.mark.parametrize("profile", PROFILES)
@each_backend
def test_coupled_velocity_motors(backend, profile):
    def setup(sim: simbridge.Sim, body: int) -> None:
        sim.set_joint_velocity(body, [0, 1], [1.0, -2.0], max_force=[5.0, 1.0])

    a, b, dq, dv, dtau = _both(backend, profile, "double_pendulum.urdf", 240, setup, [0, 1])
    # the rule: exact (MuJoCo, to 1e-9); PyBullet's solver: -1.99999 ... -1.9993 (its gap)
    exact = tolerance(backend, 1e-9, scale=2.0)  # a float32 state: 2 ulps at 2 rad/s
    assert b[-1, 2:4] == pytest.approx([1.0, -2.0], abs=gap(backend, "coupled_motor_rows") or exact)
    assert a[-1, 2:4] == pytest.approx([1.0, -2.0], abs=1e-3)
    # measured: 3.3e-4 rad, 8.5e-4 rad/s, 2.1e-2 N m. Identical while a motor saturates (the
    # first 10 steps match to 1e-6); once both rows are free, PyBullet's iterative solve of
    # the two coupled rows leaves the elbow 1e-4 .. 7e-4 rad/s short of -2 each step, which
    # accumulates in the angle. Tolerances: ~3x.
    assert dq < 1e-3
    assert dv < 3e-3
    assert dtau < 0.1


@pytest.mark.parametrize(
    ("start", "speed"),
    [(0.4, 1.0), (0.41, 0.0), (0.439, 0.0), (0.441, 0.0), (0.7, 0.0), (0.7, -0.5), (-0.45, 2.0)],
)
@pytest.mark.parametrize("profile", PROFILES)
@each_backend
def test_joint_limit_rows_follow_pybullets_rule(backend, profile, start, speed):
    """slider.urdf's carriage (limits +-0.4 m) reset at or past a limit: PyBullet's limit row
    stops outward motion and, within 0.04 of the limit, pushes back at 0.2 x depth / dt;
    deeper it only stops (0.7: the carriage stays). MuJoCo's limit rows are given that law
    (backends/mujoco/motor_rows.py). Measured over 60 steps, both profiles: 4.7e-7 m, 1.9e-6 m/s:
    MuJoCo's hardened limit row keeps a regulariser of 1e-6 of the speed change it asks for (the
    motor rows are polished to exact, the limit rows are not). Tolerances ~2.5x. PhysX's limit
    threw the carriage back (1.10 m, 57.6 m/s off); the backend stands in for the row while the
    joint is past its limit (backends/physx/limits.py): 3.0e-7 m, 4.8e-7 m/s, but 1.68e-6 m for
    0.7 at -0.5 m/s under "urdf": the float32 position steps 0.5 / 240 m 60 times at ~0.6 m and
    rounds the same way each time (2.8e-8 m a step; raw SAPIEN's slider the same,
    bench/physx_limit_reset.py). Tolerance there: 4 x the float32 gap (1e-6 relative)."""

    def setup(sim: simbridge.Sim, body: int) -> None:
        sim.set_joint_velocity(body, 0, 0.0, max_force=0.0)  # no brake, no friction: free
        sim.reset_joint_state(body, 0, start, speed)

    a, b, dq, dv, _ = _both(backend, profile, "slider.urdf", 60, setup, [0])
    inside = min(max(start, -0.4), 0.4)
    if abs(start) - 0.4 >= 0.04 and speed * start >= 0:  # deep: held where it is
        assert a[-1, 0] == pytest.approx(start, abs=1e-12)
    elif abs(start) >= 0.4:  # at the limit or shallow: back towards it, never further out
        assert abs(a[-1, 0]) <= abs(start) + 1e-12
        assert np.all(np.abs(a[:, 0]) <= max(abs(start), abs(inside)) + 1e-12)
    assert dq < tolerance(backend, 1.2e-6, scale=4.0)
    assert dv < 5e-6


@pytest.mark.parametrize(
    "offset", ["0 0 0", "0.2 0 0", '0.2 -0.1 0.05" rpy="0.3 0.5 -0.7'], ids=["none", "x", "rotated"]
)
@each_backend
def test_a_free_body_spinning_about_an_offset_centre_of_mass(backend, offset):
    """One free body, no gravity, no damping ("urdf"), spinning with its centre of mass off its
    link origin (and its inertial frame rotated): both engines keep the centre of mass moving
    straight at 0.1 m/s and agree on its pose, spin and link frame. MuJoCo's free joint sits at
    the body frame, so the backend makes a free base's body frame its centre-of-mass frame (as
    Bullet integrates the base); with the joint at the link origin the centre of mass drifted
    by 1.25 cm/s after 1 s (first order in dt). Measured: 7.1e-15 (link frame: PyBullet's
    float32, 6e-8)."""
    urdf = (
        f'<robot name="b"><link name="a"><inertial><origin xyz="{offset}"/>'
        '<mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.03"/>'
        '</inertial><collision><origin xyz="0.2 0 0"/><geometry>'
        '<box size="0.1 0.2 0.3"/></geometry></collision></link></robot>'
    )
    out = []
    for name in (REFERENCE, backend):
        with simbridge.Sim(name, profile="urdf", gravity=(0, 0, 0)) as sim:
            body = sim.load_urdf(urdf)
            sim.reset_base_state(body, (0, 0, 1), (0, 0, 0, 1), (0.1, 0, 0), (0.0, 0.3, 5.0))
            sim.step(240)
            s = sim.base_state(body)
            link = sim.link_state(body, -1)
            out.append(
                np.r_[s.position, s.linear_velocity, s.angular_velocity, link.link_frame_position]
            )
            exact = tolerance(name, 1e-12, scale=0.1)
            assert s.linear_velocity == pytest.approx((0.1, 0.0, 0.0), abs=exact)
    ref, got = out
    # float32 link frame on PyBullet; a backend's own integration of the gyroscopic term
    assert np.abs(ref - got).max() < tolerance(backend, 1e-6, "free_spin_gyroscopic")
    assert np.abs(ref[:9] - got[:9]).max() < tolerance(backend, 1e-12, "free_spin_gyroscopic")


@pytest.mark.parametrize("target", [0.6, 0.4, 0.3, -0.9])
@pytest.mark.parametrize("profile", PROFILES)
@each_backend
def test_a_position_target_past_a_limit_is_the_limit(backend, profile, target):
    """PyBullet clamps a POSITION_CONTROL target to the joint's limits (measured on raw
    PyBullet: a target of 0.6 on the slider (limit 0.4) moves it exactly as a target of 0.4).
    Measured over 30 steps, both profiles: 4.0e-11 m, 1.1e-9 m/s, 8.4e-9 N (0.6 without the
    clamp: 1.2e-3 m apart after one step). Tolerances loose but far below that."""

    def setup(sim: simbridge.Sim, body: int) -> None:
        sim.reset_joint_state(body, 0, 0.399, 0.0)
        sim.set_joint_position(body, 0, target, max_force=20.0)

    a, b, dq, dv, dtau = _both(backend, profile, "slider.urdf", 30, setup, [0])
    # a float32 state: 0.4 m held to its float32 steps
    assert dq < tolerance(backend, 1e-9, scale=0.4)
    assert dv < tolerance(backend, 1e-6, "trajectory_float32") and dtau < 1e-3
