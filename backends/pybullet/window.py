"""PyBullet's own window for ``Sim(gui=True)``: its camera on the robots, loads without redraws.

Measured under Xvfb (Mesa llvmpipe, 2 loaded cores): with the window drawing, loading r2d2
took 17-19 s (a redraw per visual shape made); with drawing paused during the load, well under
1 s. The side panels and their synthetic camera previews are hidden (``g`` in the window shows
them again), so the window is the scene.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from contextlib import contextmanager

import pybullet as p

__all__ = ["Window"]

YAW, PITCH = 50.0, -35.0  # PyBullet's own start view
MIN_DISTANCE = 1.0  # metres


class Window:
    """The GUI connection ``c``'s camera and drawing."""

    def __init__(self, c: int) -> None:
        self._c = c
        self._centre: tuple[float, float, float] | None = None
        p.configureDebugVisualizer(p.COV_ENABLE_GUI, 0, physicsClientId=c)

    @contextmanager
    def paused(self) -> Iterator[None]:
        """No redraws while bodies are made."""
        p.configureDebugVisualizer(p.COV_ENABLE_RENDERING, 0, physicsClientId=self._c)
        try:
            yield
        finally:
            p.configureDebugVisualizer(p.COV_ENABLE_RENDERING, 1, physicsClientId=self._c)

    def _robots(self, bodies: Iterable[tuple[int, bool]]) -> tuple[list[float], list[float]]:
        """The bounding box of the free bodies, else of every body (``(id, free)`` pairs)."""
        c = self._c
        listed = list(bodies)
        chosen = [b for b, free in listed if free] or [b for b, _ in listed]
        lo, hi = [math.inf] * 3, [-math.inf] * 3
        for b in chosen:
            for link in range(-1, p.getNumJoints(b, physicsClientId=c)):
                a, z = p.getAABB(b, link, physicsClientId=c)
                lo = [min(x, y) for x, y in zip(lo, a, strict=True)]
                hi = [max(x, y) for x, y in zip(hi, z, strict=True)]
        return lo, hi

    def aim(self, bodies: Iterable[tuple[int, bool]]) -> None:
        """Look at the robots from a distance that fits them (after a load)."""
        lo, hi = self._robots(bodies)
        if not all(math.isfinite(v) for v in lo + hi):
            self._centre = None
            return
        centre = tuple((a + b) / 2 for a, b in zip(lo, hi, strict=True))
        size = math.dist(lo, hi)
        if size > 50:  # a ground plane alone: PyBullet's own view of the origin
            centre, size = (0.0, 0.0, 0.0), 2.5
        self._centre = (centre[0], centre[1], centre[2])
        p.resetDebugVisualizerCamera(
            max(MIN_DISTANCE, 2.0 * size), YAW, PITCH, self._centre, physicsClientId=self._c
        )

    def follow(self, bodies: Iterable[tuple[int, bool]]) -> None:
        """Move the camera with the robots (after a step), keeping the user's angle and zoom."""
        if self._centre is None:
            return
        lo, hi = self._robots(bodies)
        if not all(math.isfinite(v) for v in lo + hi) or math.dist(lo, hi) > 50:
            return
        now = tuple((a + b) / 2 for a, b in zip(lo, hi, strict=True))
        info = p.getDebugVisualizerCamera(physicsClientId=self._c)
        yaw, pitch, distance, target = info[8], info[9], info[10], info[11]
        moved = [t + n - o for t, n, o in zip(target, now, self._centre, strict=True)]
        self._centre = (now[0], now[1], now[2])
        p.resetDebugVisualizerCamera(distance, yaw, pitch, moved, physicsClientId=self._c)
