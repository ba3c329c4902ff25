"""Contact points of the last step in PyBullet's terms (``Backend.contact_points``).

MuJoCo keeps the contacts its last step found in ``d.contact`` (found at the start of the step)
and their forces in ``d.efc_force``; ``mj_contactForce`` turns a contact's pyramid-edge forces
into a force in the contact frame (normal first, then the two tangents), the force geom 1 puts
on geom 2. Each contact becomes one :class:`~simbridge.types.ContactPoint` with A = geom 1's link
and B = geom 2's (the Sim orients them as asked):

* a geom's link comes from model.py's record of the collision geoms (``RobotSpec.geoms``);
* ``normal_on_b`` is minus MuJoCo's normal (which points from geom 1 to geom 2);
* ``distance`` is MuJoCo's ``dist`` less the contact's ``includemargin`` (the pair margin, 1
  mm, that stands in for PyBullet's collision margin), so 0 is where the force starts, as in
  PyBullet; the points on A and B lie ``distance / 2`` either side of MuJoCo's contact point
  along the normal, so ``position_on_a = position_on_b + distance * normal_on_b``;
* the friction directions are minus MuJoCo's tangents, the forces along them MuJoCo's: the
  friction force on A.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, NoReturn

import mujoco
import numpy as np

from simbridge.exceptions import SimulationDivergedError
from simbridge.types import ContactPoint

from ..locking import exclusive
from .robots import Compiled, Robot

__all__ = ["ContactReads", "contact_points_of"]


class ContactReads:
    """``contact_points`` (a part of :class:`MujocoBackend`)."""

    if TYPE_CHECKING:  # provided by MujocoBackend
        _robots: dict[int, Robot]
        _diverged: SimulationDivergedError | None

        @property
        def _w(self) -> Compiled: ...

        def _engine_failed(self, detail: str) -> NoReturn: ...

        def _py_mark(self) -> None: ...

    # (compile, owner body id per geom, link per geom): rebuilt when the world is recompiled
    _geom_owner_cache: tuple[Compiled, np.ndarray, np.ndarray] | None = None

    def _geom_owners(self) -> tuple[np.ndarray, np.ndarray]:
        """Per MuJoCo geom: the body id and PyBullet link index of its robot (-1, -2 for a
        geom that is no collision geom of a robot)."""
        c = self._w
        cached = self._geom_owner_cache
        if cached is not None and cached[0] is c:
            return cached[1], cached[2]
        m = c.m
        owner = np.full(m.ngeom, -2, np.intp)
        link = np.full(m.ngeom, -2, np.intp)
        for robot in self._robots.values():
            for g in robot.spec.geoms:
                gid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, g.name)
                if gid >= 0:
                    owner[gid] = robot.id
                    link[gid] = g.link
        self._geom_owner_cache = (c, owner, link)
        return owner, link

    @exclusive
    def contact_points(self) -> list[ContactPoint]:
        """See Backend.contact_points.

        MuJoCo: ``d.contact`` of the last step, as the module says.
        """
        c = self._w
        if c.kernel is not None:  # refused from a MuJoCo callback inside the step
            c.kernel.check_idle()
        elif self._diverged is not None:
            raise self._diverged
        else:
            self._py_mark()
        owner, link = self._geom_owners()
        return contact_points_of(c.m, c.d, owner, link)


def contact_points_of(m: Any, d: Any, owner: np.ndarray, link: np.ndarray) -> list[ContactPoint]:
    """The contact points of MuJoCo's ``d.contact`` (the last step's), as PyBullet gives them.

    Args:
        m: The compiled model.
        d: Its data after a step.
        owner: (ngeom,) the simbridge body of each geom: -1 for the world's own geoms (a
            model read as MuJoCo reads it: its floor), -2 for a geom of no body (skipped).
        link: (ngeom,) the PyBullet link index of each geom in its body (-1: the base).

    Returns:
        One point per MuJoCo contact between two geoms of bodies: the points on A and B, B's
        normal (from B to A), the distance (margin taken off), the normal force and the two
        friction forces along their directions.
    """
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
    geom, pos, frame = geom.copy(), pos.copy(), frame.copy()  # views into d: taken now
    normal = frame[:, 0:3]
    on_a = pos - normal * (0.5 * dist)[:, None]
    on_b = pos + normal * (0.5 * dist)[:, None]
    rows = zip(
        owner[geom[:, 0]].tolist(),
        owner[geom[:, 1]].tolist(),
        link[geom[:, 0]].tolist(),
        link[geom[:, 1]].tolist(),
        on_a.tolist(),
        on_b.tolist(),
        (-normal).tolist(),
        dist.tolist(),
        force[:, 0:3].tolist(),
        (-frame[:, 3:6]).tolist(),
        (-frame[:, 6:9]).tolist(),
        strict=True,
    )
    out: list[ContactPoint] = []
    for body_a, body_b, link_a, link_b, pa, pb, nb, dd, f, t1, t2 in rows:
        if body_a < -1 or body_b < -1:
            continue  # a geom of no body (-2)
        out.append(
            ContactPoint(
                0,
                body_a,
                body_b,
                link_a,
                link_b,
                tuple(pa),
                tuple(pb),
                tuple(nb),
                dd,
                f[0],
                f[1],
                tuple(t1),
                f[2],
                tuple(t2),
            )
        )
    return out
