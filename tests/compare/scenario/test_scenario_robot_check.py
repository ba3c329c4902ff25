"""A scenario's robot files and joint names are checked before any run starts: a misspelt
joint, a joint index out of range or a robot file not found is told as ``FILE:LINE: key`` at
once, and no engine runs first (it took a run of about 9 s, and named neither file nor key)."""

from __future__ import annotations

from pathlib import Path

import pytest

from simbridge.compare import compare, load_scenario
from simbridge.compare.errors import ScenarioError
from simbridge.compare.run import studyjobs

PENDULUM = (Path(__file__).resolve().parents[3] / "compare/scenarios/pendulum.toml").read_text()


@pytest.fixture
def no_runs(monkeypatch):
    """Starting the jobs fails the test: the check comes first."""

    def refuse(*a, **k):
        raise AssertionError("the jobs started")

    monkeypatch.setattr(studyjobs, "run_jobs", refuse)
    import simbridge.compare.pipeline as pipeline

    monkeypatch.setattr(pipeline, "run_jobs", refuse)


@pytest.mark.parametrize(
    ("old", "new", "key", "says"),
    [
        ('joints = "hinge"', 'joints = "hinje"', "phases[0].commands[0].joints", "did you mean"),
        ('joints = "hinge"', "joints = 5", "phases[0].commands[0].joints", "has no joint 5"),
        ("{ hinge = 0.5 }", "{ hinje = 0.5 }", "robots[0].joint_positions.hinje", "'hinge'"),
        ('urdf = "pendulum.urdf"', 'urdf = "pendulumm.urdf"', "robots[0].urdf", "pendulumm"),
    ],
)
def test_a_robot_mistake_names_file_line_and_key_before_any_run(
    tmp_path, no_runs, old, new, key, says
):
    path = tmp_path / "mine.toml"
    assert old in PENDULUM
    path.write_text(PENDULUM.replace(old, new, 1))
    line = next(i for i, t in enumerate(path.read_text().splitlines(), 1) if new in t)
    sc = load_scenario(path)  # the file alone is valid
    with pytest.raises(ScenarioError) as err:
        compare(sc, ["pybullet", "pybullet"], duration=0.1, ensemble=1, workers=0)
    assert str(err.value).startswith(f"{path}:{line}: key {key!r}: ")
    assert says in str(err.value)
    assert (err.value.line, err.value.key) == (line, key)


def test_a_robot_not_found_lists_the_scenarios_folder_first(tmp_path, monkeypatch):
    """The scenario's own folder is searched first (Scenario.resolve_urdf): the list says so,
    each place once, in the order searched, and the file near the name there is offered."""
    from simbridge.model.urdf_source import search_path

    monkeypatch.delenv("SIMBRIDGE_URDF_PATH", raising=False)
    sub = tmp_path / "my" / "sub"
    sub.mkdir(parents=True)
    (sub / "foo.urdf").write_text(
        (Path(__file__).resolve().parents[3] / "robots/pendulum.urdf").read_text()
    )
    path = sub / "mine.toml"
    path.write_text(PENDULUM.replace('urdf = "pendulum.urdf"', 'urdf = "fooo.urdf"', 1))
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    from simbridge.compare.scenario.robot_check import check_robots

    with pytest.raises(ScenarioError) as err:
        check_robots(load_scenario(path))
    said = str(err.value)
    assert "URDF 'fooo.urdf' is neither a file, a name on the search path, nor URDF text " \
        "(did you mean 'foo.urdf'?); searched: " in said  # fmt: skip
    robots, data = search_path()
    places = [sub / "fooo.urdf", elsewhere / "fooo.urdf"]
    places += [f / n for f in (robots, data) for n in ("fooo.urdf", "fooo.urdf.urdf")]
    assert said.endswith("searched: [" + ", ".join(repr(str(p)) for p in places) + "]")


def test_a_right_scenario_passes_the_check():
    from simbridge.compare.scenario.robot_check import check_robots

    for name in ("pendulum", "double-pendulum", "r2d2", "kuka-reach", "ant-gait"):
        check_robots(load_scenario(name))


def test_a_robot_file_changed_since_is_read_again(tmp_path):
    """The joint names read are kept by file and its time and size: an edit is seen."""
    from simbridge.compare.scenario.robot_check import check_robots

    robots = Path(__file__).resolve().parents[3] / "robots"
    urdf = (robots / "pendulum.urdf").read_text()
    (tmp_path / "mine.urdf").write_text(urdf)
    path = tmp_path / "mine.toml"
    path.write_text(PENDULUM.replace('urdf = "pendulum.urdf"', 'urdf = "mine.urdf"', 1))
    check_robots(load_scenario(path))
    (tmp_path / "mine.urdf").write_text(urdf.replace('"hinge"', '"hinge2"'))
    with pytest.raises(ScenarioError, match="did you mean 'hinge2'"):
        check_robots(load_scenario(path))
