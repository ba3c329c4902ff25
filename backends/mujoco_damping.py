"""PyBullet's link damping and speed clamp, for MuJoCo.

``btMultiBody::computeAccelerationsArticulatedBodyAlgorithmMultiDof`` adds, for the base and
every link, in its centre-of-mass frame (principal axes), the forces

    f = -m   k_lin (1 + |v|) v          (v: linear velocity of the centre of mass)
    t = -I . k_ang (1 + |w|) w          (I: principal moments, element-wise)

with k_lin = linearDamping, k_ang = angularDamping (0.04 each by default): a linear plus a
quadratic drag, applied explicitly with the smooth forces. Here they go into ``xfrc_applied``
(world force and torque at the centre of mass) between ``mj_step1`` and ``mj_step2``; the
velocities come from two MuJoCo sensors per body (``framelinvel`` and ``frameangvel`` of the
inertial frame, world axes), computed in C by ``mj_step1``; the torque is formed in the
principal axes (``ximat``) and turned back to the world. The compiled step loop
(``_mjkernel.c``) does the same from ``cvel`` (the transform those sensors use) and needs no
sensors.

``btMultiBody::applyDeltaVeeMultiDof`` clamps every velocity coordinate (the 6 base coordinates
and every joint) to +-maxJointVelocity (100); measured on PyBullet, the velocity after the whole
step obeys it (a motor asking for 150 rad/s ends at 100). :func:`clamp_acceleration` limits
MuJoCo's ``qacc`` after the constraint solve so that ``qvel + dt qacc`` obeys it. MuJoCo's
free-joint coordinates are the origin's linear velocity and the body-frame angular velocity,
PyBullet's the centre of mass's and the world-frame one: the base clamp differs when the base
spins (a departure listed in the manifest).
"""

from __future__ import annotations

import numpy as np

__all__ = ["LinkDamping", "clamp_acceleration"]


class LinkDamping:
    """Link damping of the bodies ``first .. first + n - 1`` (a contiguous range of body ids)."""

    def __init__(
        self,
        first: int,
        mass: np.ndarray,  # (n,)
        inertia: np.ndarray,  # (n, 3) principal moments
        k_lin: float,
        k_ang: float,
        sensor_adr: int,
    ) -> None:
        self.first = first
        self.n = n = len(mass)
        self.sensor = slice(sensor_adr, sensor_adr + 6 * n)
        self.lin_gain = -k_lin * mass  # (n,)
        self.ang_gain = -k_ang * inertia  # (n, 3)
        self._sq = np.empty((n, 2))
        self._tl = np.empty((n, 3))
        self._out = np.empty((n, 6))

    def apply(self, d, out: np.ndarray | None = None) -> float:  # type: ignore[no-untyped-def]
        """Write the damping forces into ``d.xfrc_applied`` (bodies of this range); return the
        largest body speed seen (m/s or rad/s), for the speed-clamp test."""
        s = d.sensordata[self.sensor].reshape(self.n, 2, 3)  # [v, w], world axes
        sq = np.einsum("ijk,ijk->ij", s, s, out=self._sq)
        np.sqrt(sq, out=sq)
        top = float(sq.max()) if self.n else 0.0
        sq += 1.0
        xf = d.xfrc_applied[self.first : self.first + self.n]
        np.multiply(s[:, 0, :], (self.lin_gain * sq[:, 0])[:, None], out=xf[:, :3])
        rot = d.ximat[self.first : self.first + self.n].reshape(self.n, 3, 3)
        tl = np.einsum("bji,bj->bi", rot, s[:, 1, :], out=self._tl)  # w in the inertial frame
        tl *= self.ang_gain
        tl *= sq[:, 1:2]
        np.einsum("bij,bj->bi", rot, tl, out=xf[:, 3:])
        return top


def clamp_acceleration(d, dt: float, limit: float) -> None:  # type: ignore[no-untyped-def]
    """Limit ``qacc`` so that the velocity after the step, ``qvel + dt qacc``, is within
    +-limit in every coordinate (and the positions integrate with the clamped velocity)."""
    qvel = d.qvel
    np.clip(d.qacc, (-limit - qvel) / dt, (limit - qvel) / dt, out=d.qacc)
