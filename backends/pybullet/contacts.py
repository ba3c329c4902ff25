"""Contact points of the last step in PyBullet's terms (``Backend.contact_points``; a part of
:class:`~simbridge.backends.pybullet.backend.PyBulletBackend`): PyBullet's own
``getContactPoints`` rows, checked for non-finite values, as
:class:`~simbridge.types.ContactPoint` records."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from simbridge.exceptions import SimulationDivergedError
from simbridge.types import ContactPoint

from .common import _all_finite, _exclusive
from .output import p  # pybullet, imported with its banner captured

__all__ = ["ContactReads", "contact_point"]


def contact_point(r: tuple[Any, ...]) -> ContactPoint:
    """One row of ``p.getContactPoints()`` as a contact point.

    Unfiltered: PyBullet's own order of A and B, in which the friction fields are the friction force
    on A.

    Args:
        r: PyBullet's row (14 fields).

    Returns:
        The :class:`~simbridge.types.ContactPoint`.
    """
    return ContactPoint(
        int(r[0]), r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8], r[9], r[10], r[11], r[12], r[13]
    )


class ContactReads:
    """``contact_points`` (a part of PyBulletBackend)."""

    if TYPE_CHECKING:  # provided by PyBulletBackend
        _c: int
        _diverged: SimulationDivergedError | None

        def _diverge(self, where: str) -> None: ...

    @_exclusive
    def contact_points(self) -> list[ContactPoint]:
        """See Backend.contact_points.

        PyBullet: ``p.getContactPoints()`` unfiltered; a non-finite value raises
        ``SimulationDivergedError``.
        """
        if self._diverged is not None:
            raise self._diverged
        # unfiltered: PyBullet keeps the friction fields in its own order of A and B when it
        # swaps them to answer a filtered query (Sim.contact_points orients them itself)
        rows = p.getContactPoints(physicsClientId=self._c)
        for r in rows:  # positions, normal, distance, forces and friction directions
            values = (*r[5], *r[6], *r[7], r[8], r[9], r[10], *r[11], r[12], *r[13])
            if not math.isfinite(sum(values)) and not _all_finite(values):
                self._diverge(f"a contact point of bodies {r[1]} and {r[2]}")
        return [contact_point(r) for r in rows]
