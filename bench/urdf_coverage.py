"""Which of pybullet_data's URDFs load, raw and through simbridge, and do they agree?

For every ``.urdf`` under pybullet_data (or the files named on the command line): load it with
raw PyBullet (``p.loadURDF``), with ``Sim("pybullet")``, ``Sim("mujoco")`` and, where its extra
is installed, ``Sim("physx")``, each at the same spawn pose, and compare with raw PyBullet: the
joint count, the 17 fields of every joint table row (floats to 1e-9, quaternions up to sign),
and every link's world frame at spawn (to 2e-7 relative: PyBullet's ``getLinkState`` rounds to
float32; PhysX's frames, float32 state composed in float32, to 1e-6). Prints the counts, then every
file that fails or differs with its reason. Files are shared among worker processes (a crash
in one file loses only its chunk, reported as such).

    python bench/urdf_coverage.py               # all of pybullet_data (about 20 s on 2 cores)
    python bench/urdf_coverage.py husky/husky.urdf plane_implicit.urdf
    python bench/urdf_coverage.py --global-scaling 1.7 --merge-fixed-links --inertia-from-file
"""

from __future__ import annotations

import argparse
import glob
import logging
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import pybullet_data

DATA = pybullet_data.getDataPath()
POSE = ((0.1, -0.2, 0.3), (0.0, 0.0, math.sin(0.3), math.cos(0.3)))
TOL = 1e-9
FRAME_REL = 2e-7
# PhysX keeps link poses in float32 and composes them in float32: measured worst 3.1e-7 m at
# 1.3 m from the origin (kuka_iiwa, tests/test_physx_backend.py), 2.4e-7 relative
FRAME_REL_BY_BACKEND = {"physx": 1e-6}


def backends() -> tuple[str, ...]:
    """pybullet and mujoco, and physx where its extra is installed."""
    import simbridge
    from simbridge.registry import unavailable_reason

    extra = tuple(
        b
        for b in ("physx",)
        if b in simbridge.available_backends() and unavailable_reason(b) is None
    )
    return ("pybullet", "mujoco", *extra)


def all_files() -> list[str]:
    return sorted(
        os.path.relpath(f, DATA)
        for f in glob.glob(os.path.join(DATA, "**", "*.urdf"), recursive=True)
    )


def _raw(p: Any, c: int, path: str, options: dict[str, Any]) -> dict[str, Any]:
    flags = (p.URDF_MERGE_FIXED_LINKS if options["merge_fixed_links"] else 0) | (
        p.URDF_USE_INERTIA_FROM_FILE if options["inertia_source"] == "file" else 0
    )
    try:
        body = p.loadURDF(
            path,
            POSE[0],
            POSE[1],
            flags=flags,
            globalScaling=options["global_scaling"],
            physicsClientId=c,
        )
    except p.error as exc:
        return {"error": str(exc)}
    n = p.getNumJoints(body, physicsClientId=c)
    table = [list(p.getJointInfo(body, i, physicsClientId=c)) for i in range(n)]
    for row in table:
        row[1], row[12] = row[1].decode(), row[12].decode()
    frames = [
        tuple(p.getLinkState(body, i, computeForwardKinematics=1, physicsClientId=c)[4:6])
        for i in range(n)
    ]
    base = p.getBasePositionAndOrientation(body, physicsClientId=c)
    local = p.getDynamicsInfo(body, -1, physicsClientId=c)[3:5]
    inv = p.invertTransform(*local)
    frames.insert(0, tuple(p.multiplyTransforms(base[0], base[1], *inv)))
    return {"n": n, "table": table, "frames": frames}


def _sim(sim: Any, path: str, options: dict[str, Any]) -> dict[str, Any]:
    try:
        body = sim.load_urdf(path, base_position=POSE[0], base_orientation=POSE[1], **options)
    except Exception as exc:  # noqa: BLE001 - reported
        return {"error": f"{type(exc).__name__}: {exc}"}
    n = sim.num_joints(body)
    table = [list(row) for row in sim.joints(body)]
    for row in table:
        row[2] = int(row[2])
    frames = []
    for i in range(-1, n):
        s = sim.link_state(body, i)
        frames.append((s.link_frame_position, s.link_frame_orientation))
    return {"n": n, "table": table, "frames": frames}


def _close(a: Any, b: Any, tol: float) -> bool:
    return all(
        abs(x - y) <= tol or (math.isnan(x) and math.isnan(y)) for x, y in zip(a, b, strict=True)
    )


def _quat_close(a: Any, b: Any, tol: float) -> bool:
    return _close(a, b, tol) or _close(a, [-v for v in b], tol)


def compare(
    raw: dict[str, Any],
    got: dict[str, Any],
    *,
    quat_sign: bool = False,
    frame_rel: float = FRAME_REL,
) -> str | None:
    """None when ``got`` matches ``raw``, else what differs first. The joint table's quaternion
    (field 15) is compared up to sign unless ``quat_sign``."""
    if raw["n"] != got["n"]:
        return f"{got['n']} joints, raw PyBullet {raw['n']}"
    for k, (r, g) in enumerate(zip(raw["table"], got["table"], strict=True)):
        for f in range(13):
            same = _close([r[f]], [g[f]], TOL) if isinstance(r[f], float) else r[f] == g[f]
            if not same:
                return f"joint {k} field {f}: {g[f]!r}, raw {r[f]!r}"
        if r[16] != g[16]:
            return f"joint {k} parent index {g[16]}, raw {r[16]}"
        if not _close(r[13], g[13], TOL) or not _close(r[14], g[14], TOL):
            return f"joint {k} axis/parent frame position: {g[13]}, {g[14]}; raw {r[13]}, {r[14]}"
        if not (_close(r[15], g[15], TOL) if quat_sign else _quat_close(r[15], g[15], TOL)):
            return f"joint {k} parent frame orientation {g[15]}, raw {r[15]}"
    for k, (r, g) in enumerate(zip(raw["frames"], got["frames"], strict=True)):
        scale = frame_rel * max(1.0, max(abs(v) for v in r[0]))
        if not _close(r[0], g[0], scale) or not _quat_close(r[1], g[1], frame_rel):
            return f"link {k - 1} frame {g}, raw {r}"
    return None


def work(names: list[str], options: dict[str, Any]) -> dict[str, dict[str, Any]]:
    import simbridge
    from simbridge.engine_output import captured

    logging.disable(logging.CRITICAL)
    with captured("pybullet", "importing"):
        import pybullet as p
    with captured("pybullet", "sweep"):
        c = p.connect(p.DIRECT)
    sims = {b: simbridge.Sim(b) for b in backends()}
    out: dict[str, dict[str, Any]] = {}
    for name in names:
        path = os.path.join(DATA, name)
        with captured("pybullet", "sweep"):
            result = {"raw": _raw(p, c, path, options)}
            p.resetSimulation(physicsClientId=c)
        for backend, sim in sims.items():
            result[backend] = _sim(sim, path, options)
            sim.reset()
        out[name] = result
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawTextHelpFormatter
    )
    parser.add_argument("files", nargs="*", help="paths under pybullet_data (default: all)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--global-scaling", type=float, default=1.0)
    parser.add_argument("--merge-fixed-links", action="store_true")
    parser.add_argument("--inertia-from-file", action="store_true")
    args = parser.parse_args(argv)
    options = {
        "global_scaling": args.global_scaling,
        "merge_fixed_links": args.merge_fixed_links,
        "inertia_source": "file" if args.inertia_from_file else "collision_aabb",
    }
    files = args.files or all_files()
    start = time.perf_counter()
    chunks = [files[i :: 8 * args.workers] for i in range(8 * args.workers)]
    chunks = [c for c in chunks if c]
    results: dict[str, dict[str, Any]] = {}
    with ProcessPoolExecutor(args.workers) as pool:
        futures = {pool.submit(work, chunk, options): chunk for chunk in chunks}
        for future, chunk in futures.items():
            try:
                results.update(future.result())
            except Exception as exc:  # noqa: BLE001 - a worker that died
                for name in chunk:
                    results[name] = {"crash": str(exc)}
    elapsed = time.perf_counter() - start
    raw_ok = [n for n, r in results.items() if "raw" in r and "error" not in r["raw"]]
    lines = []
    counts = {}
    for backend in backends():
        loaded = [n for n, r in results.items() if backend in r and "error" not in r[backend]]
        same = 0
        for name in sorted(results):
            r = results[name]
            if "crash" in r:
                lines.append(f"{name}: worker crashed: {r['crash']}")
                continue
            raw, got = r["raw"], r[backend]
            if "error" in got and "error" not in raw:
                lines.append(f"[{backend}] {name}: refused, raw PyBullet loads it: {got['error']}")
            elif "error" not in got and "error" in raw:
                lines.append(f"[{backend}] {name}: loads, raw PyBullet refuses it")
            elif "error" not in got:
                why = compare(raw, got, frame_rel=FRAME_REL_BY_BACKEND.get(backend, FRAME_REL))
                if why is None:
                    same += 1
                else:
                    lines.append(f"[{backend}] {name}: differs: {why}")
        counts[backend] = (len(loaded), same)
    print(f"{len(files)} URDF files, loaded with {options}; raw PyBullet loads {len(raw_ok)}")
    for backend, (loaded, same) in counts.items():
        print(f"Sim({backend!r}) loads {loaded}; same joint table and link frames as raw: {same}")
    for name in sorted(n for n, r in results.items() if "raw" in r and "error" in r["raw"]):
        print(f"raw PyBullet refuses {name}")
    for line in sorted(set(lines)):
        print(line)
    print(f"({elapsed:.0f} s, {args.workers} workers)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
