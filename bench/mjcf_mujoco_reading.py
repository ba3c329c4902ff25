"""Gymnasium's ant and half cheetah read as MuJoCo reads them (``semantics="mujoco"``) on
MuJoCo, PyBullet and PhysX, against raw MuJoCo and raw MuJoCo with one setting changed: the
figures of docs/mjcf_mujoco_reading.md.

1. **standing**: the ant, zero controls, from ``qpos0`` (Gymnasium's ``init_qpos``, no reset
   noise): the torso's height after 0.5, 5 and 30 s;
2. **in the air**: the ant with gravity 0 (no contact ever), an actuator pattern
   ``ctrl_i = sin(2 pi t + i)`` for 1 s: the joints' RMS angle difference against raw MuJoCo
   (RK4, the file's) and raw MuJoCo under Euler; PyBullet also with its armature force turned
   off (``armature 0``), which measures what that force buys;
3. **running**: the half cheetah under the same pattern for 5 s: its x, height and pitch;
4. **every model of gymnasium's MuJoCo tasks** under ``0.5 sin(2 pi t + i)`` for 2 s: the
   first three coordinates of ``qpos`` on each engine, or the refusal;
5. **an ellipsoid** (radii 0.2, 0.1, 0.05 m, 1 kg) dropped from 0.3 m: its rest height after
   2 s (MuJoCo's true ellipsoid against the engines' hull of points on it);
6. the cost of a step (printed with 1).

::

    .venv/bin/python bench/mjcf_mujoco_reading.py
"""

from __future__ import annotations

import importlib.util
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

import simbridge

ENGINES = ("mujoco", "pybullet", "physx")


def asset(name: str) -> str:
    """The path of one of gymnasium's MuJoCo models."""
    spec = importlib.util.find_spec("gymnasium")
    assert spec is not None and spec.origin is not None, "pip install 'gymnasium[mujoco]'"
    return str(Path(spec.origin).parent / "envs" / "mujoco" / "assets" / name)


def pattern(t: float, nu: int) -> np.ndarray:
    """The fixed actuator pattern: ctrl_i = sin(2 pi t + i)."""
    return np.sin(2.0 * np.pi * t + np.arange(nu))


def raw(path: str, change: Callable[[Any], None] | None = None) -> tuple[Any, Any]:
    """Raw MuJoCo's model and data, one setting changed."""
    m = mujoco.MjModel.from_xml_path(path)
    if change is not None:
        change(m)
    return m, mujoco.MjData(m)


def standing() -> None:
    """The ant's torso height, zero controls."""
    path, marks = asset("ant.xml"), (50, 500, 3000)
    print("1. ant, zero controls, torso z (m) after 0.5 / 5 / 30 s")

    def run_raw(label: str, change: Callable[[Any], None] | None) -> None:
        m, d = raw(path, change)
        out = []
        for n in marks:
            mujoco.mj_step(m, d, nstep=n - round(d.time / m.opt.timestep))
            out.append(float(d.qpos[2]))
        print(f"   raw MuJoCo {label:28s}" + "".join(f"{z:9.4f}" for z in out))

    run_raw("(the file's: RK4)", None)
    run_raw("integrator Euler", lambda m: setattr(m.opt, "integrator", 0))
    run_raw("geom margin 0", lambda m: m.geom_margin.__setitem__(slice(None), 0.0))
    run_raw("Euler, margin 0", lambda m: (setattr(m.opt, "integrator", 0),
                                          m.geom_margin.__setitem__(slice(None), 0.0)))  # fmt: skip
    for engine in ENGINES:
        with simbridge.Sim(engine) as sim:
            sim.load_mjcf(path, semantics="mujoco")
            out, t0 = [], time.perf_counter()
            for n in marks:
                sim.step(n - round(sim.time / 0.01))
                out.append(float(sim.qpos()[2]))
            us = (time.perf_counter() - t0) / marks[-1] * 1e6
        print(f"   {engine:39s}" + "".join(f"{z:9.4f}" for z in out) + f"   {us:6.0f} us/step")
    print("   the same, the torso placed 1e-9, -1e-9, 2e-9 and 1e-8 m higher: range of each figure")
    for engine in ENGINES:
        runs = []
        for eps in (1e-9, -1e-9, 2e-9, 1e-8):
            with simbridge.Sim(engine) as sim:
                sim.load_mjcf(path, semantics="mujoco")
                q = sim.qpos()
                q[2] += eps
                sim.set_qpos_qvel(q, None)
                heights = []
                for n in marks:
                    sim.step(n - round(sim.time / 0.01))
                    heights.append(float(sim.qpos()[2]))
                runs.append(heights)
        lo, hi = np.min(runs, axis=0), np.max(runs, axis=0)
        print(
            f"   {engine:39s}" + "".join(f"  {a:.3f}-{b:.3f}" for a, b in zip(lo, hi, strict=True))
        )


def _air_run(step: Callable[[np.ndarray], np.ndarray], nu: int, steps: int) -> np.ndarray:
    out = []
    for k in range(steps):
        out.append(step(pattern(k * 0.01, nu)))
    return np.array(out)


def in_the_air() -> None:
    """The ant's joints under the pattern, no contact: RMS angle differences (rad)."""
    path, steps = asset("ant.xml"), 100
    print("2. ant in the air (gravity 0), pattern for 1 s: joints' RMS angle difference (rad)")
    refs = {}
    for label, integ in (("RK4", None), ("Euler", 0)):

        def change(m: Any, i: int | None = integ) -> None:
            m.opt.gravity[:] = 0.0
            if i is not None:
                m.opt.integrator = i

        m, d = raw(path, change)
        d.qpos[2] = 5.0

        def step(ctrl: np.ndarray, m: Any = m, d: Any = d) -> np.ndarray:
            d.ctrl[:] = ctrl
            mujoco.mj_step(m, d)
            return d.qpos[7:].copy()

        refs[label] = _air_run(step, m.nu, steps)
    print(f"   MuJoCo RK4 vs Euler: {np.sqrt(np.mean((refs['RK4'] - refs['Euler']) ** 2)):.4f}")
    for engine, no_armature in (("mujoco", False), ("pybullet", False), ("pybullet", True),
                                ("physx", False)):  # fmt: skip
        with simbridge.Sim(engine, gravity=(0.0, 0.0, 0.0)) as sim:
            sim.load_mjcf(path, semantics="mujoco")
            if no_armature:
                from simbridge.backends.pybullet.inspect import mjcf_world

                mjcf_world(sim).m.dof_armature[:] = 0.0
            q0 = sim.qpos()
            q0[2] = 5.0
            sim.set_qpos_qvel(q0, np.zeros(len(sim.qvel())))

            def step(ctrl: np.ndarray, sim: Any = sim) -> np.ndarray:
                sim.set_actuator_controls(ctrl)
                sim.step(1)
                return sim.qpos()[7:]

            try:
                got = _air_run(step, len(sim.actuators()), steps)
                errs = [np.sqrt(np.mean((got - refs[k]) ** 2)) for k in ("RK4", "Euler")]
                text = f"vs RK4 {errs[0]:.4f}   vs Euler {errs[1]:.4f}"
            except simbridge.exceptions.SimulationDivergedError as exc:
                text = f"diverged ({exc})"
        label = engine + (" (armature force off)" if no_armature else "")
        print(f"   {label:32s} {text}")


def running() -> None:
    """The half cheetah under the pattern: x, z and pitch after 1 and 5 s."""
    path = asset("half_cheetah.xml")
    print("3. half cheetah, pattern: (rootx m, rootz m, rooty rad) after 1 s and after 5 s")
    for engine in ENGINES:
        with simbridge.Sim(engine) as sim:
            sim.load_mjcf(path, semantics="mujoco")
            marks = []
            for k in range(500):
                sim.set_actuator_controls(pattern(k * 0.01, 6))
                sim.step(1)
                if k + 1 in (100, 500):
                    marks.append(tuple(round(float(v), 3) for v in sim.qpos()[:3]))
        print(f"   {engine:9s} {marks[0]}  {marks[1]}")


def corpus() -> None:
    """Every gymnasium MuJoCo model, 2 s of a small pattern, on the three engines."""
    folder = Path(asset("ant.xml")).parent
    print("4. gymnasium's models, 0.5 sin(2 pi t + i) for 2 s: qpos[:3], or the refusal")
    for path in sorted(folder.glob("*.xml")):
        row = [f"   {path.name:29s}"]
        for engine in ENGINES:
            try:
                with simbridge.Sim(engine) as sim:
                    sim.load_mjcf(path, semantics="mujoco")
                    nu = len(sim.actuators())
                    for k in range(200):
                        sim.set_actuator_controls(0.5 * pattern(k * 0.01, nu))
                        sim.step(1)
                    row.append(f"{engine} {np.round(sim.qpos()[:3], 2).tolist()}")
            except simbridge.exceptions.SimbridgeError as exc:
                row.append(f"{engine} {type(exc).__name__}: {str(exc)[:70]}")
        print(" | ".join(row))


ELLIPSOID = """<mujoco><option timestep="0.002"/><worldbody><geom type="plane" size="5 5 0.1"/>
<body name="e" pos="0 0 0.3"><freejoint/><geom type="ellipsoid" size="0.2 0.1 0.05" mass="1"/>
</body></worldbody></mujoco>"""


def ellipsoid() -> None:
    """An ellipsoid's rest height on each engine."""
    print("5. ellipsoid (0.2, 0.1, 0.05 m) dropped from 0.3 m: centre height after 2 s (m)")
    for engine in ENGINES:
        with simbridge.Sim(engine) as sim:
            sim.load_mjcf(ELLIPSOID, semantics="mujoco")
            sim.step(1000)
            print(f"   {engine:9s} {float(sim.qpos()[2]):.5f}")


if __name__ == "__main__":
    standing()
    in_the_air()
    running()
    corpus()
    ellipsoid()
