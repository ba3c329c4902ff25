"""Does SimVectorEnv's thread pool help? N worlds of one task stepped with action 0, serially and
in a pool of k threads, in alternating rounds (on a shared machine one round is noise).

    python bench/envs_threads.py a1_stand --backend mujoco --worlds 4 --threads 2 --rounds 2
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from simbridge.envs.vector import SimVectorEnv


def throughput(task: str, backend: str, worlds: int, threads: int, steps: int) -> float:
    """Env-steps per second of ``worlds`` worlds over ``steps`` vector steps (after 20)."""
    venv = SimVectorEnv(worlds, task, backend=backend, threads=threads)
    venv.reset(seed=0)
    action = np.zeros((worlds, *venv.single_action_space.shape), np.float32)
    for _ in range(20):
        venv.step(action)
    start = time.perf_counter()
    for _ in range(steps):
        venv.step(action)
    elapsed = time.perf_counter() - start
    venv.close()
    return worlds * steps / elapsed


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("task")
    ap.add_argument("--backend", default="mujoco")
    ap.add_argument("--worlds", type=int, default=4)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--steps", type=int, default=200)
    args = ap.parse_args()
    print("| round | threads | env-steps/s |\n|---|---|---|")
    for r in range(args.rounds):
        for k in (0, args.threads):
            rate = throughput(args.task, args.backend, args.worlds, k, args.steps)
            print(f"| {r + 1} | {k} | {rate:.0f} |")


if __name__ == "__main__":
    main()
