"""What the divergence check costs a step: raw step, raw step + the check, and the layer's step
with and without it, side by side in one run.

    python bench/divergence.py                 # r2d2 on the plane, a fixed KUKA iiwa
    python bench/divergence.py --quick --repeats 3

PyBullet keeps a NaN state and steps on, so the PyBullet backend checks for it itself: every
state read checks the numbers it returns (a few float additions: no read hands out a NaN), and
every body is probed with one engine call (a free base's pose, a fixed base's movable leaf
joints) after every 8th step and after the first step after a load, a teleport or a restore.
The table gives, per world, the fastest of many short repeats (the least disturbed: on a shared
machine a median moves by 10 % between runs) and the median; the columns of a repeat run back to
back on identical worlds, in a rotating order, so the machine's load falls on all of them alike:

* raw: ``p.stepSimulation`` alone;
* raw + probe: the same and the backend's probe after every step (what checking at every step
  would cost);
* layer, no check: ``Sim.step()`` with the probe switched off (reads still check themselves);
* layer: ``Sim.step()`` as shipped (probe every 8th step); the ratio to "no check" is the
  check's cost (target: at most 1.02);
* layer, every step: ``Sim.step()`` under ``Sim(divergence_check="every_step")`` (a probe
  after every step: the step that diverged raises); measured 1.01-1.09x a step on PyBullet
  (the figure the Sim's ``divergence_check`` docstring gave until issue 32 moved it here);
* step(n): one ``Sim.step(n)`` call per block, without the probe and as shipped (it probes
  inside the call every 8th step).

Figures behind the PyBullet backend's rules (backends/pybullet/backend.py ``_CHECK_EVERY``,
``_probe``; backends/pybullet/common.py ``_finite_base``), measured with this script: a probe
costs 0.6-1.5 µs per body, 5-10 % of a fixed KUKA's 11-16 µs step if taken at every step; one
in 8 steps is under 2 %. Timed apart from this script's table: the probe's hot path (a sum of
the numbers) 0.9 µs for one body; a base state's 13 numbers summed by explicit additions
0.15 µs, by ``sum()`` 0.3 µs.

MuJoCo needs no probe of the layer's: ``mj_step`` checks positions, velocities and accelerations
itself (mj_checkPos, mj_checkVel, mj_checkAcc, in raw MuJoCo too: a bad value warns and resets
the state), and the compiled step loop reads MuJoCo's warning counters once per call, which the
backend turns into SimulationDivergedError.
"""

from __future__ import annotations

import argparse
import functools
import math
import platform
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import pybullet as p
import pybullet_data

import simbridge
from simbridge.backends.pybullet.inspect import set_check_every

DATA = Path(pybullet_data.getDataPath())


def _raw_world(world: str) -> tuple[int, int, list[int]]:
    """A raw PyBullet client with the world loaded and settled: (client, body, probe joints;
    empty for a free base)."""
    c = p.connect(p.DIRECT)
    p.setGravity(0, 0, -9.8, physicsClientId=c)
    p.setTimeStep(1 / 240, physicsClientId=c)
    if world == "r2d2":
        p.loadURDF(str(DATA / "plane.urdf"), physicsClientId=c)
        body = p.loadURDF(str(DATA / "r2d2.urdf"), (0, 0, 0.5), physicsClientId=c)
        leaves: list[int] = []
    else:
        body = p.loadURDF(str(DATA / "kuka_iiwa/model.urdf"), useFixedBase=True, physicsClientId=c)
        p.setJointMotorControlArray(
            body,
            list(range(7)),
            p.POSITION_CONTROL,
            targetPositions=[0.3] * 7,
            forces=[300.0] * 7,
            physicsClientId=c,
        )
        leaves = [6]
    for _ in range(240):
        p.stepSimulation(physicsClientId=c)
    return c, body, leaves


def _sim_world(world: str, every: int | None) -> simbridge.Sim:
    """The world in a Sim: probed every ``every``-th step, or under
    ``divergence_check="every_step"`` (None: the option a user sets)."""
    sim = simbridge.Sim("pybullet", divergence_check="every_step" if every is None else "periodic")
    if world == "r2d2":
        sim.load_urdf("plane.urdf")
        sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
    else:
        body = sim.load_urdf("kuka_iiwa/model.urdf", fixed_base=True)
        sim.set_joint_position(body, list(range(7)), 0.3, max_force=300.0)
    sim.step(240)
    if every is not None:
        set_check_every(sim, every)
    return sim


def columns(world: str, steps: int) -> dict[str, Callable[[], float]]:
    """The timed loops of one world: each returns seconds per step."""
    c1, _, _ = _raw_world(world)
    c2, body2, leaves2 = _raw_world(world)
    off = _sim_world(world, 10**12)
    shipped = _sim_world(world, 8)
    every = _sim_world(world, None)

    def raw() -> float:
        t0 = time.perf_counter()
        for _ in range(steps):
            p.stepSimulation(physicsClientId=c1)
        return (time.perf_counter() - t0) / steps

    def raw_probe() -> float:
        t0 = time.perf_counter()
        for _ in range(steps):
            p.stepSimulation(physicsClientId=c2)
            if leaves2:
                for r in p.getJointStates(body2, leaves2, c2):
                    if not math.isfinite(r[0] + r[1] + r[3]):
                        raise FloatingPointError
            else:
                pos, orn = p.getBasePositionAndOrientation(body2, c2)
                if not math.isfinite(sum(pos) + sum(orn)):
                    raise FloatingPointError
        return (time.perf_counter() - t0) / steps

    def layer(sim: simbridge.Sim) -> Callable[[], float]:
        def run() -> float:
            t0 = time.perf_counter()
            for _ in range(steps):
                sim.step()
            return (time.perf_counter() - t0) / steps

        return run

    def layer_n(sim: simbridge.Sim) -> Callable[[], float]:
        def run() -> float:
            t0 = time.perf_counter()
            sim.step(steps)
            return (time.perf_counter() - t0) / steps

        return run

    return {
        "raw": raw,
        "raw + probe": raw_probe,
        "layer, no check": layer(off),
        "layer": layer(shipped),
        "layer, every step": layer(every),
        "step(n), no check": layer_n(off),
        "step(n)": layer_n(shipped),
    }


def _cell(fast: dict[str, float], mid: dict[str, float], name: str, base: str | None = None) -> str:
    """A column: fastest (median) µs, and the ratio to ``base`` alike."""
    text = f"{fast[name]:.2f} ({mid[name]:.2f})"
    if base is not None:
        text += f" | {fast[name] / fast[base]:.3f} ({mid[name] / mid[base]:.3f})"
    return text


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--repeats", type=int, default=101)
    parser.add_argument("--steps", type=int, default=120, help="steps per timed block")
    parser.add_argument("--quick", action="store_true", help="20-step blocks (a smoke run)")
    args = parser.parse_args(argv)
    steps = 20 if args.quick else args.steps
    print(
        f"# simbridge divergence check: {platform.node()} | Python {platform.python_version()} | "
        f"pybullet {p.getAPIVersion()} | {args.repeats} repeats of {steps} steps: fastest "
        "(median)\n"
    )
    print(
        "| world | raw µs | raw + probe µs | ratio | layer, no check µs | layer µs | ratio "
        "| layer, every step µs | ratio | step(n), no check µs | step(n) µs | ratio |"
    )
    print("|------|------|------|------|------|------|------|------|------|------|------|------|")
    for world, label in (("r2d2", "r2d2 resting on the plane"), ("kuka", "KUKA, fixed")):
        cols = columns(world, steps)
        times: dict[str, list[float]] = {name: [] for name in cols}
        order = list(cols)
        for k in range(args.repeats):
            for name in order[k % len(order) :] + order[: k % len(order)]:
                times[name].append(cols[name]())
        fast = {name: min(v) * 1e6 for name, v in times.items()}
        mid = {name: statistics.median(v) * 1e6 for name, v in times.items()}
        cell = functools.partial(_cell, fast, mid)
        print(
            f"| {label} | {cell('raw')} | {cell('raw + probe', 'raw')} "
            f"| {cell('layer, no check')} | {cell('layer', 'layer, no check')} "
            f"| {cell('layer, every step', 'layer, no check')} "
            f"| {cell('step(n), no check')} | {cell('step(n)', 'step(n), no check')} |"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
