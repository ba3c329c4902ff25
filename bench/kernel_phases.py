"""Where a MuJoCo step of the layer goes: the compiled step loop timed phase by phase.

Compiles backends/mujoco/_mjkernel.c with its phase timers (-DSIMBRIDGE_KERNEL_TIMERS) into a
temporary folder (removed at exit), runs r2d2 driving on the plane (wheels at -100 rad/s,
10 N·m, from a resting start) through ``Sim("mujoco")`` on it, and prints the time per step
of each phase, beside raw ``mj_step`` on the same world with velocity actuators
(bench/cases.py's raw floor)::

    python bench/kernel_phases.py [--repeats 7]

Needs a C compiler; the installed package is not touched.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import subprocess
import sys
import sysconfig
import tempfile
import time

import mujoco
import numpy as np

import simbridge
from simbridge.backends.mujoco import kernel as mujoco_kernel
from simbridge.backends.mujoco.inspect import compiled

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import cases  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PHASES = [
    "mj_step1 (positions, velocities, rows)",
    "motor offsets, row hardening",
    "link damping",
    "mj_fwdActuation + mj_fwdAcceleration",
    "constraint solve (or exact motors)",
    "motor polish (exact rows)",
    "mj_checkAcc + mj_Euler",
]


def build(folder: str):  # type: ignore[no-untyped-def]
    include = os.path.join(os.path.dirname(mujoco.__file__), "include")
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    out = os.path.join(folder, "_mjkernel" + suffix)
    cc = (sysconfig.get_config_var("CC") or "cc").split()[0]
    cmd = [
        cc,
        "-O2",
        "-std=c11",
        "-shared",
        "-fPIC",
        "-DSIMBRIDGE_KERNEL_TIMERS",
        f"-I{include}",
        f"-I{sysconfig.get_paths()['include']}",
        os.path.join(ROOT, "backends", "mujoco", "_mjkernel.c"),
        "-o",
        out,
    ]
    subprocess.run(cmd, check=True)
    spec = importlib.util.spec_from_file_location("_mjkernel", out)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def world() -> tuple[simbridge.Sim, int]:
    sim = simbridge.Sim("mujoco")
    sim.load_urdf("plane.urdf")
    robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, cases.START_Z))
    return sim, robot


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    if mujoco_kernel.reason():
        print(f"the compiled loop is not in use: {mujoco_kernel.reason()}")
        return 1
    steps = 980
    with tempfile.TemporaryDirectory() as folder:
        module = build(folder)
        mujoco_kernel._state["class"] = module.Kernel  # noqa: SLF001 - the timed build
        phases, totals, raws = [], [], []
        for _ in range(args.repeats):
            sim, robot = world()
            try:
                m, d, _, _ = cases._mujoco_raw_model(sim, robot)  # noqa: SLF001
                d.ctrl[:] = -100.0
                m.actuator_forcerange[:] = [-10.0, 10.0]
                t0 = time.perf_counter()
                mujoco.mj_step(m, d, steps)
                raws.append((time.perf_counter() - t0) / steps * 1e6)
                sim.set_joint_velocity(robot, cases.WHEELS, -100.0, max_force=10.0)
                compiled(sim).kernel.timers()  # reset
                t0 = time.perf_counter()
                sim.step(steps)
                totals.append((time.perf_counter() - t0) / steps * 1e6)
                phases.append(np.array(compiled(sim).kernel.timers()) / steps / 1e3)
            finally:
                sim.close()
    med = np.median(np.array(phases), axis=0)
    print(
        f"# MuJoCo step phases, r2d2 driving on the plane, {steps} steps, medians of "
        f"{args.repeats} (µs per step)"
    )
    for name, value in zip(PHASES, med, strict=True):
        print(f"{name:42s} {value:7.2f}")
    print(f"{'sum of phases':42s} {med.sum():7.2f}")
    print(f"{'Sim.step(980), timed build':42s} {np.median(totals):7.2f}")
    print(f"{'raw mj_step, velocity actuators':42s} {np.median(raws):7.2f}")
    print(f"{'ratio':42s} {np.median(totals) / np.median(raws):7.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
