"""The `Sim`'s pictures: ``render`` (a part of :class:`simbridge.Sim`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from simbridge.exceptions import InvalidArgumentError
from simbridge.sim.arguments import vec

if TYPE_CHECKING:
    from simbridge.backend import Backend

__all__ = ["Pictures", "MAX_RENDER_SIZE"]

MAX_RENDER_SIZE = 4096
"""Pixels: the largest width or height :meth:`Pictures.render` draws."""


class Pictures:
    """A picture of the world (a part of :class:`Sim`)."""

    if TYPE_CHECKING:  # provided by simbridge.sim.Sim
        _b: Backend

    def render(
        self,
        width: int = 320,
        height: int = 240,
        *,
        eye: Sequence[float],
        target: Sequence[float],
        up: Sequence[float] = (0.0, 0.0, 1.0),
        fov: float = 50.0,
    ) -> np.ndarray:
        """Draw the world as it stands, seen from ``eye`` (m, world) looking at ``target``.

        Args:
            width, height: the picture's size in pixels (1 to 4096 each).
            eye, target: where the camera is and what it looks at (m, world; apart).
            up: the direction that points up in the picture (world; not along eye - target).
            fov: vertical field of view in degrees (more than 0, less than 180).

        Returns:
            A (height, width, 3) ``uint8`` RGB array.

        Raises:
            InvalidArgumentError: a size, point, direction or angle out of range.
            BackendUnsupportedError: a backend that draws no pictures (the PyBullet backend
                draws them on the CPU, on any machine).
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
        return self._b.render(int(width), int(height), e, t, u, float(fov))  # type: ignore[arg-type]
