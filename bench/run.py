"""What the layer costs: raw engine code against simbridge, side by side in one process.

    python bench/run.py                 # full run (about a minute)
    python bench/run.py --repeats 1 --quick   # smoke run

Each row times the raw code and the layer's code interleaved (raw, layer, raw, layer ...) in
this one process, ``--repeats`` times, and prints the medians, their spread (min..max) and the
ratio layer/raw against the target from ../shared/PERFORMANCE.md. Raw code is written the fast,
idiomatic way (``setJointMotorControlArray``; ``d.ctrl[:] = array``). The N-environment rows
(bench/parallel.py) run 8 worlds on two threads or two processes, raw and layer alike, and
give the wall-clock time per env-step (the target 1.11x is PERFORMANCE.md's "at least 0.9x the
raw throughput").

PhysX's drive misses its 1.10x target against raw SAPIEN with PhysX's own (linear) link damping:
the layer gives PhysX PyBullet's link damping law (``f = -m k (1 + |v|) v``) and PyBullet's
clamp of joint speeds, both in Python at every step. SAPIEN 3.0.3's CPU articulation reads
link velocities one link at a time, so the law costs two velocity reads and one
``add_force_torque`` per moving link per step (r2d2: 16 links, 48 engine calls); the clamp a
``qvel`` read per step and a write where a speed is past it (212 of the drive's 980 steps). The
row "raw applying PyBullet's link damping" is raw SAPIEN doing only the law's calls (bound
methods, one preallocated buffer); "raw with PyBullet's damping and speed clamp" does the clamp
too and ends the drive in the layer's state bit for bit (the row's note checks it): the floor
of the layer's work. Whole drives a second apart see the shared machine's load change; the same
comparison step by step in pairs is bench/physx_drive_pairs.py (docs/benchmarks.md, PhysX speed).
"""

from __future__ import annotations

import argparse
import platform
import statistics
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import cases  # noqa: E402  (bench/cases.py: the raw and layer code of every row)
import parallel  # noqa: E402  (bench/parallel.py: N environments on the cores)


@dataclass
class Row:
    name: str
    unit: str
    raw: list[float]
    layer: list[float]
    target: float | None
    note: str = ""

    @property
    def ratio(self) -> float:
        return statistics.median(self.layer) / statistics.median(self.raw)

    def verdict(self) -> str:
        if self.target is None:
            return ""
        return "ok" if self.ratio <= self.target else "MISSED"


def interleave(
    raw: Callable[[], float], layer: Callable[[], float], repeats: int
) -> tuple[list[float], list[float]]:
    """Run raw and layer alternately; each callable returns the seconds of its timed part."""
    raw()  # warm both up (imports, caches, first compile)
    layer()
    r, lay = [], []
    for _ in range(repeats):
        r.append(raw())
        lay.append(layer())
    return r, lay


def import_times(repeats: int) -> tuple[list[float], list[float]]:
    """Seconds to import numpy alone, and numpy then simbridge, in fresh interpreters."""
    code = (
        "import time; t0 = time.perf_counter(); import numpy; t1 = time.perf_counter(); "
        "{extra}; t2 = time.perf_counter(); print(t1 - t0, t2 - t0)"
    )
    base, full = [], []
    for _ in range(repeats):
        out = subprocess.run(
            [sys.executable, "-c", code.format(extra="import simbridge")],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.split()
        base.append(float(out[0]))
        full.append(float(out[1]))
    return base, full


def fmt(values: list[float], unit: str) -> str:
    scale = {"µs/step": 1e6, "µs/env-step": 1e6, "µs": 1e6, "ms": 1e3, "s": 1.0}[unit]
    med = statistics.median(values) * scale
    return f"{med:9.2f} ({min(values) * scale:.1f}..{max(values) * scale:.1f})"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--repeats", type=int, default=7, help="timed repeats per row (default 7)")
    parser.add_argument("--quick", action="store_true", help="fewer steps and calls (smoke run)")
    parser.add_argument("--backends", nargs="+", default=cases.BACKENDS, choices=cases.BACKENDS)
    args = parser.parse_args(argv)
    reps = max(1, args.repeats)
    scale = 0.1 if args.quick else 1.0

    rows: list[Row] = []
    for backend in args.backends:
        drive = cases.DRIVES[backend]
        raw, lay = interleave(drive.raw, drive.layer, reps)
        rows.append(
            Row(
                f"{backend}: r2d2 drive, 980 steps, velocity commands",
                "µs/step",
                [t / 980 for t in raw],
                [t / 980 for t in lay],
                drive.target,
            )
        )
        floor = cases.DAMPED_FLOOR if backend == "physx" else None
        if floor is not None:  # the raw code doing what PyBullet's link damping takes
            raw, lay = interleave(floor.raw, floor.layer, reps)
            rows.append(
                Row(
                    f"{backend}: same drive, raw applying PyBullet's link damping",
                    "µs/step",
                    [t / 980 for t in raw],
                    [t / 980 for t in lay],
                    floor.target,
                    "the floor: raw + 2 reads, 1 write per link",
                )
            )
        clamped = cases.CLAMPED_FLOOR if backend == "physx" else None
        if clamped is not None:  # and PyBullet's speed clamp: the layer's trajectory exactly
            same = "same" if cases.physx_floor_matches_layer() else "NOT the same"
            raw, lay = interleave(clamped.raw, clamped.layer, reps)
            row = Row(
                f"{backend}: same drive, raw with PyBullet's damping and speed clamp",
                "µs/step",
                [t / 980 for t in raw],
                [t / 980 for t in lay],
                clamped.target,
            )
            row.note = f"{row.verdict()}; the floor + the clamp: {same} end state, bit for bit"
            rows.append(row)
        bound = cases.BOUND_DRIVES[backend]
        raw, lay = interleave(bound.raw, bound.layer, reps)
        rows.append(
            Row(
                f"{backend}: same drive through a bound velocity command",
                "µs/step",
                [t / 980 for t in raw],
                [t / 980 for t in lay],
                bound.target,
            )
        )
        rec = cases.RECORDED_DRIVES[backend]
        raw, lay = interleave(rec.raw, rec.layer, reps)
        rows.append(
            Row(
                f"{backend}: same drive, recording base pose + wheel states",
                "µs/step",
                [t / 980 for t in raw],
                [t / 980 for t in lay],
                rec.target,
            )
        )
        for call in cases.single_calls(backend, int(2000 * scale) or 200):
            raw, lay = interleave(call.raw, call.layer, reps)
            rows.append(Row(f"{backend}: {call.name}", "µs", raw, lay, call.target, call.note))

    steps = int(980 * scale)
    for case in parallel.cases_for(args.backends, steps):
        raw, lay = interleave(case.raw, case.layer, max(1, reps // 2))
        per = parallel.WORLDS * steps
        rows.append(
            Row(
                case.name,
                "µs/env-step",
                [t / per for t in raw],
                [t / per for t in lay],
                case.target,
                case.note,
            )
        )

    base, full = import_times(max(3, reps))
    extra = [f - b for b, f in zip(base, full, strict=True)]
    rows.append(
        Row(
            "import simbridge after numpy (extra seconds)",
            "ms",
            base,
            full,
            None,
            f"extra {statistics.median(extra) * 1e3:.1f} ms (target <= 50 ms)",
        )
    )

    comp = cases.compare_end_to_end() if len(args.backends) > 1 else None
    if comp is not None:
        raw, lay = interleave(comp.raw, comp.layer, max(1, reps // 2))
        rows.append(
            Row(
                "compare r2d2 (two engines, record, diff) vs plain script",
                "s",
                raw,
                lay,
                comp.target,
                comp.note,
            )
        )

    print(
        f"# simbridge benchmark: {platform.node()} | {platform.processor() or platform.machine()}"
        f" | Python {platform.python_version()} | {cases.engine_versions()} | repeats {reps}"
    )
    print()
    head = "| unit | raw median (min..max) | simbridge median (min..max) | ratio | target | |"
    print(f"| {'case':<62} {head}")
    print(f"|{'-' * 64}|------|------|------|------|------|--|")
    for row in rows:
        target = f"{row.target:.2f}x" if row.target else "-"
        note = row.note or row.verdict()
        print(
            f"| {row.name:<62} | {row.unit} | {fmt(row.raw, row.unit)} "
            f"| {fmt(row.layer, row.unit)} | {row.ratio:5.3f} | {target} | {note} |"
        )
    return 0


if __name__ == "__main__":
    np.set_printoptions(precision=4)
    sys.exit(main())
