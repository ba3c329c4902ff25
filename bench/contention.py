"""Do this machine's cores slow each other down? The CPU time of the same work alone and with
``--together - 1`` copies of it running at once, back to back.

    python bench/contention.py                      # every workload, alone vs 2 at once
    python bench/contention.py --work python pybullet --together 2 8 --rounds 3

A process's CPU time (``time.process_time``) does not grow when other processes share its core
by turns (the load average): it grows when the processes run at the same time on cores that share
what executes them (two vCPUs that are one physical core's two hardware threads, a shared cache,
memory bandwidth). So "CPU per unit together / alone" is what running N jobs at once costs on
this machine whatever else it runs: 1.0 where the cores are independent; a pool of N workers
cannot reach a parallel efficiency above alone / together.

Workloads (each unit the same work every time; one warm-up unit before the clock):

- ``python``: a pure-Python integer loop (no memory traffic: the core's own execution units);
- ``numpy``: 256 x 256 matrix products, one BLAS thread (floating point, in cache);
- ``memory``: sums over a 64 MB array (memory bandwidth);
- ``pybullet``, ``mujoco``: one r2d2 ensemble member, as ``bench/jobs.py``'s jobs.

The rounds alternate alone and together, so that a change of the machine's load between them
moves both; the figure is the median over units and rounds.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import statistics
import sys
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
WORKS = ("python", "numpy", "memory", "pybullet", "mujoco")
ONE_THREAD = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def _unit(work: str) -> Any:
    """A callable doing one unit of ``work``."""
    if work == "python":

        def loop() -> int:
            s = 0
            for i in range(3_000_000):
                s += i * i
            return s

        return loop
    if work in ("numpy", "memory"):
        import numpy as np

        if work == "numpy":
            a = np.random.default_rng(0).random((256, 256))

            def products() -> float:
                b = a
                for _ in range(40):
                    b = a @ b
                    b /= b.max()
                return float(b[0, 0])

            return products
        big = np.ones(8 << 20)  # 64 MB, past any cache

        def sums() -> float:
            return float(sum(big.sum() for _ in range(8)))

        return sums
    sys.path.insert(0, str(HERE))
    from jobs import ensemble_jobs

    from simbridge.compare.run.jobs import run_job

    job = ensemble_jobs(work, 2)[1]
    return lambda: run_job(job)


def _child(work: str, units: int, barrier: Any, out: Any) -> None:
    fn = _unit(work)
    fn()  # warm-up: imports, first-call costs
    barrier.wait()
    cpu = []
    t0 = time.perf_counter()
    for _ in range(units):
        c0 = time.process_time()
        fn()
        cpu.append(time.process_time() - c0)
    out.put((cpu, time.perf_counter() - t0))


def together(work: str, n: int, units: int) -> tuple[list[float], float]:
    """CPU seconds of each unit of ``n`` processes doing ``units`` units of ``work`` at once
    (started together at a barrier), and the longest wall time among them."""
    ctx = multiprocessing.get_context("spawn")
    barrier, out = ctx.Barrier(n), ctx.SimpleQueue()
    saved = {k: os.environ.get(k) for k in ONE_THREAD}
    os.environ.update(dict.fromkeys(ONE_THREAD, "1"))
    try:
        procs = [ctx.Process(target=_child, args=(work, units, barrier, out)) for _ in range(n)]
        for p in procs:
            p.start()
        results = [out.get() for _ in procs]
        for p in procs:
            p.join()
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    return [c for cpu, _ in results for c in cpu], max(w for _, w in results)


def measure(work: str, n: int, units: int, rounds: int) -> dict[str, float]:
    """Median CPU per unit alone and with ``n`` at once, ``rounds`` alternating rounds."""
    alone: list[float] = []
    paired: list[float] = []
    for _ in range(rounds):
        alone += together(work, 1, units)[0]
        paired += together(work, n, units)[0]
    a, p = statistics.median(alone), statistics.median(paired)
    return {"alone": a, "together": p, "ratio": p / a}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", nargs="+", default=list(WORKS), choices=WORKS)
    ap.add_argument("--together", nargs="+", type=int, default=[2], help="processes at once")
    ap.add_argument("--units", type=int, default=4, help="units per process and round")
    ap.add_argument("--rounds", type=int, default=2)
    args = ap.parse_args(argv)
    print(f"cpus {os.cpu_count()}, load average {os.getloadavg()[0]:.1f}")
    print("work       at once  CPU/unit alone s  CPU/unit together s  together/alone")
    for work in args.work:
        for n in args.together:
            r = measure(work, n, args.units, args.rounds)
            print(
                f"{work:<10} {n:7d}  {r['alone']:16.3f}  {r['together']:19.3f}  {r['ratio']:14.2f}",
                flush=True,
            )
    print(f"load average after {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
