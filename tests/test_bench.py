"""Smoke test of the benchmark: it runs and prints its table. Speed itself is never asserted
here (timings belong to bench/run.py, not to pass/fail)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from _engines import installed_backends, require_backend

import simbridge

pytestmark = pytest.mark.slow  # among the slowest files: left out of the quick tier

ROOT = Path(__file__).resolve().parents[1]


def test_bench_runs_with_a_tiny_repeat_count():
    proc = subprocess.run(
        [sys.executable, str(ROOT / "bench" / "run.py"), "--repeats", "1", "--quick"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = proc.stdout
    for row in (
        "pybullet: r2d2 drive, 980 steps",
        "mujoco: r2d2 drive, 980 steps",
        "pybullet: same drive through a bound velocity command",
        "mujoco: same drive through a bound velocity command",
        "recording base pose + wheel states",
        "single call: link_state",
        "single call: joint_states",
        "single call: set_joint_velocity",
        "mujoco: 8 worlds, 2 threads, open loop (rollout)",
        "mujoco: 8 worlds, 2 processes, command every step",
        "pybullet: 8 worlds, 2 processes, command every step",
        "import simbridge after numpy",
    ):
        assert row in out, f"row {row!r} missing from the table:\n{out}"
    # Every row carries a raw figure, a layer figure and their ratio.
    table = [line for line in out.splitlines() if line.startswith("| ") and "case" not in line]
    for line in table:
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert float(cells[4]) > 0, line


def test_calls_table_times_every_call_on_every_engine():
    """bench/calls.py: every Sim call on r2d2 and a fixed KUKA, a legged observation's reads
    on a standing A1, every installed engine side by side (a figure in each engine's column,
    its ratio over PyBullet's), then command + step against the step alone, and the drive raw,
    plain and through a bound command."""
    proc = subprocess.run(
        [sys.executable, str(ROOT / "bench" / "calls.py"), "--quick", "--repeats", "1"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    lines = proc.stdout.splitlines()
    engines = ["PyBullet", "MuJoCo"] + (["PhysX"] if "physx" in _usable_engines() else [])
    top = lines.index(next(line for line in lines if line.startswith("| call |")))
    end = lines.index("", top)  # the calls table ends at the first blank line
    header = lines[top]
    head = [c.strip() for c in header.strip("|").split("|")]
    layer = [head.index(f"{e} µs") for e in engines]
    ratio = [head.index(f"{e}/PyBullet") for e in engines[1:]]
    raw = [head.index(f"raw {e} µs") for e in engines]
    calls = [line for line in lines[top:end] if line.startswith(("| r2d2: ", "| kuka: "))]
    names = {line.split("|")[1].split(":", 1)[1].strip() for line in calls}
    for call in (
        "set_joint_velocity (list)",
        "set_joint_velocity (numpy)",
        "set_joint_position (numpy)",
        "set_joint_torque (list)",
        "link_state(link)",
        "link_states(every link)",
        "link_state of every link, a call each",
        "base_state",
        "joint_states(commanded joints)",
        "joint_info",
        "dynamics_info",
        "reset_joint_state(commanded joints)",
        "reset_base_state(pose)",
        "step, contact-free",
        "contact_points",
    ):
        assert call in names, f"{call!r} missing:\n{proc.stdout}"
    assert len(calls) == 2 * len(names)  # each call on both robots
    for line in calls:
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert len(cells) == len(head), line
        # a call within the noise of the timing loop's own cost reads "<0.01", with no ratio
        pb = cells[layer[0]]
        for c in (cells[k] for k in layer):
            assert c == "<0.01" or float(c) > 0, line
        for k, r in zip(layer[1:], ratio, strict=True):
            floor = "<0.01" in (pb, cells[k])
            assert (cells[r] == "") if floor else float(cells[r].split()[0]) > 0, line
    # every engine has a raw figure for the step and the reads a raw user makes
    for call in (
        "step, contact-free",
        "link_state(link)",
        "link_states(every link)",
        "joint_states(commanded joints)",
        "contact_points",
    ):
        line = next(line for line in calls if line.startswith(f"| r2d2: {call} |"))
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert all(float(cells[k]) > 0 for k in raw), line
    # the A1: the reads a legged observation makes, each with a raw figure on every engine
    legged = [line for line in lines[top:end] if line.startswith("| a1: ")]
    assert [line.split("|")[1].strip() for line in legged] == [
        "a1: link_state(link)",
        "a1: link_states(every link)",
        "a1: base_state",
        "a1: joint_states(commanded joints)",
        "a1: contact_points",
    ]
    for line in legged:
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert all(float(cells[k]) > 0 for k in layer + raw), line
    # r2d2 rests on its contacts in the contact_points row, the A1 stands on its feet: every
    # engine reports some points
    for robot in ("r2d2", "a1"):
        said = next(line for line in lines if line.startswith(f"{robot}: contact_points: points: "))
        counts = dict(x.split() for x in said.partition(": points: ")[2].split(" (")[0].split(", "))
        assert set(counts) == {e.lower() for e in engines}, said
        assert all(int(v) > 0 for v in counts.values()), said
    assert any("position_command targets" in line for line in lines)
    drive = [line for line in lines if line.startswith(tuple(f"| {e.lower()} |" for e in engines))]
    assert len(drive) == len(engines) and all(float(line.split("|")[6]) > 0 for line in drive)
    summary = [line for line in lines if " calls over 1.5x PyBullet's: " in line]
    assert [line.split()[0] for line in summary] == engines[1:]
    if "PhysX" in engines:  # the bounds table: raw, raw + the layer's work, the layer
        bounds = [line for line in lines[end:] if line.startswith("| kuka: step, contact-free")]
        assert len(bounds) == 1 and all(float(c) > 0 for c in bounds[0].split("|")[2:5])


def test_calls_only_times_the_rows_named():
    """bench/calls.py --only TEXT: the calls table's rows whose name holds TEXT, on every
    robot that has the row, and no other table."""
    proc = subprocess.run(
        [
            sys.executable,
            str(ROOT / "bench" / "calls.py"),
            "--quick",
            "--repeats",
            "1",
            "--backends",
            "pybullet,mujoco",
            "--only",
            "link_states",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = [
        line for line in proc.stdout.splitlines() if line.startswith(("| r2d2", "| kuka", "| a1"))
    ]
    assert [row.split("|")[1].strip() for row in rows] == [
        "r2d2: link_states(every link)",
        "kuka: link_states(every link)",
        "a1: link_states(every link)",
    ]
    assert "position_command targets" not in proc.stdout  # the other tables left out


def test_physx_floor_row_ends_the_drive_in_the_layers_state():
    """bench/run.py's PhysX floor (raw SAPIEN applying PyBullet's link damping and speed clamp
    itself) does the layer's physics: the same drive ends in the layer's state bit for bit, so
    the ratio against it is the layer's own cost."""
    require_backend("physx")
    code = "import cases; print(cases.physx_floor_matches_layer())"
    proc = subprocess.run(
        [sys.executable, "-c", code],
        cwd=ROOT / "bench",
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.split()[-1] == "True", proc.stdout


def _usable_engines() -> list[str]:
    return installed_backends()  # in CI, a registered engine that does not load fails


def test_calls_on_one_engine_and_the_before_after_table_of_two_trees(tmp_path):
    """bench/calls.py --backends mujoco --stat min times MuJoCo alone (no PyBullet figure);
    bench/ab.py, given this interpreter's environment as both trees' .venv,
    tables each MuJoCo row's figure per tree and their ratio."""
    (tmp_path / "tree").mkdir()
    (tmp_path / "tree" / ".venv").symlink_to(sys.prefix)  # this interpreter's environment
    assert (tmp_path / "tree" / ".venv" / "bin" / "python").exists()
    proc = subprocess.run(
        [
            sys.executable,
            str(ROOT / "bench" / "ab.py"),
            str(tmp_path / "tree"),
            str(tmp_path / "tree"),
            "--rounds",
            "1",
            "--",
            "--quick",
            "--repeats",
            "1",
            "--backends",
            "mujoco",
            "--stat",
            "min",
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = [line for line in proc.stdout.splitlines() if line.startswith(("| r2d2: ", "| kuka: "))]
    assert any("link_state(link)" in line for line in rows), proc.stdout
    for line in rows:
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert cells[1] == "MuJoCo µs", line  # no PyBullet column was timed
        assert float(cells[2]) > 0 and float(cells[3]) > 0 and float(cells[4]) > 0, line
    assert any(line.startswith("| mujoco | bound µs") for line in proc.stdout.splitlines())


def test_kernel_phases_runs_and_accounts_for_the_step():
    """bench/kernel_phases.py builds the timed kernel in a temporary folder and its phases add
    up to the timed step (they are timed inside it), which is all a smoke run can check."""
    with simbridge.Sim("mujoco") as sim:
        loop = sim.manifest()["step_loop"]
    if not loop.startswith("compiled"):  # pragma: no cover - machines without the compiled loop
        pytest.skip(f"no compiled loop: {loop}")
    proc = subprocess.run(
        [sys.executable, str(ROOT / "bench" / "kernel_phases.py"), "--repeats", "1"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = dict(
        (line[:42].strip(), float(line[42:])) for line in proc.stdout.splitlines()[1:] if line
    )
    assert rows["sum of phases"] > 0 and rows["raw mj_step, velocity actuators"] > 0
    assert rows["sum of phases"] <= rows["Sim.step(980), timed build"] * 1.001


def test_load_table_times_raw_and_both_backends_side_by_side():
    """bench/load.py on one robot: a row with raw PyBullet's load, each backend's and their
    ratios (first load and again), simbridge's mesh reading, and the total."""
    r2d2 = str(Path(simbridge.__file__).parent.parent.parent / "robots" / "r2d2.urdf")
    proc = subprocess.run(
        [sys.executable, str(ROOT / "bench" / "load.py"), r2d2],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = [line for line in proc.stdout.splitlines() if line.startswith("| ")]
    robot = next(line for line in rows if "r2d2.urdf" in line)
    total = next(line for line in rows if "total, 1 robots" in line)
    for line in (robot, total):
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert len(cells) == 13, line
        times = [float(cells[i]) for i in (1, 2, 4, 6, 7, 9, 11)]
        ratios = [float(cells[i]) for i in (3, 5, 8, 10)]
        assert all(t > 0 for t in times) and all(r > 0 for r in ratios), line
        assert float(cells[12]) >= 0, line  # the meshes' share: 0.00 for r2d2's small ones
        assert float(cells[3]) == pytest.approx(float(cells[2]) / float(cells[1]), rel=0.05)
