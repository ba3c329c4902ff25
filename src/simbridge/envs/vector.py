"""`SimVectorEnv`: N worlds of one task stepped in one process, with Gymnasium's autoreset modes
(``gymnasium.make_vec(id, n, vectorization_mode="vector_entry_point")``).

It is Gymnasium's :class:`~gymnasium.vector.SyncVectorEnv` over N :class:`SimEnv`, the batching,
seeding (``reset(seed=s)`` seeds world i with ``s + i``) and autoreset modes its own, with one
option more: ``threads``, which steps the worlds in a thread pool (an engine whose step releases
the GIL, MuJoCo's, can then run several at once; what it gains here: docs/envs.md).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from gymnasium.vector.utils import concatenate, iterate

from simbridge.envs.env import SimEnv
from simbridge.envs.task import Task

__all__ = ["SimVectorEnv"]


class SimVectorEnv(SyncVectorEnv):
    """N copies of one task, stepped together.

    Args:
        num_envs: how many worlds.
        task: as :class:`SimEnv`'s.
        backend: as :class:`SimEnv`'s.
        autoreset_mode: ``AutoresetMode.NEXT_STEP`` (Gymnasium's default: the step after an
            episode's end resets that world and returns its first observation, reward 0),
            ``SAME_STEP`` (reset in the same step; the last observation and info in
            ``info["final_obs"]``, ``info["final_info"]``) or ``DISABLED`` (the caller resets,
            ``reset(options={"reset_mask": ...})``).
        threads: 0: step the worlds one after another; k > 0: in a pool of k threads.
        **kwargs: passed to each :class:`SimEnv` (``render_mode``, ``engine_settings``).
    """

    def __init__(
        self,
        num_envs: int = 1,
        task: Task | str | os.PathLike[str] = "cartpole",
        *,
        backend: str = "pybullet",
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
        threads: int = 0,
        **kwargs: Any,
    ) -> None:
        kwargs.pop("max_episode_steps", None)  # the task's episode_steps rule
        fns = [lambda: SimEnv(task, backend=backend, **kwargs) for _ in range(num_envs)]
        super().__init__(fns, copy=True, autoreset_mode=autoreset_mode)
        self._pool = ThreadPoolExecutor(threads) if threads > 0 else None

    def _one(self, i: int, action: Any) -> dict[str, Any]:
        """Step world i as the autoreset mode says; returns its info (``final_obs`` and
        ``final_info`` included under SAME_STEP)."""
        env, mode = self.envs[i], self.autoreset_mode
        if mode == AutoresetMode.NEXT_STEP and self._autoreset_envs[i]:
            self._env_obs[i], info = env.reset()
            self._rewards[i], self._terminations[i], self._truncations[i] = 0.0, False, False
            return info
        out = env.step(action)
        self._env_obs[i], self._rewards[i], self._terminations[i], self._truncations[i] = out[:4]
        info = out[4]
        if mode == AutoresetMode.SAME_STEP and (out[2] or out[3]):
            final = {"final_obs": out[0], "final_info": info}
            self._env_obs[i], info = env.reset()
            return {**final, "_reset_info": info}
        return info

    def step(self, actions: Any) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every world once.

        Args:
            actions: ``(num_envs, n)``.

        Returns:
            Batched ``(observations, rewards, terminations, truncations, infos)``, as
            :class:`~gymnasium.vector.SyncVectorEnv`'s.

        Raises:
            ActionError: a world's action of the wrong shape or not finite.
        """
        if self._pool is None:
            return super().step(actions)
        if self.autoreset_mode == AutoresetMode.DISABLED:
            assert not self._autoreset_envs.any(), "DISABLED: reset the ended worlds first"
        acts = list(iterate(self.action_space, actions))
        results = list(self._pool.map(self._one, range(self.num_envs), acts))
        infos: dict[str, Any] = {}
        for i, info in enumerate(results):
            if "_reset_info" in info:
                reset_info = info.pop("_reset_info")
                infos = self._add_info(infos, info, i)
                info = reset_info
            infos = self._add_info(infos, info, i)
        self._observations = concatenate(
            self.single_observation_space, self._env_obs, self._observations
        )
        self._autoreset_envs = np.logical_or(self._terminations, self._truncations)
        return (
            np.copy(self._observations),
            np.copy(self._rewards),
            np.copy(self._terminations),
            np.copy(self._truncations),
            infos,
        )

    def close_extras(self, **kwargs: Any) -> None:
        """Close every world and the thread pool.

        Args:
            **kwargs: as :meth:`SyncVectorEnv.close_extras`'s.
        """
        if self._pool is not None:
            self._pool.shutdown()
        super().close_extras(**kwargs)
