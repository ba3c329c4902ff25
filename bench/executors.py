"""The same jobs serially, on the local process pool and on a Dask LocalCluster of this machine
(compare/run/executors.py's run_all).

    python bench/executors.py [--runs 64] [--workers N] [--scenario r2d2] [--no-dask]

The jobs: ``--runs`` members of an ensemble of the scenario per engine (PyBullet and MuJoCo;
member k's spawn pose moved by the k-th offset of 1e-9 m / rad, as compare's ensembles), each
a whole run in its worker returning the followed robot's end point. Three timings of the same
jobs, which must give the same end points:

- serial: every job in this process, one after the other (``workers=0``), the engines
  already loaded (one warm-up run per engine before the clock starts);
- pool: the local pool of ``--workers`` processes (default the CPU count), its start and the
  workers' imports included; parallel efficiency = serial / (wall x workers); then "warm":
  the same jobs again on that pool, which ``run_all`` keeps for the next call;
- Dask: a LocalCluster of ``--workers`` worker processes, one thread each, started before the
  clock (a standing cluster); its workers load the engines on their first job, inside the
  timing; the ratio is Dask's wall / the pool's.

Other work on the machine slows every figure; the efficiency and the ratio are only meaningful
when nothing else runs (say so with the figures). The CPU column does not depend on that load:
the CPU time this process and its finished child processes spent on the timing (user + system),
so CPU / serial CPU is what the executor costs on top of the runs themselves (worker starts,
imports, pickling, Dask's scheduler).
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import platform
import resource
import sys
import time

from simbridge.compare import load_scenario
from simbridge.compare.run.ensemble import end_point, offsets, perturbed
from simbridge.compare.run.executors import JobFailed, run_all, shutdown_pool
from simbridge.compare.run.recording import run
from simbridge.compare.scenario import Scenario


def member(args: tuple[Scenario, str, int, int]) -> tuple[float, ...]:
    """One ensemble member: ``(scenario, backend, k, size)`` -> where the robot ends (m)."""
    scenario, backend, k, size = args
    dpos, drot = offsets(size, len(scenario.robots), 1e-9, 1e-9, seed=0)
    tr = run(perturbed(scenario, dpos[k], drot[k]), backend)
    return tuple(float(v) for v in end_point(tr.body))


def cpu() -> float:
    """CPU seconds (user + system) of this process and its reaped child processes."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def workers_cpu(pids: set[int]) -> float:
    """CPU seconds (user + system) so far of the running processes ``pids`` (Linux's /proc):
    the kept pool's workers, which are not reaped when a call ends."""
    total = 0.0
    for pid in pids:
        try:
            with open(f"/proc/{pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        total += (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    return total


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=64, help="ensemble members per engine")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--scenario", default="r2d2")
    ap.add_argument("--backends", nargs="+", default=["pybullet", "mujoco"])
    ap.add_argument("--no-dask", action="store_true", help="skip the Dask LocalCluster timing")
    args = ap.parse_args()

    scenario = load_scenario(args.scenario)
    items = [(scenario, b, k, args.runs) for b in args.backends for k in range(args.runs)]
    labels = [f"{b} member {k}" for _, b, k, _ in items]
    quiet = {"progress": lambda done, total, label: None, "labels": labels}
    for b in args.backends:  # warm-up: the engines loaded in this process
        member((scenario, b, 0, args.runs))

    t0, c0 = time.perf_counter(), cpu()
    serial = run_all(member, items, workers=0, **quiet)
    t_serial, c_serial = time.perf_counter() - t0, cpu() - c0

    shutdown_pool()  # a pool started for these jobs: its start in the wall
    t0, c0 = time.perf_counter(), cpu()
    pooled = run_all(member, items, workers=args.workers, **quiet)
    t_pool = time.perf_counter() - t0
    kept = {p.pid for p in multiprocessing.active_children()}  # its workers, kept warm
    c_pool = cpu() - c0 + workers_cpu(kept)
    assert pooled == serial, "the pool's end points differ from the serial ones"
    t0, c0 = time.perf_counter(), cpu() + workers_cpu(kept)
    warm = run_all(member, items, workers=args.workers, **quiet)
    t_warm, c_warm = time.perf_counter() - t0, cpu() + workers_cpu(kept) - c0
    assert warm == serial, "the warm pool's end points differ from the serial ones"
    shutdown_pool()

    t_dask = c_dask = None
    if not args.no_dask:
        import logging

        from distributed import LocalCluster

        with LocalCluster(
            n_workers=args.workers,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=":0",  # any free port, none taken from another cluster
            silence_logs=logging.ERROR,
        ) as cluster:
            t0, c0 = time.perf_counter(), cpu()
            on_dask = run_all(member, items, scheduler=cluster.scheduler_address, **quiet)
            t_dask = time.perf_counter() - t0
            cluster.close()  # its workers reaped: their CPU time counted
            c_dask = cpu() - c0
        assert on_dask == serial, "Dask's end points differ from the serial ones"
    assert not any(isinstance(r, JobFailed) for r in serial)

    load = os.getloadavg()
    print(
        f"# run_all: {len(items)} {args.scenario} runs ({args.runs} per engine: "
        f"{', '.join(args.backends)}) | {platform.machine()} | {os.cpu_count()} CPUs | "
        f"Python {platform.python_version()} | load average {load[0]:.1f} {load[1]:.1f}"
    )
    print()
    print("| executor | workers | wall s | per run ms | CPU s (x serial) | figure |")
    print("|---|---|---|---|---|---|")
    per = 1000 / len(items)
    print(
        f"| serial (this process) | 1 | {t_serial:.2f} | {t_serial * per:.0f} | {c_serial:.1f} | |"
    )
    eff = t_serial / (t_pool * args.workers)
    print(
        f"| local pool | {args.workers} | {t_pool:.2f} | {t_pool * per:.0f} | "
        f"{c_pool:.1f} ({c_pool / c_serial:.2f}) | parallel efficiency {eff:.2f} |"
    )
    print(
        f"| local pool, warm (kept from the call above) | {args.workers} | {t_warm:.2f} | "
        f"{t_warm * per:.0f} | {c_warm:.1f} ({c_warm / c_serial:.2f}) | parallel efficiency "
        f"{t_serial / (t_warm * args.workers):.2f} |"
    )
    if t_dask is not None and c_dask is not None:
        print(
            f"| Dask LocalCluster | {args.workers} | {t_dask:.2f} | {t_dask * per:.0f} | "
            f"{c_dask:.1f} ({c_dask / c_serial:.2f}) | {t_dask / t_pool:.2f}x the pool's wall |"
        )
    print()
    print(f"every executor gave the same {len(serial)} end points, to the last bit")
    return 0


if __name__ == "__main__":
    sys.exit(main())
