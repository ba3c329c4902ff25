"""Running a policy for episodes and counting its successes, with a Wilson interval.

::

    python -m simbridge.envs.evaluate cartpole --backends pybullet mujoco physx --episodes 20

runs each shipped task's reference controller (or ``--policy module:callable``, called with the
env and returning a callable observation -> action) on each engine over seeds 0..N-1 and prints
one row per engine: successes of N, the rate and its 95% Wilson interval, the mean return and
steps, and the wall time per control step (policy included).
"""

from __future__ import annotations

import argparse
import importlib
import math
import time
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import numpy as np

from simbridge.envs.controllers import reference_controller
from simbridge.envs.env import SimEnv

__all__ = ["Episode", "Rate", "main", "run_episode", "success_rate", "wilson"]


class Episode(NamedTuple):
    """One episode's result."""

    seed: int
    """The seed given to ``reset``."""
    success: bool
    """``info["is_success"]`` at its end."""
    ret: float
    """The sum of its rewards."""
    steps: int
    """Control steps taken."""
    failure: str | None
    """The termination that ended it, if any (``"diverged"``: the engine's state)."""


class Rate(NamedTuple):
    """Successes of N with a 95% Wilson score interval."""

    successes: int
    """Episodes that succeeded."""
    n: int
    """Episodes run."""
    low: float
    """The interval's lower end."""
    high: float
    """Its upper end."""


def wilson(successes: int, n: int, z: float = 1.959964) -> Rate:
    """The Wilson score interval of a proportion.

    Args:
        successes: successes (0..n).
        n: trials (> 0).
        z: the normal quantile (1.96: 95%).

    Returns:
        A :class:`Rate`.

    Raises:
        ValueError: n <= 0 or successes outside 0..n.
    """
    if n <= 0 or not 0 <= successes <= n:
        raise ValueError(f"expected 0 <= successes <= n and n > 0, got {successes} of {n}")
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return Rate(successes, n, max(0.0, centre - half), min(1.0, centre + half))


def run_episode(env: SimEnv, policy: Callable[[np.ndarray], Any], seed: int) -> Episode:
    """One episode of ``policy`` from ``reset(seed=seed)`` to its end.

    Args:
        env: the env.
        policy: observation -> action.
        seed: the reset's seed.

    Returns:
        Its :class:`Episode`.
    """
    obs, _ = env.reset(seed=seed)
    total, steps = 0.0, 0
    while True:
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        total += reward
        steps += 1
        if terminated or truncated:
            return Episode(seed, bool(info.get("is_success")), total, steps, info.get("failure"))


def success_rate(
    env: SimEnv, policy: Callable[[np.ndarray], Any], seeds: Sequence[int]
) -> tuple[Rate, list[Episode]]:
    """Episodes of ``policy`` over ``seeds`` and their success rate.

    Args:
        env: the env.
        policy: observation -> action.
        seeds: one episode per seed.

    Returns:
        The :class:`Rate` and every :class:`Episode`.
    """
    episodes = [run_episode(env, policy, s) for s in seeds]
    return wilson(sum(e.success for e in episodes), len(episodes)), episodes


def main(argv: Sequence[str] | None = None) -> None:
    """The command line (module docstring).

    Args:
        argv: the arguments; None: ``sys.argv``.
    """
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("task", help="a shipped task's name or a task file")
    ap.add_argument("--backends", nargs="+", default=["pybullet", "mujoco", "physx"])
    ap.add_argument("--episodes", type=int, default=20)
    ap.add_argument("--policy", help="module:callable taking the env, returning obs -> action")
    args = ap.parse_args(argv)
    print("| engine | successes | rate | 95% interval | mean return | mean steps | ms/step |")
    print("|---|---|---|---|---|---|---|")
    for backend in args.backends:
        env = SimEnv(args.task, backend=backend)
        if args.policy:
            module, _, name = args.policy.partition(":")
            policy = getattr(importlib.import_module(module), name)(env)
        else:
            policy = reference_controller(env)
        start = time.perf_counter()
        rate, eps = success_rate(env, policy, range(args.episodes))
        ms = (time.perf_counter() - start) * 1e3 / sum(e.steps for e in eps)
        env.close()
        print(
            f"| {backend} | {rate.successes}/{rate.n} | {rate.successes / rate.n:.2f} | "
            f"{rate.low:.2f}-{rate.high:.2f} | {np.mean([e.ret for e in eps]):.1f} | "
            f"{np.mean([e.steps for e in eps]):.0f} | {ms:.2f} |"
        )


if __name__ == "__main__":
    main()
