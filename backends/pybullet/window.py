"""PyBullet's own window for ``Sim(gui=True)``: its camera on the robots, loads without redraws.

Drawing is paused while bodies are made: the window redraws after every visual shape made,
which makes a load many times slower (the figures: docs/pybullet_backend.md, "The window").
The side panels and their synthetic camera previews are hidden (``g`` in the window shows
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
PENDING_STEPS = 100  # step calls a camera set here may wait to be shown (then: moved by hand)


class Window:
    """The GUI connection ``c``'s camera and drawing.

    Args:
        c: The PyBullet client id of the GUI connection.
    """

    def __init__(self, c: int) -> None:
        self._c = c
        self._centre: tuple[float, float, float] | None = None
        # the camera last set here, until the window shows it: PyBullet's window takes a new
        # camera at its next frame, and read back before that it gives the old one
        self._pending: tuple[float, list[float]] | None = None
        self._waited = 0
        p.configureDebugVisualizer(p.COV_ENABLE_GUI, 0, physicsClientId=c)

    @contextmanager
    def paused(self) -> Iterator[None]:
        """No redraws while bodies are made.

        Yields:
            Nothing; rendering is off until the ``with`` block ends.
        """
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
        """Look at the robots from a distance that fits them (after a load).

        Args:
            bodies: ``(body id, whether its base is free)`` of each body in the world.
        """
        lo, hi = self._robots(bodies)
        if not all(math.isfinite(v) for v in lo + hi):
            self._centre = None
            return
        centre = tuple((a + b) / 2 for a, b in zip(lo, hi, strict=True))
        size = math.dist(lo, hi)
        if size > 50:  # a ground plane alone: PyBullet's own view of the origin
            centre, size = (0.0, 0.0, 0.0), 2.5
        self._centre = (centre[0], centre[1], centre[2])
        self._set(max(MIN_DISTANCE, 1.6 * size), YAW, PITCH, list(self._centre))

    def _set(self, distance: float, yaw: float, pitch: float, target: list[float]) -> None:
        p.resetDebugVisualizerCamera(distance, yaw, pitch, target, physicsClientId=self._c)
        self._pending, self._waited = (distance, target), 0

    def follow(self, bodies: Iterable[tuple[int, bool]]) -> None:
        """Move the camera with the robots (after a step), keeping the user's angle and zoom.

        Args:
            bodies: ``(body id, whether its base is free)`` of each body in the world.
        """
        if self._centre is None:
            return
        lo, hi = self._robots(bodies)
        if not all(math.isfinite(v) for v in lo + hi) or math.dist(lo, hi) > 50:
            return
        now = tuple((a + b) / 2 for a, b in zip(lo, hi, strict=True))
        info = p.getDebugVisualizerCamera(physicsClientId=self._c)
        yaw, pitch, distance, target = info[8], info[9], info[10], info[11]
        if self._pending is not None:
            want_distance, want_target = self._pending
            shown = abs(distance - want_distance) < 1e-3 and math.dist(target, want_target) < 1e-3
            self._waited += 1
            if not shown and self._waited < PENDING_STEPS:
                return  # not drawn yet: what reads back is the camera before it
            self._pending = None
        moved = [t + n - o for t, n, o in zip(target, now, self._centre, strict=True)]
        self._centre = (now[0], now[1], now[2])
        self._set(distance, yaw, pitch, moved)
