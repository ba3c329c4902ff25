"""Scenario files: the shipped ones, a round trip, and errors that name the key and the line."""

from __future__ import annotations

from pathlib import Path

import pytest

from simbridge.compare import (
    dumps_scenario,
    list_scenarios,
    load_scenario,
    loads_scenario,
    save_scenario,
)
from simbridge.compare.errors import ScenarioError
from simbridge.compare.scenario import find_key_line

SHIPPED = [
    "ant-gait",
    "ant-mujoco",
    "cheetah-mujoco",
    "double-pendulum",
    "kuka-reach",
    "laikago-stand",
    "pendulum",
    "r2d2",
    "r2d2-gentle",
    "r2d2-goto",
    "spinning-wheel",
]

GOOD = """\
name = "tiny"
description = "a test"
timestep = "1/240"

[[robots]]
name = "plane"
urdf = "plane.urdf"

[[robots]]
name = "bot"
urdf = "r2d2.urdf"
position = [0, 0, 0.5]

[[phases]]
name = "wait"
steps = 10

[[phases]]
name = "drive"
steps = 20
[[phases.commands]]
joints = [2, 3]
mode = "velocity"
target = -1
max_force = 10
[[phases.commands]]
joints = ["left_front_wheel_joint", 7]
mode = "position"
target = [0.5, 0.25]
max_force = 10
kp = 0.2
"""


def test_shipped_scenarios_are_listed_with_a_description():
    items = list_scenarios()
    assert [s.name for s in items] == SHIPPED
    assert all(s.description for s in items)


def test_r2d2_is_the_tutorial_drive():
    s = load_scenario("r2d2")
    assert s.timestep == 1 / 240
    assert s.gravity == (0.0, 0.0, -9.8)
    assert [r.urdf for r in s.robots] == ["plane.urdf", "r2d2.urdf"]
    assert s.robot("r2d2").position == (0.0, 0.0, 0.1)
    assert [(p.name, p.steps) for p in s.phases] == [
        ("settle", 240),
        ("turn", 240),
        ("forward", 500),
    ]
    assert s.phases[0].commands == ()
    turn = {(c.joints, c.target, c.max_force) for c in s.phases[1].commands}
    assert turn == {
        ((2, 3), (-100.0, -100.0), (50.0, 50.0)),
        ((6, 7), (100.0, 100.0), (50.0, 50.0)),
    }
    (fwd,) = s.phases[2].commands
    assert (fwd.joints, fwd.mode, fwd.target, fwd.max_force) == (
        (2, 3, 6, 7),
        "velocity",
        (-100.0,) * 4,
        (10.0,) * 4,
    )


@pytest.mark.parametrize("name", SHIPPED)
def test_round_trip_of_shipped_scenarios(name, tmp_path):
    s = load_scenario(name)
    path = save_scenario(s, tmp_path / f"{name}.toml")
    again = load_scenario(path)
    assert again == s
    assert dumps_scenario(again) == dumps_scenario(s)


def test_round_trip_keeps_every_field(tmp_path):
    s = loads_scenario(GOOD)
    again = loads_scenario(dumps_scenario(s))
    assert again == s
    cmd = again.phases[1].commands[1]
    assert cmd.joints == ("left_front_wheel_joint", 7)
    assert cmd.kp == 0.2 and cmd.kd is None
    assert again.subject == "bot"  # default: the last robot


def test_with_timestep_keeps_durations():
    s = load_scenario("r2d2").with_timestep(1 / 480)
    assert [p.steps for p in s.phases] == [480, 480, 1000]
    assert s.duration == pytest.approx(980 / 240, rel=1e-12)


def test_with_timestep_refuses_a_step_that_does_not_divide_a_phase():
    msg = r"'phases\[2\].steps': phase 'forward' lasts 2.08333 s, .* of 1/7 s steps \(14.5833\)"
    with pytest.raises(ScenarioError, match=msg):
        load_scenario("r2d2").with_timestep(1 / 7)


def test_a_user_file_path_loads_and_resolves_urdfs_beside_it(tmp_path):
    (tmp_path / "robots").mkdir()
    (tmp_path / "robots" / "box.urdf").write_text(
        '<robot name="box"><link name="b"><inertial><mass value="1"/>'
        '<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>'
    )
    path = tmp_path / "mine.toml"
    path.write_text('[[robots]]\nurdf = "robots/box.urdf"\n[[phases]]\nsteps = 3\n')
    s = load_scenario(str(path))
    assert s.name == "mine" and s.robots[0].name == "box"
    assert s.resolve_urdf(s.robots[0]) == str(tmp_path / "robots" / "box.urdf")


def test_unknown_scenario_lists_the_shipped_ones():
    with pytest.raises(
        ScenarioError,
        match="shipped scenarios: ant-gait, ant-mujoco, cheetah-mujoco, double-pendulum",
    ):
        load_scenario("no-such-scenario")


def _error(text: str) -> ScenarioError:
    with pytest.raises(ScenarioError) as info:
        loads_scenario(text, file="bad.toml")
    return info.value


def _line_of(text: str, needle: str) -> int:
    return next(i for i, line in enumerate(text.splitlines(), 1) if needle in line)


def test_syntax_error_gives_the_line():
    text = GOOD.replace("steps = 20", "steps = = 20")
    err = _error(text)
    assert err.line == _line_of(text, "steps = = 20")
    assert str(err).startswith(f"bad.toml:{err.line}: TOML syntax error")


@pytest.mark.parametrize(
    ("old", "new", "key", "message"),
    [
        (
            'mode = "position"',
            'mode = "speed"',
            "phases[1].commands[1].mode",
            "expected one of velocity, position, torque, got 'speed'",
        ),
        ("kp = 0.2", "kq = 0.2", "phases[1].commands[1].kq", "unknown key; valid keys here"),
        (
            "target = -1",
            'target = "fast"',
            "phases[1].commands[0].target",
            "expected a number, got 'fast'",
        ),
        (
            "target = [0.5, 0.25]",
            "target = [0.5]",
            "phases[1].commands[1].target",
            "expected one number or 2 (one per joint), got 1",
        ),
        ("steps = 20", "steps = 0", "phases[1].steps", "expected an integer from 1 to 1000000"),
        (
            "steps = 20",
            "steps = 9223372036854775807",
            "phases[1].steps",
            "expected an integer from 1 to 1000000, got 9223372036854775807",
        ),
        (
            'description = "a test"',
            'profile = "nope"',
            "profile",
            "unknown profile 'nope'; valid: ['pybullet', 'urdf']",
        ),
        ('name = "tiny"', 'name = "../../elsewhere"', "name", "expected a folder name (no path)"),
        (
            "position = [0, 0, 0.5]",
            "position = [0, 0]",
            "robots[1].position",
            "expected a list of 3 numbers",
        ),
        (
            'timestep = "1/240"',
            'timestep = "fast"',
            "timestep",
            "expected a number of seconds or a fraction",
        ),
        ('urdf = "r2d2.urdf"', 'urdf = ""', "robots[1].urdf", "expected a non-empty string"),
    ],
)
def test_semantic_errors_name_the_key_and_its_line(old, new, key, message):
    assert old in GOOD
    text = GOOD.replace(old, new)
    err = _error(text)
    assert err.key == key
    assert err.line == _line_of(text, new)
    assert str(err) == f"bad.toml:{err.line}: key {key!r}: " + str(err).split(": ", 2)[2]
    assert message in str(err)


def test_a_missing_key_points_at_its_table():
    text = GOOD.replace("steps = 10\n", "")
    err = _error(text)
    assert err.key == "phases[0].steps"
    assert "missing" in str(err)
    assert err.line == _line_of(text, "[[phases]]")  # the first [[phases]] header


def test_max_force_is_required_for_velocity_commands():
    text = GOOD.replace("target = -1\nmax_force = 10\n", "target = -1\n")
    err = _error(text)
    assert err.key == "phases[1].commands[0].max_force"
    assert err.line == _line_of(text, "[[phases.commands]]")


def test_unknown_robot_in_a_command():
    text = GOOD.replace("joints = [2, 3]", 'robot = "ghost"\njoints = [2, 3]')
    err = _error(text)
    assert err.key == "phases[1].commands[0].robot"
    assert err.line == _line_of(text, 'robot = "ghost"')
    assert "robots: ['bot', 'plane']" in str(err)


def test_find_key_line_counts_arrays_of_tables():
    assert find_key_line(GOOD, ["phases", 1, "commands", 1, "kp"]) == _line_of(GOOD, "kp = 0.2")
    assert find_key_line(GOOD, ["robots", 0, "urdf"]) == _line_of(GOOD, 'urdf = "plane.urdf"')
    assert find_key_line(GOOD, ["description"]) == 2
    assert find_key_line(GOOD, ["nowhere"]) is None


def test_file_errors_name_the_file(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text('name = "x"\n[[robots]]\nurdf = 3\n')
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert str(info.value).startswith(f"{path}:3: key 'robots[0].urdf'")


def test_shipped_files_are_package_data():
    from simbridge.compare.scenario import SCENARIOS_DIR

    assert sorted(p.stem for p in Path(SCENARIOS_DIR).glob("*.toml")) == SHIPPED


def test_rpy_is_read_as_a_quaternion():
    import math

    s = loads_scenario(
        '[[robots]]\nurdf = "r2d2.urdf"\nrpy = [0, 0, 1.5707963267948966]\n[[phases]]\nsteps = 1\n'
    )
    x, y, z, w = s.robots[0].orientation
    assert (x, y) == (0.0, 0.0)
    assert z == pytest.approx(math.sqrt(0.5), rel=1e-15)
    assert w == pytest.approx(math.sqrt(0.5), rel=1e-15)
    assert loads_scenario(dumps_scenario(s)) == s
