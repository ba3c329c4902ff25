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

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, NoReturn, TypeVar

import mujoco
import numpy as np

from simbridge.exceptions import SimulationDivergedError
from simbridge.types import ContactPoint

from ..locking import exclusive
from .robots import Compiled, Robot

__all__ = ["ContactReads", "contact_points_of"]

_T = TypeVar("_T", bound=tuple[Any, ...])
# a NamedTuple from a tuple, without the Python __new__ it is given
_new_tuple: Callable[[type[_T], tuple[Any, ...]], _T] = tuple.__new__


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
    _geom_owner_cache: tuple[Compiled, list[int], list[int]] | None = None

    def _geom_owners(self) -> tuple[list[int], list[int]]:
        """Per MuJoCo geom: the body id and PyBullet link index of its robot (-2, -2 for a
        geom that is no collision geom of a robot), as lists (looked up per contact)."""
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
        self._geom_owner_cache = (c, owner.tolist(), link.tolist())
        return self._geom_owner_cache[1], self._geom_owner_cache[2]

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


def contact_points_of(m: Any, d: Any, owner: list[int], link: list[int]) -> list[ContactPoint]:
    """The contact points of MuJoCo's ``d.contact`` (the last step's), as PyBullet gives them.

    Args:
        m: The compiled model.
        d: Its data after a step.
        owner: per geom (ngeom ints), the simbridge body of each geom: -1 for the world's own
            geoms (a model read as MuJoCo reads it: its floor), -2 for a geom of no body
            (skipped).
        link: per geom (ngeom ints), the PyBullet link index of each geom in its body (-1: the
            base).

    Returns:
        One point per MuJoCo contact between two geoms of bodies: the points on A and B, B's
        normal (from B to A), the distance (margin taken off), the normal force and the two
        friction forces along their directions.
    """
    n = d.ncon
    if n == 0:
        return []
    con = d.contact
    geoms = con.geom[:n].tolist()  # (n, 2): geom 1, geom 2
    adr = con.efc_address[:n].tolist()
    force = np.zeros((n, 6))
    for i in range(n):
        if adr[i] >= 0:
            mujoco.mj_contactForce(m, d, i, force[i])
    # each contact in Python floats (a few contacts: numpy's per-call cost on (n, 3) arrays
    # was most of the call), the operations of the array version this replaced: the same bits
    rows = zip(
        geoms,
        con.dist[:n].tolist(),
        con.includemargin[:n].tolist(),
        con.pos[:n].tolist(),
        con.frame[:n].tolist(),
        force.tolist(),
        strict=True,
    )
    out: list[ContactPoint] = []
    add = out.append
    for (g1, g2), dist, margin, (px, py, pz), fr, f in rows:
        body_a, body_b = owner[g1], owner[g2]
        if body_a < -1 or body_b < -1:
            continue  # a geom of no body (-2)
        link_a, link_b = link[g1], link[g2]
        dist -= margin
        half = 0.5 * dist
        nx, ny, nz = fr[0], fr[1], fr[2]  # MuJoCo's normal, from geom 1 to geom 2
        hx, hy, hz = nx * half, ny * half, nz * half
        # fmt: off
        add(_new_tuple(ContactPoint, (
            0, body_a, body_b, link_a, link_b,
            (px - hx, py - hy, pz - hz), (px + hx, py + hy, pz + hz), (-nx, -ny, -nz), dist,
            f[0], f[1], (-fr[3], -fr[4], -fr[5]), f[2], (-fr[6], -fr[7], -fr[8]),
        )))
        # fmt: on
    return out
