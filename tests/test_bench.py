"""Smoke test of the benchmark: it runs and prints its table. Speed itself is never asserted
here (timings belong to bench/run.py, not to pass/fail)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import simbridge

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
