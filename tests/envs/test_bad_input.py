"""Bad input gets a typed error that names what was given and what would be right: an action of
the wrong size or not finite (both layouts in the message), a joint the robot lacks (the joint
and the robot's joints), a task file with a wrong key (FILE:LINE), bad normalisation sizes. An
action past the clip is clipped and counted in info, never silently."""

from __future__ import annotations

import dataclasses
import pickle
import re

import numpy as np
import pytest

from simbridge.envs import (
    ActionError,
    SimEnv,
    TaskFileError,
    TaskJointError,
    load_task,
    loads_task,
    shipped_tasks,
)
from simbridge.exceptions import InvalidArgumentError, UnknownJointError


@pytest.fixture(scope="module")
def env():
    e = SimEnv("kuka_reach", backend="pybullet")
    e.reset(seed=0)
    yield e
    e.close()


def test_an_action_of_the_wrong_size_names_both_layouts(env):
    with pytest.raises(
        ActionError,
        match=r"got shape \(3,\); task 'kuka_reach' takes an action "
        r"of shape \(7,\), one position entry per joint in this order: "
        r"\['lbr_iiwa_joint_1', .*'lbr_iiwa_joint_7'\]",
    ):
        env.step(np.zeros(3))
    with pytest.raises(ActionError, match=r"got shape \(1, 7\)"):
        env.step(np.zeros((1, 7)))


def test_a_nan_action_is_refused_naming_the_joint(env):
    a = np.zeros(7)
    a[3] = np.nan
    with pytest.raises(ActionError, match=r"non-finite value for \['lbr_iiwa_joint_4'\]"):
        env.step(a)
    assert isinstance(ActionError("x", "t", ["j"], "pd"), InvalidArgumentError)


def test_an_action_past_the_clip_is_clipped_and_counted(env):
    _, _, _, _, info = env.step(np.array([3.0, 0, 0, -2.0, 0, 0, 0.5]))
    assert info["action_clipped"] == 2
    assert np.array_equal(env.world.last_action, [1.0, 0, 0, -1.0, 0, 0, 0.5])


def test_a_joint_the_robot_lacks_names_it_and_the_robots_joints():
    task = load_task("kuka_reach")
    joints = (*task.action.joints[:6], "elbow")
    bad = dataclasses.replace(task, action=dataclasses.replace(task.action, joints=joints))
    with pytest.raises(UnknownJointError, match=r"no joint 'elbow'.*'lbr_iiwa_joint_7'"):
        SimEnv(bad, backend="mujoco")


@pytest.mark.parametrize(
    ("good", "bad", "key"),
    [
        ('joints = ["slider_to_cart"]', 'joints = ["slider_to_kart"]', "action.joints"),
        ('released = ["cart_to_pole"]', 'released = ["cart_to_pol"]', "robots[0].released"),
        (
            'params = { joint = "cart_to_pole", limit',
            'params = { joint = "cart_to_pol", limit',
            "terminations[0].params",
        ),
    ],
)
def test_a_joint_a_task_file_names_that_the_robot_lacks_gives_file_and_line(
    tmp_path, good, bad, key
):
    text = shipped_tasks()["cartpole"].read_text(encoding="utf-8")
    assert good in text
    text = text.replace(good, bad, 1)
    path = tmp_path / "mine.toml"
    path.write_text(text, encoding="utf-8")
    line = next(i for i, s in enumerate(text.splitlines(), 1) if s.startswith(bad))
    with pytest.raises(TaskJointError) as caught:
        SimEnv(str(path), backend="pybullet")
    message = str(caught.value)
    assert message.startswith(f"{path}:{line}: key {key!r}: "), message
    assert "did you mean" in message and "['slider_to_cart', 'cart_to_pole']" in message
    # still the lookup error it was, and a task-file error
    assert isinstance(caught.value, UnknownJointError) and isinstance(caught.value, TaskFileError)
    again = pickle.loads(pickle.dumps(caught.value))
    assert type(again) is TaskJointError and str(again) == message and again.line == line


def test_a_wrong_key_in_a_task_file_gives_file_and_line(tmp_path):
    text = shipped_tasks()["cartpole"].read_text(encoding="utf-8")
    text = text.replace('offset = "zero"', 'ofset = "zero"')
    path = tmp_path / "mine.toml"
    path.write_text(text, encoding="utf-8")
    line = next(i for i, s in enumerate(text.splitlines(), 1) if s.startswith("ofset"))
    with pytest.raises(
        TaskFileError,
        match=re.escape(f"{path}:{line}: key 'action.ofset': unknown key (did you mean 'offset'?)"),
    ):
        load_task(path)


@pytest.mark.parametrize(
    "change, key, detail",
    [
        ('mode = "torque"', "action.mode", "expected one of position, velocity, torque, pd"),
        ('term = "alive"', "rewards[0].term", "unknown term"),
        ("limit = 0.2095", "terminations[0].params.limit", "expected a number"),
    ],
)
def test_a_bad_value_gives_its_key_and_line(change, key, detail):
    text = shipped_tasks()["cartpole"].read_text(encoding="utf-8")
    bad = {
        'mode = "torque"': 'mode = "force"',
        'term = "alive"': 'term = "alvie"',
        "limit = 0.2095": 'limit = "small"',
    }[change]
    text = text.replace(change, bad, 1)
    line = next(i for i, s in enumerate(text.splitlines(), 1) if bad in s)
    with pytest.raises(TaskFileError, match=re.escape(f"mine.toml:{line}: key {key!r}: ") + detail):
        loads_task(text, file="mine.toml")


def test_an_unknown_task_lists_the_shipped_ones():
    with pytest.raises(
        TaskFileError,
        match=r"no such task file or shipped task; shipped: "
        r"\['a1_stand', 'a1_walk', 'ant', 'cartpole', 'half_cheetah', 'husky_goto', 'kuka_reach'\]",
    ):
        SimEnv("carpole")


def test_normalisation_of_another_size_is_refused():
    from simbridge.envs import Normalisation

    task = dataclasses.replace(
        load_task("cartpole"), normalisation=Normalisation((0.0,) * 3, (1.0,) * 3)
    )
    with pytest.raises(
        InvalidArgumentError,
        match=r"one entry per observation entry \(4: 4 x "
        r"history 1\), got 3 and 3",
    ):
        SimEnv(task)
