"""The largest model each backend takes: load and first-step times of chains of N links.

    python bench/limits.py                       # N = 100, 121, 500, 1000, 1022, 2000
    python bench/limits.py --sizes 100 500 --raw-max 500 --timeout 120

A chain of N revolute links (fixed base, one element a line, PyBullet's default motor on every
joint) is loaded and stepped once through ``Sim`` on each backend, and the same chain through
the raw engine (``p.loadURDF`` + ``p.stepSimulation``; ``MjSpec.compile`` + ``mj_step`` on a
chain of N hinged bodies with joint limits and friction loss, the rows the backend's brake
and limits make). Each measurement runs in a child process with a time limit (a raw PyBullet
step of a 2000-link chain takes minutes). What a backend refuses up front is a
BackendUnsupportedError from ``load_urdf``, timed too:

* PyBullet: at most 121 movable joints and 127 joints per body (past them its state reads fail
  or read 0: backends/pybullet_backend.py MAX_BODY_*);
* MuJoCo: joints nested at most 1022 deep (its compiler refuses a deeper body tree, after tens
  of seconds: backends/mujoco/backend.py MAX_TREE_DEPTH).

Timings on the shared machine are rough (seconds, one run each); their growth with N is the
point.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SIZES = (100, 121, 500, 1000, 1022, 2000)

LINK = (
    '<link name="l{i}"><inertial><mass value="0.1"/>'
    '<inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>'
)
JOINT = (
    '<joint name="j{i}" type="revolute"><parent link="l{p}"/><child link="l{i}"/>'
    '<origin xyz="0 0 0.01"/><axis xyz="0 1 0"/>'
    '<limit lower="-1" upper="1" effort="10" velocity="10"/></joint>'
)


def chain_urdf(n: int) -> str:
    lines = [f'<robot name="chain{n}">', LINK.format(i=0)]
    for i in range(1, n + 1):
        lines += [LINK.format(i=i), JOINT.format(i=i, p=i - 1)]
    return "\n".join([*lines, "</robot>"]) + "\n"


def measure(how: str, n: int) -> dict[str, object]:
    """One measurement, in this process: load (or compile) and one step, seconds."""
    t0 = time.perf_counter()
    if how in ("pybullet", "mujoco"):
        import simbridge
        from simbridge.exceptions import BackendUnsupportedError

        sim = simbridge.Sim(how)
        t0 = time.perf_counter()
        try:
            sim.load_urdf(chain_urdf(n), fixed_base=True)
        except BackendUnsupportedError as exc:
            return {"refused": time.perf_counter() - t0, "why": str(exc)}
        t1 = time.perf_counter()
        sim.step()
    elif how == "raw pybullet":
        import pybullet as p

        with tempfile.NamedTemporaryFile("w", suffix=".urdf", delete=False) as f:
            f.write(chain_urdf(n))
        c = p.connect(p.DIRECT)
        p.setGravity(0, 0, -9.8, physicsClientId=c)
        t0 = time.perf_counter()
        p.loadURDF(f.name, useFixedBase=True, physicsClientId=c)
        t1 = time.perf_counter()
        p.stepSimulation(physicsClientId=c)
        Path(f.name).unlink()
    else:
        import mujoco

        spec = mujoco.MjSpec()
        spec.option.timestep = 1 / 240
        body = spec.worldbody
        for i in range(n + 1):  # the root, welded to the world, then n hinged links
            body = body.add_body(pos=[0, 0, 0.01])
            body.add_geom(size=[0.01, 0, 0], mass=0.1)
            if i > 0:
                body.add_joint(
                    type=mujoco.mjtJoint.mjJNT_HINGE,
                    axis=[0, 1, 0],
                    range=[-1, 1],
                    limited=1,
                    frictionloss=240.0,
                )
        t0 = time.perf_counter()
        try:
            model = spec.compile()
        except ValueError as exc:
            return {"refused": time.perf_counter() - t0, "why": str(exc).splitlines()[0]}
        data = mujoco.MjData(model)
        t1 = time.perf_counter()
        mujoco.mj_step(model, data)
    return {"load": t1 - t0, "step": time.perf_counter() - t1}


def _cell(r: dict[str, object] | None) -> str:
    if r is None:
        return "not run"
    if "timeout" in r:
        return f"> {r['timeout']:.0f} s (stopped)"
    if "refused" in r:
        return f"refused in {r['refused']:.2f} s"
    return f"{r['load']:.3f} s, {r['step']:.4f} s"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--sizes", type=int, nargs="+", default=list(SIZES))
    parser.add_argument("--raw-max", type=int, default=500, help="largest raw PyBullet chain")
    parser.add_argument("--timeout", type=float, default=300.0, help="per measurement, s")
    parser.add_argument("--one", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.one:
        print(json.dumps(measure(args.one[0], int(args.one[1]))))
        return 0
    hows = ("pybullet", "raw pybullet", "mujoco", "raw mujoco")
    print("# simbridge limits: chains of N revolute links, fixed base; load, then one step\n")
    print("| N | PyBullet (Sim) | raw PyBullet | MuJoCo (Sim) | raw MuJoCo |")
    print("|------|------|------|------|------|")
    why: dict[str, str] = {}
    for n in args.sizes:
        cells = []
        for how in hows:
            if how == "raw pybullet" and n > args.raw_max:
                cells.append(_cell(None))
                continue
            try:
                child = subprocess.run(
                    [sys.executable, __file__, "--one", how, str(n)],
                    capture_output=True,
                    text=True,
                    timeout=args.timeout,
                )
                r = json.loads(child.stdout.strip().splitlines()[-1])
            except subprocess.TimeoutExpired:
                r = {"timeout": args.timeout}
            if "why" in r:
                why.setdefault(how, str(r["why"]))
            cells.append(_cell(r))
        print(f"| {n} | " + " | ".join(cells) + " |", flush=True)
    for how, text in why.items():
        print(f"\n{how} refuses: {text}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
