"""The command line: exit codes 0 (done), 1 (failed, one line on stderr), 2 (bad usage)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from simbridge.cli import main


def test_scenarios_lists_one_line_each(capsys):
    assert main(["scenarios"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines] == [
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
    assert "tutorial" in lines[7]
    assert "closed loop" in lines[9]


@pytest.mark.parametrize(
    "argv",
    [
        [],
        ["compare"],
        ["frobnicate"],
        ["compare", "r2d2", "--backends", "pybullet"],
        ["compare", "r2d2", "--backends", "pybullet", "bullet3"],
        ["compare", "r2d2", "--timestep", "fast"],
        ["compare", "r2d2", "--timestep", "-1"],
        ["compare", "r2d2", "--profile", "soft"],
        [
            "compare",
            "r2d2",
            "--backends",
            "pybullet",
            "mujoco",
            "--profile",
            "urdf",
            "urdf",
            "urdf",
        ],
        ["compare", "r2d2", "--duration", "0"],
        ["compare", "r2d2", "--duration", "inf"],
        ["compare", "r2d2", "--timestep", "1e400"],
        ["joints"],
    ],
)
def test_bad_usage_exits_2(argv, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "usage: simbridge" in err and "error:" in err


def test_help_exits_0(capsys):
    assert main(["compare", "--help"]) == 0
    assert "--timestep" in capsys.readouterr().out


def test_unknown_scenario_is_bad_usage(capsys):
    assert main(["compare", "no-such-scenario"]) == 2
    err = capsys.readouterr().err
    # the command's usage (as argparse prints it), then one line
    assert err.startswith("usage: simbridge compare ") and err.count(": error: ") == 1
    assert err.splitlines()[-1].startswith(
        "simbridge compare: error: no-such-scenario: no such scenario file, and not a shipped "
        "scenario; shipped scenarios: ant-gait, ant-mujoco, cheetah-mujoco, double-pendulum,"
    )


def test_bad_scenario_file_fails_naming_key_and_line(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text('[[robots]]\nurdf = "r2d2.urdf"\n\n[[phases]]\nsteps = "many"\n')
    assert main(["compare", str(path), "--backends", "pybullet", "pybullet"]) == 1
    err = capsys.readouterr().err
    assert err == (
        f"simbridge: error: {path}:5: key 'phases[0].steps': "
        "expected an integer from 1 to 1000000, got 'many'\n"
    )


def test_a_command_on_a_fixed_joint_fails_naming_the_command(tmp_path, capsys):
    path = tmp_path / "fixed.toml"
    path.write_text(
        '[[robots]]\nurdf = "r2d2.urdf"\n\n[[phases]]\nsteps = 2\n[[phases.commands]]\n'
        'joints = 0\nmode = "velocity"\ntarget = 0.0\nmax_force = 1.0\n'
    )
    # two engines: pybullet twice would add the null-comparison warning before the error
    assert main(["compare", str(path), "--backends", "pybullet", "mujoco"]) == 1
    err = capsys.readouterr().err
    assert err == (
        f"simbridge: error: {path}: key 'phases[0].commands[0].joints': joint 0 "
        "('base_to_right_leg') of robot 'r2d2' is fixed and takes no command\n"
    )


def test_a_time_step_that_needs_too_many_steps_fails(capsys):
    assert main(["compare", "pendulum", "--timestep", "1e-9"]) == 1
    assert "would take 2000000000 steps; at most 1000000 per phase" in capsys.readouterr().err


def test_a_step_that_does_not_divide_the_phases_fails(capsys):
    assert main(["compare", "r2d2", "--backends", "pybullet", "pybullet", "--timestep", "1/7"]) == 1
    assert "not a whole number of 1/7 s steps" in capsys.readouterr().err


def test_compare_writes_the_report(tmp_path, capsys):
    out = tmp_path / "rep"
    argv = [
        "compare",
        "pendulum",
        "--backends",
        "pybullet",
        "pybullet",
        "--profile",
        "pybullet",
        "urdf",
        "--duration",
        "0.25",
        "--out",
        str(out),
        "--no-plots",
    ]
    assert main(argv) == 0
    stdout = capsys.readouterr().out
    lines = stdout.splitlines()
    assert lines[-1] == f"report: {out / 'report.md'}"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["profiles"] == ["pybullet", "urdf"]
    assert summary["manifest"]["command_line"] == ["simbridge", *argv]
    # the short headline: the verdict first, the key figures, the path; the paragraphs in the
    # report alone
    assert len(lines) <= 6
    assert lines[0].startswith("pendulum, pybullet (pybullet) against pybullet (urdf): ")
    assert summary["verdict"]["verdict"].upper() in lines[0]
    assert lines[1].startswith("Nominal runs end ")
    assert "The nominal runs (no offset) end" not in stdout
    assert "The nominal runs (no offset) end" in (out / "report.md").read_text()
    assert (out / "frames" / "replay.gif").is_file()


def test_no_replay_draws_no_pictures(tmp_path, capsys):
    out = tmp_path / "rep"
    argv = ["compare", "pendulum", "--backends", "pybullet", "mujoco", "--duration", "0.05",
            "--ensemble", "1", "--resync-every", "0", "--no-plots", "--no-replay", "--out",
            str(out)]  # fmt: skip
    assert main(argv) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) <= 6 and lines[-1] == f"report: {out / 'report.md'}"
    assert "AGREE, the gap below 1 cm" in lines[0]
    assert not (out / "frames").exists()
    text = (out / "report.md").read_text()
    assert "## The runs, seen" not in text and ".gif" not in text


def test_default_out_dir_is_reports_scenario(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    argv = [
        "compare",
        "pendulum",
        "--backends",
        "pybullet",
        "pybullet",
        "--duration",
        "0.05",
        "--no-plots",
    ]
    assert main(argv) == 0
    assert (tmp_path / "reports" / "pendulum" / "report.md").is_file()


def test_joints_of_a_missing_urdf_fails(capsys):
    assert main(["joints", "no_such_robot.urdf"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("simbridge: error: URDF 'no_such_robot.urdf'") and err.count("\n") == 1


def _module(*args):
    return subprocess.run(
        [sys.executable, "-m", "simbridge", *args], capture_output=True, text=True, timeout=120
    )


def test_python_dash_m_simbridge():
    ok = _module("scenarios")
    assert ok.returncode == 0 and "r2d2-gentle" in ok.stdout
    bad = _module("joints", "no_such_robot.urdf")
    assert bad.returncode == 1 and "Traceback" not in bad.stderr
    assert bad.stderr.strip().splitlines()[-1].startswith("simbridge: error:")
    for usage in (_module("compare"), _module("compare", "no-such-scenario")):
        assert usage.returncode == 2 and "Traceback" not in usage.stderr


def test_an_out_path_that_is_no_folder_fails_before_the_engines_run(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["compare", "pendulum", "--out", str(blocker)]) == 1
    err = capsys.readouterr().err
    assert err == f"simbridge: error: report folder {str(blocker)!r} exists and is not a folder\n"


def test_a_duration_shorter_than_a_step_is_refused_not_agreed(capsys, tmp_path):
    """--duration 1e-300 ran no step and reported "agree"."""
    argv = ["compare", "pendulum", "--duration", "1e-300", "--no-plots", "--out", str(tmp_path)]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "argument 'duration'" in err and "no step would run" in err
    assert not (tmp_path / "report.md").exists()


@pytest.mark.parametrize(
    "duration, timesteps",
    [("0.003", []), ("0.0063", []), ("0.0063", ["1/240", "1/480"]), ("0.0063", ["1/480", "1/240"])],
)
def test_a_duration_between_whole_steps_runs(capsys, tmp_path, duration, timesteps):
    """A duration that rounds to another count of half steps than twice the steps (0.0063 s:
    2 steps of 1/240 s, 3 of 1/480 s) ended in a raw IndexError: the half-step run now covers
    the same steps' time, also where the sweep holds a step and its half."""
    argv = ["compare", "pendulum", "--duration", duration, "--ensemble", "1", "--no-plots",
            "--out", str(tmp_path)]  # fmt: skip
    if timesteps:
        argv += ["--timestep", *timesteps]
    assert main(argv) == 0, capsys.readouterr().err
    summary = json.loads((tmp_path / "summary.json").read_text())
    # whole steps of the sweep's coarsest step (1/240 s), its half and 1/480 s alike
    steps = round(float(duration) * 240)
    assert summary["duration"] == pytest.approx(steps / 240)


@pytest.mark.parametrize(
    "scenario,start,end",
    [
        # the run stops inside "to A": B and C were not run
        (
            "kuka-reach",
            "**settles at B**: not evaluated: phase 'to B' was not run (the run was cut at 1 s).",
            "",
        ),
        # the height is measured from 3 s on (the function is named by its resolved path)
        (
            "laikago-stand",
            "**holds 0.45 m**: not evaluated: not evaluable on the run cut at 1 s: ",
            "stand.py:height_error(trajectory) raised ValueError: no instant from 3 s on: the run "
            "ends at 1 s.",
        ),
    ],
)
def test_a_duration_that_cuts_a_phase_reports_what_was_not_measured(
    tmp_path, capsys, scenario, start, end
):
    out = tmp_path / "rep"
    argv = ["compare", scenario, "--duration", "1", "--ensemble", "1", "--resync-every", "0"]
    assert main([*argv, "--no-plots", "--out", str(out)]) == 0
    headline = capsys.readouterr().out
    report_lines = (out / "report.md").read_text().splitlines()
    assert [x for x in report_lines if x.startswith(start) and x.endswith(end)], start
    # the terminal's outcomes line names it among those not evaluated; report.md says why
    name = start.split("**")[1]
    said = [x for x in headline.splitlines() if x.startswith("outcomes:")]
    assert said and "not evaluated" in said[0] and name in said[0], headline
    assert len(headline.splitlines()) <= 6

    def no_nan(text: str) -> float:
        raise AssertionError(f"{text} in summary.json")

    json.loads((out / "summary.json").read_text(), parse_constant=no_nan)
