"""Errors through the public API, every backend: the exception class and its message are pinned;
after each, no temporary file is left behind and the Sim still closes cleanly (and, where the
error came before any simulation, still works)."""

from __future__ import annotations

import re

import numpy as np
import pybullet_data
import pytest
from _gaps import declared, gap

import simbridge
from simbridge import exceptions as exc

GOOD = """<robot name="ok"><link name="a"><inertial><mass value="1"/>
<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>"""


def _robot(joints: str, links: str = '<link name="a"/><link name="b"/>') -> str:
    return f'<robot name="bad">{links}{joints}</robot>'


LOAD_ERRORS = {
    "malformed XML": (
        '<robot name="bad"><link name="a"></robot>',
        exc.UrdfParseError,
        r"<urdf text>: malformed URDF XML: mismatched tag: line 1",
    ),
    "no links": ('<robot name="empty"></robot>', exc.UrdfStructureError, r"has no <link>"),
    "a cycle": (
        _robot(
            '<joint name="ab" type="fixed"><parent link="a"/><child link="b"/></joint>'
            '<joint name="ba" type="fixed"><parent link="b"/><child link="a"/></joint>'
        ),
        exc.UrdfStructureError,
        r"robot 'bad': every link has a parent: the joints form a cycle",
    ),
    "a cycle below the root": (
        _robot(
            '<joint name="bc" type="fixed"><parent link="b"/><child link="c"/></joint>'
            '<joint name="cb" type="fixed"><parent link="c"/><child link="b"/></joint>',
            '<link name="a"/><link name="b"/><link name="c"/>',
        ),
        exc.UrdfStructureError,
        r"links \['b', 'c'\] form a cycle detached from the root",
    ),
    "a missing mesh": (
        '<robot name="bad"><link name="a"><collision><geometry>'
        '<mesh filename="no_such_mesh.stl"/></geometry></collision></link></robot>',
        exc.MeshNotFoundError,
        r"<urdf text>:1: link 'a' <collision> #0: mesh file 'no_such_mesh\.stl' not found",
    ),
    "a planar joint": (
        _robot('<joint name="plane" type="planar"><parent link="a"/><child link="b"/></joint>'),
        exc.UnsupportedJointError,
        r"joint 'plane': joint type 'planar' is not supported \(PyBullet's planar joint is "
        r"broken",
    ),
    "a robot without a name": (
        '<robot><link name="a"/></robot>',
        exc.UrdfStructureError,
        r"<urdf text>:1: <robot>: has no name attribute",
    ),
    "a box without a size": (
        '<robot name="bad"><link name="a"><collision><geometry><box/></geometry></collision>'
        "</link></robot>",
        exc.UrdfStructureError,
        r"link 'a' <collision> #0 <box>: has no size attribute",
    ),
    "a negative box size": (
        '<robot name="bad"><link name="a"><visual><geometry><box size="-1 0.1 0.1"/>'
        "</geometry></visual></link></robot>",
        exc.UrdfStructureError,
        r"link 'a' <visual> #0 <box size>: sizes must be >= 0, got \(-1\.0, 0\.1, 0\.1\)",
    ),
    "a negative joint damping": (
        _robot(
            '<joint name="j" type="continuous"><parent link="a"/><child link="b"/>'
            '<dynamics damping="-2"/></joint>'
        ),
        exc.UrdfStructureError,
        r"joint 'j' <dynamics>: damping must be >= 0, got -2\.0",
    ),
    "a mesh in a format no engine reads": (
        '<robot name="bad"><link name="a"><visual><geometry>'
        f'<mesh filename="{pybullet_data.getDataPath()}/plane.urdf"/></geometry></visual>'
        "</link></robot>",
        exc.UrdfStructureError,
        r"plane\.urdf': unsupported mesh format; valid: \.obj, \.stl, \.dae",
    ),
    "a missing file": (
        "no_such_robot.urdf",
        exc.UrdfNotFoundError,
        r"URDF 'no_such_robot\.urdf' is neither a file, a name on the search path, nor URDF text",
    ),
}


@pytest.mark.parametrize("case", sorted(LOAD_ERRORS))
def test_bad_urdf(make_sim, private_tmp, case):
    text, error, message = LOAD_ERRORS[case]
    sim = make_sim()
    with pytest.raises(error, match=message):
        sim.load_urdf(text)
    assert list(private_tmp.iterdir()) == []
    assert sim.bodies() == []
    body = sim.load_urdf(GOOD)  # the Sim still works
    sim.step()
    assert sim.bodies() == [body]
    assert list(private_tmp.iterdir()) == []
    sim.close()
    assert sim.closed


def test_unknown_backend_lists_the_registered_ones(private_tmp):
    names = simbridge.available_backends()
    listed = ", ".join(re.escape(repr(n)) for n in sorted(names))
    with pytest.raises(
        exc.UnknownBackendError,
        match=rf"unknown backend 'bullet' \(did you mean 'pybullet'\?\); available backends: "
        rf"\[{listed}\]",
    ):
        simbridge.Sim("bullet")
    assert list(private_tmp.iterdir()) == []


def test_unknown_names_list_the_valid_ones(make_sim, private_tmp):
    sim = make_sim()
    body = sim.load_urdf("pendulum.urdf", fixed_base=True)
    with pytest.raises(
        exc.UnknownJointError,
        match=r"body 0 \('pendulum', pendulum\.urdf\) has no joint 'elbow'; valid joints are "
        r"indices 0\.\.0 or names \['hinge'\]",
    ):
        sim.joint_info(body, "elbow")
    with pytest.raises(exc.UnknownJointError, match=r"has no joint 1;"):
        sim.set_joint_velocity(body, 1, 0.0, max_force=1.0)
    with pytest.raises(
        exc.UnknownLinkError,
        match=r"body 0 \('pendulum', pendulum\.urdf\) has no link 'arm'; valid links are -1 "
        r"\(base\), indices 0\.\.0 or names \['bob'\]",
    ):
        sim.link_state(body, "arm")
    with pytest.raises(exc.UnknownLinkError, match=r"has no link -2"):
        sim.dynamics_info(body, -2)
    with pytest.raises(
        exc.UnknownBodyError, match=rf"unknown body 99; bodies in this Sim: \[{body}\]"
    ):
        sim.base_state(99)
    assert sim.link_state(body, "pivot") == sim.link_state(body, -1)  # the root's name is -1
    sim.step()
    sim.close()
    assert list(private_tmp.iterdir()) == []


BAD_ARGUMENTS = {
    "target shape": (
        lambda s, b: s.set_joint_velocity(b, ["shoulder", "elbow"], [1, 2, 3], max_force=1),
        r"argument 'target': expected a number or shape \(2,\) for 2 joint\(s\), got shape \(3,\)",
    ),
    "target NaN": (
        lambda s, b: s.set_joint_velocity(b, "shoulder", float("nan"), max_force=1),
        r"argument 'target': values must be finite, got nan",
    ),
    "max_force inf": (
        lambda s, b: s.set_joint_velocity(b, "shoulder", 0.0, max_force=float("inf")),
        r"argument 'max_force': values must be finite",
    ),
    "max_force negative": (
        lambda s, b: s.set_joint_velocity(b, "shoulder", 0.0, max_force=-1.0),
        r"argument 'max_force': values must be >= 0, got -1\.0",
    ),
    "torque inf in an array": (
        lambda s, b: s.set_joint_torque(b, ["shoulder", "elbow"], [1.0, float("-inf")]),
        r"argument 'torque': values must be finite",
    ),
    "position target 2-d": (
        lambda s, b: s.set_joint_position(b, ["shoulder"], [[1.0]], max_force=1.0),
        r"argument 'target': expected a number or shape \(1,\) for 1 joint\(s\), got shape "
        r"\(1, 1\)",
    ),
    "reset NaN": (
        lambda s, b: s.reset_joint_state(b, "elbow", float("nan")),
        r"argument 'positions': values must be finite",
    ),
    "base position shape": (
        lambda s, b: s.reset_base_state(b, position=(1.0, 2.0)),
        r"argument 'position': expected 3 numbers, got 2",
    ),
    "base orientation not unit": (
        lambda s, b: s.reset_base_state(b, orientation=(0, 0, 0, 2)),
        r"argument 'orientation': expected a unit quaternion \(x, y, z, w\)",
    ),
    "load position inf": (
        lambda s, b: s.load_urdf("pendulum.urdf", base_position=(0, 0, float("inf"))),
        r"argument 'base_position': values must be finite",
    ),
    "a joint given twice": (
        lambda s, b: s.set_joint_torque(b, ["elbow", 1], [1.0, 2.0]),
        r"argument 'joints': a joint is given twice",
    ),
    "negative step count": (
        lambda s, b: s.step(-1),
        r"argument 'n': must be an integer >= 0, got -1",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD_ARGUMENTS))
def test_bad_arguments(make_sim, private_tmp, case):
    call, message = BAD_ARGUMENTS[case]
    sim = make_sim()
    body = sim.load_urdf("double_pendulum.urdf", fixed_base=True)
    before = sim.joint_states(body)
    with pytest.raises(exc.InvalidArgumentError, match=message):
        call(sim, body)
    after = sim.joint_states(body)  # nothing was half applied
    assert before.positions.tobytes() == after.positions.tobytes()
    assert sim.bodies() == [body]
    sim.step()
    sim.close()
    assert list(private_tmp.iterdir()) == []


def test_fixed_joint_takes_no_command(make_sim):
    sim = make_sim()
    body = sim.load_urdf("r2d2.urdf")
    with pytest.raises(
        exc.InvalidArgumentError,
        match=r"joint 'base_to_right_leg' \(index 0\) of body 'physics' is fixed and takes no "
        r"command",
    ):
        sim.set_joint_velocity(body, 0, 1.0, max_force=1.0)


def test_closed_sim_refuses_everything(make_sim, private_tmp):
    sim = make_sim()
    body = sim.load_urdf("free_box.urdf")
    sim.close()
    sim.close()  # twice is fine
    for call in (sim.step, lambda: sim.base_state(body), sim.bodies, lambda: sim.time):
        with pytest.raises(exc.SimClosedError, match=r"this Sim is closed; create a new one"):
            call()
    assert list(private_tmp.iterdir()) == []


# A state turned NaN or infinite. The trigger must work on every engine; an absurd time step is
# engine-neutral: free fall reaches g dt^2 ~ 1e401 m, past float64, within one step. Backends
# probe for divergence periodically (PyBullet backend: every 8th step), so 32 steps are taken.
# A backend that needs another trigger adds it here by name, with the reason.
DIVERGENCE_TRIGGERS: dict[str, dict[str, float]] = {}
DEFAULT_TRIGGER = {"timestep": 1e200}


def test_diverged_simulation_is_reported(backend, make_sim, profile, private_tmp):
    trigger = declared(DIVERGENCE_TRIGGERS, backend) or DEFAULT_TRIGGER
    sim = make_sim(profile=profile, **trigger)
    sim.load_urdf("free_box.urdf", base_position=(0, 0, 1))
    with pytest.raises(
        exc.SimulationDivergedError,
        match=rf"simulation on backend '{backend}' diverged at t=.* s: .* is not finite",
    ) as first:
        for _ in range(32):
            sim.step()
    # the world is not a simulation any more (NaN on PyBullet; MuJoCo has reset its state to
    # the reference pose): steps and reads say so again, with the same time, until reset()
    t = sim.time
    with pytest.raises(exc.SimulationDivergedError) as again:
        sim.step()
    assert str(again.value) == str(first.value) and sim.time == t
    with pytest.raises(exc.SimulationDivergedError):
        sim.base_state(sim.bodies()[0])
    other = sim.load_urdf("cube_small.urdf", base_position=(3, 0, 1))  # a new model: still
    with pytest.raises(exc.SimulationDivergedError):  # the diverged world, refused
        sim.step()
    sim.remove(other)
    with pytest.raises(exc.SimulationDivergedError):
        sim.step()
    sim.reset()  # a new world (with the same 1e200 s step it would diverge again)
    body = sim.load_urdf("free_box.urdf", base_position=(0, 0, 1))
    assert sim.time == 0.0
    assert sim.base_state(body).position == pytest.approx((0, 0, 1))
    sim.close()
    assert sim.closed
    assert list(private_tmp.iterdir()) == []


def test_huge_torque_is_either_finite_or_reported(make_sim, private_tmp):
    """The largest finite torque on a free-spinning wheel ("urdf": no clamp, no damping): the
    backend either keeps a finite state or raises SimulationDivergedError, never returns NaN."""
    sim = make_sim(profile="urdf")
    body = sim.load_urdf("wheel.urdf", fixed_base=True)
    try:
        for _ in range(64):
            sim.set_joint_torque(body, "axle", 1.7e308)
            sim.step()
    except exc.SimulationDivergedError:
        pass
    else:
        state = sim.joint_states(body, "axle")
        assert np.isfinite(state.velocities).all() and np.isfinite(state.positions).all()
    sim.close()
    assert list(private_tmp.iterdir()) == []


@pytest.mark.parametrize(
    "entry",
    [
        {"integrator": "no such integrator"},
        {"contact_model": "no such contact model"},
        {"friction_combine": "no such rule"},
    ],
    ids=lambda e: next(iter(e)),
)
def test_a_profile_entry_the_backend_cannot_honour_is_refused(make_sim, private_tmp, entry):
    """A profile value the engine has no switch for raises BackendUnsupportedError naming the
    entry before any world exists, instead of being silently ignored."""
    from simbridge import Profile

    name, value = next(iter(entry.items()))
    with pytest.raises(exc.BackendUnsupportedError, match=name.split("_")[0]) as info:
        make_sim(profile=Profile(name="odd", **entry))
    assert value in str(info.value) or "other than" in str(info.value)


@pytest.mark.parametrize(
    "content",
    [
        '<?xml version="1.0"?><COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" '
        'version="1.4.1"><scene/></COLLADA>',
        "not xml at all",
        "",
    ],
    ids=["empty scene", "garbage", "empty file"],
)
def test_a_bad_collada_mesh_is_an_error_not_a_crash(make_sim, tmp_path, content):
    """PyBullet's COLLADA reader ends the process on a .dae with an empty <scene> (measured:
    SIGSEGV); every .dae is read before an engine sees it, and a bad one is a UrdfStructureError
    naming the file, link and element."""
    (tmp_path / "bad.dae").write_text(content)
    urdf = tmp_path / "bad.urdf"
    urdf.write_text(
        '<robot name="bad"><link name="a"><visual><geometry><mesh filename="bad.dae"/>'
        "</geometry></visual></link></robot>"
    )
    sim = make_sim()
    with pytest.raises(exc.UrdfStructureError, match=r"bad\.urdf:1: link 'a' <visual> #0 <mesh>"):
        sim.load_urdf(urdf)
    assert sim.bodies() == []


@pytest.mark.parametrize(
    ("source", "error", "message"),
    [
        ("x" * 300, exc.UrdfNotFoundError, r"URDF 'x{100}\.\.\. \(300 characters\)' is neither"),
        ("a\x00b", exc.UrdfNotFoundError, r"URDF 'a\\x00b' is neither a file"),
    ],
    ids=["a name too long for a file", "a NUL byte"],
)
def test_a_source_no_file_system_takes_is_not_found(make_sim, source, error, message):
    with pytest.raises(error, match=message):
        make_sim().load_urdf(source)


def test_urdf_text_with_a_byte_order_mark_is_text(make_sim):
    sim = make_sim()
    body = sim.load_urdf("\ufeff" + GOOD)
    assert sim.body_name(body) == "ok"


def test_an_empty_joint_sequence_is_a_command_on_no_joint(make_sim):
    sim = make_sim()
    body = sim.load_urdf("r2d2.urdf")
    sim.set_joint_velocity(body, [], [], max_force=[])
    sim.set_joint_position(body, [], [], max_force=1.0)
    sim.set_joint_torque(body, [], 0.0)
    assert len(sim.joint_states(body, []).positions) == 0
    sim.step()


def test_repr_never_raises(make_sim):
    sim = make_sim()
    assert "t=0.0000s" in repr(sim)
    sim.close()
    assert repr(sim).endswith("closed)")


def test_a_joint_of_a_body_without_joints(make_sim):
    sim = make_sim()
    cube = sim.load_urdf("cube.urdf")
    with pytest.raises(
        exc.UnknownJointError, match=r"body 0 \('.*', cube\.urdf\) has no joint 0: it has no joints"
    ):
        sim.joint_info(cube, 0)


def test_a_negative_moment_of_inertia_is_refused_only_where_it_is_simulated(make_sim):
    """Under "urdf" (the file's inertia) a negative ixx is an error naming the link; under
    "pybullet" the file's inertia is not used (the collision box's is) and the file loads, as
    in raw PyBullet."""
    text = (
        '<robot name="odd"><link name="a"><inertial><mass value="1"/>'
        '<inertia ixx="-1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>'
        '<collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link></robot>'
    )
    with pytest.raises(
        exc.UrdfStructureError,
        match=r"link 'a' <inertia>: ixx, iyy and izz must be >= 0 to be simulated, got -1\.0",
    ):
        make_sim(profile="urdf").load_urdf(text)
    sim = make_sim(profile="pybullet")
    body = sim.load_urdf(text)
    sim.step()
    assert sim.dynamics_info(body).local_inertia_diagonal[0] > 0


def test_a_robot_named_with_the_empty_string_loads(make_sim):
    sim = make_sim()
    body = sim.load_urdf('<robot name=""><link name="a"/></robot>')
    assert sim.body_name(body) == ""


# ---------------------------------------------------------------- non-finite states


def _pair(mass: str = "1", xyz: str = "0 0 0") -> str:
    """Two boxes on a continuous joint; the base's mass and inertial origin as given."""
    inertia = '<inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/>'
    box = '<collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision>'
    return (
        f'<robot name="pair"><link name="a"><inertial><origin xyz="{xyz}"/>'
        f'<mass value="{mass}"/>{inertia}</inertial>{box}</link>'
        f'<link name="b"><inertial><mass value="1"/>{inertia}</inertial>{box}</link>'
        '<joint name="j" type="continuous"><parent link="a"/><child link="b"/>'
        '<origin xyz="0 0 0.2"/><axis xyz="0 0 1"/></joint></robot>'
    )


def _torque(sim, body):
    sim.set_joint_velocity(body, "j", 0.0, max_force=0.0)  # release the brake
    sim.set_joint_torque(body, "j", 1e308)


# Inputs after which one step leaves PyBullet's state NaN (measured before the fix: the reads
# returned NaN and joint_states never raised); MuJoCo takes a mass of 1e300 as a finite world.
BLOW_UPS = {
    "a mass of 1e300 in the URDF": (_pair(mass="1e300"), None),
    "an inertial origin of 1e300 in the URDF": (_pair(xyz="1e300 0 0"), None),
    "a torque of 1e308": (_pair(), _torque),
}


def _reads(sim, body):
    """Every state read of the Sim, as flat lists of floats."""
    return {
        "base_state": lambda: [v for part in sim.base_state(body) for v in part],
        "link_state": lambda: [v for part in sim.link_state(body, 0) for v in part],
        "link_states": lambda: np.concatenate(sim.link_states(body), axis=1).ravel().tolist(),
        "joint_states": lambda: np.concatenate(sim.joint_states(body)[:3]).tolist(),
        "contact_points": lambda: [
            v
            for c in sim.contact_points()
            for v in (*c.position_on_a, *c.position_on_b, c.contact_distance, c.normal_force)
        ],
        "get_state": lambda: [
            v for b in sim.get_state().bodies for v in (*b.base_position, *b.joint_positions)
        ],
    }


@pytest.mark.parametrize("case", sorted(BLOW_UPS))
def test_after_any_step_a_non_finite_state_is_refused_until_reset(make_sim, private_tmp, case):
    """After each step, each read returns finite numbers or raises SimulationDivergedError;
    once one raised, every read and step raises it until reset(), and the world works again
    after it."""
    urdf, then = BLOW_UPS[case]
    sim = make_sim()
    sim.load_urdf("plane.urdf")
    body = sim.load_urdf(urdf, base_position=(0, 0, 1))
    if then is not None:
        then(sim, body)
    reads = _reads(sim, body)
    diverged = None
    for _ in range(3):
        try:
            sim.step()
        except exc.SimulationDivergedError as error:
            diverged = error
        for name, read in reads.items():
            try:
                values = read()
            except exc.SimulationDivergedError as error:
                diverged = diverged or error
                continue
            assert diverged is None, f"{name} answered after the divergence ({diverged})"
            assert np.isfinite(values).all(), f"{name} returned {values}"
        if diverged is not None:
            break
    if diverged is not None:
        assert re.search(r"diverged at t=.* s: .* is not finite", str(diverged))
        for name, read in [("step", sim.step), *reads.items()]:
            with pytest.raises(exc.SimulationDivergedError):
                read()
                pytest.fail(f"{name} answered")
        sim.reset()
        body = sim.load_urdf(_pair(), base_position=(0, 0, 1))
        sim.step(10)
        assert np.isfinite(sim.joint_states(body).positions).all()
    sim.close()
    assert list(private_tmp.iterdir()) == []


def test_a_divergence_nobody_reads_is_raised_by_a_step_soon_after(make_sim):
    """Stepping on without reading: step raises SimulationDivergedError within 8 steps of the
    one that blew up (PyBullet probes every body every 8th step; MuJoCo at every step). Under
    "urdf" (no speed clamp: under "pybullet" MuJoCo clamps the wheel to 100 rad/s, finite)."""
    sim = make_sim(profile="urdf")
    body = sim.load_urdf(_pair(), base_position=(0, 0, 1))
    sim.step(21)
    _torque(sim, body)
    with pytest.raises(exc.SimulationDivergedError, match=r"is not finite"):
        for _ in range(8):
            sim.step()
    with pytest.raises(exc.SimulationDivergedError):
        sim.joint_states(body)


def test_every_step_check_raises_at_the_step_that_diverged(make_sim, private_tmp):
    """divergence_check="every_step": the step after which the state is not finite raises,
    with that step's time, on every backend; later steps and reads refuse until reset()."""
    sim = make_sim(profile="urdf", divergence_check="every_step")
    assert sim.manifest()["divergence_check"] == "every_step"
    body = sim.load_urdf(_pair(), base_position=(0, 0, 1))
    sim.step(21)
    _torque(sim, body)
    with pytest.raises(exc.SimulationDivergedError, match=r"is not finite") as first:
        sim.step()
    assert sim.time == pytest.approx(22 * sim.timestep, abs=1e-12)
    assert f"diverged at t={sim.time:.6f} s" in str(first.value)
    for call in (sim.step, lambda: sim.joint_states(body), lambda: sim.base_state(body)):
        with pytest.raises(exc.SimulationDivergedError):
            call()
    sim.reset()
    body = sim.load_urdf(_pair(), base_position=(0, 0, 1))
    sim.step(30)
    assert np.isfinite(sim.joint_states(body).positions).all()
    assert list(private_tmp.iterdir()) == []


def test_a_divergence_inside_one_step_call_stops_it_at_that_step(make_sim):
    """``step(n)`` stops at the step that diverged (it does not step on from a NaN or, on
    MuJoCo, from the reference pose MuJoCo put back), so the error and ``sim.time`` name the
    step where it happened, not the end of the call."""
    sim = make_sim(profile="urdf", divergence_check="every_step")
    body = sim.load_urdf(_pair(), base_position=(0, 0, 1))
    sim.step(5)
    _torque(sim, body)
    with pytest.raises(exc.SimulationDivergedError):
        sim.step(500)
    assert sim.time == pytest.approx(6 * sim.timestep, abs=1e-12)


def test_the_divergence_check_changes_no_result(make_sim):
    """The check only reads: r2d2 driven for 200 steps ends bit-identical either way."""

    def drive(mode: str) -> np.ndarray:
        sim = make_sim(divergence_check=mode)
        sim.load_urdf("plane.urdf")
        robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
        sim.set_joint_velocity(robot, [2, 3, 6, 7], -5.0, max_force=10.0)
        sim.step(200)
        base = sim.base_state(robot)
        return np.concatenate([base.position, base.orientation, sim.joint_states(robot).positions])

    np.testing.assert_array_equal(drive("every_step"), drive("periodic"))


def test_a_periodic_check_stops_a_long_step_call_soon_after(make_sim):
    """Under "periodic" a step(500) that blows up at its first step stops within 8 steps
    (PyBullet probes inside the call, every 8th step; MuJoCo at the step itself), not at the
    end of the call."""
    sim = make_sim(profile="urdf")
    body = sim.load_urdf(_pair(), base_position=(0, 0, 1))
    sim.step(21)
    _torque(sim, body)
    with pytest.raises(exc.SimulationDivergedError):
        sim.step(500)
    assert 22 * sim.timestep - 1e-12 <= sim.time <= 29 * sim.timestep + 1e-12


@pytest.mark.parametrize("bad", ["always", "", None, True, 1])
def test_an_unknown_divergence_check_names_the_choices(backend, bad):
    with pytest.raises(
        exc.InvalidArgumentError, match=r"'divergence_check'.*\['periodic', 'every_step'\]"
    ):
        simbridge.Sim(backend, divergence_check=bad)


def test_a_sim_is_neither_copied_nor_pickled_but_its_state_is(make_sim):
    """copy.copy shared the engine (closing the copy broke the original with a raw engine
    error); deepcopy and pickle raised raw TypeErrors. All three are SimNotCopyableError and
    the Sim goes on; its WorldState pickles and restores into a Sim loaded alike."""
    import copy
    import pickle

    sim = make_sim()
    robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
    sim.step(10)
    for how in (copy.copy, copy.deepcopy, pickle.dumps):
        with pytest.raises(exc.SimNotCopyableError, match=r"get_state\(\)"):
            how(sim)
    state = pickle.loads(pickle.dumps(sim.get_state()))
    sim.step(10)
    other = make_sim()
    twin = other.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
    other.set_state(state)
    other.step(10)
    assert other.base_state(twin).position == sim.base_state(robot).position


# ---------------------------------------------------------------- switches and ids

SWITCHES = {
    "fixed_base 'false'": (
        lambda s: s.load_urdf("pendulum.urdf", fixed_base="false"),
        r"argument 'fixed_base': must be True or False \(a bool\), got 'false'",
    ),
    "fixed_base 'no'": (
        lambda s: s.load_urdf("pendulum.urdf", fixed_base="no"),
        r"argument 'fixed_base': must be True or False \(a bool\), got 'no'",
    ),
    "fixed_base 1": (
        lambda s: s.load_urdf("pendulum.urdf", fixed_base=1),
        r"argument 'fixed_base': must be True or False \(a bool\), got 1",
    ),
    "realtime 'no'": (
        lambda s: s.step(1, realtime="no"),
        r"argument 'realtime': must be True or False \(a bool\), got 'no'",
    ),
    "exact 'false'": (
        lambda s: s.get_state(exact="false"),
        r"argument 'exact': must be True or False \(a bool\), got 'false'",
    ),
}


@pytest.mark.parametrize("case", sorted(SWITCHES))
def test_a_switch_is_a_bool_not_a_truthy_value(make_sim, case):
    """A truthy string welded the base (fixed_base="false") on both backends: a switch takes
    True or False (numpy's too) and names itself otherwise."""
    call, message = SWITCHES[case]
    sim = make_sim()
    with pytest.raises(exc.InvalidArgumentError, match=message):
        call(sim)
    assert sim.bodies() == [] and sim.time == 0.0
    body = sim.load_urdf("pendulum.urdf", fixed_base=np.False_)
    assert sim.manifest()["bodies"][body]["fixed_base"] is False


def test_gui_is_a_bool(backend):
    with pytest.raises(
        exc.InvalidArgumentError, match=r"argument 'gui': must be True or False \(a bool\)"
    ):
        simbridge.Sim(backend, gui="false")


def test_a_body_id_is_an_int_not_a_bool(make_sim):
    """set_joint_velocity(body=True, ...) drove body 1: ids are ints (numpy's too)."""
    sim = make_sim()
    sim.load_urdf("pendulum.urdf", fixed_base=True)
    one = sim.load_urdf("pendulum.urdf", base_position=(1, 0, 0), fixed_base=True)
    assert one == 1
    for call, argument in (
        (lambda: sim.set_joint_velocity(True, 0, 1.0, max_force=1.0), "body"),
        (lambda: sim.base_state(True), "body"),
        (lambda: sim.joint_states(1.0), "body"),
        (lambda: sim.remove(True), "body"),
        (lambda: sim.contact_points(True), "body_a"),
        (lambda: sim.contact_points(0, True), "body_b"),
    ):
        with pytest.raises(
            exc.InvalidArgumentError,
            match=rf"argument '{argument}': a body id is an int \(as load_urdf returns it\)",
        ):
            call()
    assert sim.bodies() == [0, 1]
    assert sim.joint_states(one).velocities.tolist() == [0.0]  # nothing was commanded
    sim.set_joint_velocity(np.int64(1), 0, 1.0, max_force=1.0)
    assert sim.base_state(np.int32(1)) == sim.base_state(1)


# ---------------------------------------------------------------- state values past any use

STATE_BOUNDS = {
    "a spawn at 1e308": (
        lambda s, b: s.load_urdf("pendulum.urdf", base_position=(1e308, 0, 0)),
        "base_position",
    ),
    "a teleport to 1e308": (lambda s, b: s.reset_base_state(b, position=(0, 1e308, 0)), "position"),
    "a base velocity of 1e300": (
        lambda s, b: s.reset_base_state(b, linear_velocity=(0, 0, -1e300)),
        "linear_velocity",
    ),
    "a spin of 1e11": (
        lambda s, b: s.reset_base_state(b, angular_velocity=(1e11, 0, 0)),
        "angular_velocity",
    ),
    "a joint velocity of 1e300": (
        lambda s, b: s.reset_joint_state(b, "j", 0.0, 1e300),
        "velocities",
    ),
    "a joint position of -1e11": (lambda s, b: s.reset_joint_state(b, "j", -1e11), "positions"),
}


@pytest.mark.parametrize("case", sorted(STATE_BOUNDS))
def test_a_position_or_velocity_no_engine_can_take_is_refused_where_it_is_given(make_sim, case):
    """Positions and velocities past 1e10 (m, rad, m/s, rad/s) guarantee a blow-up: MuJoCo
    resets a state past 1e10 as diverged at the next step, and PyBullet's float32 link poses
    read past 3.4e38 as infinite (a base teleported to 1e308: NaN link states, measured). They
    are refused when given, naming the argument; 1e10 itself is taken."""
    call, argument = STATE_BOUNDS[case]
    sim = make_sim()
    body = sim.load_urdf(_pair(), base_position=(0, 0, 1))
    with pytest.raises(
        exc.InvalidArgumentError, match=rf"argument '{argument}': values must be within \+-1e\+10"
    ):
        call(sim, body)
    assert sim.bodies() == [body]
    assert sim.base_state(body).position == pytest.approx((0, 0, 1), abs=1e-6)
    sim.reset_joint_state(body, "j", 1e10)  # the bound itself is a position
    sim.step()


@pytest.mark.parametrize("depth", [96, 200_000])
def test_elements_nested_deeper_than_the_engine_reads(make_sim, backend, private_tmp, depth):
    """Unknown elements nested inside a link (one a line): PyBullet's XML reader refuses more
    than 98 levels, <robot> counting 1 (measured on raw PyBullet); the backend says so instead
    of raising a raw RecursionError (200,000 levels) from rewriting the text for it."""
    nested = "<a>\n" * depth + "</a>\n" * depth
    text = f'<robot name="deep"><link name="l">\n{nested}</link></robot>'
    sim = make_sim()
    limit = gap(backend, "deepest_xml")  # the deepest its engine's reader takes; None: no limit
    if limit is not None and depth + 2 > limit:
        with pytest.raises(
            exc.UrdfStructureError,
            match=rf"elements nested {depth + 2} deep: PyBullet's XML reader refuses more than "
            rf"{limit:.0f}",
        ):
            sim.load_urdf(text)
        assert sim.bodies() == []
    else:
        body = sim.load_urdf(text)
        assert sim.body_name(body) == "deep"
    sim.step()
    assert list(private_tmp.iterdir()) == []


# Mesh files that are not meshes: PyBullet loads random bytes, an empty file or NaN vertices as a
# link without a shape and reads an .obj's missing numbers as uninitialised memory (inertia 1e41,
# measured); the MuJoCo backend raised a raw IndexError on 'v 1 2'; trimesh drops a .dae's NaN
# vertex quietly. Each is refused when the URDF is read, naming the
# URDF, the link, the mesh, its line where it has one, and what is wrong.
GARBAGE_MESHES = {
    "random bytes as .stl": (
        "bad.stl",
        bytes(range(256)) * 20,
        r"'bad\.stl' cannot be read as a mesh: not an \.stl: neither binary .* nor ASCII text "
        r"starting with 'solid' \(5120 bytes\)",
    ),
    "an empty .stl": ("bad.stl", b"", r"not an \.stl: .* \(an empty file\)"),
    "an ASCII .stl with a bad vertex": (
        "bad.stl",
        b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0\nvertex 0 1 0\n",
        r"'bad\.stl' cannot be read as a mesh \(line 5\): 'vertex' needs 3 numbers \(x y z\), "
        r"got 'vertex 1 0'",
    ),
    "an .obj vertex with 2 numbers": (
        "bad.obj",
        b"v 0 0 0\nv 1 2\nv 0 1 0\nf 1 2 3\n",
        r"'bad\.obj' cannot be read as a mesh \(line 2\): 'v' needs 3 numbers \(x y z\), got "
        r"'v 1 2'",
    ),
    "an .obj vertex of words": (
        "bad.obj",
        b"v 0 0 0\r\nv 1 0 0\r\nv a b c\r\nf 1 2 3\r\n",
        r"\(line 3\): 'v' needs 3 numbers \(x y z\), got 'v a b c'",
    ),
    "binary bytes as .obj": ("bad.obj", b"\x00\x01v 1 2 3\n", r"not an \.obj: binary data"),
    "an empty .obj": ("bad.obj", b"", r"'bad\.obj' cannot be read as a mesh: holds no vertex"),
    "an .obj of comments": ("bad.obj", b"# nothing\n", r"holds no vertex"),
    "a NaN vertex in an .obj": (
        "bad.obj",
        b"v 0 0 0\nv 0.1 0 0\nv 0 nan 0\nv 0 0 0.1\nf 1 2 3\nf 1 3 4\n",
        r"'bad\.obj' cannot be read as a mesh \(line 3\): vertex 3 is not finite: \(0, nan, 0\)",
    ),
    "an infinite vertex in an ASCII .stl": (
        "bad.stl",
        b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex inf 0 0\n"
        b"vertex 0 1 0\nendloop\nendfacet\nendsolid x\n",
        r"\(line 5\): vertex 2 is not finite: \(inf, 0, 0\)",
    ),
    "a NaN vertex in a binary .stl": (
        "bad.stl",
        bytes(80)
        + (1).to_bytes(4, "little")
        + np.array([0, 0, 1, 0, 0, 0, 1, 0, 0, 0, np.nan, 0], dtype="<f4").tobytes()
        + bytes(2),
        r"'bad\.stl' cannot be read as a mesh: triangle 1 vertex 3 is not finite: \(0, nan, 0\)",
    ),
    "a face past the vertices of an .obj": (
        "bad.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 99\n",
        r"\(line 5\): a face corner is vertex 99; the file has 4 vertices",
    ),
    "a NaN in a COLLADA <float_array>": (
        "bad.dae",
        b'<?xml version="1.0"?><COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" '
        b'version="1.4.1"><library_geometries><geometry id="g"><mesh><source id="p">\n'
        b'<float_array id="a" count="9">0 0 0 0.1 0 0 0 nan 0</float_array></source>'
        b"</mesh></geometry></library_geometries></COLLADA>",
        r"'bad\.dae' cannot be read as COLLADA \(MeshReadError: .*bad\.dae:2: a number of a "
        r"<float_array> is not finite: 'nan'\)",
    ),
}


@pytest.mark.parametrize("case", sorted(GARBAGE_MESHES))
def test_a_mesh_file_that_is_no_mesh_is_refused(make_sim, private_tmp, tmp_path, case):
    name, content, message = GARBAGE_MESHES[case]
    (tmp_path / name).write_bytes(content)
    urdf = tmp_path / "robot.urdf"
    urdf.write_text(
        '<robot name="bad"><link name="a">\n<collision><geometry>'
        f'<mesh filename="{name}"/></geometry></collision></link></robot>'
    )
    sim = make_sim()
    with pytest.raises(exc.UrdfStructureError, match=r"robot\.urdf:2: link 'a' <collision> #0 "):
        sim.load_urdf(urdf)
    with pytest.raises(exc.UrdfStructureError, match=message):
        sim.load_urdf(urdf)
    assert sim.bodies() == []
    assert list(private_tmp.iterdir()) == []


def test_the_cli_refuses_a_mesh_that_is_no_mesh(backend, tmp_path, capsys):
    """`simbridge joints` on a URDF whose .stl is random bytes printed the joint table and
    exited 0: it exits 1 with the error on stderr and nothing on stdout."""
    from simbridge.cli import main

    (tmp_path / "bad.stl").write_bytes(bytes(range(256)) * 20)
    urdf = tmp_path / "robot.urdf"
    urdf.write_text(
        '<robot name="bad"><link name="a"><collision><geometry><mesh filename="bad.stl"/>'
        '</geometry></collision></link><link name="b"/><joint name="j" type="continuous">'
        '<parent link="a"/><child link="b"/></joint></robot>'
    )
    assert main(["joints", str(urdf), "--backend", backend]) == 1
    out, err = capsys.readouterr()
    assert out == ""
    assert "'bad.stl' cannot be read as a mesh: not an .stl" in err
