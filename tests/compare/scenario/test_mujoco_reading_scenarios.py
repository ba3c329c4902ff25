"""A scenario whose robot is an MJCF read as MuJoCo reads it (issue 33, item 5): the
``semantics`` key, the file's ``<option>`` as the scenario's world, and the shipped ant-mujoco
and cheetah-mujoco run on the MuJoCo backend as raw MuJoCo runs them."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from simbridge import compare
from simbridge.compare import dumps_scenario, load_scenario, loads_scenario
from simbridge.compare.analysis.verdict import VERDICTS
from simbridge.compare.errors import ScenarioError
from simbridge.compare.run.offsets import perturbed
from simbridge.model.urdf_source import locate

ANT = "package://gymnasium/envs/mujoco/assets/ant.xml"
NATIVE = f"""\
name = "native"

[[robots]]
name = "ant"
mjcf = "{ANT}"
semantics = "mujoco"

[[phases]]
name = "wait"
steps = 5
"""


def _error(text: str) -> ScenarioError:
    with pytest.raises(ScenarioError) as info:
        loads_scenario(text, file="bad.toml")
    return info.value


def test_the_files_option_gives_time_step_and_gravity_the_scenario_leaves_out():
    sc = loads_scenario(NATIVE)
    assert sc.robots[0].semantics == "mujoco"
    assert sc.timestep == 0.01  # ant.xml: <option timestep="0.01" integrator="RK4"/>
    assert sc.gravity == (0.0, 0.0, -9.81)  # MuJoCo's default gravity
    given = loads_scenario(NATIVE.replace('name = "native"\n', 'name = "n"\ntimestep = 0.005\n'))
    assert given.timestep == 0.005
    assert loads_scenario(dumps_scenario(sc)) == sc  # the writer keeps the reading


@pytest.mark.parametrize(
    ("old", "new", "key", "message"),
    [
        (
            'semantics = "mujoco"',
            'semantics = "bullet"',
            "robots[0].semantics",
            "'pybullet', 'mujoco'",
        ),
        (
            f'mjcf = "{ANT}"',
            'urdf = "r2d2.urdf"',
            "robots[0].semantics",
            "only for a robot from an MJCF file",
        ),
        (
            f'mjcf = "{ANT}"',
            'mjcf = "package://gymnasium/envs/mujoco/assets/no_such.xml"',
            "robots[0].mjcf",
            "no_such.xml",
        ),
        (
            "[[phases]]",
            '[[robots]]\nname = "plane"\nurdf = "plane.urdf"\n\n[[phases]]',
            "robots[0].semantics",
            "the whole world",
        ),
    ],
)
def test_a_wrong_reading_is_named_at_its_key(old, new, key, message):
    text = NATIVE.replace(old, new, 1)
    err = _error(text)
    assert err.key == key
    assert message in str(err)


def test_a_missing_python_package_is_said():
    err = _error(NATIVE.replace("package://gymnasium/", "package://no_such_package_here/"))
    assert "no Python package 'no_such_package_here' is installed" in str(err)


def _raw(path: Path, steps: int, frequency: float, amplitude: float, phase_step: float):
    """The pattern's run on raw MuJoCo: qpos after ``steps`` steps (the controller's time is
    the step's index times the time step, as the run gives it)."""
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    for k in range(steps):
        w = 2.0 * math.pi * frequency * (k * m.opt.timestep)
        d.ctrl[:] = [amplitude * math.sin(w + i * phase_step) for i in range(m.nu)]
        mujoco.mj_step(m, d)
    return d.qpos.copy()


@pytest.mark.skipif(importlib.util.find_spec("gymnasium") is None, reason="needs gymnasium")
@pytest.mark.parametrize("name", ["ant-mujoco", "cheetah-mujoco"])
def test_shipped_scenarios_run_on_mujoco_as_raw_mujoco_does(name):
    sc = load_scenario(name)
    robot = sc.robots[0]
    params = sc.phases[0].controller.params
    qpos = _raw(locate(robot.urdf, kind="MJCF")[0], sc.phases[0].steps, **dict(params))
    tr = compare.run(sc, "mujoco")
    body = tr.bodies[robot.name]
    # the last recorded row is the state after the last step (the same engine, the same
    # process: bit for bit)
    if robot.name == "ant":
        np.testing.assert_array_equal(body.base_position[-1], qpos[0:3])
    else:
        col = list(body.joint_names).index("rootx")
        assert body.joint_positions[-1, col] == qpos[0]
    assert all(o.success for o in tr.outcomes.values()), tr.outcomes


@pytest.mark.skipif(importlib.util.find_spec("gymnasium") is None, reason="needs gymnasium")
@pytest.mark.parametrize("name", ["ant-mujoco", "cheetah-mujoco"])
def test_every_pair_of_engines_is_judged(name):
    """Issue 33's done-when, short: the scenario runs on the three engines and every pair gets
    a verdict."""
    c = compare.compare(
        name, ["pybullet", "mujoco", "physx"], duration=0.2, ensemble=2, workers=0, cache=False
    )
    assert len(c.pairs) == 3
    assert all(pair.verdict.verdict in VERDICTS for pair in c.pairs)


@pytest.mark.parametrize("backend", ["pybullet", "mujoco", "physx"])
def test_an_offset_of_a_fixed_base_moves_the_joints(backend):
    """The cheetah's base is fixed in its file (rootx, rootz, rooty are joints): an ensemble
    member's offset moves its hinge and slide coordinates, 1e-9 apart, not refused."""
    sc = load_scenario("cheetah-mujoco").truncated(0.01)
    scale = 1e4 if backend == "physx" else 1.0  # PhysX's float32 state: offsets of 1e-5
    dpos = np.array([[1e-9, -2e-9, 3e-9]]) * scale
    drot = np.array([[0.0, 4e-9, 0.0]]) * scale
    nominal = compare.run(sc, backend).bodies["cheetah"]
    moved = compare.run(perturbed(sc, dpos, drot), backend).bodies["cheetah"]
    gap = moved.joint_positions[0] - nominal.joint_positions[0]
    # rootx, rootz, rooty, then the six leg joints: components 0..5, 0..2 of the offset
    want = np.array([1e-9, -2e-9, 3e-9, 0.0, 4e-9, 0.0, 1e-9, -2e-9, 3e-9]) * scale
    assert np.allclose(gap, want, rtol=0, atol=5e-11 * scale)
