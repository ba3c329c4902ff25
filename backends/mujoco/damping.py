"""PyBullet's link damping and speed clamp, for MuJoCo.

``btMultiBody::computeAccelerationsArticulatedBodyAlgorithmMultiDof`` adds, for the base and
every link, in its centre-of-mass frame (principal axes), the forces

    f = -m   k_lin (1 + |v|) v          (v: linear velocity of the centre of mass)
    t = -I . k_ang (1 + |w|) w          (I: principal moments, element-wise)

with k_lin = linearDamping, k_ang = angularDamping (0.04 each by default): a linear plus a
quadratic drag, applied explicitly with the smooth forces. Here they are added to
``qfrc_passive`` between ``mj_step1`` and ``mj_step2`` (``mj_step1`` computes it afresh and
``mj_fwdAcceleration`` sums it into the smooth forces): the velocities come from ``cvel`` (world
axes, about the tree's centre of mass, as ``mj_step1`` leaves it), the torque is formed in the
principal axes (``ximat``) and turned back to the world, and each body's force and torque
become generalised forces J^T f through ``cdof``, summed over the subtree of each dof's body
(as MuJoCo's own recursive Newton-Euler pass does). Writing them into ``xfrc_applied`` instead
gives the same forces but costs ``mj_fwdAcceleration`` a Jacobian per body (1.5 us per r2d2
step, measured). The compiled step loop (``_mjkernel.c``) does the same in C.

``btMultiBody::applyDeltaVeeMultiDof`` clamps every velocity coordinate (the 6 base coordinates
and every joint) to +-maxJointVelocity (100); measured on PyBullet, the velocity after the whole
step obeys it (a motor asking for 150 rad/s ends at 100). :func:`clamp_acceleration` limits
MuJoCo's ``qacc`` after the constraint solve so that ``qvel + dt qacc`` obeys it. MuJoCo's
free-joint coordinates are the origin's linear velocity and the body-frame angular velocity,
PyBullet's the centre of mass's and the world-frame one: the base clamp differs when the base
spins (a departure listed in the manifest).
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["LinkDamping", "clamp_acceleration"]


class LinkDamping:
    """Link damping of the bodies ``first .. first + n - 1`` (a contiguous range of body ids)."""

    def __init__(
        self,
        m: Any,  # mujoco.MjModel
        first: int,
        k_lin: float,
        k_ang: float,
    ) -> None:
        self.first = first
        self.n = n = m.nbody - first
        self.rows = slice(first, first + n)
        self.lin_gain = -k_lin * m.body_mass[self.rows].copy()  # (n,)
        self.ang_gain = np.ascontiguousarray(-k_ang * m.body_inertia[self.rows])  # (n, 3)
        self.root = m.body_rootid[self.rows].copy()
        # subtree[j, i]: body first + i lies in the subtree of dof j's body (dof j moves it)
        parent = m.body_parentid
        inside = np.zeros((m.nbody, n), bool)
        for i in range(n):
            b = first + i
            while b > 0:
                inside[b, i] = True
                b = parent[b]
        self.subtree = inside[m.dof_bodyid].astype(float)  # (nv, n)

    def apply(self, d: Any) -> None:
        """Add the damping forces to ``d.qfrc_passive`` as generalised forces (after
        ``mj_step1``, which computes both)."""
        rows = self.rows
        cvel = d.cvel[rows]  # [w, v at the tree's centre of mass], world axes
        w = cvel[:, :3]
        r = d.xipos[rows] - d.subtree_com[self.root]
        v = cvel[:, 3:] - np.cross(r, w)  # velocity of each body's centre of mass
        sv = np.sqrt(np.einsum("ij,ij->i", v, v))
        sw = np.sqrt(np.einsum("ij,ij->i", w, w))
        force = v * (self.lin_gain * (sv + 1.0))[:, None]
        rot = d.ximat[rows].reshape(self.n, 3, 3)
        tl = np.einsum("bji,bj->bi", rot, w)  # w in the principal axes
        tl *= self.ang_gain
        tl *= (sw + 1.0)[:, None]
        torque = np.einsum("bij,bj->bi", rot, tl)
        # the spatial force about the tree's centre of mass, summed over each dof's subtree
        spatial = np.concatenate([torque + np.cross(r, force), force], axis=1)
        d.qfrc_passive += np.einsum("jk,jk->j", d.cdof, self.subtree @ spatial)


def clamp_acceleration(d: Any, dt: float, limit: float) -> None:
    """Limit ``qacc`` so that the velocity after the step, ``qvel + dt qacc``, is within
    +-limit in every coordinate (and the positions integrate with the clamped velocity)."""
    qvel = d.qvel
    np.clip(d.qacc, (-limit - qvel) / dt, (limit - qvel) / dt, out=d.qacc)
