"""The spawn-pose offsets of an ensemble's members: seeded directions (:func:`directions`), their
sizes per engine (:func:`engine_perturbation`: raised for a float32 state), and the scenario
moved by them (:func:`perturbed`). :mod:`.ensemble`'s docstring says how they are drawn."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from simbridge.transforms import quat_multiply

from ..scenario import Scenario
from .portable import length, norm

__all__ = [
    "FLOAT_SPACINGS",
    "directions",
    "engine_perturbation",
    "offsets",
    "perturbed",
    "scaled",
]


def _unit_vectors(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    v = rng.standard_normal(shape + (3,))
    return v / norm(v, keepdims=True)


def directions(size: int, robots: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The unit directions of an ensemble's offsets, ``(positions, rotation axes)`` each
    (size, robots, 3), drawn from ``numpy.random.default_rng(seed)`` (row 0 too, then unused:
    the nominal run); every engine of a comparison gets these same directions."""
    rng = np.random.default_rng(seed)
    return _unit_vectors(rng, (size, robots)), _unit_vectors(rng, (size, robots))


def scaled(
    units: tuple[np.ndarray, np.ndarray], eps_m: float, eps_rad: float
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`directions` made offsets of length ``eps_m`` and ``eps_rad``, row 0 zero."""
    dpos = units[0] * eps_m
    drot = units[1] * eps_rad
    dpos[0] = 0.0
    drot[0] = 0.0
    return dpos, drot


def offsets(
    size: int, robots: int, eps_m: float, eps_rad: float, seed: int
) -> tuple[np.ndarray, np.ndarray]:
    """The spawn-pose offsets of an ensemble: ``(positions (size, robots, 3) m, rotation
    vectors (size, robots, 3) rad)``, row 0 zero (the nominal run), every other row of length
    exactly ``eps_m`` and ``eps_rad`` in directions drawn from
    ``numpy.random.default_rng(seed)`` (:func:`directions`)."""
    return scaled(directions(size, robots, seed), eps_m, eps_rad)


FLOAT_SPACINGS = 8
"""A perturbation is at least this many spacings of the engine's state type at the scenario's
largest spawn coordinate (:func:`engine_perturbation`)."""


def engine_perturbation(
    requested: tuple[float, float], state_dtype: str, scenario: Scenario
) -> tuple[float, float]:
    """The perturbation ``(m, rad)`` an engine keeping its state in ``state_dtype`` gets: for
    the position ``max(requested m, FLOAT_SPACINGS x the type's spacing at x)``, x the
    scenario's largest spawn coordinate (the largest absolute value of a component of any
    robot's spawn position); for the orientation ``max(requested rad, FLOAT_SPACINGS x the
    type's spacing at 1)`` (a quaternion's components reach 1).

    Why: the engine stores the spawn pose in its type, so an offset component below half a
    spacing there is rounded away and one above it is rounded to a whole spacing: a float32
    engine (spacing 1.19e-7 at 1 m, 7.5e-9 at 0.1 m) cannot see a 1e-9 m offset of a
    coordinate near 1 m, and the offsets it does see are not the sizes asked for. With
    ``FLOAT_SPACINGS`` = 8 spacings each component is off by at most 1/16 of the offset, the
    stored offset by at most sqrt(3)/16 = 11% of its length. Measured on r2d2 (spawn z 0.1 m,
    PhysX, 8 runs, seed 0; the spread of the base position at the end, 4.08 s): 1.71 mm at
    1e-9 m / rad and 1.66 mm at 1e-8 (below float32's spacing the spread does not follow the
    size asked for: it is float32's rounding of the spawn pose), 9.0 mm at 1.2e-7, 4.78 cm at
    1.2e-6; at this rule's 5.96e-8 m / 9.54e-7 rad, 6.03 cm (docs/compare.md, "A float32
    engine's perturbation"). For float64 (spacing 2.2e-16 at 1)
    the requested 1e-9 stands: PyBullet and MuJoCo keep the sizes asked for, and every engine
    keeps the same random directions (:func:`directions`)."""
    kind = np.dtype(state_dtype).type
    extent = max((abs(float(c)) for r in scenario.robots for c in r.position), default=0.0)
    position = FLOAT_SPACINGS * float(np.spacing(kind(extent)))
    orientation = FLOAT_SPACINGS * float(np.spacing(kind(1.0)))
    return max(requested[0], position), max(requested[1], orientation)


def perturbed(scenario: Scenario, dpos: np.ndarray, drot: np.ndarray) -> Scenario:
    """``scenario`` with robot r's spawn position moved by ``dpos[r]`` (m, world) and its
    orientation turned by the rotation vector ``drot[r]`` (rad, world frame, applied after the
    spawn orientation)."""
    robots = []
    for r, spec in enumerate(scenario.robots):
        angle = length(drot[r])
        if angle > 0:
            axis = drot[r] / angle
            s = math.sin(angle / 2)
            dq = (axis[0] * s, axis[1] * s, axis[2] * s, math.cos(angle / 2))
            orientation = quat_multiply(dq, spec.orientation)
        else:
            orientation = tuple(spec.orientation)  # type: ignore[assignment]
        x, y, z = (float(p + d) for p, d in zip(spec.position, dpos[r], strict=True))
        position = (x, y, z)
        robots.append(replace(spec, position=position, orientation=orientation))
    return replace(scenario, robots=tuple(robots))
