"""Pictures of the world (a part of
:class:`~simbridge.backends.pybullet.backend.PyBulletBackend`): ``render`` through PyBullet's
TinyRenderer, a CPU rasteriser that needs no display and no GPU, so a picture is drawn alike on
every machine."""

from __future__ import annotations

import math
from contextlib import AbstractContextManager
from typing import TYPE_CHECKING

import numpy as np

from simbridge.types import Vec3

from .output import p  # pybullet, imported with its banner captured

__all__ = ["Rendering"]


class Rendering:
    """The ``Backend.render`` of PyBulletBackend."""

    if TYPE_CHECKING:  # provided by PyBulletBackend
        _c: int

        def _idle(self) -> AbstractContextManager[None]: ...

    def render(
        self,
        width: int,
        height: int,
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        fov: float,
    ) -> np.ndarray:
        """See Backend.render. PyBullet: ``p.getCameraImage`` with TinyRenderer."""
        distance = math.dist(eye, target)
        view = p.computeViewMatrix(eye, target, up, physicsClientId=self._c)
        # near and far planes around the target: the depth buffer's precision where it matters
        proj = p.computeProjectionMatrixFOV(
            fov, width / height, distance * 0.01, distance * 100.0, physicsClientId=self._c
        )
        with self._idle():
            _, _, rgba, _, _ = p.getCameraImage(
                width,
                height,
                view,
                proj,
                renderer=p.ER_TINY_RENDERER,
                flags=p.ER_NO_SEGMENTATION_MASK,
                physicsClientId=self._c,
            )
        pixels = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)
        return np.ascontiguousarray(pixels[:, :, :3])
