"""Hand-made trajectories with known offsets, headings and joint states (no engine)."""

from __future__ import annotations

import math

import numpy as np

from simbridge.compare import BodyTrajectory, Trajectory


def quat_z(yaw: np.ndarray | float) -> np.ndarray:
    """(x, y, z, w) of a rotation by ``yaw`` about z; shape (..., 4)."""
    yaw = np.asarray(yaw, dtype=np.float64)
    return np.stack(
        [np.zeros_like(yaw), np.zeros_like(yaw), np.sin(yaw / 2), np.cos(yaw / 2)], axis=-1
    )


def quat_x(angle: float) -> np.ndarray:
    return np.array([math.sin(angle / 2), 0.0, 0.0, math.cos(angle / 2)])


def trajectory(
    *,
    dt: float = 0.125,
    steps: int = 16,
    position=None,
    yaw=None,
    orientation=None,
    q=None,
    v=None,
    phases=None,
    backend: str = "synthetic",
    fixed_base: bool = False,
) -> Trajectory:
    """A trajectory of ``steps`` steps of ``dt``: callables of time give each quantity.

    ``position(t) -> (T, 3)``, ``yaw(t) -> (T,)`` or ``orientation(t) -> (T, 4)``,
    ``q(t)``/``v(t) -> (T, 2)`` for two joints. Links: the base and one link 1 m above it."""
    t = np.arange(steps + 1, dtype=np.float64) * dt
    n = len(t)
    pos = np.zeros((n, 3)) if position is None else np.asarray(position(t), dtype=np.float64)
    if orientation is not None:
        quat = np.asarray(orientation(t), dtype=np.float64)
    else:
        quat = quat_z(np.zeros(n) if yaw is None else yaw(t))
    qq = np.zeros((n, 2)) if q is None else np.asarray(q(t), dtype=np.float64)
    vv = np.zeros((n, 2)) if v is None else np.asarray(v(t), dtype=np.float64)
    links = np.stack([pos, pos + np.array([0.0, 0.0, 1.0])], axis=1)
    body = BodyTrajectory(
        name="bot",
        fixed_base=fixed_base,
        joint_indices=np.array([0, 1]),
        joint_names=["j0", "j1"],
        link_names=["base", "l0"],
        base_position=pos,
        base_orientation=quat,
        base_linear_velocity=np.zeros((n, 3)),
        base_angular_velocity=np.zeros((n, 3)),
        joint_positions=qq,
        joint_velocities=vv,
        joint_forces=np.zeros((n, 2)),
        joint_targets=np.full((n, 2), np.nan),
        joint_modes=np.zeros((n, 2), dtype=np.int8),
        link_positions=links,
    )
    return Trajectory(
        scenario="synthetic",
        backend=backend,
        profile="pybullet",
        timestep=dt,
        time=t,
        bodies={"bot": body},
        subject="bot",
        phases=phases or [("all", 0, steps)],
    )
