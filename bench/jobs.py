"""A study's runs as jobs on the local process pool, and a report rebuilt from the cache.

1. Per engine, a ``--size``-run ensemble of r2d2 (the nominal run and ``size - 1`` perturbed
   members: the very jobs ``simbridge compare r2d2 --ensemble SIZE`` makes) run three times: one
   after the other in this process (the serial time, after one warm-up run), then on a local
   pool of ``--workers`` processes started for them ("cold": the pool's start and its workers'
   imports in the wall), then again on that pool, which ``run_all`` keeps ("warm": what a
   study's next call, a sweep's next point, gets). Parallel efficiency = serial / (wall x
   workers); the issue's target is >= 0.85 on 2 cores. CPU per job is what each job measured
   where it ran (``JobResult.cpu_time``): pool / serial above 1 is what running ``workers``
   jobs at once costs each of them on this machine (``bench/contention.py`` measures it for
   plain loops too).
2. ``compare("r2d2", ensemble=SIZE)`` into the same cache (its members are already there: only
   the nominal, half-step and resync runs run), its report written, then the report rebuilt
   from the cache alone (``simbridge report DIR``: no engine runs): its wall time; the target
   is < 3 s.

::

    .venv/bin/python bench/jobs.py                      # 64 runs, pybullet and mujoco, 2 workers
    .venv/bin/python bench/jobs.py --size 8 --backends pybullet   # a quick look

Timings depend on what else the machine runs: the serial and the pool runs are taken back to
back, each engine in turn, and the load average is printed beside them, with the CPU seconds
of each (this process and its workers), which the load does not move: pool CPU over serial CPU
is what the pool costs on top of the runs. Below the table, per engine and pool: the workers' CPU
outside the jobs, per worker (a cold pool's start: the interpreter, the imports; each job's
unpickling), each worker's first job's CPU against the median of the others (a first job imports
the engine), and the CPU of a fresh interpreter importing what a job needs.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from executors import workers_cpu  # bench/executors.py, beside this file

ROOT = Path(__file__).resolve().parents[1]


def ensemble_jobs(backend: str, size: int, seed: int = 0) -> list:
    """The jobs of ``backend``'s ``size``-run r2d2 ensemble as compare() makes them."""
    from simbridge.compare import load_scenario
    from simbridge.compare.run.ensemble import EnsembleRunner, perturbed
    from simbridge.compare.run.jobs import Job

    sc = load_scenario("r2d2")
    quantity = "base_distance"
    runner = EnsembleRunner(sc, [(backend, sc.profile)], quantity, size=size, seed=seed)
    dpos, drot = runner.engine_offsets[0]
    jobs = [Job.of("nominal", sc, backend, sc.profile)]
    for k in range(1, size):
        jobs.append(
            Job.of(
                "member",
                perturbed(sc, dpos[k], drot[k]),
                backend,
                sc.profile,
                seed=runner.seed,
                member=k,
                quantity=quantity,
            )
        )
    return jobs


def measure(backend: str, size: int, workers: int, cache: Path, serial: bool) -> dict:
    """Serial and pool timings of ``backend``'s ensemble; CPU per job as each job measured it
    (:attr:`JobResult.cpu_time`), so pool / serial CPU per job is what running ``workers``
    jobs at once costs each of them on this machine."""
    from simbridge.compare.run.cache import Cache
    from simbridge.compare.run.executors import shutdown_pool
    from simbridge.compare.run.jobs import run_job

    jobs = ensemble_jobs(backend, size)
    for job in jobs:  # their cache keys, made before the clock as compare()'s plan makes them
        job.key  # noqa: B018 - a cached property
    out: dict = {"backend": backend, "jobs": len(jobs), "workers": workers}
    if serial:
        run_job(jobs[1])  # warm-up: the engine loaded, as in a pool's worker after its first job
        t0, c0 = time.perf_counter(), time.process_time()
        done = [run_job(job) for job in jobs]
        out["serial"] = time.perf_counter() - t0
        out["serial_cpu"] = time.process_time() - c0
        out["serial_job_cpu"] = sum(r.cpu_time for r in done) / len(done)
    store = Cache(cache)
    shutdown_pool()  # cold: the pool's start and its workers' imports in the wall
    out["cold"] = _pool(jobs, workers, store, set())
    out["warm"] = _pool(jobs, workers, store, out["cold"]["pids"])  # the pool kept from it
    if serial:
        for mode in ("cold", "warm"):
            out[mode]["efficiency"] = out["serial"] / (out[mode]["wall"] * workers)
    return out


def _pool(jobs: list, workers: int, store: Any, known: set[int]) -> dict:
    """The jobs on the local pool (``known``: its workers' pids when it is kept from a previous
    call): wall, CPU (this process and the workers), the sum of the jobs' own wall times and
    their CPU per job, and when the first job started."""
    import resource

    from simbridge.compare.run.executors import run_all
    from simbridge.compare.run.jobs import run_job

    arrived: list[float] = [0.0] * len(jobs)

    def keep(i: int, r: Any) -> None:
        arrived[i] = time.perf_counter()
        store.put(jobs[i].key, r)

    me = resource.getrusage(resource.RUSAGE_SELF)
    w0 = workers_cpu(known)
    c0 = me.ru_utime + me.ru_stime + w0
    t0 = time.perf_counter()
    results = run_all(
        run_job,
        jobs,
        labels=[j.label for j in jobs],
        workers=workers,
        progress=lambda *_: None,
        on_result=keep,
    )
    wall = time.perf_counter() - t0
    pids = known | {r.pid for r in results}
    me = resource.getrusage(resource.RUSAGE_SELF)
    w1 = workers_cpu(pids)
    out: dict = {"wall": wall, "cpu": me.ru_utime + me.ru_stime + w1 - c0}
    out["pids"] = pids
    # the workers' CPU outside the jobs, per worker: their start (interpreter, imports) when the
    # pool is started for the call, and each job's unpickling and its result's pickling
    used = {r.pid for r in results}
    out["outside_jobs"] = (w1 - w0 - sum(r.cpu_time for r in results)) / len(used)
    # each worker's first job (a worker runs its jobs one after the other: their arrival
    # order) against the others: what a job's first run in a process costs (the engine's import)
    by_pid: dict[int, list[float]] = {}
    for i in sorted(range(len(results)), key=lambda i: arrived[i]):
        by_pid.setdefault(results[i].pid, []).append(results[i].cpu_time)
    out["first_cpu"] = [cpus[0] for cpus in by_pid.values()]
    rest = sorted(c for cpus in by_pid.values() for c in cpus[1:])
    out["rest_cpu"] = rest[len(rest) // 2] if rest else float("nan")
    out["in_jobs"] = sum(r.wall_time for r in results)
    out["job_cpu"] = sum(r.cpu_time for r in results) / len(results)
    # the first job's start, seen from here: the pool's start and its worker's imports
    first = min(range(len(results)), key=lambda i: arrived[i])
    out["start"] = arrived[first] - t0 - results[first].wall_time
    return out


def rebuild_time(backends: list[str], size: int, workers: int, cache: Path) -> dict:
    from simbridge.compare import compare, report
    from simbridge.compare.report.rebuild import rebuild

    t0 = time.perf_counter()
    c = compare("r2d2", backends, ensemble=size, workers=workers, cache=cache, progress=None)
    study = time.perf_counter() - t0
    times = {}
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "r2d2"
        report(c, out)
        for plots in (True, False):
            t0, c0 = time.perf_counter(), time.process_time()
            rebuild(out, cache=cache, plots=plots, replay=plots)
            times[plots] = (time.perf_counter() - t0, time.process_time() - c0)
    assert c.jobs is not None
    return {"study": study, "ran": c.jobs.ran, "cached": c.jobs.cached, "rebuild": times}


def _import_cpu(runs: int = 3) -> float:
    """CPU seconds of importing what a job needs (its module, the run stage) in a fresh
    interpreter, the least of ``runs``: a pool worker's imports before its first job."""
    import subprocess

    code = (
        "import time; c = time.process_time(); import simbridge.compare.run.jobs, "
        "simbridge.compare.run.recording, simbridge.compare.run.ensemble; "
        "print(time.process_time() - c)"
    )
    return min(
        float(
            subprocess.run(
                [sys.executable, "-c", code], capture_output=True, text=True, check=True
            ).stdout
        )
        for _ in range(runs)
    )


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--backends", nargs="+", default=["pybullet", "mujoco"])
    p.add_argument("--size", type=int, default=64, help="runs per engine (default 64)")
    p.add_argument("--workers", type=int, default=2, help="pool processes (default 2)")
    p.add_argument("--no-serial", action="store_true", help="skip the serial runs")
    p.add_argument("--no-rebuild", action="store_true", help="skip the report rebuild")
    p.add_argument("--rebuild-only", action="store_true", help="only the report rebuild")
    p.add_argument("--cache", type=Path, help="cache folder (default: a temporary one)")
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        cache = args.cache or Path(tmp) / "cache"
        print(f"cpus {os.cpu_count()}, load average before {os.getloadavg()[0]:.1f}")
        print(
            "engine    runs  workers  pool  serial s  wall s  efficiency  start s  in-jobs s"
            "  CPU/job serial s  CPU/job pool s  pool/serial  CPU serial s  CPU pool s  load"
        )
        nan = float("nan")
        notes = []
        for backend in [] if args.rebuild_only else args.backends:
            r = measure(backend, args.size, args.workers, cache, not args.no_serial)
            sj = r.get("serial_job_cpu", nan)
            for mode in ("cold", "warm"):
                m = r[mode]
                print(
                    f"{backend:<9} {r['jobs']:4d}  {r['workers']:7d}  {mode}"
                    f"  {r.get('serial', nan):8.1f}  {m['wall']:6.1f}"
                    f"  {m.get('efficiency', nan):10.2f}  {m['start']:7.2f}  {m['in_jobs']:9.1f}"
                    f"  {sj:16.3f}  {m['job_cpu']:14.3f}  {m['job_cpu'] / sj:11.2f}"
                    f"  {r.get('serial_cpu', nan):12.1f}  {m['cpu']:10.1f}"
                    f"  {os.getloadavg()[0]:4.1f}",
                    flush=True,
                )
                first = ", ".join(f"{c:.3f}" for c in m["first_cpu"])
                notes.append(
                    f"  {backend} {mode}: {m['outside_jobs']:.3f} s per worker outside the jobs; "
                    f"first job per worker {first} s, median of the others {m['rest_cpu']:.3f} s"
                )
        if notes:
            print(
                "workers' CPU outside the jobs (a cold pool: the workers' start and imports; "
                "each job's unpickling) and each worker's first job's CPU:"
            )
            print("\n".join(notes))
            print(f"a worker's imports: {_import_cpu():.3f} s CPU (fresh interpreter, least of 3)")
        if not args.no_rebuild:
            pair = args.backends if len(args.backends) >= 2 else ["pybullet", "mujoco"]
            r = rebuild_time(pair, args.size, args.workers, cache)
            print(
                f"compare r2d2 --ensemble {args.size}: {r['study']:.1f} s ({r['ran']} jobs ran, "
                f"{r['cached']} from the cache)"
            )
            for plots, (wall, cpu) in r["rebuild"].items():
                print(
                    f"report rebuilt from the cache{'' if plots else ', no figures nor frames'}: "
                    f"{wall:.2f} s wall, {cpu:.2f} s CPU (load {os.getloadavg()[0]:.1f})"
                )
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    sys.exit(main())
