"""Which of pybullet_data's MJCF and SDF files load, raw and through simbridge, and do they agree?
And what MuJoCo's own reading of each MJCF file would simulate that PyBullet's does not.

For every ``mjcf/*.xml`` and ``**/*.sdf`` under pybullet_data (or the files named on the command
line): load it with raw PyBullet (``p.loadMJCF``/``p.loadSDF``) in a fresh process (a crash costs
that file only; the joint names PyBullet makes up are then a first load's), with
``Sim("pybullet")`` and with ``Sim("mujoco")``; compare every body's joint table (the 17
fields, names exactly; floats to 1e-9, quaternions up to sign) and every link's world frame (to
2e-7 relative: PyBullet's ``getLinkState`` rounds to float32). The PhysX column: every file both
load as raw PyBullet does is loaded on ``Sim("physx")`` too (where SAPIEN is installed) and
compared the same way, its link frames to 1e-6 relative (float32 state:
``FRAME_REL_BY_BACKEND``). Prints the counts, then every file that fails or differs with its
reason.

``--departures`` prints, per MJCF file, MuJoCo's own reading (``mujoco.MjModel.from_xml_path``:
the file's density, joint damping and armature, time step, integrator, free joints) beside the
model simbridge simulates on both engines (PyBullet's reading): what loading the file natively in
MuJoCo would change.

    python bench/mjcf_sdf_coverage.py                   # all 41 files (about 15 s on 2 cores)
    python bench/mjcf_sdf_coverage.py mjcf/ant.xml --departures

Measured (pybullet 3.2.7, mujoco 4.0.0, SAPIEN 3.0.3; the shared 2-core machine):
38 of the 41 files load on Sim("pybullet") and Sim("mujoco") with raw PyBullet's joint tables and
link frames (72 bodies), the 3 others refused by raw PyBullet too; physx: 38/38 load with the
same tables and frames (72 bodies), 0 listed. 130 s on the loaded machine (physx branch at
87381f5; at 62ccff4, before the links were placed at load, 16/38).
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
from typing import Any

import numpy as np
import pybullet_data

import simbridge
from simbridge.exceptions import SimbridgeError
from simbridge.registry import unavailable_reason

DATA = pybullet_data.getDataPath()
TOL = 1e-9
FRAME_REL = 2e-7
# Link frames on PhysX, whose state is float32: bench/urdf_coverage.py's FRAME_REL_BY_BACKEND
# says why
FRAME_REL_BY_BACKEND = {"physx": 1e-6}

_RAW = """
import json, sys, pybullet as p
c = p.connect(p.DIRECT)
path = sys.argv[1]
ids = p.loadMJCF(path) if path.endswith(".xml") else p.loadSDF(path)
out = []
for b in ids:
    n = p.getNumJoints(b)
    rows = []
    for i in range(n):
        r = list(p.getJointInfo(b, i)); r[1] = r[1].decode(); r[12] = r[12].decode(); rows.append(r)
    base = p.getBasePositionAndOrientation(b)
    local = p.getDynamicsInfo(b, -1)[3:5]
    frames = [p.multiplyTransforms(*base, *p.invertTransform(*local))]
    frames += [p.getLinkState(b, i, computeForwardKinematics=1)[4:6] for i in range(n)]
    out.append({"table": rows, "frames": frames})
print("RAW" + json.dumps(out))
"""


def all_files() -> list[str]:
    mjcf = glob.glob(os.path.join(DATA, "mjcf", "*.xml"))
    sdf = glob.glob(os.path.join(DATA, "**", "*.sdf"), recursive=True)
    return sorted(os.path.relpath(f, DATA) for f in mjcf) + sorted(
        os.path.relpath(f, DATA) for f in sdf
    )


def raw_load(name: str) -> list[dict[str, Any]] | str:
    """Raw PyBullet's bodies, or why it failed."""
    run = subprocess.run(
        [sys.executable, "-c", _RAW, os.path.join(DATA, name)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    if "RAW" in run.stdout:
        return json.loads(run.stdout.split("RAW", 1)[1].splitlines()[0])  # type: ignore[no-any-return]
    if run.returncode < 0:
        return f"raw PyBullet died (signal {-run.returncode})"
    last = (run.stderr.strip().splitlines() or ["?"])[-1]
    return f"raw PyBullet refuses it: {last}"


def _close(a: Any, b: Any, tol: float) -> bool:
    return bool(np.allclose(np.asarray(a, float), np.asarray(b, float), rtol=0.0, atol=tol))


def table_difference(got: list[Any], raw: list[list[Any]]) -> str | None:
    if len(got) != len(raw):
        return f"{len(got)} joints, raw {len(raw)}"
    for k, (g, r) in enumerate(zip(got, raw, strict=True)):
        for f in (*range(13), 16):
            same = (
                math.isclose(g[f], r[f], rel_tol=0.0, abs_tol=TOL)
                if isinstance(r[f], float)
                else g[f] == r[f]
            )
            if not same:
                return f"joint {k} field {f}: {g[f]!r}, raw {r[f]!r}"
        if not _close(g[13], r[13], TOL) or not _close(g[14], r[14], TOL):
            return f"joint {k} axis or parent frame position"
        if not (_close(g[15], r[15], TOL) or _close(g[15], -np.asarray(r[15]), TOL)):
            return f"joint {k} parent frame orientation {g[15]}, raw {r[15]}"
    return None


def frames_difference(sim: simbridge.Sim, body: int, raw: list[Any]) -> str | None:
    rel = FRAME_REL_BY_BACKEND.get(sim.backend, FRAME_REL)
    for k, (rp, ro) in enumerate(raw):
        s = sim.link_state(body, k - 1)
        tol = rel * max(1.0, float(np.abs(rp).max()))
        go = s.link_frame_orientation
        if not _close(s.link_frame_position, rp, tol) or not (
            _close(go, ro, rel) or _close(go, -np.asarray(ro), rel)
        ):
            gp = s.link_frame_position
            if float(np.abs(gp).max()) < 1e-6 < float(np.abs(rp).max()):
                return f"link {k - 1} frame at the world origin at load: {gp}, raw {rp}"
            return f"link {k - 1} frame {gp}, raw {rp} (beyond {rel:g} relative)"
    return None


def physx_check(name: str, raw: list[dict[str, Any]]) -> tuple[str, str]:
    """PhysX's load of a file both other backends load as raw PyBullet does: ('ok', bodies)
    or ('refused' | 'differs', the reason)."""
    kind = "mjcf" if name.endswith(".xml") else "sdf"
    with simbridge.Sim("physx") as sim:
        load = sim.load_mjcf if kind == "mjcf" else sim.load_sdf
        try:
            ids = load(os.path.join(DATA, name))
        except SimbridgeError as exc:
            return "refused", f"{type(exc).__name__}: {exc}".replace(f"{DATA}{os.sep}", "")
        if len(ids) != len(raw):
            return "differs", f"{len(ids)} bodies, raw {len(raw)}"
        for body, r in zip(ids, raw, strict=True):
            why = table_difference(sim.joints(body), r["table"]) or frames_difference(
                sim, body, r["frames"]
            )
            if why:
                return "differs", f"body {body}: {why}"
    return "ok", f"{len(ids)} bodies"


def check(name: str, physx: bool = False) -> tuple[str, str, tuple[str, str] | None]:
    """(status, detail, PhysX's): status 'ok', 'differs', 'both refuse', 'refused' (simbridge
    only) for Sim("pybullet") and Sim("mujoco"); with ``physx``, where they are 'ok',
    :func:`physx_check`'s (status, detail), else None."""
    raw = raw_load(name)
    status, detail = _check_two(name, raw)
    if status != "ok" or not physx:
        return status, detail, None
    assert not isinstance(raw, str)
    return status, detail, physx_check(name, raw)


def _check_two(name: str, raw: list[dict[str, Any]] | str) -> tuple[str, str]:
    kind = "mjcf" if name.endswith(".xml") else "sdf"
    results = []
    for backend in ("pybullet", "mujoco"):
        with simbridge.Sim(backend) as sim:
            try:
                load = sim.load_mjcf if kind == "mjcf" else sim.load_sdf
                ids = load(os.path.join(DATA, name))
            except SimbridgeError as exc:
                if isinstance(raw, str):
                    return "both refuse", f"{raw}; simbridge: {type(exc).__name__}: {exc}"
                return "refused", f"{backend}: {type(exc).__name__}: {exc}"
            if isinstance(raw, str):
                return "differs", f"{raw}, but simbridge loads it"
            if len(ids) != len(raw):
                return "differs", f"{backend}: {len(ids)} bodies, raw {len(raw)}"
            for body, r in zip(ids, raw, strict=True):
                why = table_difference(sim.joints(body), r["table"]) or frames_difference(
                    sim, body, r["frames"]
                )
                if why:
                    return "differs", f"{backend} body {body}: {why}"
            results.append(len(ids))
    return "ok", f"{results[0]} bodies"


# ---------------------------------------------------------------- departures


def departures(name: str) -> str:
    """MuJoCo's own reading of an MJCF file against simbridge's (PyBullet's)."""
    import mujoco

    from simbridge.model.inertia import model_inertials
    from simbridge.model.scene_reader import parse_scene

    path = os.path.join(DATA, name)
    try:
        m = mujoco.MjModel.from_xml_path(path)
    except ValueError as exc:
        native = f"MuJoCo refuses it: {str(exc).splitlines()[0]}"
    else:
        free = int((m.jnt_type == mujoco.mjtJoint.mjJNT_FREE).sum())
        integrator = mujoco.mjtIntegrator(m.opt.integrator).name.removeprefix("mjINT_")
        native = (
            f"mass {m.body_mass.sum():.4g} kg, {m.nv} dof ({free} free joints), damping "
            f"{m.dof_damping.sum():.3g}, armature {m.dof_armature.sum():.3g} (summed over dofs), "
            f"dt {m.opt.timestep:g} s, {integrator}"
        )
    bodies = parse_scene(path, "mjcf")
    mass = sum(i.mass for b in bodies for i in model_inertials(b, False, "collision_aabb"))
    dof = sum(j.type != "fixed" for b in bodies for j in b.joints)
    free = sum(b.base.inertial.mass > 0 for b in bodies)
    ours = (
        f"mass {mass:.4g} kg, {dof} joints + {free} free bases, no damping or armature, "
        "dt and integrator the Sim's"
    )
    return f"{name}\n    MuJoCo's own reading: {native}\n    simbridge (PyBullet's): {ours}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("files", nargs="*", help="files under pybullet_data (default: all)")
    parser.add_argument("--departures", action="store_true", help="MuJoCo's own reading")
    args = parser.parse_args()
    logging.basicConfig(level=logging.ERROR)
    files = args.files or all_files()
    if args.departures:
        for name in files:
            if name.endswith(".xml"):
                print(departures(name))
        return 0
    t0 = time.perf_counter()
    physx = unavailable_reason("physx") is None
    results = {name: check(name, physx) for name in files}
    counts: dict[str, int] = {}
    for status, _, _ in results.values():
        counts[status] = counts.get(status, 0) + 1
    mj = sum(1 for f in files if f.endswith(".xml"))
    print(
        f"{len(files)} files ({mj} MJCF, {len(files) - mj} SDF) in {time.perf_counter() - t0:.0f} "
        f"s: " + ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
    )
    print(
        f"bodies equal to raw PyBullet's on both backends: "
        f"{sum(int(d.split()[0]) for s, d, _ in results.values() if s == 'ok')}"
    )
    for name, (status, detail, _) in results.items():
        if status != "ok":
            print(f"  {name}: {status}: {detail}")
    if not physx:
        print(f"physx: not run ({unavailable_reason('physx')})")
        return 0 if counts.get("ok", 0) + counts.get("both refuse", 0) == len(files) else 1
    held = {name: px for name, (s, _, px) in results.items() if px is not None}
    same = [name for name, px in held.items() if px[0] == "ok"]
    print(
        f"physx: {len(same)}/{len(held)} of the files both pybullet and mujoco load as raw "
        f"PyBullet does load with the same joint tables and link frames "
        f"({sum(int(held[n][1].split()[0]) for n in same)} bodies); "
        f"{len(held) - len(same)} listed with reasons"
    )
    for name, px in held.items():
        if px[0] != "ok":
            print(f"  [physx] {name}: {px[0]}: {px[1]}")
    ok = counts.get("ok", 0) + counts.get("both refuse", 0) == len(files)
    # PhysX may refuse what it cannot build (BackendUnsupportedError, its reason said); any
    # other refusal or difference fails the run
    px_ok = all(
        px[0] == "ok" or px[1].startswith("BackendUnsupportedError") for px in held.values()
    )
    return 0 if ok and px_ok else 1


if __name__ == "__main__":
    sys.exit(main())
