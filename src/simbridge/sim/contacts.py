"""Choosing and orienting contact points as ``p.getContactPoints`` does (engine-free).

A backend reports every contact point of the last step once, in its own order
(:meth:`simbridge.backend.Backend.contact_points`); :func:`select` keeps those a query asks for
and turns each so that the asked body (and link) is A.
"""

from __future__ import annotations

from collections.abc import Iterable

from simbridge.types import ContactPoint

__all__ = ["select"]


def _matches(c: ContactPoint, a: int, la: int | None, b: int | None, lb: int | None) -> bool:
    return (
        c.body_a == a
        and (la is None or c.link_a == la)
        and (b is None or c.body_b == b)
        and (lb is None or c.link_b == lb)
    )


def select(
    points: Iterable[ContactPoint],
    body_a: int | None,
    link_a: int | None,
    body_b: int | None,
    link_b: int | None,
) -> tuple[ContactPoint, ...]:
    """The points between ``body_a`` (its link ``link_a``) and ``body_b`` (its link
    ``link_b``), None meaning any, each oriented with ``body_a`` as A; all points as the engine
    gave them when ``body_a`` is None. A point matching in both orientations (a robot touching
    itself) is kept once, in the engine's order. The caller checks that a link filter comes
    with its body.

    Args:
        points: every contact point of the last step, as the backend reports them.
        body_a: a body id; None: every point, as given.
        link_a: a link index of ``body_a`` (-1 = base); None: any.
        body_b: a body id; None: any.
        link_b: a link index of ``body_b``; None: any.

    Returns:
        The matching points, ``body_a`` as A.
    """
    pts = tuple(points)
    if body_a is None:
        return pts
    out: list[ContactPoint] = []
    for c in pts:
        if c.body_a == body_a and _matches(c, body_a, link_a, body_b, link_b):
            out.append(c)
        elif c.body_b == body_a:
            s = c.swapped()
            if _matches(s, body_a, link_a, body_b, link_b):
                out.append(s)
    return tuple(out)
