"""N environments on this machine's cores: raw engine code against the layer, per env-step.

../shared/PERFORMANCE.md's targets: MuJoCo at least 0.9x ``mujoco.rollout``/``mujoco.batch`` on
the same model, PyBullet at least 0.9x two plain processes. Each case runs ``WORLDS`` r2d2
worlds from the resting start (bench/cases.py) for ``steps`` steps each and returns the
wall-clock seconds of the stepping alone (worlds are built before the clock starts; in the
process cases every worker builds its worlds, waits at a barrier, and the time runs from the
first worker's start to the last one's end, on the machine-wide monotonic clock).

* MuJoCo, open loop, 2 threads: raw ``mujoco.rollout`` (a constant ``ctrl``: the wheels at
  -100 rad/s, 10 N·m, one ``MjData`` per thread) against the layer's Sims stepped by
  ``Sim.step(steps)`` in two threads (the compiled loop releases the GIL; the command
  persists, as a constant ctrl does).
* MuJoCo and PyBullet, a command every step, 2 processes: each process drives its share of the
  worlds through the tutorial's schedule (bench/cases.py's drive: settle, turn at 50 N·m,
  forward at 10 N·m), ``d.ctrl[:] = a; mj_step`` or ``setJointMotorControlArray;
  stepSimulation`` against ``set_joint_velocity; step``. Python threads do not help here:
  every step hands the GIL over.
"""

from __future__ import annotations

import multiprocessing as mp
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import cases
import numpy as np

WORLDS = 8
WORKERS = 2  # the cores of this project's machines


# ---------------------------------------------------------------- MuJoCo open loop


def mujoco_rollout(steps: int) -> float:
    import mujoco
    from mujoco import rollout

    sim, robot = cases._layer_sim("mujoco")  # noqa: SLF001
    try:
        m, d, _, _ = cases._mujoco_raw_model(sim, robot)  # noqa: SLF001
    finally:
        sim.close()
    kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty((WORLDS, mujoco.mj_stateSize(m, kind)))
    for i in range(WORLDS):
        mujoco.mj_getState(m, d, state[i], kind)
    control = np.tile(cases.FORWARD, (WORLDS, steps, 1))
    datas = [mujoco.MjData(m) for _ in range(WORKERS)]
    t0 = time.perf_counter()
    rollout.rollout([m] * WORLDS, datas, state, control)
    return time.perf_counter() - t0


def layer_threads(steps: int) -> float:
    worlds = [cases._layer_sim("mujoco") for _ in range(WORLDS)]  # noqa: SLF001
    try:
        for sim, robot in worlds:
            sim.set_joint_velocity(robot, cases.WHEELS, cases.FORWARD, max_force=10.0)

        def run(group: list) -> None:
            for sim, _ in group:
                sim.step(steps)

        groups = [worlds[i::WORKERS] for i in range(WORKERS)]
        with ThreadPoolExecutor(WORKERS) as pool:
            t0 = time.perf_counter()
            list(pool.map(run, groups))
            return time.perf_counter() - t0
    finally:
        for sim, _ in worlds:
            sim.close()


# ---------------------------------------------------------------- a command every step, processes


def _raw_mujoco_worker(n: int, steps: int) -> Callable[[], None]:
    import mujoco

    sims = [cases._layer_sim("mujoco") for _ in range(n)]  # noqa: SLF001
    pairs = []
    for sim, robot in sims:
        m, d, _, _ = cases._mujoco_raw_model(sim, robot)  # noqa: SLF001
        pairs.append((m, d))
        sim.close()
    step = mujoco.mj_step

    def run() -> None:
        for k in range(steps):
            command = cases.drive_command(k)
            if k == cases.FORWARD_FROM:
                for m, _ in pairs:
                    m.actuator_forcerange[:] = [-10.0, 10.0]
            for m, d in pairs:
                if command is not None:
                    d.ctrl[:] = command[0]
                step(m, d)

    return run


def _raw_pybullet_worker(n: int, steps: int) -> Callable[[], None]:
    import pybullet as p
    import pybullet_data

    worlds = []
    for _ in range(n):
        c = p.connect(p.DIRECT)
        p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=c)
        p.setGravity(0, 0, -9.8, physicsClientId=c)  # the layer's default, as in cases.py
        p.loadURDF("plane.urdf", physicsClientId=c)
        robot = p.loadURDF("r2d2.urdf", [0, 0, cases.START_Z], physicsClientId=c)
        worlds.append((c, robot))
    schedule = [cases.drive_command(k) for k in range(steps)]
    schedule = [(c[0].tolist(), [c[1]] * 4) if c else None for c in schedule]

    def run() -> None:
        for command in schedule:
            for c, robot in worlds:
                if command is not None:
                    p.setJointMotorControlArray(
                        robot,
                        cases.WHEELS,
                        p.VELOCITY_CONTROL,
                        targetVelocities=command[0],
                        forces=command[1],
                        physicsClientId=c,
                    )
                p.stepSimulation(physicsClientId=c)

    return run


def _layer_worker(backend: str, n: int, steps: int) -> Callable[[], None]:
    worlds = [cases._layer_sim(backend) for _ in range(n)]  # noqa: SLF001
    wheels = np.array(cases.WHEELS)
    schedule = [cases.drive_command(k) for k in range(steps)]

    def run() -> None:
        for command in schedule:
            for sim, robot in worlds:
                if command is not None:
                    sim.set_joint_velocity(robot, wheels, command[0], max_force=command[1])
                sim.step()

    return run


def _worker(kind: str, n: int, steps: int, barrier, out) -> None:  # type: ignore[no-untyped-def]
    if kind == "raw mujoco":
        run = _raw_mujoco_worker(n, steps)
    elif kind == "raw pybullet":
        run = _raw_pybullet_worker(n, steps)
    else:
        run = _layer_worker(kind, n, steps)
    barrier.wait()
    t0 = time.perf_counter()
    run()
    out.put((t0, time.perf_counter()))


def in_processes(kind: str, steps: int) -> float:
    """``WORLDS`` worlds split over ``WORKERS`` processes; the seconds from the first worker's
    start to the last one's end (set-up excluded)."""
    ctx = mp.get_context("fork")
    barrier = ctx.Barrier(WORKERS)
    out = ctx.Queue()
    share = [WORLDS // WORKERS + (i < WORLDS % WORKERS) for i in range(WORKERS)]
    procs = [ctx.Process(target=_worker, args=(kind, k, steps, barrier, out)) for k in share]
    for proc in procs:
        proc.start()
    spans = [out.get(timeout=600) for _ in procs]
    for proc in procs:
        proc.join()
        if proc.exitcode:
            raise RuntimeError(f"a {kind} worker ended with exit code {proc.exitcode}")
    return max(e for _, e in spans) - min(s for s, _ in spans)


def cases_for(backends: list[str], steps: int) -> list[cases.Case]:
    """The N-environment rows: each callable returns seconds for ``WORLDS * steps`` env-steps."""
    out = []
    target = 1 / 0.9  # at least 0.9x the raw throughput, as time per env-step
    if "mujoco" in backends:
        out.append(
            cases.Case(
                f"mujoco: {WORLDS} worlds, 2 threads, open loop (rollout)",
                lambda: mujoco_rollout(steps),
                lambda: layer_threads(steps),
                target,
            )
        )
        out.append(
            cases.Case(
                f"mujoco: {WORLDS} worlds, 2 processes, command every step",
                lambda: in_processes("raw mujoco", steps),
                lambda: in_processes("mujoco", steps),
                target,
            )
        )
    if "pybullet" in backends:
        out.append(
            cases.Case(
                f"pybullet: {WORLDS} worlds, 2 processes, command every step",
                lambda: in_processes("raw pybullet", steps),
                lambda: in_processes("pybullet", steps),
                target,
            )
        )
    return out
