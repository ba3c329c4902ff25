"""The quantities two runs are compared in (:data:`QUANTITIES`), and what each is computed
from and how (:func:`features`, :func:`distance`): the geometry of one run or two, which the
ensembles and the one-step resync measure as they run, and the analysis's :func:`diff` over
whole runs.

==================== ====== ===============================================================
``base_distance``    m      distance between the two base link-frame positions
``link_distance``    m      the largest distance between the same link's centres of mass (base
                            included)
``heading``          rad    |yaw_a - yaw_b| wrapped to [0, pi] (yaw of the base about world z)
``orientation``      rad    angle of the rotation taking one base orientation to the other
``joint_position_rms`` rad  RMS over movable joints of q_a - q_b (rad or m; unwrapped angles)
``joint_velocity_rms`` rad/s RMS over movable joints of v_a - v_b
==================== ====== ===============================================================
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from .portable import acos, dot, length, norm

__all__ = [
    "DEG",
    "Quantity",
    "QUANTITIES",
    "features",
    "distance",
    "FEATURE_SOURCES",
    "yaw",
    "tilt",
    "tilt_from",
    "rotate",
    "up_axis",
    "up_of",
    "rotation_angle",
]

DEG = math.pi / 180.0


@dataclass(frozen=True)
class Quantity:
    key: str
    title: str
    unit: str  # "m", "rad", "rad/s"
    thresholds: tuple[float, ...]  # in the unit; the first one is where "they part"


QUANTITIES: dict[str, Quantity] = {
    q.key: q
    for q in (
        Quantity("base_distance", "base position distance", "m", (0.01, 0.1, 1.0)),
        Quantity("link_distance", "largest link distance", "m", (0.01, 0.1, 1.0)),
        Quantity("heading", "heading (yaw) difference", "rad", (1 * DEG, 10 * DEG)),
        Quantity("orientation", "base orientation angle", "rad", (1 * DEG, 10 * DEG)),
        Quantity("joint_position_rms", "joint position RMS", "rad", (1 * DEG, 10 * DEG)),
        Quantity("joint_velocity_rms", "joint velocity RMS", "rad/s", (0.1, 1.0, 10.0)),
    )
}


# ---------------------------------------------------------------- rotations, (x, y, z, w)


def yaw(q: np.ndarray) -> np.ndarray:
    """Yaw (rad, about world z, in (-pi, pi]) of quaternions ``q`` (..., 4) x, y, z, w."""
    x, y, z, w = np.moveaxis(np.asarray(q, dtype=np.float64), -1, 0)
    return np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def tilt(q: np.ndarray) -> np.ndarray:
    """Angle (rad) between the body's z axis and world z: 0 upright, pi/2 on its side."""
    x, y, _, _ = np.moveaxis(np.asarray(q, dtype=np.float64), -1, 0)
    return acos(np.clip(1.0 - 2.0 * (x * x + y * y), -1.0, 1.0))


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Vectors ``v`` (..., 3) rotated by quaternions ``q`` (..., 4) x, y, z, w (broadcast)."""
    q = np.asarray(q, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    u, w = q[..., :3], q[..., 3:4]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def up_axis(gravity: Any) -> np.ndarray:
    """The unit vector against ``gravity`` (m/s², world); world z when gravity is zero or
    unknown (None)."""
    g = np.zeros(3) if gravity is None else np.asarray(gravity, dtype=np.float64)
    n = length(g)
    return -g / n if n > 0 else np.array([0.0, 0.0, 1.0])


def tilt_from(q: np.ndarray, q_ref: np.ndarray, up: Any = (0.0, 0.0, 1.0)) -> np.ndarray:
    """Angle (rad, in [0, pi]) between the body axis that pointed ``up`` (world, unit) in the
    reference orientation ``q_ref`` and where that axis points in ``q`` (both x, y, z, w): 0
    while the body stands as it stood at ``q_ref``, pi/2 on its side, whatever its yaw and
    whichever of its own axes is its up (a y-up URDF turned upright included)."""
    up = np.asarray(up, dtype=np.float64)
    q_ref = np.asarray(q_ref, dtype=np.float64)
    conj = q_ref * np.array([-1.0, -1.0, -1.0, 1.0])
    axis = rotate(conj, up)  # the body-frame axis that was up
    now = rotate(q, axis)
    return acos(np.clip(dot(now, up), -1.0, 1.0))


def rotation_angle(qa: np.ndarray, qb: np.ndarray) -> np.ndarray:
    """Angle (rad, in [0, pi]) of the rotation between orientations ``qa`` and ``qb``."""
    qa = np.asarray(qa, dtype=np.float64)
    qb = np.asarray(qb, dtype=np.float64)
    ax, ay, az, aw = np.moveaxis(qa, -1, 0)
    bx, by, bz, bw = np.moveaxis(qb, -1, 0)
    # conj(qa) * qb
    w = aw * bw + ax * bx + ay * by + az * bz
    x = aw * bx - ax * bw - ay * bz + az * by
    y = aw * by + ax * bz - ay * bw - az * bx
    z = aw * bz - ax * by + ay * bx - az * bw
    return 2.0 * np.arctan2(np.sqrt(x * x + y * y + z * z), np.abs(w))


def _wrap(angle: np.ndarray) -> np.ndarray:
    """Into (-pi, pi]."""
    return -((-angle + math.pi) % (2 * math.pi) - math.pi)


# ---------------------------------------------------------------- quantities as distances

FEATURE_SOURCES: dict[str, str] = {
    "base_distance": "base_position",
    "link_distance": "link_positions",
    "heading": "base_orientation",
    "orientation": "base_orientation",
    "joint_position_rms": "joint_positions",
    "joint_velocity_rms": "joint_velocities",
}
"""The :class:`~simbridge.compare.run.BodyTrajectory` array each quantity is computed from."""


def features(quantity: str, source: np.ndarray) -> np.ndarray:
    """What :func:`distance` compares for ``quantity``, from its source array
    (:data:`FEATURE_SOURCES`, rows = recorded instants): the array itself, except ``heading``,
    which takes the yaw (rad) of the (x, y, z, w) orientations. Shapes: base position (T, 3),
    link positions (T, L, 3), yaw (T,), orientation (T, 4), joints (T, J)."""
    if quantity == "heading":
        return yaw(source)
    return np.asarray(source, dtype=np.float64)


def distance(quantity: str, fa: np.ndarray, fb: np.ndarray) -> np.ndarray:
    """``quantity`` between two runs at every instant, from their :func:`features` (any leading
    shape, broadcast): metres between base positions, the largest distance between the same
    link (m), the wrapped yaw difference in [0, pi], the rotation angle between orientations,
    the RMS over joints (rad or m, rad/s or m/s). Shape: the features' less their own axes."""
    if quantity == "base_distance":
        return norm(fa - fb)
    if quantity == "link_distance":
        return np.max(norm(fa - fb), axis=-1)
    if quantity == "heading":
        return np.abs(_wrap(fa - fb))
    if quantity == "orientation":
        return rotation_angle(fa, fb)
    if quantity in ("joint_position_rms", "joint_velocity_rms"):
        if fa.shape[-1] == 0:
            return np.zeros(np.broadcast_shapes(fa.shape, fb.shape)[:-1])
        return np.sqrt(np.mean((fa - fb) ** 2, axis=-1))
    raise KeyError(f"unknown quantity {quantity!r}; quantities: {', '.join(QUANTITIES)}")


class _Recorded(Protocol):
    """What :func:`up_of` reads of a :class:`~simbridge.compare.run.Trajectory` (named by its
    shape: .trajectory imports .outcomes, which imports this module)."""

    manifest: dict[str, Any]


def up_of(tr: _Recorded) -> np.ndarray:
    """The world's up (against the gravity the run had, from its manifest; z when unknown)."""
    return up_axis((tr.manifest.get("profile") or {}).get("gravity"))
