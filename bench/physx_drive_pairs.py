"""The PhysX drive, the layer against its floor, step by step in pairs.

    python bench/physx_drive_pairs.py              # 5 drives of 980 paired steps
    python bench/physx_drive_pairs.py --runs 9

bench/run.py times whole drives, raw then layer; on a shared machine whose load moves by the
second, two drives a second apart see different loads and the ratio wanders by 10-20 %. Here
the two worlds are stepped in turn, one step each (the order swapped every step), each step
timed alone: a step of one and its twin of the other are a millisecond apart. The floor is raw
SAPIEN doing what the layer does at each step (``set_drive_velocity_target`` per wheel where
the schedule commands, PyBullet's link damping law, ``scene.step()``, PyBullet's speed clamp:
bench/cases.py ``physx_raw_drive(..., pybullet_damping=True, speed_clamp=True)``), so both
worlds compute the same trajectory, bit for bit (checked at the end of every drive): the
engine's work is the same at every step, and what differs is the layer's Python.

Prints, per drive, the sum of the layer's step times over the floor's and the median of the
per-step ratios; then the median over drives, and of the per-step differences in µs.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import cases  # noqa: E402  (bench/cases.py: the drive's schedule and worlds)


def paired_drive() -> tuple[np.ndarray, np.ndarray, bool]:
    """One drive of 980 steps in both worlds: (floor's step times, layer's, same end state)."""
    clock = time.perf_counter_ns
    lay_sim, lay_robot = cases._layer_sim("physx")
    raw_sim, raw_robot = cases._layer_sim("physx")
    try:
        raw_step, _ = cases.physx_raw_stepper(raw_sim, raw_robot, True, True)
        wheels = np.array(cases.WHEELS)
        raw_t = np.empty(980)
        lay_t = np.empty(980)

        def layer_step(k: int) -> None:
            if k >= cases.TURN_FROM:
                if k < cases.FORWARD_FROM:
                    lay_sim.set_joint_velocity(lay_robot, wheels, cases.TURN, max_force=50.0)
                else:
                    lay_sim.set_joint_velocity(lay_robot, wheels, cases.FORWARD, max_force=10.0)
            lay_sim.step()

        for k in range(980):
            if k % 2:
                t0 = clock()
                raw_step(k)
                t1 = clock()
                layer_step(k)
                t2 = clock()
                raw_t[k], lay_t[k] = t1 - t0, t2 - t1
            else:
                t0 = clock()
                layer_step(k)
                t1 = clock()
                raw_step(k)
                t2 = clock()
                lay_t[k], raw_t[k] = t1 - t0, t2 - t1
        a = cases.physx_final_state(raw_sim, raw_robot)
        b = cases.physx_final_state(lay_sim, lay_robot)
        same = all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
        return raw_t / 1e3, lay_t / 1e3, same
    finally:
        raw_sim.close()
        lay_sim.close()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--runs", type=int, default=5, help="paired drives (default 5)")
    args = parser.parse_args(argv)
    paired_drive()  # warm up
    sums, medians, diffs = [], [], []
    print(f"load average before: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")
    print("| drive | floor µs/step | layer µs/step | sum ratio | median step ratio | same |")
    print("|---|---|---|---|---|---|")
    for i in range(max(1, args.runs)):
        raw, lay, same = paired_drive()
        sums.append(lay.sum() / raw.sum())
        medians.append(float(np.median(lay / raw)))
        diffs.append(float(np.median(lay - raw)))
        print(
            f"| {i + 1} | {raw.mean():.1f} | {lay.mean():.1f} | {sums[-1]:.3f} "
            f"| {medians[-1]:.3f} | {'bit for bit' if same else 'DIFFERENT'} |"
        )
    print(f"load average after: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")
    print(
        f"layer / floor: sum ratio median {statistics.median(sums):.3f} "
        f"({min(sums):.3f}..{max(sums):.3f}); median step ratio {statistics.median(medians):.3f} "
        f"({min(medians):.3f}..{max(medians):.3f}); the layer's extra "
        f"{statistics.median(diffs):.1f} µs a step (median over drives of the median step)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
