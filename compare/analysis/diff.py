"""How two trajectories part: :func:`diff` and :class:`Divergence`.

The quantities (``base_distance``, ``link_distance``, ``heading``, ``orientation``,
``joint_position_rms``, ``joint_velocity_rms``) are computed on the subject robot at every
common instant; :mod:`..run.quantities` defines each, with its unit.

A threshold is crossed at the first recorded instant whose value is ``>=`` the threshold.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from simbridge.exceptions import SimbridgeError

from ..run.portable import norm
from ..run.quantities import (
    DEG,
    FEATURE_SOURCES,
    QUANTITIES,
    Quantity,
    distance,
    features,
    rotate,
    rotation_angle,
    tilt,
    tilt_from,
    up_axis,
    up_of,
    yaw,
)
from ..run.trajectory import BodyTrajectory, Trajectory

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
    "up_of",
    "DEG",
]

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
    return out / norm(out, keepdims=True)


# ---------------------------------------------------------------- result


@dataclass(frozen=True)
class FinalPose:
    """One run's subject at the last compared instant (SI units)."""

    position: list[float]  # m, the base
    orientation: list[float]  # the base's quaternion (x, y, z, w)
    yaw: float  # rad, heading about the world's z
    tilt: float  # rad, from the world's z
    tilt_from_spawn: float  # rad, from its spawn orientation, about the world's up
    joint_names: list[str]
    joint_positions: list[float]  # rad or m
    joint_velocities: list[float]  # rad/s or m/s


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
    final_pose: dict[str, FinalPose]  # "a" and "b": each run's subject at the last instant
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


def _crossing(time: np.ndarray, values: np.ndarray, threshold: float) -> float | None:
    hit = np.flatnonzero(values >= threshold)
    return float(time[hit[0]]) if hit.size else None


def _pose(body: BodyTrajectory, row: int, up: np.ndarray) -> FinalPose:
    q = body.base_orientation[row]
    return FinalPose(
        position=[float(v) for v in body.base_position[row]],
        orientation=[float(v) for v in q],
        yaw=float(yaw(q)),
        tilt=float(tilt(q)),
        tilt_from_spawn=float(tilt_from(q, body.base_orientation[0], up)),
        joint_names=list(body.joint_names),
        joint_positions=[float(v) for v in body.joint_positions[row]],
        joint_velocities=[float(v) for v in body.joint_velocities[row]],
    )


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
        link_gaps=norm(sa["links"] - sb["links"]),
    )
