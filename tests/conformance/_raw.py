"""Raw PyBullet as the reference: what ``p.loadURDF`` itself gives for a file (joint table, link
frames at spawn, dynamics), and comparisons of a `Sim` body with it.

Link frames from ``getLinkState`` are float32-rounded by PyBullet (``KNOWN_GAPS``
``link_state_float32``), so frames are compared to 2e-7 relative; the joint table and masses,
computed in double precision by both, to 1e-9.
"""

from __future__ import annotations

import functools
import math
import os
import tempfile
from dataclasses import dataclass
from typing import Any

import numpy as np
import pybullet_data
from _gaps import gap

import simbridge
from simbridge.engine_output import captured

DATA = pybullet_data.getDataPath()
TABLE_TOL = 1e-9
FRAME_REL = 2e-7


@functools.cache
def _client() -> Any:
    with captured("pybullet", "importing"):
        import pybullet as p
    with captured("pybullet", "connecting"):
        return p, p.connect(p.DIRECT)


@dataclass
class RawBody:
    """What raw PyBullet loaded: the ``getJointInfo`` rows, each link's URDF frame in the
    world (base first), ``getDynamicsInfo`` per link (base first), and the body id."""

    table: list[tuple[Any, ...]]
    frames: list[tuple[tuple[float, ...], tuple[float, ...]]]
    dynamics: list[tuple[Any, ...]]
    body: int


def raw_load(
    source: str,
    *,
    base_position=(0.0, 0.0, 0.0),
    base_orientation=(0.0, 0.0, 0.0, 1.0),
    fixed_base: bool = False,
    flags: int = 0,
    global_scaling: float | None = None,
    keep: bool = False,
) -> RawBody:
    """``p.loadURDF`` on a path or on URDF text (written to a temporary file beside nothing:
    meshes must be absolute). The body is removed again unless ``keep``."""
    p, c = _client()
    path, temp = source, None
    if "<" in source:  # URDF text, not a path
        fd, temp = tempfile.mkstemp(prefix="simbridge_raw_", suffix=".urdf")
        with os.fdopen(fd, "w") as f:
            f.write(source)
        path = temp
    kwargs = {} if global_scaling is None else {"globalScaling": global_scaling}
    try:
        with captured("pybullet", "raw load"):
            body = p.loadURDF(
                path,
                base_position,
                base_orientation,
                useFixedBase=fixed_base,
                flags=flags,
                physicsClientId=c,
                **kwargs,
            )
    finally:
        if temp:
            os.unlink(temp)
    n = p.getNumJoints(body, physicsClientId=c)
    table = []
    for i in range(n):
        row = list(p.getJointInfo(body, i, physicsClientId=c))
        row[1], row[12] = row[1].decode(), row[12].decode()
        table.append(tuple(row))
    base = p.getBasePositionAndOrientation(body, physicsClientId=c)
    local = p.getDynamicsInfo(body, -1, physicsClientId=c)[3:5]
    frames = [p.multiplyTransforms(*base, *p.invertTransform(*local))]
    frames += [
        tuple(p.getLinkState(body, i, computeForwardKinematics=1, physicsClientId=c)[4:6])
        for i in range(n)
    ]
    dynamics = [p.getDynamicsInfo(body, i, physicsClientId=c) for i in range(-1, n)]
    if not keep:
        p.removeBody(body, physicsClientId=c)
    return RawBody(table, frames, dynamics, body)


def raw_client() -> Any:
    """(pybullet module, client id) of the shared raw connection."""
    return _client()


def close(a: Any, b: Any, tol: float) -> bool:
    """Every element of ``a`` within ``tol`` of ``b``'s."""
    return bool(np.allclose(np.asarray(a, float), np.asarray(b, float), rtol=0.0, atol=tol))


def same_quat(a: Any, b: Any, tol: float) -> bool:
    """The same rotation: quaternions equal to ``tol`` up to sign."""
    return close(a, b, tol) or close(a, -np.asarray(b, float), tol)


def table_difference(got: list[Any], raw: list[tuple[Any, ...]]) -> str | None:
    """None when the 17 fields of every row agree (floats to 1e-9, the parent frame's
    quaternion with its sign: Bullet's ``getRotation`` picks it, and so does the joint table),
    else the first difference."""
    if len(got) != len(raw):
        return f"{len(got)} joints, raw PyBullet {len(raw)}"
    for k, (g, r) in enumerate(zip(got, raw, strict=True)):
        for f in range(13):
            same = (
                math.isclose(g[f], r[f], rel_tol=0.0, abs_tol=TABLE_TOL)
                if isinstance(r[f], float)
                else g[f] == r[f]
            )
            if not same:
                return f"joint {k} field {f}: {g[f]!r}, raw {r[f]!r}"
        if g[16] != r[16]:
            return f"joint {k} parent {g[16]}, raw {r[16]}"
        if not close(g[13], r[13], TABLE_TOL) or not close(g[14], r[14], TABLE_TOL):
            return f"joint {k} axis, parent frame position {g[13]}, {g[14]}; raw {r[13]}, {r[14]}"
        if not close(g[15], r[15], TABLE_TOL):
            return f"joint {k} parent frame orientation {g[15]}, raw {r[15]}"
    return None


def sim_frames(sim: simbridge.Sim, body: int) -> list[tuple[Any, Any]]:
    """Every link's URDF frame in the world, base first."""
    out = []
    for i in range(-1, sim.num_joints(body)):
        s = sim.link_state(body, i)
        out.append((s.link_frame_position, s.link_frame_orientation))
    return out


def frame_rel(backend: str) -> float:
    """How close ``backend``'s link frames at load must be to raw PyBullet's, relative to
    max(1, |position|): PyBullet's float32 rounding (2e-7), or the backend's measured gap."""
    size = gap(backend, "link_frames_vs_raw")
    return FRAME_REL if size is None else size


def largest_frame_error(got: list[Any], raw: list[Any]) -> float:
    """The largest difference between a link frame and raw PyBullet's: position relative to
    max(1, |position|), quaternion components up to sign (what :func:`frames_difference` holds
    to ``rel``)."""
    worst = 0.0
    for (gp, go), (rp, ro) in zip(got, raw, strict=True):
        scale = max(1.0, float(np.abs(rp).max()))
        position = float(np.abs(np.subtract(gp, rp)).max()) / scale
        turn = min(float(np.abs(np.subtract(go, ro)).max()), float(np.abs(np.add(go, ro)).max()))
        worst = max(worst, position, turn)
    return worst


def frames_difference(got: list[Any], raw: list[Any], rel: float = FRAME_REL) -> str | None:
    """None when every link frame agrees to ``rel`` relative (PyBullet's float32 rounding,
    2e-7, unless a backend's :func:`frame_rel` says more)."""
    if len(got) != len(raw):
        return f"{len(got)} links, raw {len(raw)}"
    for k, ((gp, go), (rp, ro)) in enumerate(zip(got, raw, strict=True)):
        tol = rel * max(1.0, float(np.abs(rp).max()))
        if not close(gp, rp, tol) or not same_quat(go, ro, rel):
            return f"link {k - 1} frame {gp}, {go}; raw {rp}, {ro}"
    return None


def dynamics_difference(sim: simbridge.Sim, body: int, raw: list[Any], rel: float) -> str | None:
    """None when every link's mass, principal moments and inertial frame agree with raw
    PyBullet's (moments to ``rel`` relative)."""
    for k, r in enumerate(raw):
        d = sim.dynamics_info(body, k - 1)
        if not math.isclose(d.mass, r[0], rel_tol=1e-12, abs_tol=1e-15):
            return f"link {k - 1} mass {d.mass}, raw {r[0]}"
        scale = max(1e-12, float(np.abs(r[2]).max()))
        if not close(d.local_inertia_diagonal, r[2], rel * scale):
            return f"link {k - 1} inertia {d.local_inertia_diagonal}, raw {r[2]}"
        if not close(d.local_inertial_position, r[3], TABLE_TOL) or not same_quat(
            d.local_inertial_orientation, r[4], 1e-7
        ):
            return (
                f"link {k - 1} inertial frame {d.local_inertial_position}, "
                f"{d.local_inertial_orientation}; raw {r[3]}, {r[4]}"
            )
    return None
