"""The MuJoCo backend's contact points (backends/mujoco/contacts.py, each contact converted in
Python floats) against the array version it used before (every contact at once on ``(n, 3)``
arrays), kept here as the reference: bit for bit, signed zeros included, over r2d2 driven on
the plane (its wheels resting, rolling and sliding) and a box resting on a slope (contacts
with friction across the normal)."""

from __future__ import annotations

import math

import mujoco
import numpy as np

import simbridge
from simbridge.backends.mujoco import inspect
from simbridge.backends.mujoco.contacts import contact_points_of
from simbridge.transforms import quat_rotate

SLOPE = """<robot name="slope"><link name="slope">
<inertial><mass value="0"/><inertia ixx="0" iyy="0" izz="0" ixy="0" ixz="0" iyz="0"/></inertial>
<collision><geometry><box size="4 4 0.2"/></geometry></collision></link></robot>"""


def _array_version(m, d, owner: np.ndarray, link: np.ndarray) -> list[tuple]:
    """The points as the backend computed them before its per-contact floats, flattened."""
    n = d.ncon
    if n == 0:
        return []
    con = d.contact
    geom = con.geom[:n]
    dist = con.dist[:n] - con.includemargin[:n]
    pos = con.pos[:n]
    frame = con.frame[:n]
    adr = con.efc_address[:n]
    force = np.zeros((n, 6))
    for i in range(n):
        if adr[i] >= 0:
            mujoco.mj_contactForce(m, d, i, force[i])
    normal = frame[:, 0:3]
    on_a = pos - normal * (0.5 * dist)[:, None]
    on_b = pos + normal * (0.5 * dist)[:, None]
    out = []
    for i in range(n):
        ba, bb = owner[geom[i, 0]], owner[geom[i, 1]]
        if ba < -1 or bb < -1:
            continue
        la, lb = link[geom[i, 0]], link[geom[i, 1]]
        out.append(
            (0, int(ba), int(bb), int(la), int(lb), *on_a[i], *on_b[i], *(-normal[i]), dist[i])
            + (force[i, 0], force[i, 1], *(-frame[i, 3:6]), force[i, 2], *(-frame[i, 6:9]))
        )
    return out


def _flat(p) -> tuple:
    out = []
    for x in p:
        out.extend(x if isinstance(x, tuple) else (x,))
    return tuple(out)


def _same_bits(sim: simbridge.Sim) -> int:
    """Checks the last step's points against the array version; returns how many."""
    m, d = inspect.model_and_data(sim)
    owner, link = inspect.backend_of(sim)._geom_owners()
    got = [_flat(p) for p in contact_points_of(m, d, owner, link)]
    want = _array_version(m, d, owner, link)
    assert len(got) == len(want)
    for g, w in zip(got, want, strict=True):
        assert g[:5] == w[:5]
        assert all(type(x) is float for x in g[5:])
        assert np.array(g[5:]).tobytes() == np.array(w[5:], dtype=float).tobytes(), (g, w)
    assert [_flat(p) for p in sim.contact_points()] == got  # what the Sim gives
    return len(got)


def test_a_driven_r2d2_bit_for_bit():
    with simbridge.Sim("mujoco") as sim:
        sim.load_urdf("plane.urdf")
        r2d2 = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
        seen = 0
        for k in range(400):
            v = 8.0 * np.sin(k / 60.0)
            sim.set_joint_velocity(r2d2, [2, 3, 6, 7], [v, v, -v, -v], max_force=50.0)
            sim.step()
            seen += _same_bits(sim)
    assert seen > 500  # r2d2 lands and rolls: points on most steps


def test_a_box_resting_on_a_slope_bit_for_bit():
    """tests/conformance/test_contacts.py's slope: 10 degrees, the box set on it, friction
    holding it (forces across the normal)."""
    tilt = (math.sin(math.radians(5)), 0.0, 0.0, math.cos(math.radians(5)))
    normal = np.asarray(quat_rotate(tilt, (0.0, 0.0, 1.0)))
    with simbridge.Sim("mujoco") as sim:
        sim.load_urdf(SLOPE, fixed_base=True, base_orientation=tilt)
        sim.load_urdf("free_box.urdf", base_position=tuple(normal * 0.3005), base_orientation=tilt)
        seen = held = 0
        for _ in range(240):
            sim.step()
            seen += _same_bits(sim)
            held += sum(1 for p in sim.contact_points() if p.lateral_friction_1 != 0.0)
    assert seen > 500 and held > 500, (seen, held)
