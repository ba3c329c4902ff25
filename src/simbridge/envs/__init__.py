"""Gymnasium environments over the :class:`~simbridge.Sim`, on any registered backend.

::

    import gymnasium, simbridge.envs

    env = gymnasium.make("simbridge/CartPole-v0", backend="physx")
    env = simbridge.envs.SimEnv("kuka_reach", backend="mujoco", render_mode="rgb_array")
    env.unwrapped.contract()        # joint order, action meaning, gains, dt, observation layout

A task (:class:`Task`, or a TOML file: docs/envs.md) states the robots, the action, the
observation, rewards, terminations, success and the initial state's spread; the shipped ones
(:func:`shipped_tasks`) each come with a reference controller (:mod:`.controllers`).
Gymnasium (``pip install "simbridge[envs]"``) is imported here and nowhere else in simbridge.
"""

from __future__ import annotations

from simbridge.envs.env import SimEnv
from simbridge.envs.errors import ActionError, TaskFileError, TaskJointError
from simbridge.envs.reader import load_task, loads_task, shipped_tasks
from simbridge.envs.registration import IDS, register_envs
from simbridge.envs.task import (
    ActionSpec,
    CommandSpec,
    Condition,
    Normalisation,
    ObsTerm,
    Randomisation,
    RewardTerm,
    RobotSpec,
    Task,
)

__all__ = [
    "IDS",
    "ActionError",
    "ActionSpec",
    "CommandSpec",
    "Condition",
    "Normalisation",
    "ObsTerm",
    "Randomisation",
    "RewardTerm",
    "RobotSpec",
    "SimEnv",
    "Task",
    "TaskFileError",
    "TaskJointError",
    "load_task",
    "loads_task",
    "register_envs",
    "shipped_tasks",
]

register_envs()
