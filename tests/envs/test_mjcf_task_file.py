"""A task file over an MJCF read as MuJoCo reads it: what the reader takes (the file's
``<option>``, the actuators in MuJoCo's order) and what it refuses, with ``FILE:LINE``."""

from __future__ import annotations

import re

import numpy as np
import pytest

from simbridge.envs import SimEnv, TaskFileError, loads_task, shipped_tasks

ANT = shipped_tasks()["ant"].read_text(encoding="utf-8")


def _refused(text: str, marker: str, key: str, detail: str) -> None:
    line = next(i for i, s in enumerate(text.splitlines(), 1) if marker in s)
    with pytest.raises(
        TaskFileError, match=re.escape(f"mine.toml:{line}: key {key!r}: ") + ".*" + detail
    ):
        loads_task(text, file="mine.toml")


def test_the_files_option_gives_the_step_unless_the_task_does():
    assert loads_task(ANT).timestep == 0.01  # ant.xml's <option timestep="0.01">
    assert loads_task(ANT).gravity == (0.0, 0.0, -9.81)
    own = loads_task("timestep = 0.005\n" + ANT)
    assert own.timestep == 0.005 and own.control_dt == 0.025


def test_actuators_by_name_in_the_tasks_order():
    text = ANT.replace(
        'mode = "actuator"', 'mode = "actuator"\nactuators = ["actuator2", "actuator0"]'
    )
    task = loads_task(text)
    assert task.action.joints == ("actuator2", "actuator0")
    env = SimEnv(task, backend="mujoco")
    try:
        env.reset(seed=0)
        env.step(np.array([0.5, -0.25]))
        ctrl = env.sim.actuator_controls()
        assert ctrl[2] == 0.5 and ctrl[0] == -0.25 and not ctrl[[1, 3, 4, 5, 6, 7]].any()
    finally:
        env.close()


def test_a_control_beyond_ctrlrange_is_clamped_by_the_model_on_every_engine(backend):
    """ctrl 1.5 is written as given, not counted as clipped, and moves the ant exactly as
    ctrl 1.0 (ant.xml's ctrlrange) does."""
    runs = []
    for scale, action in ((3.0, 0.5), (1.0, 1.0)):
        env = SimEnv(loads_task(ANT.replace("scale = 1.0", f"scale = {scale}")), backend=backend)
        try:
            env.reset(seed=0)
            for _ in range(4):
                _, _, _, _, info = env.step(np.full(8, action))
                assert info["action_clipped"] == 0
            assert (env.sim.actuator_controls() == scale * action).all()
            runs.append(env.sim.qpos())
        finally:
            env.close()
    np.testing.assert_array_equal(runs[0], runs[1])


@pytest.mark.parametrize(
    ("old", "new", "marker", "key", "detail"),
    [
        ('semantics = "mujoco"\n', "", "mjcf = ", "robots[0].mjcf", "an environment reads an MJCF"),
        (
            'semantics = "mujoco"',
            'semantics = "pybullet"',
            "semantics = ",
            "robots[0].semantics",
            "expected semantics = 'mujoco', got 'pybullet'",
        ),
        (
            'semantics = "mujoco"',
            'semantics = "mujoco"\nposition = [0, 0, 1]',
            "position = ",
            "robots[0].position",
            "not with mjcf",
        ),
        ("assets/ant.xml", "assets/nope.xml", "mjcf = ", "robots[0].mjcf", ".*nope.xml"),
        (
            'mode = "actuator"',
            'mode = "actuator"\nactuators = ["hip_9"]',
            "actuators = ",
            "action.actuators[0]",
            r"the model has no actuator 'hip_9'; actuators: \['actuator0'",
        ),
        (
            'mode = "actuator"',
            'mode = "torque"',
            'mode = "torque"',
            "action.mode",
            "expected mode = 'actuator', got 'torque'",
        ),
        (
            'mode = "actuator"',
            'mode = "actuator"\nkp = 2.0',
            "kp = ",
            "action.kp",
            "not with mode = 'actuator'",
        ),
        (
            "qvel_normal = 0.1",
            "qvel_normal = 0.1\njoint_position = 0.1",
            "joint_position",
            "randomisation.joint_position",
            "not with an MJCF read as MuJoCo reads it",
        ),
        (
            "params = { exclude = 2 }",
            "params = { exclude = -1 }",
            "exclude = -1",
            "observation[0].params.exclude",
            "expected an integer >= 0",
        ),
    ],
)
def test_bad_mjcf_tasks_are_named_with_their_line(old, new, marker, key, detail):
    assert old in ANT
    _refused(ANT.replace(old, new, 1), marker, key, detail)


def test_an_mjcf_world_shares_the_task_with_nothing():
    text = ANT.replace(
        "[[robots]]", '[[robots]]\nname = "plane"\nurdf = "plane.urdf"\n\n[[robots]]', 1
    )
    _refused(text, "mjcf = ", "robots[1].mjcf", "it cannot share the task with \\['plane'\\]")


def test_mujocos_coordinates_are_only_for_an_mjcf_task():
    text = shipped_tasks()["cartpole"].read_text(encoding="utf-8")
    text = text.replace("[[observation]]", '[[observation]]\nterm = "qvel"\n\n[[observation]]', 1)
    _refused(text, 'term = "qvel"', "observation[0].term", "'qvel' reads MuJoCo's generalized")
    text = shipped_tasks()["cartpole"].read_text(encoding="utf-8")
    text = re.sub(r'mode = "\w+"', 'mode = "actuator"', text, count=1)
    _refused(text, 'mode = "actuator"', "action.mode", "an actuator action needs a robot read")
