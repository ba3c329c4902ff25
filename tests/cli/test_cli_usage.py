"""Bad usage on the command line: exit 2, the command's usage and one argparse-style line
(``simbridge COMMAND: error: ...``), before any engine runs; close matches suggested; and the
Python API's own errors for PyBullet's names and missing arguments."""

from __future__ import annotations

import pytest

import simbridge
from simbridge.cli import main
from simbridge.exceptions import UnknownJointError, UnknownLinkError


def _usage(capsys: pytest.CaptureFixture[str], argv: list[str], command: str) -> str:
    """Run ``argv``, check it is bad usage of ``command``, return the error line."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"usage: simbridge {command} "), err
    last = err.rstrip("\n").splitlines()[-1]
    assert last.startswith(f"simbridge {command}: error: "), err
    return last


@pytest.mark.parametrize(
    "assignment, says",
    [
        ("mujoco.stiffness=3", "argument --set: engine setting mujoco.stiffness: unknown setting"),
        ("mujoco.impratio=abc", "argument --set: engine setting mujoco.impratio: expected"),
        ("nosuch.impratio=1", "argument --set: "),
    ],
)
def test_a_bad_set_is_bad_usage(capsys, assignment, says):
    line = _usage(capsys, ["compare", "pendulum", "--set", assignment], "compare")
    assert says in line


@pytest.mark.parametrize(
    "assignment, says",
    [
        (  # a profile entry, not an engine setting: the form that sets it
            "pybullet.solver_iterations=50",
            "--set: pybullet.solver_iterations: solver_iterations is a profile entry "
            "(one value for every engine), not an engine setting: set it with --profile "
            "PROFILE+solver_iterations=50, the profile (the scenario's by default; one of "
            "pybullet, urdf) with the entry changed, e.g. --profile pybullet+solver_iterations=50",
        ),
        (
            "solver_iterations=50",
            "argument --set: expected BACKEND.KEY=VALUE (mujoco.impratio=10), got "
            "'solver_iterations=50': solver_iterations is a profile entry",
        ),
        (
            "mujoco.timestep=1/480",
            "--set: mujoco.timestep: timestep is the scenario's, not an engine "
            "setting: set it with --timestep 1/480",
        ),
        (  # argparse's "argument --set:" once, and the engine that has the key
            "impratio=10",
            "argument --set: expected BACKEND.KEY=VALUE (mujoco.impratio=10), got "
            "'impratio=10': impratio is a setting of mujoco alone: --set mujoco.impratio=10",
        ),
        (
            "solver=newton",
            "got 'solver=newton': solver is a setting of mujoco and physx: --set "
            "mujoco.solver=newton or --set physx.solver=newton",
        ),
        (
            "imprato=10",
            "got 'imprato=10': no engine has a setting imprato; did you mean impratio, a "
            "setting of mujoco alone: --set mujoco.impratio=10",
        ),
        ("zzz=1", "argument --set: expected BACKEND.KEY=VALUE (mujoco.impratio=10), got 'zzz=1'"),
    ],
)
def test_a_set_of_no_engine_setting_names_the_form_that_sets_it(capsys, assignment, says):
    line = _usage(capsys, ["compare", "pendulum", "--set", assignment], "compare")
    assert line.startswith("simbridge compare: error: argument --set: ") and says in line, line
    assert line.count("argument") == 1, line  # was "argument --set: argument '--set': ..."


def test_a_bad_profile_change_says_argument_once(capsys):
    line = _usage(capsys, ["compare", "pendulum", "--profile", "pybullet+foo=1"], "compare")
    assert line.startswith("simbridge compare: error: argument --profile: unknown entry 'foo'")


@pytest.mark.parametrize("command", ["compare", "sweep", "explain"])
def test_one_backend_is_bad_usage_in_every_study(capsys, command):
    argv = [command, "pendulum", "--backends", "pybullet"]
    if command == "sweep":
        argv += ["--vary", "timestep=1/240,1/480"]
    line = _usage(capsys, argv, command)
    assert line == f"simbridge {command}: error: --backends takes two or more backends"


def test_the_sweep_key_error_names_the_settings_command(capsys):
    line = _usage(capsys, ["sweep", "pendulum", "--vary", "mujoco_x=1,2"], "sweep")
    assert "(`simbridge settings [BACKEND]` lists the keys)" in line


@pytest.mark.parametrize("name", ["./kuka-hold.tml", "no/such/dir/r2d2", "kuka-reach.toml"])
def test_a_missing_file_is_named_by_its_absolute_path(capsys, monkeypatch, tmp_path, name):
    monkeypatch.chdir(tmp_path)
    line = _usage(capsys, ["compare", name], "compare")
    assert line.endswith(f"file not found: {(tmp_path / name).resolve()}"), line
    assert "shipped scenarios" not in line


def test_an_unknown_scenario_name_suggests_the_closest(capsys):
    line = _usage(capsys, ["explain", "r2d3"], "explain")
    assert "not a shipped scenario (did you mean 'r2d2'?); shipped scenarios: " in line


def test_an_unknown_backend_suggests_the_closest(capsys):
    line = _usage(capsys, ["compare", "r2d2", "--backends", "mujco", "pybullet"], "compare")
    assert "invalid choice: 'mujco'" in line and line.endswith("(did you mean 'mujoco'?)")
    with pytest.raises(simbridge.exceptions.UnknownBackendError, match="did you mean 'physx'"):
        simbridge.Sim("physics")


def test_help_says_bad_usage_is_2(capsys):
    assert main(["--help"]) == 0
    assert "2 on bad usage" in capsys.readouterr().out


@pytest.fixture
def r2d2():
    sim = simbridge.Sim("pybullet")
    sim.load_urdf("plane.urdf")
    body = sim.load_urdf("r2d2.urdf")
    yield sim, body
    sim.close()


@pytest.mark.parametrize(
    "name, ours",
    [
        ("getLinkState", "sim.link_state"),
        ("get_link_state", "sim.link_state"),
        ("getJointInfo", "sim.joint_info"),
        ("setJointMotorControl2", "sim.set_joint_velocity"),
        ("stepSimulation", "sim.step"),
        ("step_simulation", "sim.step"),
    ],
)
def test_a_pybullet_name_names_simbridges(r2d2, name, ours):
    sim, _ = r2d2
    with pytest.raises(AttributeError, match=rf"no attribute '{name}'; simbridge's .*{ours}"):
        getattr(sim, name)


def test_other_missing_attributes_stay_plain(r2d2):
    sim, _ = r2d2
    with pytest.raises(AttributeError, match=r"^'Sim' object has no attribute 'nosuch'$"):
        sim.nosuch  # noqa: B018
    assert not hasattr(sim, "nosuch")


def test_a_missing_argument_names_the_sims_method(r2d2):
    sim, body = r2d2
    with pytest.raises(TypeError, match=r"^Sim\.set_joint_velocity\(\) missing 1 required "):
        sim.set_joint_velocity(body, 2, 1.0)  # type: ignore[call-arg]
    with pytest.raises(TypeError, match=r"^Sim\.set_joint_position\(\) missing"):
        sim.set_joint_position(body, 2, 1.0)  # type: ignore[call-arg]
    with pytest.raises(TypeError, match=r"^Sim\.link_state\(\) missing"):
        sim.link_state(body)  # type: ignore[call-arg]


def test_an_unknown_joint_names_the_body_by_id_name_and_file(r2d2):
    sim, body = r2d2
    with pytest.raises(UnknownJointError, match=r"^body 1 \('physics', r2d2\.urdf\) has no joint"):
        sim.joint_info(body, "nosuch")
    with pytest.raises(UnknownLinkError, match=r"^body 1 \('physics', r2d2\.urdf\) has no link 99"):
        sim.link_state(body, 99)
    with pytest.raises(UnknownJointError, match=r"'head_swivle' \(did you mean 'head_swivel'\?\)"):
        sim.joint_index(body, "head_swivle")


def test_a_misspelt_entry_of_a_derived_profile_gets_a_did_you_mean():
    from simbridge.exceptions import InvalidArgumentError

    with pytest.raises(InvalidArgumentError, match=r"did you mean 'lateral_friction'\?"):
        simbridge.get_profile("pybullet+lateral_frction=0.3")


def test_a_vary_slot_of_another_engine_says_where_that_engine_is():
    from simbridge.compare.study.points import check_vary, parse_vary
    from simbridge.exceptions import InvalidArgumentError

    backends = ["pybullet", "mujoco", "physx"]
    with pytest.raises(InvalidArgumentError) as err:
        check_vary([parse_vary("physx.solver@1=PGS,TGS")], backends)
    text = str(err.value)
    assert "engine 1 is 'pybullet', not 'physx'" in text
    assert "'physx' is engine 3 (physx.solver@3)" in text


@pytest.mark.parametrize("kind", ["missing", "file"])
def test_report_of_a_missing_folder_says_so_with_the_report_prefix(capsys, tmp_path, kind):
    folder = tmp_path / "nonexistent"
    if kind == "file":
        folder.write_text("")
    line = _usage(capsys, ["report", str(folder)], "report")
    expected = {
        "missing": f"argument DIR: no such folder: {str(folder)!r}",
        "file": f"argument DIR: {str(folder)!r} is not a folder",
    }[kind]
    assert line == f"simbridge report: error: {expected}", line
    assert "study.json" not in line
