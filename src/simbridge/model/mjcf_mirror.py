"""MuJoCo's own formulas on the state of another engine: the forces and reads of an MJCF model
read with ``semantics="mujoco"`` that PyBullet or PhysX steps.

A :class:`Mirror` holds an ``MjData`` of the compiled model. The engine's state, written into
it as MuJoCo's ``qpos``/``qvel`` (:meth:`Mirror.set_state`), gives by MuJoCo's own functions:

* each step's generalized forces (:meth:`Mirror.forces`): ``qfrc_actuator`` (every actuator's
  gain, bias, gear, ``ctrlrange`` clamp where ``ctrllimited``, ``forcerange`` clamp, as
  ``mj_fwdActuation`` computes them), ``qfrc_spring`` (``stiffness``, ``springref``),
  ``qfrc_gravcomp`` and ``qfrc_fluid``; the joint damping apart, with the diagonal of the joint
  space inertia (without armature), for the engine to apply its own way;
* the reads (frames, centres of mass, velocities, sites, sensors) of the state as it stands,
  so that every engine reports a body, a site or a sensor as MuJoCo computes it from the same
  ``qpos``/``qvel``: what differs between engines is then the motion, not the read.

Nothing here steps MuJoCo: only ``mj_kinematics``, ``mj_comPos``, ``mj_crb``, ``mj_tendon``,
``mj_transmission``, ``mj_fwdVelocity``, ``mj_fwdActuation`` and, for sensors, ``mj_forward``
(contacts and constraint forces then are MuJoCo's own of that state, not the engine's).
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

__all__ = ["Mirror", "body_name", "own_overlaps"]


class Mirror:
    """An ``MjData`` of a compiled model, set from another engine's state.

    Args:
        model: The compiled ``mujoco.MjModel`` (its ``opt`` gives gravity for ``gravcomp``).
    """

    def __init__(self, model: Any) -> None:
        self.m = model
        self.d = mujoco.MjData(model)
        self.stale = True
        self._full = np.zeros((model.nv, model.nv))  # the joint-space inertia, dense

    def set_state(self, qpos: np.ndarray | None, qvel: np.ndarray | None) -> None:
        """Write the state (MuJoCo's order and conventions; None keeps one).

        Args:
            qpos: (nq,) float64 or None.
            qvel: (nv,) float64 or None.
        """
        if qpos is not None:
            self.d.qpos[:] = qpos
        if qvel is not None:
            self.d.qvel[:] = qvel
        self.stale = True

    def refresh(self) -> None:
        """Frames and velocities of the state as it stands (for the reads)."""
        if self.stale:
            m, d = self.m, self.d
            mujoco.mj_kinematics(m, d)
            mujoco.mj_comPos(m, d)
            mujoco.mj_comVel(m, d)
            self.stale = False

    def forces(self, ctrl: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """MuJoCo's generalized forces at the state as it stands, under ``ctrl``.

        Args:
            ctrl: (nu,) the actuator controls (clamped here to ``ctrlrange`` as MuJoCo does).

        Returns:
            ``(qfrc, damping, mass)``: the actuator, spring, gravity compensation and fluid
            forces (nv,) (N·m or N), MuJoCo's ``dof_damping`` (nv,) and the joint-space inertia
            without armature (nv, nv).
        """
        m, d = self.m, self.d
        d.ctrl[:] = ctrl
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_crb(m, d)
        mujoco.mj_tendon(m, d)
        mujoco.mj_transmission(m, d)
        mujoco.mj_fwdVelocity(m, d)
        mujoco.mj_fwdActuation(m, d)
        self.stale = False
        qfrc = d.qfrc_actuator + d.qfrc_spring + d.qfrc_gravcomp + d.qfrc_fluid
        mujoco.mj_fullM(m, d, self._full)
        return qfrc, m.dof_damping, self._full - np.diag(m.dof_armature)

    def body_com(self, bid: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """A body's centre of mass: pose and velocity (world), as the MuJoCo backend reads it.

        Args:
            bid: The MuJoCo body id.

        Returns:
            Position (3,), orientation (4,) x, y, z, w, linear and angular velocity (3,).
        """
        self.refresh()
        q = np.empty(4)
        mujoco.mju_mat2Quat(q, self.d.ximat[bid])
        vel = np.empty(6)
        mujoco.mj_objectVelocity(self.m, self.d, mujoco.mjtObj.mjOBJ_BODY, bid, vel, 0)
        return self.d.xipos[bid].copy(), q[[1, 2, 3, 0]], vel[3:], vel[:3]

    def quat(self, mat: np.ndarray) -> np.ndarray:
        """A rotation matrix's quaternion (x, y, z, w) as MuJoCo computes it.

        Args:
            mat: (9,) or (3, 3).

        Returns:
            (4,) x, y, z, w.
        """
        q = np.empty(4)
        mujoco.mju_mat2Quat(q, np.ascontiguousarray(mat, dtype=float).reshape(9))
        return q[[1, 2, 3, 0]]

    def sensor(self, sensor: int, ctrl: np.ndarray) -> np.ndarray:
        """One sensor's values of the state as it stands (``mj_forward``: a contact or force
        sensor reads MuJoCo's own contacts of that state).

        Args:
            sensor: The sensor's index.
            ctrl: (nu,) the controls in force.

        Returns:
            (dim,) a copy of its part of ``sensordata``.
        """
        m, d = self.m, self.d
        d.ctrl[:] = ctrl
        mujoco.mj_forward(m, d)
        self.stale = False
        a, n = int(m.sensor_adr[sensor]), int(m.sensor_dim[sensor])
        return d.sensordata[a : a + n].copy()


def own_overlaps(model: Any, qpos: np.ndarray) -> dict[frozenset[int], float]:
    """MuJoCo's own contacts at a state, as the depth of each pair of rigid groups: what its
    collision detection (``mj_forward`` on a fresh ``MjData``, filters included) finds there.

    Args:
        model: The compiled ``mujoco.MjModel``.
        qpos: (nq,) the state's generalized positions.

    Returns:
        ``{frozenset of the two bodies' weld roots (body_weldid; the world 0): the smallest
        contact distance (m; negative: overlapping)}``.
    """
    d = mujoco.MjData(model)
    d.qpos[:] = qpos
    mujoco.mj_forward(model, d)
    weld = model.body_weldid
    out: dict[frozenset[int], float] = {}
    for i in range(d.ncon):
        g1, g2 = int(d.contact.geom1[i]), int(d.contact.geom2[i])
        key = frozenset((int(weld[model.geom_bodyid[g1]]), int(weld[model.geom_bodyid[g2]])))
        out[key] = min(out.get(key, np.inf), float(d.contact.dist[i]))
    return out


def body_name(model: Any, body: int) -> str:
    """A MuJoCo body's name.

    Args:
        model: The compiled ``mujoco.MjModel``.
        body: The body's id.

    Returns:
        Its name: ``world`` for body 0, ``body<id>`` when unnamed.
    """
    if body == 0:
        return "world"
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body) or f"body{body}"
