"""The tutorial's steps, as shipped in examples/, run on every backend unchanged."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

import simbridge

pytestmark = pytest.mark.slow  # whole corpora (or examples' runs): left out of the quick tier

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
BACKENDS = ["pybullet", "mujoco"]  # the shipped backends


def _example(name: str):
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("backend", BACKENDS)
def test_hello_cube_falls_freely_for_one_second(backend):
    state = _example("hello_cube").main(["--backend", backend])
    # No ground in this step of the tutorial: 240 semi-implicit Euler steps from z = 1, with
    # PyBullet's link damping 0.04 (profile "pybullet") slowing the fall by about 2%.
    assert -3.75 < state.position[2] < -3.5
    assert abs(state.position[0]) < 1e-9 and abs(state.position[1]) < 1e-9


@pytest.mark.parametrize("backend", BACKENDS)
def test_joint_table_has_r2d2s_15_joints(backend):
    table = _example("joint_table").main(["--backend", backend])
    assert len(table) == 15
    assert table[0].name == "base_to_right_leg" and table[0].type == simbridge.JointType.FIXED
    for i in (2, 3, 6, 7):
        assert table[i].type == simbridge.JointType.REVOLUTE
        assert table[i].axis == (0.0, 0.0, 1.0)
        assert (table[i].lower_limit, table[i].upper_limit) == (0.0, -1.0)


@pytest.mark.parametrize("backend", BACKENDS)
def test_link_table_right_leg(backend):
    rows = _example("link_table").main(["--backend", backend])
    index, name, mass, friction, pos, orn = rows[0]
    assert name == "right_leg" and mass == 10.0 and friction == 0.5
    # The leg's inertial frame is tilted 90 degrees about y: orientation (0, 0.707, 0, 0.707).
    assert orn == pytest.approx((0.0, 0.70710, 0.0, 0.70710), abs=1e-4)


@pytest.mark.parametrize("backend", BACKENDS)
def test_r2d2_drive_moves_the_robot(backend):
    state = _example("r2d2_drive").main(["--backend", backend])
    assert (state.position[0] ** 2 + state.position[1] ** 2) ** 0.5 > 0.3


def test_controller_compare_runs_its_controller_on_both_engines(tmp_path):
    # the controller is defined in the example's file, which is loaded here under another
    # name: the ensemble's worker processes import it again from that file
    summary = _example("controller_compare").main(["--ensemble", "2", "--out", str(tmp_path)])
    for label in ("pybullet", "mujoco"):
        goal = summary["outcomes"]["engines"][label]["reaches the goal"]
        # measured: reached at 8.66 s (PyBullet) and 6.81 s (MuJoCo) of the 10 s drive
        assert goal["success"]["successes"] == goal["success"]["runs"] == 2
        assert 5.0 < goal["value"]["mean"] < 9.5
    assert (tmp_path / "report.md").read_text().count("## Outcomes") == 1
