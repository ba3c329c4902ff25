"""External (contact) wrenches from contact points, in MuJoCo's ``cfrc_ext`` convention
(engine-free; :meth:`simbridge.backend.Backend.external_forces` and the backends use it).

A wrench is 6 numbers, torque then force (N m, N), in the world frame, the torque taken about
one point: the centre of mass of the whole body the link belongs to (MuJoCo's
``subtree_com[rootid]``). A contact point's force on A is its normal force along
``normal_on_b`` plus its two friction forces along their directions; it acts at the middle of
the point's two positions (MuJoCo's contact position); B takes the opposite force at the same
point, so a body touching itself gets both.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence

import numpy as np

from simbridge.types import ContactPoint

__all__ = ["centre_of_mass", "external_wrenches"]


def external_wrenches(
    points: Iterable[ContactPoint],
    row_of: Callable[[int, int], int],
    rows: int,
    centre: Sequence[float] | np.ndarray,
) -> np.ndarray:
    """The contact wrenches on each row (a link, or a MuJoCo body) of one body.

    Args:
        points: contact points, A and B in any order (the engine's).
        row_of: ``(body, link) -> row`` of the output, or -1 for a link of another body.
        rows: the number of rows.
        centre: ``(3,)`` the point the torques are taken about (m, world).

    Returns:
        ``(rows, 6)`` float64: per row the sum of ``[(p - centre) x f, f]`` over the points
        on it, ``f`` the force on it (N), ``p`` the point (m, world); zeros where none.
    """
    out = np.zeros((rows, 6))
    sides: list[int] = []  # per point and side: the row, or -1
    signs: list[float] = []
    fields: list[Sequence[float]] = []  # per point: on A, on B, normal, dir 1, dir 2, forces
    for c in points:
        ra, rb = row_of(c.body_a, c.link_a), row_of(c.body_b, c.link_b)
        if ra < 0 and rb < 0:
            continue
        sides += (ra, rb)
        signs += (1.0, -1.0)
        fields += (
            c.position_on_a,
            c.position_on_b,
            c.normal_on_b,
            c.lateral_friction_dir_1,
            c.lateral_friction_dir_2,
            (c.normal_force, c.lateral_friction_1, c.lateral_friction_2),
        )
    if not sides:
        return out
    raw = np.asarray(fields, dtype=np.float64).reshape(-1, 6, 3)  # (k, 6, 3)
    on_a = raw[:, 5, 0:1] * raw[:, 2] + raw[:, 5, 1:2] * raw[:, 3] + raw[:, 5, 2:3] * raw[:, 4]
    at = 0.5 * (raw[:, 0] + raw[:, 1]) - np.asarray(centre, dtype=np.float64)  # (k, 3)
    force = np.repeat(on_a, 2, axis=0) * np.asarray(signs)[:, None]  # (2k, 3): A's, then B's
    arm = np.repeat(at, 2, axis=0)
    wrench = np.concatenate((np.cross(arm, force), force), axis=1)  # (2k, 6)
    idx = np.asarray(sides)
    keep = idx >= 0
    np.add.at(out, idx[keep], wrench[keep])
    return out


def centre_of_mass(masses: Sequence[float], centres: Sequence[Sequence[float]]) -> np.ndarray:
    """The mass-weighted mean of the links' centres of mass.

    Args:
        masses: ``(n,)`` kg, the base first.
        centres: ``(n, 3)`` each link's centre of mass (m, world).

    Returns:
        ``(3,)`` (m, world); the base's centre where the masses sum to 0 (a massless body).
    """
    m = np.asarray(masses, dtype=np.float64)
    c = np.asarray(centres, dtype=np.float64).reshape(-1, 3)
    total = float(m.sum())
    if total <= 0.0:
        return c[0].copy()
    return (m @ c) / total
