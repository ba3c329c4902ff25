"""Which of pybullet_data's URDFs load, raw and through simbridge, and do they agree?

For every ``.urdf`` under pybullet_data (or the files named on the command line): load it with
raw PyBullet (``p.loadURDF``), with ``Sim("pybullet")``, ``Sim("mujoco")`` and ``Sim("physx")``
(each backend that is installed), each at the same spawn pose, and compare with raw PyBullet:
the joint count, the 17 fields of every joint table row (floats to 1e-9, quaternions up to
sign), and every link's world frame at spawn (to 2e-7 relative: PyBullet's ``getLinkState``
rounds to float32; PhysX to 1e-6 relative: ``FRAME_REL_BY_BACKEND``). Prints the counts, the PhysX
column (of the files both other backends load as raw PyBullet does, how many PhysX loads the
same), then every file that fails or differs with its reason, and the reasons grouped by cause.
Files are shared among worker processes, PhysX's apart from the others' (a crash in one file
loses only its chunk of that engine, reported as such).

    python bench/urdf_coverage.py               # all of pybullet_data (about 2 min on 2 cores)
    python bench/urdf_coverage.py husky/husky.urdf plane_implicit.urdf
    python bench/urdf_coverage.py --backend physx
    python bench/urdf_coverage.py --global-scaling 1.7 --merge-fixed-links --inertia-from-file

Measured (pybullet 3.2.7, mujoco 4.0.0, SAPIEN 3.0.3; the shared 2-core machine):
raw PyBullet loads 1092 of the 1095 files; Sim("pybullet"), Sim("mujoco") and Sim("physx") load
1091 each, all with raw PyBullet's joint table and link frames (random_urdfs/168, an all-NaN
mesh, refused by all three): physx: 1091/1091 load with the same table and frames, 0 listed;
its largest frame difference 3.0e-7 relative (humanoid/humanoid.urdf). 262 s on the loaded
machine (physx branch at 87381f5; at 62ccff4, before the links were placed at load, 1047/1091).
"""

from __future__ import annotations

import argparse
import glob
import logging
import math
import os
import re
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import pybullet_data

DATA = pybullet_data.getDataPath()
POSE = ((0.1, -0.2, 0.3), (0.0, 0.0, math.sin(0.3), math.cos(0.3)))
TOL = 1e-9
FRAME_REL = 2e-7
BACKENDS = ("pybullet", "mujoco", "physx")
# The two backends whose agreement with raw PyBullet defines the files a further backend is
# held to (its column: "N/M load with the same table and frames").
FIRST_TWO = ("pybullet", "mujoco")
# Link frames of a backend whose state is float32, relative to max(1, |position|): PhysX keeps
# every pose in float32 (spacing 1.2e-7 at 1) and places each link by composing float32 joint
# frames down the chain, each composition rounding again; raw PyBullet's own frames are float32
# too. Measured worst over pybullet_data: 3.0e-7 (bicycle/bike.urdf; kuka_iiwa/model.urdf's
# link 3 2.2e-7): 1e-6 is about 8 float32 spacings.
FRAME_REL_BY_BACKEND = {"physx": 1e-6}


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


def link_frame_error(r: Any, g: Any) -> float:
    """How far link frame ``g`` is from raw PyBullet's ``r``: the largest of its position's
    difference relative to max(1, |position|) and its quaternion's (up to sign)."""
    scale = max(1.0, max(abs(v) for v in r[0]))
    position = max(abs(x - y) for x, y in zip(r[0], g[0], strict=True)) / scale
    turn = min(
        max(abs(x - y) for x, y in zip(r[1], g[1], strict=True)),
        max(abs(x + y) for x, y in zip(r[1], g[1], strict=True)),
    )
    return max(position, turn)


def frame_error(raw: dict[str, Any], got: dict[str, Any]) -> float:
    """The largest :func:`link_frame_error` over the links (NaN when the joint counts differ)."""
    if raw.get("n") != got.get("n"):
        return math.nan
    return max(
        (link_frame_error(r, g) for r, g in zip(raw["frames"], got["frames"], strict=True)),
        default=0.0,
    )


def compare(
    raw: dict[str, Any],
    got: dict[str, Any],
    *,
    quat_sign: bool = False,
    frame_rel: float = FRAME_REL,
) -> str | None:
    """None when ``got`` matches ``raw``, else what differs first. The joint table's quaternion
    (field 15) is compared up to sign unless ``quat_sign``; link frames to ``frame_rel``
    relative to max(1, |position|)."""
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
            if max(abs(v) for v in g[0]) < 1e-6 < max(abs(v) for v in r[0]):
                return f"link {k - 1} frame at the world origin at load: {g}, raw {r}"
            error = link_frame_error(r, g)
            return f"link {k - 1} frame off by {error:.1e} relative (> {frame_rel:g}): {g}, raw {r}"
    return None


_PARTICULARS = [
    (re.compile(r"(?:/[^\s:'\"]+)+"), "<path>"),  # file paths
    (re.compile(r"'[^']*'"), "'…'"),  # names
    (re.compile(r"\[\[[^\]]*\], \[[^\]]*\]\]"), "(…)"),  # frames as JSON lists
    (re.compile(r"\[[^\]]*\]"), "[…]"),  # lists of names
    (re.compile(r"\([-+0-9.e, ()naif]*\)"), "(…)"),  # vectors and frames
    (re.compile(r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?"), "#"),  # numbers
]


def cause(reason: str) -> str:
    """The kind of a refusal or difference, for grouping: ``reason`` less its particulars (file
    paths, names, numbers, vectors)."""
    for pattern, placeholder in _PARTICULARS:
        reason = pattern.sub(placeholder, reason)
    return reason


def work(names: list[str], options: dict[str, Any], phases: tuple[str, ...]) -> dict[str, Any]:
    """Load each of ``names`` on each of ``phases`` ("raw": raw PyBullet; else a backend)."""
    import simbridge
    from simbridge.engine_output import captured

    logging.disable(logging.CRITICAL)
    p: Any = None
    c = -1
    if "raw" in phases:
        with captured("pybullet", "importing"):
            import pybullet

        p = pybullet
        with captured("pybullet", "sweep"):
            c = p.connect(p.DIRECT)
    sims = {b: simbridge.Sim(b) for b in phases if b != "raw"}
    out: dict[str, dict[str, Any]] = {}
    for name in names:
        path = os.path.join(DATA, name)
        result = {}
        if p is not None:
            with captured("pybullet", "sweep"):
                result["raw"] = _raw(p, c, path, options)
                p.resetSimulation(physicsClientId=c)
        for backend, sim in sims.items():
            result[backend] = _sim(sim, path, options)
            sim.reset()
        out[name] = result
    return out


def installed(backends: tuple[str, ...]) -> list[str]:
    """Those of ``backends`` whose engine is installed here."""
    from simbridge.registry import unavailable_reason

    return [b for b in backends if unavailable_reason(b) is None]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawTextHelpFormatter
    )
    parser.add_argument("files", nargs="*", help="paths under pybullet_data (default: all)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument(
        "--backend",
        action="append",
        choices=BACKENDS,
        help="a backend to run (repeatable; default: every one installed)",
    )
    parser.add_argument("--global-scaling", type=float, default=1.0)
    parser.add_argument("--merge-fixed-links", action="store_true")
    parser.add_argument("--inertia-from-file", action="store_true")
    args = parser.parse_args(argv)
    options = {
        "global_scaling": args.global_scaling,
        "merge_fixed_links": args.merge_fixed_links,
        "inertia_source": "file" if args.inertia_from_file else "collision_aabb",
    }
    backends = installed(tuple(b for b in BACKENDS if b in (args.backend or BACKENDS)))
    missing = [b for b in (args.backend or BACKENDS) if b not in backends]
    files = args.files or all_files()
    start = time.perf_counter()
    chunks = [files[i :: 8 * args.workers] for i in range(8 * args.workers)]
    chunks = [c for c in chunks if c]
    # PhysX in processes of its own: a crash there loses none of the others' results
    groups = [("raw", *(b for b in backends if b in FIRST_TWO))]
    groups += [(b,) for b in backends if b not in FIRST_TWO]
    results: dict[str, dict[str, Any]] = {name: {} for name in files}
    with ProcessPoolExecutor(args.workers) as pool:
        futures = {
            pool.submit(work, chunk, options, group): (chunk, group)
            for group in groups
            for chunk in chunks
        }
        for future, (chunk, group) in futures.items():
            try:
                for name, got in future.result().items():
                    results[name].update(got)
            except Exception as exc:  # noqa: BLE001 - a worker that died
                for name in chunk:
                    for phase in group:
                        results[name][phase] = {"crash": f"{type(exc).__name__}: {exc}"}
    elapsed = time.perf_counter() - start
    raw_ok = [n for n, r in results.items() if "error" not in r["raw"] and "crash" not in r["raw"]]
    lines: dict[str, list[tuple[str, str]]] = {b: [] for b in backends}
    same: dict[str, set[str]] = {b: set() for b in backends}
    worst: dict[str, tuple[float, str]] = {b: (0.0, "") for b in backends}
    for name in sorted(results):
        r = results[name]
        raw = r["raw"]
        if "crash" in raw:
            lines.setdefault("raw", []).append((name, f"worker crashed: {raw['crash']}"))
            continue
        for backend in backends:
            got = r[backend]
            if "crash" in got:
                lines[backend].append((name, f"worker crashed: {got['crash']}"))
            elif "error" in got and "error" not in raw:
                lines[backend].append((name, f"refused, raw PyBullet loads it: {got['error']}"))
            elif "error" not in got and "error" in raw:
                lines[backend].append((name, "loads, raw PyBullet refuses it"))
            elif "error" not in got:
                rel = FRAME_REL_BY_BACKEND.get(backend, FRAME_REL)
                why = compare(raw, got, frame_rel=rel)
                if why is None:
                    same[backend].add(name)
                    worst[backend] = max(worst[backend], (frame_error(raw, got), name))
                else:
                    lines[backend].append((name, f"differs: {why}"))
    print(f"{len(files)} URDF files, loaded with {options}; raw PyBullet loads {len(raw_ok)}")
    for backend in backends:
        loaded = sum(
            "error" not in r[backend] and "crash" not in r[backend] for r in results.values()
        )
        rel = FRAME_REL_BY_BACKEND.get(backend, FRAME_REL)
        error, where = worst[backend]
        print(
            f"Sim({backend!r}) loads {loaded}; same joint table and link frames as raw: "
            f"{len(same[backend])} (frames to {rel:g} relative"
            + (f"; the largest difference among them {error:.1e}, {where})" if where else ")")
        )
    for b in missing:
        print(f"Sim({b!r}): not installed here, not run")
    reference = (
        set.intersection(*(same[b] for b in FIRST_TWO))
        if set(FIRST_TWO) <= set(backends)
        else set()
    )
    for backend in backends:
        if backend in FIRST_TWO or not reference:
            continue
        held = sorted(reference)
        ok = sum(name in same[backend] for name in held)
        print(
            f"{backend}: {ok}/{len(held)} of the files both {' and '.join(FIRST_TWO)} load as raw "
            f"PyBullet does load with the same joint table and link frames; "
            f"{len(held) - ok} listed with reasons"
        )
    for name in sorted(n for n, r in results.items() if "error" in r["raw"]):
        print(f"raw PyBullet refuses {name}")
    prefix = f"{DATA}{os.sep}"
    for backend, found in lines.items():
        for name, why in found:
            print(f"[{backend}] {name}: {why.replace(prefix, '')}")
    for backend, found in lines.items():
        if not found:
            continue
        groups_of: dict[str, list[str]] = {}
        for name, why in found:
            groups_of.setdefault(cause(why), []).append(name)
        print(f"[{backend}] by cause:")
        for kind, names in sorted(groups_of.items(), key=lambda kv: -len(kv[1])):
            print(f"  {len(names)}: {kind} (e.g. {names[0]})")
    print(f"({elapsed:.0f} s, {args.workers} workers)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
