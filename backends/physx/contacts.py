"""Contact points of the last step in PyBullet's terms (``Backend.contact_points``).

``scene.get_contacts()`` gives the contact pairs PhysX reported for its last step, each with
its two components and points (position, normal, impulse, separation). Each point becomes one
:class:`~simbridge.types.ContactPoint` with A = the first component's link, B = the second's:

* PhysX's normal points from the second shape towards the first: it is ``normal_on_b``;
* ``distance`` is PhysX's separation less the two shapes' rest offsets (1 mm, standing in for
  PyBullet's collision margin), so 0 is where the force starts; the point PhysX gives is taken
  as the point on B, ``position_on_a = position_on_b + distance * normal_on_b``;
* the normal force is PhysX's impulse over the step (impulse / dt) along the normal. PhysX
  reports no friction impulse per point (SAPIEN 3.0.3): the friction fields are 0, along an
  arbitrary frame perpendicular to the normal (a departure).

SAPIEN 3.0.3 reads a contact's points one attribute at a time (each vector a new numpy array;
there is no batched read on the CPU system), so each point is converted where it is read, in
Python floats (:func:`_point`): for the few points a robot's feet or wheels make, numpy's
per-call cost over whole arrays cost more than the arithmetic itself (r2d2 resting on a plane,
16 points: 104 µs a call in arrays, 62 in floats, of which 39 are SAPIEN's own reads).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from simbridge.exceptions import SimulationDivergedError
from simbridge.types import ContactPoint

from ..locking import exclusive
from .model import REST_OFFSET
from .robots import Robot

__all__ = ["ContactReads"]

# two shapes rest this far apart (the sum of their rest offsets, model.py): distance 0 there
REST = 2.0 * REST_OFFSET


_T = TypeVar("_T", bound=tuple[Any, ...])
# a NamedTuple from a tuple, without the Python __new__ it is given (as reads.py)
_new_tuple: Callable[[type[_T], tuple[Any, ...]], _T] = tuple.__new__
_sqrt = math.sqrt


def _point(
    pair: tuple[int, int, int, int],
    position: list[float],
    normal: list[float],
    impulse: list[float],
    separation: float,
    inv_dt: float,
    rest: float,
) -> ContactPoint:
    """One PhysX point as a ContactPoint: ``pair`` (body A, body B, link A, link B), PhysX's
    position (on B, m), normal (on B, unit) and impulse (N s) as 3 floats each, its separation
    (m), ``1 / dt`` (1/s) and the rest distance (m, distance 0 there).

    Plain float arithmetic, the operations in the order of the array version it replaced
    (dot products summed x, y, z in turn; a cross product's terms as ``np.cross``): the same
    bits (tests/backends/physx/test_physx_contacts.py). Where the impulse has no part across
    the normal (PhysX gives none: mostly), friction direction 1 is ``normal x axis``
    normalised, the axis x, or y where the normal is within 26 degrees of x."""
    px, py, pz = position
    nx, ny, nz = normal
    fx = impulse[0] * inv_dt  # N
    fy = impulse[1] * inv_dt
    fz = impulse[2] * inv_dt
    f = fx * nx + fy * ny + fz * nz  # along the normal
    tx = fx - f * nx  # across it
    ty = fy - f * ny
    tz = fz - f * nz
    size = _sqrt(tx * tx + ty * ty + tz * tz)
    if size > 0.0:
        d0, d1, d2 = tx / size, ty / size, tz / size
    else:  # normal x (1 - y, y, 0), y = 1 near x: the terms of np.cross, zeros included
        y = 1.0 if abs(nx) >= 0.9 else 0.0
        x = 1.0 - y
        d0 = ny * 0.0 - nz * y
        d1 = nz * x - nx * 0.0
        d2 = nx * y - ny * x
        norm = _sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        if norm == 0.0:  # a normal of length 0 (never a unit one): numpy's 0 / 0, as before
            d0, d1, d2 = (np.array([d0, d1, d2]) / norm).tolist()
        else:
            d0, d1, d2 = d0 / norm, d1 / norm, d2 / norm
    dist = separation - rest
    return _new_tuple(
        ContactPoint,
        (
            0,
            *pair,
            (px + dist * nx, py + dist * ny, pz + dist * nz),
            (px, py, pz),
            (nx, ny, nz),
            dist,
            0.0 if f < 0.0 else f,  # max(f, 0.0), -0.0 kept
            size,
            (d0, d1, d2),
            0.0,
            (ny * d2 - nz * d1, nz * d0 - nx * d2, nx * d1 - ny * d0),  # normal x direction 1
        ),
    )


class ContactReads:
    """``contact_points`` (a part of :class:`PhysxBackend`)."""

    if TYPE_CHECKING:
        _robots: dict[int, Robot]
        _diverged: SimulationDivergedError | None
        _scene: Any
        _dt: float
        _contacts_cache: list[Any] | None
        _contacts_kept: list[ContactPoint] | None
        profile: Any

    def _owners(self) -> dict[int, tuple[int, int]]:
        """id of each PhysX component -> (body id, link index)."""
        out: dict[int, tuple[int, int]] = {}
        for body, robot in self._robots.items():
            if robot.static:
                out[id(robot.built.actor)] = (body, -1)
            else:
                for k, comp in enumerate(robot.built.links):
                    out[id(comp)] = (body, k - 1)
        return out

    @exclusive
    def contact_points(self) -> list[ContactPoint]:
        """See Backend.contact_points. PhysX: the contacts the scene reported for the last step."""
        if self._diverged is not None:
            raise self._diverged
        out = self._last_contacts()
        self._contacts_cache = out
        return out

    def _last_contacts(self) -> list[ContactPoint]:
        """The last step's points: those read already, or since a remove the points kept then
        (the scene's report of that step still names the removed components: reading it
        crashed the process, SAPIEN 3.0.3, a static plane removed under a resting robot), or
        else the scene's report."""
        if self._contacts_cache is not None:
            return self._contacts_cache
        if self._contacts_kept is not None:
            return self._contacts_kept
        owners = self._owners()
        # the engine setting rest_offset, where the profile sets one (settings_physx.py)
        given = self.profile.engine("physx").get("rest_offset")
        rest = REST if given is None else 2.0 * float(given)
        inv_dt = 1.0 / self._dt
        out: list[ContactPoint] = []
        add = out.append
        for contact in self._scene.get_contacts():
            bodies = contact.bodies
            a = owners.get(id(bodies[0]))
            b = owners.get(id(bodies[1]))
            if a is None or b is None:
                continue
            pair = (a[0], b[0], a[1], b[1])
            for q in contact.points:  # each vector read is a new float32 array: as floats
                add(
                    _point(
                        pair,
                        q.position.tolist(),
                        q.normal.tolist(),
                        q.impulse.tolist(),
                        q.separation,
                        inv_dt,
                        rest,
                    )
                )
        return out

    def _keep_contacts_but(self, body: int) -> None:
        """Before ``body`` is removed: the last step's points less its own, read while every
        component they name is alive, are what ``contact_points`` gives until the next step
        (as PyBullet's, which drops the removed body's manifolds and keeps the others)."""
        kept = [c for c in self._last_contacts() if body not in (c.body_a, c.body_b)]
        self._contacts_kept = kept
        self._contacts_cache = None
