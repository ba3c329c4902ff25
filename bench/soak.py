"""Soak: many Sim lifetimes (or many loads in one Sim) in one process; memory, open files and
temporary files must stay flat.

    python bench/soak.py                          # 1000 cycles of each pattern, every backend
    python bench/soak.py --cycles 200 --check     # exit 1 where something is not flat

Patterns (each on each backend, in its own child process, so one does not inherit another's
memory):

* ``create-close``: ``Sim(backend)``, load r2d2 by name and a small robot from URDF text (the
  PyBullet backend writes text to a temporary file), 10 steps, ``close()``;
* ``load-remove``: one Sim; load r2d2, 10 steps, ``remove`` (the world empties every cycle);
* ``load-remove beside a plane``: the same with a plane that stays loaded;
* ``raw PyBullet load-remove``: the same two cycles written against pybullet itself, for
  reference (``removeBody`` keeps a body's collision meshes until ``resetSimulation``).

Each row: resident memory (RSS) after a warm-up (a tenth of the cycles, at least 100: three
of the PyBullet backend's renewals of an emptied world, see RECYCLE_AFTER_REMOVALS), its peak
and its value at the end, the growth from the warm-up to the end per cycle, open file
descriptors after the warm-up and at the end, and temporary files left in a private temporary
folder.
``--check``: every create-close and load-remove row must end within ``--allow`` MB plus
``--limit`` kB per cycle of its RSS after the warm-up (the allocator moves RSS by a few MB either
way: measured, MuJoCo's create-close over 1500 cycles stays within -10..+9 MB of it; a real leak
is r2d2's removeBody's 620 kB per cycle), with as many open files as after the warm-up and no
temporary file. Memory figures are the process's own (not timings): the machine's load does not
change them.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

PATTERNS = ("create-close", "load-remove", "load-remove beside a plane", "raw PyBullet load-remove")
TEXT_ROBOT = (
    '<robot name="soak"><link name="a"><inertial><mass value="1"/>'
    '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>'
    '<collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>'
    '<link name="b"><inertial><mass value="0.1"/>'
    '<inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>'
    '<joint name="j" type="continuous"><parent link="a"/><child link="b"/></joint></robot>'
)


def _rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def _fds() -> int:
    return len(os.listdir("/proc/self/fd"))


def usable_backends() -> list[str]:
    """Every registered backend whose engine is installed here (PhysX with the physx extra)."""
    import simbridge
    from simbridge.registry import unavailable_reason

    return [b for b in simbridge.available_backends() if unavailable_reason(b) is None]


def _cycle_function(pattern: str, backend: str) -> Any:
    import simbridge

    if pattern == "create-close":

        def cycle() -> None:
            sim = simbridge.Sim(backend)
            sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
            sim.load_urdf(TEXT_ROBOT, base_position=(2, 0, 1))
            sim.step(10)
            sim.close()

        return cycle
    if pattern.startswith("load-remove"):
        sim = simbridge.Sim(backend)
        if "plane" in pattern:
            sim.load_urdf("plane.urdf")

        def cycle() -> None:
            body = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
            sim.step(10)
            sim.remove(body)

        return cycle
    import pybullet as p
    import pybullet_data

    client = p.connect(p.DIRECT)
    r2d2 = str(Path(pybullet_data.getDataPath()) / "r2d2.urdf")

    def cycle() -> None:
        body = p.loadURDF(r2d2, (0, 0, 0.5), physicsClientId=client)
        for _ in range(10):
            p.stepSimulation(physicsClientId=client)
        p.removeBody(body, physicsClientId=client)

    return cycle


def run_one(pattern: str, backend: str, cycles: int) -> dict[str, Any]:
    """Run ``cycles`` cycles of ``pattern`` in this process; the figures as a dict."""
    folder = tempfile.mkdtemp(prefix="soak_")
    os.environ["TMPDIR"] = folder
    tempfile.tempdir = folder
    cycle = _cycle_function(pattern, backend)
    # the warm-up spans three of the PyBullet backend's world renewals (every 32 removals)
    warm = min(max(cycles // 10, 100), cycles // 2)
    every = max(cycles // 20, 1)
    for _ in range(warm):
        cycle()
    rss0, fds0 = _rss_mb(), _fds()
    peak = rss0
    for k in range(1, cycles - warm + 1):
        cycle()
        if k % every == 0:
            peak = max(peak, _rss_mb())
    rss1, fds1 = _rss_mb(), _fds()
    left = sorted(os.listdir(folder))
    shutil.rmtree(folder, ignore_errors=True)  # the private folder itself (measured: empty)
    return {
        "pattern": pattern,
        "backend": backend,
        "cycles": cycles,
        "rss_warm_mb": rss0,
        "rss_peak_mb": max(peak, rss1),
        "rss_end_mb": rss1,
        "kb_per_cycle": (rss1 - rss0) * 1024 / max(cycles - warm, 1),
        "fds_warm": fds0,
        "fds_end": fds1,
        "temp_left": left,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--cycles", type=int, default=1000)
    parser.add_argument("--backend", nargs="+", help="default: every installed backend")
    parser.add_argument("--pattern", nargs="+", default=list(PATTERNS), choices=PATTERNS)
    parser.add_argument("--check", action="store_true", help="exit 1 where not flat")
    parser.add_argument("--limit", type=float, default=10.0, help="kB per cycle (--check)")
    parser.add_argument("--allow", type=float, default=10.0, help="MB, any count (--check)")
    parser.add_argument("--one", nargs=2, metavar=("PATTERN", "BACKEND"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.one:  # a child: one row, as JSON
        print(json.dumps(run_one(args.one[0], args.one[1], args.cycles)))
        return 0
    backends = args.backend or usable_backends()
    rows = []
    for pattern in args.pattern:
        for backend in ["pybullet"] if pattern.startswith("raw") else backends:
            child = subprocess.run(
                [sys.executable, __file__, "--cycles", str(args.cycles), "--one", pattern, backend],
                capture_output=True,
                text=True,
            )
            if child.returncode != 0:
                print(child.stderr[-3000:], file=sys.stderr)
                return 1
            rows.append(json.loads(child.stdout.strip().splitlines()[-1]))
    print(f"# simbridge soak: {args.cycles} cycles per row, each row in its own process\n")
    print("| pattern | backend | RSS after warm-up MB | peak MB | at end MB | kB per cycle |")
    print("|------|------|------|------|------|------|")
    for r in rows:
        print(
            f"| {r['pattern']} | {r['backend']} | {r['rss_warm_mb']:.1f} | {r['rss_peak_mb']:.1f} "
            f"| {r['rss_end_mb']:.1f} | {r['kb_per_cycle']:.1f} |"
        )
    print("\n| pattern | backend | open files after warm-up | at end | temporary files left |")
    print("|------|------|------|------|------|")
    for r in rows:
        left = ", ".join(r["temp_left"]) or "none"
        print(f"| {r['pattern']} | {r['backend']} | {r['fds_warm']} | {r['fds_end']} | {left} |")
    bad = [
        r
        for r in rows
        if r["pattern"] in ("create-close", "load-remove")
        and (
            r["rss_end_mb"] - r["rss_warm_mb"] > args.allow + args.limit * r["cycles"] / 1024
            or r["fds_end"] != r["fds_warm"]
            or r["temp_left"]
        )
    ]
    for r in bad:
        print(f"NOT FLAT: {r['pattern']} on {r['backend']}: {r}", file=sys.stderr)
    return 1 if args.check and bad else 0


if __name__ == "__main__":
    sys.exit(main())
