"""A study's runs as jobs on the local process pool, and a report rebuilt from the cache.

1. Per engine, a ``--size``-run ensemble of r2d2 (the nominal run and ``size - 1`` perturbed
   members: the very jobs ``simbridge compare r2d2 --ensemble SIZE`` makes) run twice: one after
   the other in this process (the serial time), then on a local pool of ``--workers``
   processes (its wall time, process start included). Parallel efficiency = serial / (wall x
   workers); the issue's target is >= 0.85 on 2 cores.
2. ``compare("r2d2", ensemble=SIZE)`` into the same cache (its members are already there: only
   the nominal, half-step and resync runs run), its report written, then the report rebuilt
   from the cache alone (``simbridge report DIR``: no engine runs): its wall time; the target
   is < 3 s.

::

    .venv/bin/python bench/jobs.py                      # 64 runs, pybullet and mujoco, 2 workers
    .venv/bin/python bench/jobs.py --size 8 --backends pybullet   # a quick look

Timings depend on what else the machine runs: the serial and the pool runs are taken back to
back, each engine in turn, and the load average is printed beside them.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

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
    from simbridge.compare.run.cache import Cache
    from simbridge.compare.run.jobs import run_job
    from simbridge.compare.run.executors import run_all

    jobs = ensemble_jobs(backend, size)
    out: dict = {"backend": backend, "jobs": len(jobs), "workers": workers}
    if serial:
        t0 = time.perf_counter()
        for job in jobs:
            run_job(job)
        out["serial"] = time.perf_counter() - t0
    store = Cache(cache)
    t0 = time.perf_counter()
    results = run_all(
        run_job,
        jobs,
        labels=[j.label for j in jobs],
        workers=workers,
        progress=lambda *_: None,
        on_result=lambda i, r: store.put(jobs[i].key, r),
    )
    out["wall"] = time.perf_counter() - t0
    out["in_jobs"] = sum(r.wall_time for r in results)
    if serial:
        out["efficiency"] = out["serial"] / (out["wall"] * workers)
    return out


def rebuild_time(backends: list[str], size: int, workers: int, cache: Path) -> dict:
    from simbridge.compare import compare, report
    from simbridge.compare.report.rebuild import rebuild

    t0 = time.perf_counter()
    c = compare("r2d2", backends, ensemble=size, workers=workers, cache=cache, progress=None)
    study = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "r2d2"
        report(c, out)
        t0 = time.perf_counter()
        rebuild(out, cache=cache)
        wall = time.perf_counter() - t0
    assert c.jobs is not None
    return {"study": study, "ran": c.jobs.ran, "cached": c.jobs.cached, "rebuild": wall}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--backends", nargs="+", default=["pybullet", "mujoco"])
    p.add_argument("--size", type=int, default=64, help="runs per engine (default 64)")
    p.add_argument("--workers", type=int, default=2, help="pool processes (default 2)")
    p.add_argument("--no-serial", action="store_true", help="skip the serial runs")
    p.add_argument("--no-rebuild", action="store_true", help="skip the report rebuild")
    p.add_argument("--cache", type=Path, help="cache folder (default: a temporary one)")
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        cache = args.cache or Path(tmp) / "cache"
        print(f"cpus {os.cpu_count()}, load average before {os.getloadavg()[0]:.1f}")
        print("engine    runs  workers  serial s  pool wall s  in-jobs s  efficiency  load")
        for backend in args.backends:
            r = measure(backend, args.size, args.workers, cache, not args.no_serial)
            serial = f"{r['serial']:8.1f}" if "serial" in r else "       -"
            eff = f"{r['efficiency']:10.2f}" if "efficiency" in r else "         -"
            print(
                f"{backend:<9} {r['jobs']:4d}  {r['workers']:7d}  {serial}  {r['wall']:11.1f}"
                f"  {r['in_jobs']:9.1f}  {eff}  {os.getloadavg()[0]:4.1f}",
                flush=True,
            )
        if not args.no_rebuild:
            r = rebuild_time(args.backends, args.size, args.workers, cache)
            print(
                f"compare r2d2 --ensemble {args.size}: {r['study']:.1f} s ({r['ran']} jobs ran, "
                f"{r['cached']} from the cache); report rebuilt from the cache: "
                f"{r['rebuild']:.2f} s (load {os.getloadavg()[0]:.1f})"
            )
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    sys.exit(main())
