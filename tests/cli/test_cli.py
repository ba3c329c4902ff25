"""The command line's output: stdout carries the results alone, the engines' words go to the log
(--verbose shows it on stderr); the joint table, its --movable filter and --json."""

from __future__ import annotations

import json
import subprocess
import sys

import simbridge
from simbridge.cli import main

WARNING_URDF = "quadruped/spirit40newer.urdf"  # PyBullet prints b3Warning lines loading it


def _simbridge(*args: str, cwd, stdout_file) -> subprocess.CompletedProcess[str]:
    """``simbridge ARGS > stdout_file`` in a child process (a fresh PyBullet import)."""
    with open(stdout_file, "w") as out:
        return subprocess.run(
            [sys.executable, "-m", "simbridge", *args],
            stdout=out,
            stderr=subprocess.PIPE,
            text=True,
            cwd=cwd,
            timeout=300,
        )


def _expected_stdout(cwd, out: str) -> str:
    """What `simbridge compare ... --out OUT` prints: the short headline of the figures the
    report holds, its last line the report's path."""
    from simbridge.compare.report import brief

    summary = json.loads((cwd / out / "summary.json").read_text())
    return "\n".join(brief(summary, f"{out}/report.md")) + "\n"


def test_compare_r2d2_into_a_file_leaves_the_headline_alone(tmp_path):
    # a smaller ensemble than the default 16 (the same code path: the headline, the engines'
    # output kept off stdout), to keep the suite short
    child = _simbridge(
        "compare",
        "r2d2",
        "--ensemble",
        "4",
        "--no-plots",
        "--out",
        "rep",
        cwd=tmp_path,
        stdout_file=tmp_path / "out",
    )
    assert child.returncode == 0, child.stderr
    assert child.stderr == ""
    out = (tmp_path / "out").read_text()
    assert out == _expected_stdout(tmp_path, "rep")
    assert "pybullet" in out.splitlines()[0] and 3 <= out.count("\n") <= 6
    assert not any(w in out for w in ("build time", "b3Warning", "b3Error", "urdfdom"))
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()


def test_verbose_shows_the_banner_on_stderr_and_stdout_stays_clean(tmp_path):
    child = _simbridge(
        "compare",
        "pendulum",
        "--backends",
        "pybullet",
        "pybullet",
        "--duration",
        "0.1",
        "--no-plots",
        "--out",
        "rep",
        "-v",
        cwd=tmp_path,
        stdout_file=tmp_path / "out",
    )
    assert child.returncode == 0, child.stderr
    # the engine is imported when its first run starts (after the jobs are counted), so the
    # banner is one of stderr's lines, not necessarily its first
    banner = "simbridge: DEBUG: pybullet (importing): pybullet build time: "
    assert any(x.startswith(banner) for x in child.stderr.splitlines()), child.stderr
    assert (tmp_path / "out").read_text() == _expected_stdout(tmp_path, "rep")


def test_a_warning_emitting_load_is_quiet_without_verbose(tmp_path):
    child = _simbridge("joints", WARNING_URDF, cwd=tmp_path, stdout_file=tmp_path / "out")
    assert child.returncode == 0 and child.stderr == ""
    out = (tmp_path / "out").read_text()
    assert "b3Warning" not in out and "No inertial" not in out
    assert out.splitlines()[0].split()[:3] == ["index", "name", "type"]


def test_verbose_logs_the_warnings_of_a_load_on_stderr(capfd):
    assert main(["joints", WARNING_URDF, "--movable", "-v"]) == 0
    out, err = capfd.readouterr()
    assert "No inertial" not in out
    warnings = [line for line in err.splitlines() if line.startswith("simbridge: WARNING: ")]
    assert len(warnings) == 4
    assert "link 'FR_upper_shoulder' has no <inertial>" in warnings[0]
    assert main(["-v", "joints", "r2d2"]) == 0  # -v before the command too
    assert main(["joints", WARNING_URDF]) == 0  # and the handler is gone after main()
    assert capfd.readouterr().err == ""


def _table(capsys, *args: str) -> list[list[str]]:
    assert main(["joints", *args]) == 0
    lines = capsys.readouterr().out.splitlines()
    return [line.split("  ") for line in lines]


def test_joints_prints_a_table(capsys):
    assert main(["joints", "r2d2.urdf"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split() == [
        "index",
        "name",
        "type",
        "parent",
        "->",
        "child",
        "link",
        "lower",
        "upper",
        "max",
        "force",
        "max",
        "velocity",
        "axis",
        "damping",
        "friction",
    ]
    assert len(lines) == 1 + 15 + 1
    rows = {int(line.split()[0]): line for line in lines[1:-1]}
    assert (
        rows[0].split()
        == ["0", "base_to_right_leg", "fixed", "base_link", "->", "right_leg"] + ["-"] * 7
    )
    wheel = rows[2].split()
    assert wheel[:6] == ["2", "right_front_wheel_joint", "revolute", "right_base", "->"] + [
        "right_front_wheel"
    ]
    assert "none none 100 N·m 100 rad/s (0, 0, 1) 0 N·m·s/rad 0 N·m" in " ".join(wheel)
    slider = " ".join(rows[8].split())
    assert slider.startswith("8 gripper_extension prismatic base_link -> gripper_pole -0.38 m 0 m")
    assert "1000 N 0.5 m/s (1, 0, 0) 0 N·s/m 0 N" in slider
    assert " ".join(rows[11].split()).endswith("(0, 0, -1) 0 N·m·s/rad 0 N·m")
    assert lines[-1] == "physics: 15 joints, 8 movable, base link base_link; backend pybullet"


def test_joints_movable_shows_the_movable_joints_alone(capsys):
    assert main(["joints", "r2d2.urdf", "--movable"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [int(line.split()[0]) for line in lines[1:-1]] == [2, 3, 6, 7, 8, 9, 11, 13]
    assert all(" fixed " not in line for line in lines)


def test_joints_json_gives_the_17_fields_with_the_type_named(capsys):
    assert main(["joints", "r2d2.urdf", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["robot"] == "physics" and doc["base_link"] == "base_link"
    assert doc["backend"] == "pybullet" and doc["fixed_base"] is False
    with simbridge.Sim("pybullet") as sim:
        infos = sim.joints(sim.load_urdf("r2d2.urdf"))
    assert len(doc["joints"]) == len(infos) == 15
    for row, info in zip(doc["joints"], infos, strict=True):
        assert list(row) == list(info._fields)
        assert row["type"] == {"name": info.type.name.lower(), "number": int(info.type)}
        assert row["axis"] == list(info.axis) and row["lower_limit"] == info.lower_limit
    assert doc["joints"][8]["type"] == {"name": "prismatic", "number": 1}
    assert main(["joints", "r2d2.urdf", "--json", "--movable", "--fixed-base"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [j["index"] for j in doc["joints"]] == [2, 3, 6, 7, 8, 9, 11, 13]
    assert doc["fixed_base"] is True


def test_an_unknown_scenario_is_bad_usage_listing_the_shipped_ones(capsys):
    assert main(["compare", "nosuch"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: simbridge")
    assert err.splitlines()[-1] == (
        "simbridge compare: error: nosuch: no such scenario file, and not a shipped scenario; "
        "shipped scenarios: ant-gait, ant-mujoco, cheetah-mujoco, double-pendulum, kuka-reach, "
        "laikago-stand, pendulum, r2d2, r2d2-gentle, r2d2-goto, spinning-wheel"
    )


def test_a_scenario_file_that_is_broken_still_fails_with_1(tmp_path, capsys):
    path = tmp_path / "broken.toml"
    path.write_text("[[robots]\n")
    assert main(["compare", str(path)]) == 1
    assert capsys.readouterr().err.startswith(f"simbridge: error: {path}:")


def test_a_log_record_clears_the_progress_bar_line_first(capsys):
    import io
    import logging

    from simbridge.cli.main import _StderrLog
    from simbridge.compare.report.progress import ProgressBar

    stream = io.StringIO()
    bar = ProgressBar(stream, enabled=True, delay=0.0)
    bar("pybullet run", 5, 10)
    assert bar.drawn and "pybullet run:  50%|###############" in stream.getvalue()
    handler = _StderrLog()  # writes to sys.stderr, here capsys's
    handler.bar = bar
    handler.emit(logging.LogRecord("simbridge.x", logging.WARNING, "", 0, "a record", None, None))
    assert not bar.drawn and stream.getvalue().endswith(" " * 60 + "\r")
    assert capsys.readouterr().err == "simbridge: WARNING: a record\n"
    bar("pybullet run", 6, 10)  # the next update draws it again
    assert bar.drawn
