"""Moving code leaves results alone: every shipped scenario's trajectories, on both backends
and on both MuJoCo step loops, hash to what they did before the MuJoCo backend became the
``backends/mujoco/`` package (tests/data/trajectory_hashes.json, written by
tests/_trajectory_hashes.py). A deliberate change of behaviour records them again, in its own
commit, saying why."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from _trajectory_hashes import all_extras, all_hashes, engine_versions  # noqa: E402

RECORD = json.loads((Path(__file__).parent / "data" / "trajectory_hashes.json").read_text())

pytestmark = pytest.mark.skipif(
    engine_versions() != RECORD["engines"],
    reason=f"hashes were recorded on {RECORD['engines']}, this is {engine_versions()}: other "
    "engine builds give other bits",
)


def _mismatches(expected: dict[str, str], got: dict[str, str]) -> list[str]:
    return [k for k in expected if got.get(k) != expected[k]]


def test_compiled_loop_and_pybullet_bit_identical() -> None:
    got = {**all_hashes(), **all_extras()}
    assert sorted(got) == sorted(RECORD["compiled"]), "the shipped scenarios changed"
    assert _mismatches(RECORD["compiled"], got) == []


def test_python_step_loop_bit_identical() -> None:
    script = Path(__file__).parent / "_trajectory_hashes.py"
    env = dict(os.environ, SIMBRIDGE_MUJOCO_STEP="python")
    out = subprocess.run(
        [sys.executable, str(script), "--mujoco-only"],
        env=env,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    got = json.loads(out)
    assert _mismatches(RECORD["python_loop_mujoco"], got) == []
