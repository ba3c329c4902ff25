"""Hashes of every shipped scenario's recorded trajectories, per backend and MuJoCo step loop.

``python tests/_trajectory_hashes.py > tests/data/trajectory_hashes.json`` records them (it runs
itself again under ``SIMBRIDGE_MUJOCO_STEP=python`` and refuses to record unless the Python
step loop gives the compiled loop's bits);
tests/test_same_results.py checks the tree still produces them bit for bit. They were
recorded before the MuJoCo backend became the ``backends/mujoco/`` package (issue 11): a
change that only moves code must leave every number of every step as it was.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys

import numpy as np

from simbridge.compare.run.recording import run
from simbridge.compare.run.trajectory import _BODY_ARRAYS, Trajectory
from simbridge.compare.scenario import list_scenarios


def trajectory_hash(traj: Trajectory) -> str:
    """sha256 over the time column and every recorded array of every body, as raw bytes."""
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(traj.time, dtype=np.float64).tobytes())
    for name in sorted(traj.bodies):
        body = traj.bodies[name]
        h.update(name.encode())
        for key in (*_BODY_ARRAYS, "joint_modes"):
            arr = np.ascontiguousarray(getattr(body, key))
            h.update(key.encode())
            h.update(str(arr.shape).encode())
            h.update(arr.tobytes())
    return h.hexdigest()


HORIZON = {"r2d2-goto": 7.0}
"""s: scenarios hashed over their first seconds only. r2d2-goto's 20 s of three robots were
three quarters of the hashes' CPU (8.9 s on PyBullet, 6.4 on MuJoCo's compiled loop, 11.3 on
PhysX of 36 s in all, measured 2026-11-29); its first robot reaches its goal at 6.60 s on
PyBullet, 6.66 on MuJoCo and 6.84 on PhysX, so within 7 s every branch of goto.py (turn, drive,
stop) runs on every engine. Recorded again on its own for this (the other hashes unchanged)."""


def all_hashes(backends: tuple[str, ...] = ("pybullet", "mujoco")) -> dict[str, str]:
    """``{"<scenario>/<backend>": sha256}`` for every shipped scenario read as PyBullet reads
    it (a model read as MuJoCo reads it steps with raw ``mj_step``, neither step loop: it is
    held to raw MuJoCo bit for bit by tests/compare/scenario/test_mujoco_reading_scenarios.py),
    over the first :data:`HORIZON` seconds where the scenario is listed there."""
    return {
        f"{sc.name}/{backend}": trajectory_hash(run(sc, backend, duration=HORIZON.get(sc.name)))
        for sc in list_scenarios()
        if all(r.semantics == "pybullet" for r in sc.robots)
        for backend in backends
    }


def _kuka_script(backend: str) -> str:
    """Not a shipped scenario: a fixed KUKA iiwa under position, then velocity, then torque
    commands, each joint's state hashed every step (guards the motor table's code paths)."""
    import simbridge

    h = hashlib.sha256()
    with simbridge.Sim(backend) as sim:
        arm = sim.load_urdf("kuka_iiwa/model.urdf", fixed_base=True)
        joints = list(range(sim.num_joints(arm)))
        for k in range(240):
            q = [0.5 * np.sin(0.02 * k + j) for j in joints]
            sim.set_joint_position(arm, joints, q, max_force=300.0)
            sim.step()
            h.update(sim.joint_states(arm).positions.tobytes())
        for _ in range(120):
            sim.set_joint_velocity(arm, joints, [0.3 * (-1) ** j for j in joints], max_force=50.0)
            sim.step()
            s = sim.joint_states(arm)
            h.update(s.positions.tobytes() + s.velocities.tobytes() + s.applied_torques.tobytes())
        sim.set_joint_velocity(arm, joints, 0.0, max_force=0.0)
        for k in range(120):
            sim.set_joint_torque(arm, joints, [5.0 * np.cos(0.05 * k + j) for j in joints])
            sim.step()
            h.update(repr(sim.link_state(arm, joints[-1])).encode())
    return h.hexdigest()


def all_extras(backends: tuple[str, ...] = ("pybullet", "mujoco")) -> dict[str, str]:
    return {f"kuka-script/{b}": _kuka_script(b) for b in backends}


def engine_versions() -> dict[str, str]:
    import mujoco
    import pybullet

    return {"mujoco": mujoco.__version__, "pybullet_api": str(pybullet.getAPIVersion())}


def physx_version() -> str | None:
    """SAPIEN's version where the PhysX backend can run here, else None."""
    from simbridge.registry import unavailable_reason

    if unavailable_reason("physx") is not None:
        return None
    import sapien

    return str(sapien.__version__)


def physx_hashes() -> dict[str, str]:
    """Every shipped scenario and the KUKA script on PhysX (CPU PhysX 5 through SAPIEN: the
    same bits over fresh runs and in two processes, measured)."""
    return {**all_hashes(("physx",)), **all_extras(("physx",))}


if __name__ == "__main__":
    if sys.argv[1:] == ["--mujoco-only"]:  # the loop SIMBRIDGE_MUJOCO_STEP chooses
        json.dump({**all_hashes(("mujoco",)), **all_extras(("mujoco",))}, sys.stdout)
        sys.exit(0)
    if sys.argv[1:] == ["--physx-only"]:  # what tests/test_same_results.py checks in a child
        json.dump(physx_hashes(), sys.stdout)
        sys.exit(0)
    # the record: the Python loop must give the compiled loop's bits (it is checked, not
    # recorded: tests/test_same_results.py)
    python_loop = subprocess.run(
        [sys.executable, __file__, "--mujoco-only"],
        env=dict(os.environ, SIMBRIDGE_MUJOCO_STEP="python"),
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    compiled = {**all_hashes(), **all_extras()}
    differ = {k for k, v in json.loads(python_loop).items() if compiled[k] != v}
    if differ:
        sys.exit(f"the Python step loop differs from the compiled loop on {sorted(differ)}")
    from _machine import libm  # beside this file

    record: dict[str, object] = {
        "engines": engine_versions(),
        "libm": libm(),
        "compiled": compiled,
    }
    sapien_version = physx_version()
    if sapien_version is not None:
        # PhysX's hashes, recorded apart: they need the physx extra and SAPIEN's exact build
        record["physx"] = {"sapien": sapien_version, "hashes": physx_hashes()}
    json.dump(record, sys.stdout, indent=2)
    print()
