"""The Gymnasium ids of the shipped tasks: ``gymnasium.make("simbridge/CartPole-v0",
backend="physx")`` after ``import simbridge.envs`` (or ``gymnasium.make("simbridge.envs:
simbridge/CartPole-v0")``, which imports it)."""

from __future__ import annotations

__all__ = ["IDS", "register_envs"]

IDS = {
    "simbridge/CartPole-v0": "cartpole",
    "simbridge/KukaReach-v0": "kuka_reach",
    "simbridge/HuskyGoTo-v0": "husky_goto",
    "simbridge/A1Stand-v0": "a1_stand",
    "simbridge/Ant-v0": "ant",
    "simbridge/HalfCheetah-v0": "half_cheetah",
    "simbridge/A1Walk-v0": "a1_walk",
}
"""Gymnasium id -> shipped task name."""


def register_envs() -> None:
    """Register every id of :data:`IDS` with Gymnasium (again: no effect).

    Each id makes :class:`~simbridge.envs.env.SimEnv` with its task; ``backend`` and the other
    keywords of ``gymnasium.make`` go to it. ``gymnasium.make_vec(id, n,
    vectorization_mode="vector_entry_point")`` makes :class:`~simbridge.envs.vector.SimVectorEnv`.
    The episode's length is the task's (``truncated`` at ``episode_steps``), so no
    ``max_episode_steps`` is set here.
    """
    from gymnasium.envs.registration import register, registry

    for env_id, task in IDS.items():
        if env_id in registry:
            continue
        register(
            id=env_id,
            entry_point="simbridge.envs.env:SimEnv",
            vector_entry_point="simbridge.envs.vector:SimVectorEnv",
            kwargs={"task": task},
        )
