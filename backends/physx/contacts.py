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
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from simbridge.exceptions import SimulationDivergedError
from simbridge.types import ContactPoint

from ..locking import exclusive
from .model import REST_OFFSET
from .robots import Robot

__all__ = ["ContactReads"]

# two shapes rest this far apart (the sum of their rest offsets, model.py): distance 0 there
REST = 2.0 * REST_OFFSET


def _perpendicular(n: np.ndarray) -> np.ndarray:
    a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    d = np.cross(n, a)
    return d / np.linalg.norm(d)


def _vec(v: Any) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


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
        inv_dt = 1.0 / self._dt
        # the engine setting rest_offset, where the profile sets one (settings_physx.py)
        given = self.profile.engine("physx").get("rest_offset")
        rest = REST if given is None else 2.0 * float(given)
        out: list[ContactPoint] = []
        for contact in self._scene.get_contacts():
            a = owners.get(id(contact.bodies[0]))
            b = owners.get(id(contact.bodies[1]))
            if a is None or b is None:
                continue
            for point in contact.points:
                n = np.asarray(point.normal, dtype=float)
                impulse = np.asarray(point.impulse, dtype=float) * inv_dt
                normal_force = float(np.dot(impulse, n))
                tangential = impulse - normal_force * n
                size = float(np.linalg.norm(tangential))
                d1 = tangential / size if size > 0.0 else _perpendicular(n)
                d2 = np.cross(n, d1)
                dist = float(point.separation) - rest
                on_b = np.asarray(point.position, dtype=float)
                on_a = on_b + dist * n
                out.append(
                    ContactPoint(
                        0,
                        a[0],
                        b[0],
                        a[1],
                        b[1],
                        _vec(on_a),
                        _vec(on_b),
                        _vec(n),
                        dist,
                        max(normal_force, 0.0),
                        size,
                        _vec(d1),
                        0.0,
                        _vec(d2),
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
