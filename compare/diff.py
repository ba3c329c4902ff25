"""How two trajectories part: :func:`diff` and :class:`Divergence`.

Quantities, computed on the subject robot at every common instant:

==================== ====== ===============================================================
``base_distance``    m      distance between the two base link-frame positions
``link_distance``    m      the largest distance between the same link's centres of mass (base
                            included)
``heading``          rad    |yaw_a - yaw_b| wrapped to [0, pi] (yaw of the base about world z)
``orientation``      rad    angle of the rotation taking one base orientation to the other
``joint_position_rms`` rad  RMS over movable joints of q_a - q_b (rad or m; unwrapped angles)
``joint_velocity_rms`` rad/s RMS over movable joints of v_a - v_b
==================== ====== ===============================================================

A threshold is crossed at the first recorded instant whose value is ``>=`` the threshold.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from simbridge.exceptions import SimbridgeError

from .run import BodyTrajectory, Trajectory

__all__ = [
    "Quantity",
    "QUANTITIES",
    "PhaseRow",
    "Divergence",
    "diff",
    "features",
    "distance",
    "FEATURE_SOURCES",
    "yaw",
    "tilt",
    "tilt_from",
    "rotate",
    "up_axis",
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
    return np.arccos(np.clip(1.0 - 2.0 * (x * x + y * y), -1.0, 1.0))


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
    n = float(np.linalg.norm(g))
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
    return np.arccos(np.clip(now @ up, -1.0, 1.0))


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
        return np.linalg.norm(fa - fb, axis=-1)
    if quantity == "link_distance":
        return np.max(np.linalg.norm(fa - fb, axis=-1), axis=-1)
    if quantity == "heading":
        return np.abs(_wrap(fa - fb))
    if quantity == "orientation":
        return rotation_angle(fa, fb)
    if quantity in ("joint_position_rms", "joint_velocity_rms"):
        if fa.shape[-1] == 0:
            return np.zeros(np.broadcast_shapes(fa.shape, fb.shape)[:-1])
        return np.sqrt(np.mean((fa - fb) ** 2, axis=-1))
    raise KeyError(f"unknown quantity {quantity!r}; quantities: {', '.join(QUANTITIES)}")


# ---------------------------------------------------------------- alignment


def _resample(t_src: np.ndarray, values: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Values at times ``t``: the recorded rows where the grids coincide, else linear."""
    dt = t_src[1] - t_src[0] if len(t_src) > 1 else 1.0
    idx = np.rint((t - t_src[0]) / dt).astype(np.intp)
    if (
        idx.min(initial=0) >= 0
        and idx.max(initial=0) < len(t_src)
        and np.allclose(t_src[idx], t, rtol=0, atol=1e-9 * max(1.0, float(t[-1])))
    ):
        return values[idx]
    flat = values.reshape(len(t_src), -1)
    out = np.empty((len(t), flat.shape[1]))
    for k in range(flat.shape[1]):
        out[:, k] = np.interp(t, t_src, flat[:, k])
    return out.reshape((len(t),) + values.shape[1:])


def _resample_quat(t_src: np.ndarray, q: np.ndarray, t: np.ndarray) -> np.ndarray:
    q = q.copy()
    # make consecutive quaternions share a hemisphere before interpolating (nlerp)
    flip = np.cumprod(np.where(np.sum(q[1:] * q[:-1], axis=1) < 0, -1.0, 1.0))
    q[1:] *= flip[:, None]
    out = _resample(t_src, q, t)
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


# ---------------------------------------------------------------- result


@dataclass
class PhaseRow:
    """One phase of the timeline: the quantities at its end and their largest value in it."""

    name: str
    start: float  # s
    end: float  # s
    at_end: dict[str, float]
    max: dict[str, float]


@dataclass
class Divergence:
    """How trajectories ``a`` and ``b`` of the same scenario part, over time.

    ``series[q]`` is the quantity ``q`` (see :data:`QUANTITIES`) at each of ``time``;
    ``crossings[q][threshold]`` the first time it reaches the threshold (None: never)."""

    a: str  # label, e.g. "pybullet @ 1/240 s"
    b: str
    subject: str
    time: np.ndarray  # (T,) s, the common instants
    series: dict[str, np.ndarray]  # quantity -> (T,)
    crossings: dict[str, dict[float, float | None]]
    phases: list[PhaseRow]
    final_pose: dict[str, dict[str, Any]]  # "a"/"b" -> position, yaw, tilt, joints...
    path_a: np.ndarray = field(repr=False, default_factory=lambda: np.empty((0, 3)))
    path_b: np.ndarray = field(repr=False, default_factory=lambda: np.empty((0, 3)))
    joint_names: list[str] = field(default_factory=list)
    joint_units: list[str] = field(default_factory=list)
    """(J,) ``rad`` (revolute, continuous) or ``m`` (prismatic)."""
    joint_gaps: np.ndarray = field(repr=False, default_factory=lambda: np.empty((0, 0)))
    """(T, J) |q_a - q_b| of every movable joint of the subject (rad or m, angles unwrapped)."""
    link_names: list[str] = field(default_factory=list)
    link_gaps: np.ndarray = field(repr=False, default_factory=lambda: np.empty((0, 0)))
    """(T, L) m: distance between the same link's centres of mass, base first."""

    @property
    def final(self) -> dict[str, float]:
        """Every quantity at the last common instant."""
        return {k: float(v[-1]) for k, v in self.series.items()}

    @property
    def maximum(self) -> dict[str, float]:
        return {k: float(np.max(v)) for k, v in self.series.items()}

    def first_crossing(self, quantity: str, threshold: float | None = None) -> float | None:
        """When ``quantity`` first reaches ``threshold`` (default: its first threshold)."""
        thr = QUANTITIES[quantity].thresholds[0] if threshold is None else threshold
        if thr in self.crossings.get(quantity, {}):
            return self.crossings[quantity][thr]
        return _crossing(self.time, self.series[quantity], thr)

    def first_to_diverge(self) -> tuple[str, float, float] | None:
        """``(quantity, threshold, time)`` of the quantity that reaches its first threshold
        earliest (ties: in :data:`QUANTITIES` order); None when none does."""
        best: tuple[str, float, float] | None = None
        for key, q in QUANTITIES.items():
            if key not in self.series:
                continue
            t = self.crossings[key][q.thresholds[0]]
            if t is not None and (best is None or t < best[2]):
                best = (key, q.thresholds[0], t)
        return best

    def to_dict(self) -> dict[str, Any]:
        """Every headline figure, JSON-ready (SI units: m, rad, s)."""
        first = self.first_to_diverge()
        return {
            "a": self.a,
            "b": self.b,
            "subject": self.subject,
            "duration": float(self.time[-1] - self.time[0]),
            "samples": len(self.time),
            "final": self.final,
            "max": self.maximum,
            "crossings": {
                k: [{"threshold": thr, "time": t} for thr, t in v.items()]
                for k, v in self.crossings.items()
            },
            "first_to_diverge": (
                None
                if first is None
                else {"quantity": first[0], "threshold": first[1], "time": first[2]}
            ),
            "phases": [
                {"name": p.name, "start": p.start, "end": p.end, "at_end": p.at_end, "max": p.max}
                for p in self.phases
            ],
            "final_pose": self.final_pose,
        }


def _crossing(time: np.ndarray, values: np.ndarray, threshold: float) -> float | None:
    hit = np.flatnonzero(values >= threshold)
    return float(time[hit[0]]) if hit.size else None


def _pose(body: BodyTrajectory, row: int, up: np.ndarray) -> dict[str, Any]:
    q = body.base_orientation[row]
    return {
        "position": [float(v) for v in body.base_position[row]],
        "orientation": [float(v) for v in q],
        "yaw": float(yaw(q)),
        "tilt": float(tilt(q)),
        "tilt_from_spawn": float(tilt_from(q, body.base_orientation[0], up)),
        "joint_names": list(body.joint_names),
        "joint_positions": [float(v) for v in body.joint_positions[row]],
        "joint_velocities": [float(v) for v in body.joint_velocities[row]],
    }


def diff(a: Trajectory, b: Trajectory) -> Divergence:
    """Compare two runs of the same scenario (any backends, any time steps).

    The comparison is made at the instants of the coarser run (larger time step) up to the
    shorter run's end; where the finer run has no row at such an instant it is interpolated
    (linear; quaternions normalised-linear).

    Raises:
        SimbridgeError: the subjects differ in joints or links (not the same robot).
    """
    ba, bb = a.body, b.body
    if ba.joint_names != bb.joint_names or len(ba.link_names) != len(bb.link_names):
        raise SimbridgeError(
            f"cannot compare {a.label} with {b.label}: subject {a.subject!r} has joints "
            f"{ba.joint_names} in one and {bb.joint_names} in the other"
        )
    coarse = a if a.timestep >= b.timestep else b
    end = min(a.time[-1], b.time[-1])
    t = coarse.time[coarse.time <= end + 1e-12]

    def take(tr: Trajectory) -> dict[str, np.ndarray]:
        body = tr.body
        out = {
            "pos": _resample(tr.time, body.base_position, t),
            "quat": _resample_quat(tr.time, body.base_orientation, t),
            "links": _resample(tr.time, body.link_positions, t),
            "q": _resample(tr.time, body.joint_positions, t),
            "v": _resample(tr.time, body.joint_velocities, t),
        }
        return out

    sa, sb = take(a), take(b)
    n_joints = sa["q"].shape[1]
    keys = {
        "base_distance": "pos",
        "link_distance": "links",
        "heading": "quat",
        "orientation": "quat",
        "joint_position_rms": "q",
        "joint_velocity_rms": "v",
    }
    series = {
        k: distance(k, features(k, sa[src]), features(k, sb[src]))
        for k, src in keys.items()
        if n_joints or not k.startswith("joint_")
    }
    crossings = {
        k: {thr: _crossing(t, v, thr) for thr in QUANTITIES[k].thresholds}
        for k, v in series.items()
    }
    phases = []
    for name, first, last in a.phases:
        t0, t1 = float(a.time[first]), float(a.time[last])
        if t0 > t[-1] + 1e-12:
            break
        sel = (t >= t0 - 1e-12) & (t <= t1 + 1e-12)
        end_row = int(np.flatnonzero(sel)[-1])
        phases.append(
            PhaseRow(
                name,
                t0,
                min(t1, float(t[-1])),
                {k: float(v[end_row]) for k, v in series.items()},
                {k: float(np.max(v[sel])) for k, v in series.items()},
            )
        )
    row_a = int(np.rint(t[-1] / a.timestep))
    row_b = int(np.rint(t[-1] / b.timestep))
    return Divergence(
        a=a.label,
        b=b.label,
        subject=a.subject,
        time=t,
        series=series,
        crossings=crossings,
        phases=phases,
        final_pose={"a": _pose(ba, row_a, up_of(a)), "b": _pose(bb, row_b, up_of(b))},
        path_a=sa["pos"],
        path_b=sb["pos"],
        joint_names=list(ba.joint_names),
        joint_units=[
            "m" if kind == "prismatic" else "rad"
            for kind in (ba.joint_types or ["revolute"] * n_joints)
        ],
        joint_gaps=np.abs(sa["q"] - sb["q"]),
        link_names=list(ba.link_names),
        link_gaps=np.linalg.norm(sa["links"] - sb["links"], axis=-1),
    )


def up_of(tr: Trajectory) -> np.ndarray:
    """The world's up (against the gravity the run had, from its manifest; z when unknown)."""
    return up_axis((tr.manifest.get("profile") or {}).get("gravity"))
