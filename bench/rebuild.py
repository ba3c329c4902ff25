"""A report rebuilt from the cache (``simbridge report DIR``): its wall and CPU time from the
command line, with and without the entries a report derives from the jobs (verdicts, figures,
frames, replay, trajectory files), and where the time goes.

1. A study: ``simbridge compare SCENARIO`` (default r2d2, every installed engine, the default
   ensemble) into a cache (``--cache``; default: a temporary one) and a report folder, unless
   ``--folder DIR`` names one written already (its study's cache given by ``--cache``).
2. ``simbridge report DIR`` as the user runs it, in a new process each time: ``cold`` with the
   derived entries removed from a copy of the cache (every verdict judged, every picture
   drawn: what a rebuild cost before they were cached), ``first`` on the cache itself (it makes
   the derived entries it lacks: all of them after simbridge's code changed), then ``warm``
   (``--repeat`` times).
   Wall time and the CPU seconds (user + system) of the process: on this shared machine the
   load moves the wall time, the CPU seconds much less.
3. The phases of one warm rebuild in this process: importing simbridge's report modules,
   reading the study and the jobs' entries, judging (the verdicts), the figures, frames,
   trajectory files, report.html, and the rest.

::

    .venv/bin/python bench/rebuild.py                                  # r2d2, ~2.5 min study
    .venv/bin/python bench/rebuild.py --folder reports/r2d2            # a study already run
    .venv/bin/python bench/rebuild.py --scenario pendulum --ensemble 4 --backends pybullet mujoco
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
NO_PICTURES = ["--no-plots", "--no-replay"]
DERIVED = ("verdicts", "figures", "frames", "replays", "trajectories")


def _simbridge() -> list[str]:
    exe = Path(sys.executable).with_name("simbridge")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "simbridge"]


def _timed_cli(argv: list[str]) -> tuple[float, float]:
    """Wall and CPU seconds (user + system) of the command ``simbridge argv``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([*_simbridge(), *argv], check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def phases(folder: Path, cache: Path) -> dict[str, tuple[float, float]]:
    """(wall, CPU) seconds of each phase of one rebuild in this process."""
    spent: dict[str, list[float]] = defaultdict(lambda: [0.0, 0.0])

    def timed(name: str, fn: Any) -> Any:
        def wrapper(*a: Any, **k: Any) -> Any:
            t0, c0 = time.perf_counter(), time.process_time()
            try:
                return fn(*a, **k)
            finally:
                spent[name][0] += time.perf_counter() - t0
                spent[name][1] += time.process_time() - c0

        return wrapper

    t0, c0 = time.perf_counter(), time.process_time()
    from simbridge.compare import pipeline
    from simbridge.compare.report import html
    from simbridge.compare.report.rebuild import rebuild
    from simbridge.compare.run import asked

    report_module: Any = sys.modules["simbridge.compare.report"]  # the package, not `report`

    spent["imports"] = [time.perf_counter() - t0, time.process_time() - c0]

    def wrap(module: Any, name: str, phase: str) -> None:
        setattr(module, name, timed(phase, getattr(module, name)))

    wrap(pipeline, "run_jobs", "read the jobs' entries")
    wrap(pipeline, "judged", "verdicts")
    # each engine's state type (registry.state_dtype): declared in the registry, nothing imported
    wrap(asked, "EnsembleRunner", "ensemble offsets")  # the study's plan draws them
    wrap(pipeline, "diff", "diffs")
    wrap(report_module, "summary", "summary.json")
    wrap(report_module, "markdown", "report.md")
    wrap(html, "write_html", "report.html")
    real_memo = report_module.memo_files

    def memo(c: Any, kind: str, *a: Any, **k: Any) -> Any:
        return timed(kind, real_memo)(c, kind, *a, **k)

    report_module.memo_files = memo
    t0, c0 = time.perf_counter(), time.process_time()
    rebuild(folder, cache=cache, plots=True, replay=True)
    total = [time.perf_counter() - t0, time.process_time() - c0]
    counted = [sum(v[i] for k, v in spent.items() if k != "imports") for i in (0, 1)]
    spent["the rest"] = [total[i] - counted[i] for i in (0, 1)]
    return {k: (v[0], v[1]) for k, v in spent.items()}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenario", default="r2d2")
    p.add_argument("--backends", nargs="+", help="default: every installed engine")
    p.add_argument("--ensemble", type=int, help="runs per engine (default: compare's)")
    p.add_argument("--folder", type=Path, help="a report folder written already")
    p.add_argument("--cache", type=Path, help="the study's cache (default: a temporary one)")
    p.add_argument("--repeat", type=int, default=3, help="warm rebuilds (default 3)")
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        cache = args.cache or Path(tmp) / "cache"
        folder = args.folder
        if folder is None:
            folder = Path(tmp) / args.scenario
            argv = ["compare", args.scenario, "--cache", str(cache), "--out", str(folder)]
            if args.backends:
                argv += ["--backends", *args.backends]
            if args.ensemble:
                argv += ["--ensemble", str(args.ensemble)]
            wall, cpu = _timed_cli(argv)
            print(f"study: simbridge {' '.join(argv[:2])}: {wall:.1f} s wall, {cpu:.1f} s CPU")
        print(f"cpus {os.cpu_count()}, load average {os.getloadavg()[0]:.1f}")
        cold_cache = Path(tmp) / "cold-cache"
        shutil.copytree(cache, cold_cache, ignore=shutil.ignore_patterns(*DERIVED))
        cold_folder = Path(tmp) / "cold-report"
        shutil.copytree(folder, cold_folder)
        print("simbridge report DIR                     wall s   CPU s   load")

        def row(what: str, argv: list[str]) -> None:
            wall, cpu = _timed_cli(["report", *argv])
            print(f"  {what:<37} {wall:7.2f} {cpu:7.2f}  {os.getloadavg()[0]:5.1f}", flush=True)

        row("cold (no derived entries)", [str(cold_folder), "--cache", str(cold_cache)])
        row("first (makes those missing)", [str(folder), "--cache", str(cache)])
        for _ in range(args.repeat):
            row("warm", [str(folder), "--cache", str(cache)])
        row("warm, --no-plots --no-replay", [str(folder), "--cache", str(cache), *NO_PICTURES])
        print("phases of a warm rebuild (in this process)  wall s   CPU s")
        for name, (wall, cpu) in phases(folder, cache).items():
            print(f"  {name:<40} {wall:7.2f} {cpu:7.2f}")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    sys.exit(main())
