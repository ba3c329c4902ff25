"""The `Sim`'s pictures: ``render``, a function of the Sim's
:class:`~simbridge.sim.shared.Shared` state."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from simbridge.exceptions import InvalidArgumentError
from simbridge.sim.arguments import vec
from simbridge.sim.shared import Shared

__all__ = ["MAX_RENDER_SIZE", "render"]

MAX_RENDER_SIZE = 4096
"""Pixels: the largest width or height :func:`render` draws."""


def render(
    s: Shared,
    width: int,
    height: int,
    eye: Sequence[float],
    target: Sequence[float],
    up: Sequence[float],
    fov: float,
) -> np.ndarray:
    """Draw the world as it stands (:meth:`simbridge.Sim.render`).

    Args:
        s: the Sim's shared state.
        width, height, eye, target, up, fov: as :meth:`simbridge.Sim.render`'s (pixels; m,
            world; degrees).

    Returns:
        A (height, width, 3) ``uint8`` RGB array.

    Raises:
        InvalidArgumentError: a size, point, direction or angle out of range.
        BackendUnsupportedError: a backend that draws no pictures.
    """
    for name, n in (("width", width), ("height", height)):
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)):
            raise InvalidArgumentError(name, f"must be an integer of pixels, got {n!r}")
        if not 1 <= n <= MAX_RENDER_SIZE:
            raise InvalidArgumentError(name, f"must be 1 to {MAX_RENDER_SIZE} pixels, got {n}")
    e = vec(eye, 3, "eye")
    t = vec(target, 3, "target")
    u = vec(up, 3, "up")
    sight = np.subtract(t, e)
    length = float(np.linalg.norm(sight))
    if length == 0.0:
        raise InvalidArgumentError("eye", f"must differ from target, both are {e!r}")
    size = float(np.linalg.norm(u))
    across = 0.0 if size == 0.0 else float(np.linalg.norm(np.cross(sight / length, u))) / size
    if across < 1e-6:
        raise InvalidArgumentError(
            "up", f"must be a direction not along the line of sight, got {u!r}"
        )
    if isinstance(fov, bool) or not isinstance(fov, (int, float, np.number)):
        raise InvalidArgumentError("fov", f"must be a number of degrees, got {fov!r}")
    if not (math.isfinite(fov) and 0.0 < fov < 180.0):
        raise InvalidArgumentError("fov", f"must be more than 0 and less than 180°, got {fov}")
    return s.backend.render(int(width), int(height), e, t, u, float(fov))  # type: ignore[arg-type]
