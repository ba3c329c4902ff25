"""Smoke runs of the fault benchmarks (bench/divergence.py, bench/limits.py): they run and print
their tables. Timings are never asserted here (they belong to the scripts' full runs,
docs/limits.md); what a row says about refusals is, since it does not depend on the machine."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _run(*args: str) -> str:
    proc = subprocess.run(
        [sys.executable, *args], capture_output=True, text=True, timeout=600, cwd=ROOT
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout


def test_divergence_bench_prints_both_worlds_with_ratios():
    out = _run("bench/divergence.py", "--quick", "--repeats", "3")
    rows = [line for line in out.splitlines() if line.startswith(("| r2d2", "| KUKA"))]
    assert len(rows) == 2, out
    for row in rows:
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert len(cells) == 12, row  # world, then 11 timings and ratios
        assert all(float(c.split()[0]) > 0 for c in cells[1:]), row


def test_limits_bench_times_what_loads_and_what_is_refused():
    out = _run("bench/limits.py", "--sizes", "10", "130", "--raw-max", "10", "--timeout", "120")
    rows = {line.split("|")[1].strip(): line for line in out.splitlines() if line[:3] == "| 1"}
    assert set(rows) == {"10", "130"}, out
    pybullet, raw, mujoco, raw_mujoco = (c.strip() for c in rows["130"].strip("|").split("|")[1:])
    assert pybullet.startswith("refused in") and raw == "not run"
    assert mujoco.endswith("s") and not mujoco.startswith("refused"), rows["130"]
    assert "a body with 130 joints" in out  # the reason, printed under the table


def test_joint_limits_bench_prints_on_and_off_limits_for_both_engines():
    out = _run("bench/limits.py", "--joint-limits", "--quick", "--repeats", "1", "--inner", "1")
    rows = [line for line in out.splitlines() if line.startswith(("| KUKA", "| Panda"))]
    assert len(rows) == 4, out  # two robots, two windows each
    for row in rows:
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert len(cells) == 9, row
        assert all(float(c) > 0 for c in cells[2:8]), row
    # every movable joint ends on a limit on both engines when driven there, none off them
    last = {row.split("|")[1].strip(): row.split("|")[-2].strip() for row in rows}
    assert last["KUKA iiwa, driven"] == "7, 7 (off: 0, 0)", last
    assert last["Panda, driven"] == "9, 9 (off: 0, 0)", last
