"""Robots from outside pybullet_data: does every robot of example-robot-data load as raw PyBullet
loads it, on every backend?

The corpus is the PyPI wheel ``example-robot-data`` (``pip install -e '.[corpus]'``: BSD, about
70 URDFs of some 40 robots with their meshes). For every URDF: load it with raw PyBullet
(``p.loadURDF``), then with ``Sim("pybullet")``, ``Sim("mujoco")`` and ``Sim("physx")`` (each
backend installed), each phase in its own child process with a timeout (a crash or a hang is
recorded as such), at the same spawn pose as ``bench/urdf_coverage.py`` and compared with its
helpers: the joint count, the 17 fields of every joint table row (floats to 1e-9, the parent
frame's quaternion *with its sign*), every link's world frame at spawn (2e-7 relative:
PyBullet's ``getLinkState`` rounds to float32; PhysX, whose state is float32, 1e-6:
``urdf_coverage.FRAME_REL_BY_BACKEND``), and the warnings each gives (PyBullet's own
``b3Warning`` lines for raw PyBullet; for a backend, what reaches the ``simbridge`` logger at
WARNING or above).
Prints one row per URDF, the counts (PhysX's over the robots both other backends load as raw
PyBullet does), the load times and every difference and warning.

    python bench/robot_coverage.py                    # every URDF of the corpus (~4 min on 2 cores)
    python bench/robot_coverage.py ur_description/urdf/ur5_robot.urdf --timeout 60
    python bench/robot_coverage.py --backend physx

Measured (pybullet 3.2.7, mujoco 4.0.0, SAPIEN 3.0.3, example-robot-data 6.0.0; the shared 2-core
machine):
raw PyBullet loads 66 of the 69 URDFs; Sim("pybullet"), Sim("mujoco") and Sim("physx") load all
66 with its joint table and link frames, each backend giving the same 103 warnings (physx:
66/66, 0 listed; at physx 62ccff4, before the links were placed at load, 1/66); MuJoCo and PhysX
also load tiago_dual.urdf (129 joints, past PyBullet's limit). 1545 s on a machine loaded 5x
(physx branch at 87381f5).
"""

from __future__ import annotations

import argparse
import glob
import json
import logging
import math
import os
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from importlib.metadata import PackageNotFoundError, distribution
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import urdf_coverage  # noqa: E402  (bench/urdf_coverage.py: the pose, the loads, the comparison)

BACKENDS = ("pybullet", "mujoco", "physx")
PHASES = ("raw",) + BACKENDS
SHORT = {"raw": "raw", "pybullet": "pb", "mujoco": "mj", "physx": "px"}


def corpus_root() -> Path | None:
    """The ``robots`` folder of the installed example-robot-data wheel (its files sit under
    ``cmeel.prefix/share/example-robot-data/robots``: it has no Python package), or None."""
    try:
        dist = distribution("example-robot-data")
    except PackageNotFoundError:
        return None
    root = Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))
    return root if root.is_dir() else None


def corpus_files(root: Path) -> list[str]:
    """Every URDF under ``root``, relative to it, sorted."""
    return sorted(
        os.path.relpath(f, root) for f in glob.glob(str(root / "**" / "*.urdf"), recursive=True)
    )


def robot_name(relpath: str) -> str:
    return Path(relpath).stem


# ---------------------------------------------------------------- one phase, in a child process


def _collect_warnings(engine_lines: bool) -> list[str]:
    """Every record of WARNING or above that reaches the ``simbridge`` logger from now on; with
    ``engine_lines``, every line PyBullet prints instead (its b3Warning lines; the backend's
    classifier keeps at DEBUG those the URDF reader says itself)."""
    seen: list[str] = []

    class Keep(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            if engine_lines and record.name != "simbridge.pybullet":
                return
            if engine_lines and "pybullet build time" in record.getMessage():
                return
            seen.append(f"[{record.name}] {record.getMessage()}")

    log = logging.getLogger("simbridge")
    log.addHandler(Keep(logging.DEBUG if engine_lines else logging.WARNING))
    log.setLevel(logging.DEBUG)
    return seen


def run_phase(phase: str, path: str) -> dict[str, Any]:
    """Load ``path`` in this process on ``phase`` (raw, pybullet, mujoco): the joint table, the
    link frames, the warnings and the load time, as JSON-ready values."""
    options = {
        "global_scaling": 1.0,
        "merge_fixed_links": False,
        "inertia_source": "collision_aabb",
    }
    warnings = _collect_warnings(engine_lines=phase == "raw")
    if phase == "raw":
        from simbridge.backends.pybullet.output import p  # registers PyBullet's classifier
        from simbridge.engine_output import captured

        with captured("pybullet", "connect"):
            c = p.connect(p.DIRECT)
        start = time.perf_counter()
        with captured("pybullet", "raw load"):
            try:
                out = urdf_coverage._raw(p, c, path, options)
            except p.error as exc:  # loaded, then a read failed (tiago_dual: past 127 joints)
                out = {"error": f"loads, then {exc}"}
        out["seconds"] = time.perf_counter() - start
    else:
        import simbridge

        sim = simbridge.Sim(phase)  # type: ignore[arg-type]
        del warnings[:]  # the engine's import and connection are not the robot's
        start = time.perf_counter()
        out = urdf_coverage._sim(sim, path, options)
        out["seconds"] = time.perf_counter() - start
        sim.close()
    out["warnings"] = list(warnings)
    return out


def _child(phase: str, path: str, timeout: float) -> dict[str, Any]:
    """``run_phase`` in a child process: its result, or what became of the child."""
    try:
        proc = subprocess.run(
            [sys.executable, str(Path(__file__).resolve()), "--phase", phase, path],
            capture_output=True,
            text=True,
            timeout=timeout,
        )
    except subprocess.TimeoutExpired:
        return {"crash": f"hung: killed after {timeout:.0f} s"}
    lines = [line for line in proc.stdout.splitlines() if line.startswith("{")]
    if proc.returncode != 0 or not lines:
        tail = (proc.stderr.strip().splitlines() or ["no output"])[-1]
        return {"crash": f"exit status {proc.returncode}: {tail}"}
    return json.loads(lines[-1])  # type: ignore[no-any-return]


def measure(
    path: str, timeout: float, phases: tuple[str, ...] = PHASES
) -> dict[str, dict[str, Any]]:
    """Every phase of one URDF, each in its own child process."""
    return {phase: _child(phase, path, timeout) for phase in phases}


# ---------------------------------------------------------------- comparison and table


def frame_error(raw: dict[str, Any], got: dict[str, Any]) -> float:
    """The largest distance between a link frame's origin and raw PyBullet's, in metres."""
    if raw.get("n") != got.get("n"):
        return math.nan
    return max(
        (math.dist(r[0], g[0]) for r, g in zip(raw["frames"], got["frames"], strict=True)),
        default=0.0,
    )


def verdict(raw: dict[str, Any], got: dict[str, Any], backend: str = "pybullet") -> str | None:
    """None when ``got`` has raw PyBullet's joint table (quaternion signs included) and link
    frames (to ``backend``'s tolerance); else the first difference."""
    rel = urdf_coverage.FRAME_REL_BY_BACKEND.get(backend, urdf_coverage.FRAME_REL)
    return urdf_coverage.compare(raw, got, quat_sign=True, frame_rel=rel)


def _state(r: dict[str, Any]) -> str:
    if "crash" in r:
        return "CRASH"
    return "no" if "error" in r else "yes"


def report(
    results: dict[str, dict[str, dict[str, Any]]],
    elapsed: float,
    workers: int,
    root_prefix: str,
    backends: tuple[str, ...] = BACKENDS,
) -> int:
    """Print the table and the details; the number of robots raw PyBullet loads that a backend
    does not load, or loads differently."""
    phases = ("raw", *backends)
    short = ", ".join(SHORT[b] for b in backends)
    print(
        "| robot | raw loads | "
        + " | ".join(f"{b} loads" for b in backends)
        + f" | table equal ({short}) | FK max error m ({short}) "
        f"| warnings (raw, {short}) | load s (raw, {short}) |"
    )
    print("|" + "---|" * (6 + len(backends)))
    details: list[str] = []
    bad = 0
    times = {phase: 0.0 for phase in phases}
    both = 0
    for name, r in sorted(results.items()):
        raw = r["raw"]
        equal, errors = [], []
        for b in backends:
            got = r[b]
            if "error" in raw or "crash" in raw:
                equal.append("-")
                errors.append("-")
                if "error" not in got and "crash" not in got:
                    details.append(f"[{b}] {name}: loads, raw PyBullet does not")
                continue
            if "error" in got or "crash" in got:
                equal.append("-")
                errors.append("-")
                bad += 1
                details.append(
                    f"[{b}] {name}: refused, raw loads it: {got.get('error', got.get('crash'))}"
                )
                continue
            why = verdict(raw, got, b)
            equal.append("yes" if why is None else "NO")
            errors.append(f"{frame_error(raw, got):.1e}")
            if why is not None:
                bad += 1
                details.append(f"[{b}] {name}: differs: {why}")
        if all(_state(r[phase]) == "yes" for phase in phases):
            both += 1
            for phase in phases:
                times[phase] += r[phase]["seconds"]
        counts = ", ".join(str(len(r[phase].get("warnings", []))) for phase in phases)
        secs = ", ".join(
            f"{r[phase]['seconds']:.2f}" if "seconds" in r[phase] else "-" for phase in phases
        )
        print(
            f"| {name} | {_state(raw)} | "
            + " | ".join(_state(r[b]) for b in backends)
            + f" | {', '.join(equal)} | {', '.join(errors)} | {counts} | {secs} |"
        )
        if "error" in raw or "crash" in raw:
            details.append(f"[raw] {name}: {raw.get('error', raw.get('crash'))}")
        for phase in phases:
            for w in r[phase].get("warnings", []):
                details.append(f"[{phase}] {name}: warning: {w}")
    raw_ok = sum(_state(r["raw"]) == "yes" for r in results.values())
    print()
    print(f"{len(results)} URDFs; raw PyBullet loads {raw_ok}")
    same: dict[str, set[str]] = {}
    for b in backends:
        same[b] = {
            name
            for name, r in results.items()
            if _state(r[b]) == "yes"
            and _state(r["raw"]) == "yes"
            and verdict(r["raw"], r[b], b) is None
        }
        print(
            f"Sim({b!r}): {len(same[b])} of those with raw PyBullet's joint table and link frames"
        )
    first = urdf_coverage.FIRST_TWO
    if set(first) <= set(backends):
        held = set.intersection(*(same[b] for b in first))
        for b in backends:
            if b not in first:
                ok = len(held & same[b])
                print(
                    f"{b}: {ok}/{len(held)} of the URDFs both {' and '.join(first)} load as raw "
                    f"PyBullet does load with the same joint table and link frames; "
                    f"{len(held) - ok} listed with reasons"
                )
    print(
        f"load time over the {both} URDFs all {len(phases)} load: "
        + ", ".join(f"{phase} {times[phase]:.1f} s" for phase in phases)
        + " (each in a fresh process: first loads, no cache)"
    )
    print()
    for line in details:
        print(line.replace(root_prefix, ""))
    by_cause: dict[str, dict[str, list[str]]] = {}
    for line in details:
        tag, rest = line.split("] ", 1)
        name, why = rest.split(": ", 1)
        if tag[1:] in backends and not why.startswith("warning: "):
            kinds = by_cause.setdefault(tag[1:], {})
            kinds.setdefault(urdf_coverage.cause(why.replace(root_prefix, "")), []).append(name)
    for b, kinds in by_cause.items():
        print(f"[{b}] by cause:")
        for kind, names in sorted(kinds.items(), key=lambda kv: -len(kv[1])):
            print(f"  {len(names)}: {kind} (e.g. {names[0]})")
    print(f"({elapsed:.0f} s, {workers} workers)")
    return bad


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawTextHelpFormatter
    )
    parser.add_argument("files", nargs="*", help="URDFs under the corpus (default: all)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--timeout", type=float, default=120.0, help="seconds per phase")
    parser.add_argument(
        "--backend",
        action="append",
        choices=BACKENDS,
        help="a backend to run (repeatable; default: every one installed)",
    )
    parser.add_argument("--phase", choices=PHASES, help=argparse.SUPPRESS)  # the child's
    args = parser.parse_args(argv)
    if args.phase:
        print(json.dumps(run_phase(args.phase, args.files[0])))
        return 0
    root = corpus_root()
    if root is None:
        print("example-robot-data is not installed: pip install -e '.[corpus]'")
        return 2
    files = args.files or corpus_files(root)
    backends = tuple(
        urdf_coverage.installed(tuple(b for b in BACKENDS if b in (args.backend or BACKENDS)))
    )
    phases = ("raw", *backends)
    start = time.perf_counter()
    with ThreadPoolExecutor(args.workers) as pool:
        done = pool.map(lambda f: measure(str(root / f), args.timeout, phases), files)
        results = dict(zip(files, done, strict=True))
    print(f"# example-robot-data ({root})\n")
    for b in args.backend or BACKENDS:
        if b not in backends:
            print(f"Sim({b!r}): not installed here, not run\n")
    bad = report(results, time.perf_counter() - start, args.workers, f"{root}{os.sep}", backends)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
