"""Sim.render: a picture of the world, drawn by PyBullet's TinyRenderer on the CPU (no display,
no GPU); the other backends refuse it by name."""

from __future__ import annotations

import numpy as np
import pytest

import simbridge
from simbridge.exceptions import BackendUnsupportedError, InvalidArgumentError

EYE, TARGET = (1.2, -1.2, 1.0), (0.0, 0.0, 0.5)


def _blue(img: np.ndarray) -> int:
    """Pixels of r2d2's blue body (the plane is light grey and pale blue)."""
    r, g, b = (img[..., k].astype(int) for k in range(3))
    return int(np.count_nonzero((b > 100) & (r < 60) & (g < 60)))


def test_render_draws_the_robot_and_sees_it_move():
    with simbridge.Sim("pybullet") as sim:
        sim.load_urdf("plane.urdf")
        empty = sim.render(160, 120, eye=EYE, target=TARGET)
        robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
        img = sim.render(160, 120, eye=EYE, target=TARGET)
        assert img.shape == (120, 160, 3) and img.dtype == np.uint8
        assert _blue(empty) == 0 and _blue(img) > 300  # the robot, not only the ground
        sim.reset_base_state(robot, position=(0.6, 0.0, 0.5))
        moved = sim.render(160, 120, eye=EYE, target=TARGET)
        assert np.abs(moved.astype(int) - img).sum(axis=2).astype(bool).mean() > 0.02


@pytest.mark.parametrize(
    "kwargs, argument",
    [
        ({"width": 0}, "width"),
        ({"height": 5000}, "height"),
        ({"width": 32.0}, "width"),
        ({"eye": TARGET}, "eye"),
        ({"up": (-1.2, 1.2, -0.5)}, "up"),  # along the line of sight
        ({"fov": 180.0}, "fov"),
        ({"target": (0, 0, float("nan"))}, "target"),
    ],
)
def test_render_refuses_bad_arguments_by_name(kwargs, argument):
    args = {"width": 32, "height": 24, "eye": EYE, "target": TARGET, **kwargs}
    with simbridge.Sim("pybullet") as sim, pytest.raises(InvalidArgumentError) as e:
        sim.render(args.pop("width"), args.pop("height"), **args)
    assert e.value.argument == argument


@pytest.mark.parametrize("backend", [b for b in simbridge.available_backends() if b != "pybullet"])
def test_other_backends_refuse_to_render_by_name(backend):
    from _engines import require_backend

    require_backend(backend)
    with simbridge.Sim(backend) as sim, pytest.raises(BackendUnsupportedError, match="pybullet"):
        sim.render(32, 24, eye=EYE, target=TARGET)
