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
  or read 0: backends/pybullet/backend.py MAX_BODY_*);
* MuJoCo: joints nested at most 1022 deep (its compiler refuses a deeper body tree, after tens
  of seconds: backends/mujoco/backend.py MAX_TREE_DEPTH).

Timings on the shared machine are rough (seconds, one run each); their growth with N is the
point.

``--joint-limits`` times something else: robots whose joints rest on their limits against the
same robots off them (no slow step at a limit, issue 19)::

    python bench/limits.py --joint-limits [--repeats 3] [--inner 5] [--quick]

Each case is one robot under position motors (100 N m, kp 0.1, kd 1), fixed base, no ground,
stepped 480 times from its command; the first 240 steps (the drive there) and the next 240
(resting) are timed apart, per step, in CPU time of the stepping thread (the machine is
shared: wall time counts other processes' turns), each window run again from its saved state
(``get_state``/``set_state``), the fastest of at least ``--inner`` runs and 0.5 s. *On its
limits*: talos_full_v2 held at its default pose (its 14 gripper joints and 2 knees rest on a
limit there, two shoulder targets lie past one), the arms and legs driven with every joint's
target past a limit (upper, lower, upper...: the motor clamps it to the limit). *Off*: the same
robot held at the middle of every joint's range (talos, reset there), or driven to a quarter
and three quarters of each range. MuJoCo on-limit against off-limit, and MuJoCo against
PyBullet on-limit, are taken in the same run, the cases interleaved, medians of the repeats;
the machine is shared, so compare the ratios. talos, ur5 and solo12 come from the PyPI package
``example-robot-data`` (``pip install example-robot-data``; skipped without it), the KUKA iiwa
and the Panda from pybullet_data.
"""

from __future__ import annotations

import argparse
import json
import math
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


# --joint-limits: (name, robot, how): a robot name in example-robot-data's robots/ folder
# ("erd:") or on simbridge's search path; "hold": held at its default pose on its limits
# against held mid-range; "drive": driven past every limit against driven inside the range
JOINT_LIMIT_CASES = (
    ("talos_full_v2, hold", "erd:talos_data/robots/talos_full_v2.urdf", "hold"),
    ("KUKA iiwa, driven", "kuka_iiwa/model.urdf", "drive"),
    ("Panda, driven", "franka_panda/panda.urdf", "drive"),
    ("ur5, driven", "erd:ur_description/urdf/ur5_robot.urdf", "drive"),
    ("solo12, driven", "erd:solo_description/robots/solo12.urdf", "drive"),
    ("talos_full_v2, driven", "erd:talos_data/robots/talos_full_v2.urdf", "drive"),
)
LIMIT_STEPS = 240  # per timed window


def _robot_path(robot: str) -> str | None:
    """A case's URDF: a path into example-robot-data's robots (None without the package), or
    the name as it is (found on simbridge's search path)."""
    if not robot.startswith("erd:"):
        return robot
    from importlib import metadata

    try:
        dist = metadata.distribution("example-robot-data")
    except metadata.PackageNotFoundError:
        return None
    path = Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))
    path = path / robot[4:]
    return str(path) if path.is_file() else None


def limit_run(
    backend: str, urdf: str, how: str, on: bool, inner: int, least: float = 0.5
) -> tuple[float, float, int]:
    """One run: (s per step over the first window, over the second, each the fastest of at
    least ``inner`` runs of it (and ``least`` s of runs) from its start state (``get_state``/
    ``set_state``), and the joints within 1e-3 of a limit at the end)."""
    import numpy as np

    import simbridge

    with simbridge.Sim(backend) as sim:
        body = sim.load_urdf(urdf, fixed_base=True)
        table = [t for t in sim.joints(body) if t.type in (0, 1) and t.upper_limit > t.lower_limit]
        joints = [t.index for t in table]
        lo = np.array([t.lower_limit for t in table])
        hi = np.array([t.upper_limit for t in table])
        even = np.arange(len(table)) % 2 == 0
        if how == "hold":
            target = np.zeros(len(table)) if on else 0.5 * (lo + hi)
            if not on:
                sim.reset_joint_state(body, joints, target)
        elif on:
            target = np.where(even, hi + 0.2, lo - 0.2)
        else:
            target = np.where(even, lo + 0.75 * (hi - lo), lo + 0.25 * (hi - lo))
        sim.set_joint_position(body, joints, target, max_force=100.0)
        best = []
        for _ in range(2):  # each window from its start state, fastest of `inner`
            start = sim.get_state()
            fastest, spent, runs = math.inf, 0.0, 0
            # at least `inner` runs and 0.5 s of them: a window of a small robot takes 2 ms,
            # which one preemption on a shared machine makes 10 times longer
            while runs < inner or (spent < least and runs < 200):
                sim.set_state(start)
                t0 = time.thread_time()  # CPU time: a shared machine's waits are not counted
                sim.step(LIMIT_STEPS)
                took = time.thread_time() - t0
                fastest, spent, runs = min(fastest, took), spent + took, runs + 1
            best.append(fastest / LIMIT_STEPS)
        q = sim.joint_states(body, joints).positions
        at = int((np.minimum(np.abs(q - lo), np.abs(q - hi)) < 1e-3).sum())
    return best[0], best[1], at


def joint_limits(repeats: int, inner: int, quick: bool = False) -> int:
    """The --joint-limits table (module docstring)."""
    import statistics

    cases = [(name, _robot_path(robot), how) for name, robot, how in JOINT_LIMIT_CASES]
    if quick:
        cases = [c for c in cases if c[0].startswith(("KUKA", "Panda"))]
    missing = [name for name, path, _ in cases if path is None]
    cases = [(name, path, how) for name, path, how in cases if path is not None]
    runs = [(be, on) for be in ("mujoco", "pybullet") for on in (True, False)]
    times: dict[tuple[str, str, bool, int], list[float]] = {}
    at: dict[tuple[str, str, bool], int] = {}
    for _ in range(repeats):
        for name, path, how in cases:
            assert path is not None
            for be, on in runs:
                first, second, n_at = limit_run(be, path, how, on, inner, 0.0 if quick else 0.5)
                times.setdefault((name, be, on, 0), []).append(first)
                times.setdefault((name, be, on, 1), []).append(second)
                at[name, be, on] = n_at
    print(
        f"# Joints on their limits: ms (CPU) per step, medians of {repeats} of the fastest of "
        f"{inner}+ runs; steps 1-{LIMIT_STEPS} (the drive there) and {LIMIT_STEPS + 1}-"
        f"{2 * LIMIT_STEPS} (resting)\n"
    )
    print(
        "| robot | steps | MuJoCo on limits | MuJoCo off | on/off | PyBullet on limits | "
        "PyBullet off | MuJoCo/PyBullet on limits | joints at a limit (MuJoCo, PyBullet) |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for name, _, _ in cases:
        for w, steps in enumerate((f"1-{LIMIT_STEPS}", f"{LIMIT_STEPS + 1}-{2 * LIMIT_STEPS}")):
            med = {(be, on): statistics.median(times[name, be, on, w]) * 1e3 for be, on in runs}
            print(
                f"| {name} | {steps} | {med['mujoco', True]:.3f} | {med['mujoco', False]:.3f} | "
                f"{med['mujoco', True] / med['mujoco', False]:.2f} | "
                f"{med['pybullet', True]:.3f} | {med['pybullet', False]:.3f} | "
                f"{med['mujoco', True] / med['pybullet', True]:.2f} | "
                f"{at[name, 'mujoco', True]}, {at[name, 'pybullet', True]} (off: "
                f"{at[name, 'mujoco', False]}, {at[name, 'pybullet', False]}) |",
                flush=True,
            )
    for name in missing:
        print(f"\n{name}: skipped, example-robot-data is not installed")
    return 0


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
    parser.add_argument(
        "--joint-limits", action="store_true", help="time robots resting on their joint limits"
    )
    parser.add_argument("--repeats", type=int, default=3, help="with --joint-limits")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="with --joint-limits: the KUKA and the Panda only, no 0.5 s of runs (a smoke run)",
    )
    parser.add_argument(
        "--inner", type=int, default=5, help="with --joint-limits: runs of each window"
    )
    args = parser.parse_args(argv)
    if args.joint_limits:
        return joint_limits(args.repeats, args.inner, args.quick)
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
