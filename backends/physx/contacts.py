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
    """A unit vector perpendicular to each row of ``n`` (``(k, 3)`` unit normals -> ``(k, 3)``):
    ``n`` crossed with x, or with y where ``n`` is within 26 degrees of x (the products of
    ``np.cross(n, axis)``, written out)."""
    n0, n1, n2 = n[:, 0], n[:, 1], n[:, 2]
    near_x = np.abs(n0) >= 0.9
    y = near_x.astype(float)  # the axis's y (1 where near x), its x is 1 - y, its z 0
    x = 1.0 - y
    d = np.empty_like(n)
    d[:, 0] = n1 * 0.0 - n2 * y
    d[:, 1] = n2 * x - n0 * 0.0
    d[:, 2] = n0 * y - n1 * x
    return d / np.sqrt(_dot(d, d))[:, None]


def _dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Row-wise dot products of two ``(k, 3)`` arrays -> ``(k,)``, summed x, y, z in turn."""
    return u[:, 0] * v[:, 0] + u[:, 1] * v[:, 1] + u[:, 2] * v[:, 2]


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Row-wise cross products of two ``(k, 3)`` arrays -> ``(k, 3)``."""
    out = np.empty_like(u)
    out[:, 0] = u[:, 1] * v[:, 2] - u[:, 2] * v[:, 1]
    out[:, 1] = u[:, 2] * v[:, 0] - u[:, 0] * v[:, 2]
    out[:, 2] = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    return out


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
        pairs: list[tuple[int, int, int, int]] = []  # (body A, body B, link A, link B)
        fields: list[Any] = []  # per point: position, normal, impulse (3 each), separation
        for contact in self._scene.get_contacts():
            a = owners.get(id(contact.bodies[0]))
            b = owners.get(id(contact.bodies[1]))
            if a is None or b is None:
                continue
            for point in contact.points:
                pairs.append((a[0], b[0], a[1], b[1]))
                fields.extend((point.position, point.normal, point.impulse))
                fields.append((point.separation, 0.0, 0.0))
        if not pairs:
            return []
        return self._points(pairs, np.array(fields, dtype=float).reshape(-1, 4, 3), rest)

    def _points(
        self, pairs: list[tuple[int, int, int, int]], raw: np.ndarray, rest: float
    ) -> list[ContactPoint]:
        """The points, all at once: ``pairs`` (body A, body B, link A, link B) per point and
        ``raw`` ``(k, 4, 3)``: PhysX's position (on B), normal (on B), impulse (N s) and
        separation (``raw[:, 3, 0]``, m) per point."""
        on_b = raw[:, 0]  # (k, 3)
        n = raw[:, 1]  # (k, 3)
        force = raw[:, 2] * (1.0 / self._dt)  # (k, 3) N
        normal_force = _dot(force, n)  # (k,)
        tangential = force - normal_force[:, None] * n  # (k, 3)
        size = np.sqrt(_dot(tangential, tangential))  # (k,)
        moving = size > 0.0  # PhysX gives no friction impulse: mostly not
        d1 = tangential / np.where(moving, size, 1.0)[:, None]
        if not moving.all():
            d1 = np.where(moving[:, None], d1, _perpendicular(n))
        d2 = _cross(n, d1)
        dist = raw[:, 3, 0] - rest  # (k,)
        on_a = on_b + dist[:, None] * n
        pushed = np.where(normal_force < 0.0, 0.0, normal_force)  # max(f, 0.0): -0.0 kept
        rows = zip(
            pairs,
            on_a.tolist(),
            on_b.tolist(),
            n.tolist(),
            dist.tolist(),
            pushed.tolist(),
            size.tolist(),
            d1.tolist(),
            d2.tolist(),
            strict=True,
        )
        return [
            ContactPoint(
                0,
                ba,
                bb,
                la,
                lb,
                tuple(pa),
                tuple(pb),
                tuple(nb),
                d,
                f,
                fs,
                tuple(t1),
                0.0,
                tuple(t2),
            )  # fmt: skip
            for (ba, bb, la, lb), pa, pb, nb, d, f, fs, t1, t2 in rows
        ]

    def _keep_contacts_but(self, body: int) -> None:
        """Before ``body`` is removed: the last step's points less its own, read while every
        component they name is alive, are what ``contact_points`` gives until the next step
        (as PyBullet's, which drops the removed body's manifolds and keeps the others)."""
        kept = [c for c in self._last_contacts() if body not in (c.body_a, c.body_b)]
        self._contacts_kept = kept
        self._contacts_cache = None
