"""How long ``load_urdf`` takes against raw PyBullet's ``loadURDF``, per robot, side by side.

Over example-robot-data's URDFs when it is installed (``pip install example-robot-data``),
otherwise over a few pybullet_data robots (or the files named on the command line). Each robot
is measured in a child process of its own, so that no robot profits from another's files:
the imports and one small load on every engine come first (not timed), then

* ``raw``: ``p.loadURDF(path)`` on a fresh ``p.connect(p.DIRECT)``;
* ``pybullet``: ``Sim("pybullet").load_urdf(path)`` on a fresh Sim;
* ``mujoco``: ``Sim("mujoco").load_urdf(path)``, simbridge's mesh cache emptied before;
* ``again``: the same three once more in the same process (raw: a new connection; the
  backends: a new Sim, their meshes now in the process's cache);
* ``meshes``: simbridge reading the robot's mesh files alone (its cache emptied), the part
  of a first load that no engine does (its checks, the inertia rules and the MuJoCo model
  read the vertices).

The columns are milliseconds (the best of ``--repeats`` child processes) and the ratios to
raw; the totals are over the robots every engine loads. Robots raw PyBullet refuses are left
out; those a backend refuses are listed with the reason. Timings depend on the machine and on
what else runs on it.

    python bench/load.py                       # the corpus, or a few pybullet_data robots
    python bench/load.py --repeats 3 r2d2.urdf husky/husky.urdf
"""

from __future__ import annotations

import argparse
import glob
import json
import logging
import os
import subprocess
import sys
import time
from typing import Any

PYBULLET_DATA_ROBOTS = (
    "r2d2.urdf",
    "kuka_iiwa/model.urdf",
    "husky/husky.urdf",
    "racecar/racecar.urdf",
    "laikago/laikago_toes.urdf",
    "humanoid/humanoid.urdf",
    "franka_panda/panda.urdf",
    "a1/a1.urdf",
)
MARK = "LOADBENCH "


def corpus_root() -> str | None:
    """example-robot-data's ``robots`` folder where the wheel is installed, else None."""
    for entry in sys.path:
        root = os.path.join(entry, "cmeel.prefix", "share", "example-robot-data", "robots")
        if os.path.isdir(root):
            return root
    return None


def robots(names: list[str]) -> tuple[str, list[str]]:
    """The folder the names are relative to, and the names."""
    if names:
        return "", names
    root = corpus_root()
    if root is not None:
        found = glob.glob(os.path.join(root, "*", "*", "*.urdf"))
        return root, sorted(os.path.relpath(f, root) for f in found)
    import pybullet_data

    data = pybullet_data.getDataPath()
    return data, [r for r in PYBULLET_DATA_ROBOTS if os.path.isfile(os.path.join(data, r))]


def _timed(load: Any) -> tuple[float | None, str | None]:
    start = time.perf_counter()
    try:
        load()
    except Exception as exc:  # noqa: BLE001 - reported in the table
        return None, f"{type(exc).__name__}: {str(exc)[:160]}"
    return time.perf_counter() - start, None


def measure(path: str) -> dict[str, Any]:
    """One robot, in this (fresh) process: see the module docstring."""
    logging.disable(logging.CRITICAL)
    import pybullet as p
    import pybullet_data

    import simbridge
    from simbridge.model import meshes

    warm = os.path.join(pybullet_data.getDataPath(), "cube_small.urdf")

    def raw() -> None:
        c = p.connect(p.DIRECT)
        try:
            p.loadURDF(path, physicsClientId=c)
        finally:
            p.disconnect(c)

    def layer(backend: str) -> Any:
        def load() -> None:
            with simbridge.Sim(backend) as sim:
                start = time.perf_counter()
                sim.load_urdf(path)
                times.append(time.perf_counter() - start)

        return load

    # imports and first calls (trimesh for COLLADA, the MuJoCo compiler), not timed
    import mujoco  # noqa: F401
    import trimesh  # noqa: F401

    c = p.connect(p.DIRECT)
    p.loadURDF(warm, physicsClientId=c)
    p.disconnect(c)
    for backend in ("pybullet", "mujoco"):
        with simbridge.Sim(backend) as sim:
            sim.load_urdf(warm)
    out: dict[str, Any] = {}
    for rnd in ("", "again_"):
        out[rnd + "raw"], err = _timed(raw)
        if err:
            return {"raw_error": err}
        for backend in ("pybullet", "mujoco"):
            if not rnd:
                meshes.clear_cache()
            times: list[float] = []
            _, err = _timed(layer(backend))
            out[rnd + backend] = times[0] if err is None else None
            if err is not None:
                out[backend + "_error"] = err
    # the part of a first load no engine does: reading the robot's mesh files in Python
    from simbridge.model.urdf import parse_urdf, resolve_source

    try:
        model = parse_urdf(resolve_source(path))
    except Exception:  # noqa: BLE001 - a backend's refusal, reported above
        out["meshes"] = None
        return out
    files = {g.mesh_path for link in model.links for g in (*link.visuals, *link.collisions)}
    meshes.clear_cache()
    start = time.perf_counter()
    for file in files - {None}:
        meshes.read_mesh(file)  # type: ignore[arg-type]
    out["meshes"] = time.perf_counter() - start
    return out


def _child(path: str) -> dict[str, Any]:
    proc = subprocess.run(
        [sys.executable, os.path.abspath(__file__), "--one", path],
        capture_output=True,
        text=True,
        timeout=900,
    )
    for line in proc.stdout.splitlines():
        if line.startswith(MARK):
            return dict(json.loads(line[len(MARK) :]))
    return {"raw_error": f"the child process ended with {proc.returncode}: {proc.stderr[-300:]}"}


def _best(runs: list[dict[str, Any]], key: str) -> float | None:
    values = [r[key] for r in runs if r.get(key) is not None]
    return min(values) if values else None


def _ms(value: float | None) -> str:
    return "-" if value is None else f"{value * 1e3:.1f}"


def _ratio(value: float | None, raw: float | None) -> str:
    return "-" if value is None or not raw else f"{value / raw:.2f}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("files", nargs="*", help="URDF paths (default: the corpus)")
    ap.add_argument("--repeats", type=int, default=1, help="child processes per robot (best)")
    ap.add_argument("--one", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.one:
        # on a line of its own: the engines print from C without a final newline
        print("\n" + MARK + json.dumps(measure(args.one)), flush=True)
        return 0
    root, names = robots(args.files)
    corpus = os.path.join(corpus_root() or os.sep * 2, "")  # files named: shown from there
    full = {name: os.path.abspath(os.path.join(root, name)) for name in names}
    shown = {
        name: path[len(corpus) :] if path.startswith(corpus) else os.path.relpath(path)
        for name, path in full.items()
    }
    print(f"load_urdf against raw loadURDF, {len(names)} robots from {root or 'the command line'}")
    print(f"best of {args.repeats} child process(es) per robot; ms; ratio = layer / raw\n")
    cols = ("raw", "pybullet", "mujoco")
    keys = (*cols, *(f"again_{c}" for c in cols), "meshes")
    print(
        "| robot | raw | pybullet | ratio | mujoco | ratio "
        "| raw again | pybullet again | ratio | mujoco again | ratio | meshes | ratio |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    totals = dict.fromkeys(keys, 0.0)
    skipped: list[str] = []
    refused: list[str] = []
    counted = 0
    for name in names:
        path = os.path.join(root, name)
        runs = [_child(path) for _ in range(max(1, args.repeats))]
        if any("raw_error" in r for r in runs):
            skipped.append(
                f"{shown[name]}: {next(r['raw_error'] for r in runs if 'raw_error' in r)}"
            )
            continue
        best = {k: _best(runs, k) for k in totals}
        for backend in ("pybullet", "mujoco"):
            errors = [r[f"{backend}_error"] for r in runs if f"{backend}_error" in r]
            if errors:
                refused.append(f"{shown[name]} on {backend}: {errors[0]}")
        print(
            f"| {shown[name]} | {_ms(best['raw'])} | {_ms(best['pybullet'])} "
            f"| {_ratio(best['pybullet'], best['raw'])} | {_ms(best['mujoco'])} "
            f"| {_ratio(best['mujoco'], best['raw'])} | {_ms(best['again_raw'])} "
            f"| {_ms(best['again_pybullet'])} "
            f"| {_ratio(best['again_pybullet'], best['again_raw'])} "
            f"| {_ms(best['again_mujoco'])} | {_ratio(best['again_mujoco'], best['again_raw'])} "
            f"| {_ms(best['meshes'])} | {_ratio(best['meshes'], best['raw'])} |",
            flush=True,
        )
        if all(v is not None for v in best.values()):
            counted += 1
            for k, v in best.items():
                totals[k] += v  # type: ignore[operator]
    print(
        f"| **total, {counted} robots** | {_ms(totals['raw'])} | {_ms(totals['pybullet'])} "
        f"| {_ratio(totals['pybullet'], totals['raw'])} | {_ms(totals['mujoco'])} "
        f"| {_ratio(totals['mujoco'], totals['raw'])} | {_ms(totals['again_raw'])} "
        f"| {_ms(totals['again_pybullet'])} "
        f"| {_ratio(totals['again_pybullet'], totals['again_raw'])} "
        f"| {_ms(totals['again_mujoco'])} | {_ratio(totals['again_mujoco'], totals['again_raw'])} "
        f"| {_ms(totals['meshes'])} | {_ratio(totals['meshes'], totals['raw'])} |"
    )
    for title, rows in (("raw PyBullet refuses (left out)", skipped), ("refused", refused)):
        if rows:
            print(f"\n{title}:")
            for row in rows:
                print(f"  {row}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
