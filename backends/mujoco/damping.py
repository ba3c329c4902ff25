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
gives the same forces but costs ``mj_fwdAcceleration`` a Jacobian per body (its cost:
docs/mujoco_backend.md, "Damping"). The compiled step loop (``_mjkernel.c``) does the same in C.

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
    """Link damping of the bodies ``first .. first + n - 1`` (a contiguous range of body ids).

    Args:
        m: The ``mujoco.MjModel`` (masses, inertias, the tree).
        first: The first damped body's id; every body from it to the last is damped.
        k_lin: The linear damping coefficient (PyBullet's ``linearDamping``).
        k_ang: The angular damping coefficient (PyBullet's ``angularDamping``).
    """

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
        self.parent = m.body_parentid.copy()
        self.nbody = m.nbody
        self.dof_body = m.dof_bodyid.copy()

    def apply(self, d: Any) -> None:
        """Add the damping forces to ``d.qfrc_passive`` as generalised forces.

        Called after ``mj_step1``, which computes both. Element-wise arithmetic only, each sum term
        by term in the compiled loop's order (no einsum or BLAS product, whose sums depend on the
        processor's kernels): the same bits as ``link_damping`` in _mjkernel.c.

        Args:
            d: The ``mujoco.MjData``, after ``mj_step1``.
        """
        rows = self.rows
        cvel = d.cvel[rows]  # [w, v at the tree's centre of mass], world axes
        w = cvel[:, :3]
        r = d.xipos[rows] - d.subtree_com[self.root]
        # velocity of each body's centre of mass: cvel's linear part moved to xipos
        v = cvel[:, 3:] - (r[:, _Y] * w[:, _Z] - r[:, _Z] * w[:, _Y])
        sv = np.sqrt(v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1] + v[:, 2] * v[:, 2])
        sw = np.sqrt(w[:, 0] * w[:, 0] + w[:, 1] * w[:, 1] + w[:, 2] * w[:, 2])
        force = v * (self.lin_gain * (sv + 1.0))[:, None]
        rot = d.ximat[rows].reshape(self.n, 3, 3)  # world = rot local
        # w in the principal axes (rot^T w), damped there, turned back (rot tl)
        tl = rot[:, 0, :] * w[:, 0:1] + rot[:, 1, :] * w[:, 1:2] + rot[:, 2, :] * w[:, 2:3]
        tl *= self.ang_gain
        tl *= (sw + 1.0)[:, None]
        torque = rot[:, :, 0] * tl[:, 0:1] + rot[:, :, 1] * tl[:, 1:2] + rot[:, :, 2] * tl[:, 2:3]
        # each body's spatial force about its tree's centre of mass, summed up the tree
        # (children after their parents in MuJoCo's order, so a reverse pass collects them)
        cf = np.zeros((self.nbody, 6))
        cf[rows, :3] = torque + r[:, _Y] * force[:, _Z] - r[:, _Z] * force[:, _Y]
        cf[rows, 3:] = force
        parent = self.parent
        for b in range(self.nbody - 1, 0, -1):
            if parent[b] > 0:
                cf[parent[b]] += cf[b]
        s = cf[self.dof_body]
        cd = d.cdof
        gen = cd[:, 0] * s[:, 0]
        for i in range(1, 6):
            gen = gen + cd[:, i] * s[:, i]
        d.qfrc_passive += gen


# the cross product's index pattern: (a x b)_i = a[_Y] b[_Z] - a[_Z] b[_Y], as written in C
_Y = [1, 2, 0]
_Z = [2, 0, 1]


def clamp_acceleration(d: Any, dt: float, limit: float) -> None:
    """Limit ``qacc`` so that the velocity after the step is within +-limit.

    The velocity after the step, ``qvel + dt qacc``, is limited in every coordinate (and the
    positions integrate with the clamped velocity).

    Args:
        d: The ``mujoco.MjData``; its ``qacc`` is written in place.
        dt: The time step (s).
        limit: The velocity limit (rad/s or m/s per coordinate).
    """
    qvel = d.qvel
    np.clip(d.qacc, (-limit - qvel) / dt, (limit - qvel) / dt, out=d.qacc)
