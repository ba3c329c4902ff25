"""PyBullet's joint motors as MuJoCo friction-loss rows, solved with everything else.

PyBullet's VELOCITY_CONTROL and POSITION_CONTROL (and its default brake) are one constraint row
per joint, solved together with contacts and limits: it asks for the joint velocity

    v_new = v_free + kd (v* - v_free) + kp (q* - q) / dt,      |impulse| <= max_force dt

(``btMultiBodyJointMotor::createConstraintRows``; v_free is the velocity after the smooth
forces, q the position at the start of the step). MuJoCo's ``frictionloss`` row of a dof is a
box-limited velocity row of the same shape: its force is clamped to ``dof_frictionloss`` and its
reference acceleration is ``aref = -B v``. So each motor is that row with

* ``dof_frictionloss = max_force`` (0 removes the row: a released joint);
* ``dof_solref = (0, -kd dmax / dt)`` ("direct" format), which makes ``B = kd / dt``, i.e. MuJoCo
  itself asks for ``-kd v / dt``, and ``dof_solimp = 0.9999``, which makes the row as hard as
  MuJoCo allows (its regulariser is 1e-4 of the row's inverse inertia);
* an offset added to ``efc_aref`` between ``mj_step1`` and ``mj_step2``:
  ``(kd v* + kp (q* - q) / dt) / dt``, plus ``(1 - kd) a_smooth`` when kd != 1, which needs
  ``qacc_smooth`` first (the split path below).

The offset is the only per-step Python work of a velocity motor, and it is skipped when every
target is 0 (the brake). Coupled motors on one body are solved exactly like PyBullet's rows: in
one solve with the body's mass matrix, by MuJoCo's solver (with the contacts) and a polish, or,
when the motor rows are the only rows, by the backend's own active-set solve
(``solve.exact_motors``; see docs/mujoco_backend.md for the measurements).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "MotorTable",
    "MOTOR_DMAX",
    "MOTOR_R_SCALE",
    "LIMIT_ERP",
    "LIMIT_DEEP",
    "LIMIT_MARGIN",
]

MOTOR_DMAX = 0.9999  # the impedance of motor rows (dof_solimp[0:2]), MuJoCo's largest
# MuJoCo's hardest row still has a regulariser R = 1e-4 of its (approximate) inverse inertia, so
# a motor would reach only 1 - 1e-4 of the velocity change it asks for. Between mj_step1 and
# mj_step2 the backend scales the rows' R (and D = 1/R) by this factor, to 1e-6 of the inverse
# inertia, which the Newton solver takes without trouble (islands are disabled so the solver
# reads efc_R/efc_D directly); the polish then removes the last 1e-6 (solve.polish).
MOTOR_R_SCALE = 1e-2

# PyBullet's joint-limit row (btMultiBodyJointLimitConstraint::createConstraintRows), measured
# on raw PyBullet 3.2.7 (a hinge reset past its limit, nothing else acting): the row exists once
# the joint is at or past its limit, only pushes the joint back in (unilateral), asks for zero
# speed along it plus, while the penetration is under 0.04 (split impulse's threshold), a
# push-back at LIMIT_ERP * penetration / dt (0.01 rad past: -0.48 rad/s at 1/240 s); deeper
# than that the row only stops outward motion (0.05 or 0.3 rad past: the joint stays there).
# The MuJoCo limit row is given that law: solref "direct" (-LIMIT_ERP / dt^2, -1 / dt) times
# the impedance, a margin of LIMIT_MARGIN so that a joint exactly at its limit is held, the
# rows hardened like the motor rows, and MuJoCo's position term K (pos - margin) replaced
# between mj_step1 and mj_step2 by PyBullet's (K pos under LIMIT_DEEP, none deeper or inside
# the margin).
LIMIT_ERP = 0.2
LIMIT_DEEP = 0.04
LIMIT_MARGIN = 1e-12


class MotorTable:
    """Motor settings of every movable joint of the world, in dof order (the order of MuJoCo's
    friction rows). Arrays are float64 of shape (n,)."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.dof = np.zeros(n, dtype=np.intp)
        self.qadr = np.zeros(n, dtype=np.intp)
        self.target_velocity = np.zeros(n)
        self.target_position = np.zeros(n)
        self.kp = np.zeros(n)
        self.kd = np.ones(n)
        self.max_force = np.zeros(n)
        self.effort = np.full(n, np.inf)  # clamp on max_force when the profile enforces it
        # derived, refreshed by refresh()
        self.active = np.zeros(0, dtype=np.intp)  # motors with max_force > 0, in row order
        self.row_of = np.full(n, -1, dtype=np.intp)
        self.all_active = False
        self.offset_rows = np.zeros(0)  # constant part of the aref offset, per active row
        self.has_offset = False
        self.position_rows = np.zeros(0, dtype=np.intp)  # rows (into active) in position mode
        self.position_qadr = np.zeros(0, dtype=np.intp)
        self.position_gain = np.zeros(0)  # kp / dt^2 per position row
        self.position_target = np.zeros(0)
        self.kd_rows = np.zeros(0, dtype=np.intp)  # rows with kd != 1 (need qacc_smooth)
        self.kd_dof = np.zeros(0, dtype=np.intp)
        self.kd_factor = np.zeros(0)  # 1 - kd
        self.n_rows = 0
        self.n_special = 0  # motors with kp != 0 or kd != 1 (position mode, velocity gain)
        self.epoch = 0  # bumped by every refresh: caches of row numbers check it

    def refresh(self, dt: float, force: np.ndarray, nv: int) -> None:
        """Recompute the per-row arrays after a command; ``force`` is the force limit in use
        (max_force, clamped to the effort limit when the profile enforces it)."""
        active = np.flatnonzero(force > 0.0)
        self.active = active
        self.dof_rows = self.dof[active]
        self.force_rows_slack = force[active] * (1.0 - 1e-9)  # below this a row is not at its limit
        self.unit_rows = np.zeros((len(active), nv))
        self.row_range = np.arange(len(active))
        self.unit_rows[self.row_range, self.dof_rows] = 1.0
        self.minv_rows = np.empty((len(active), nv))
        self.n_special = int(np.count_nonzero((self.kp != 0.0) | (self.kd != 1.0)))
        self.epoch += 1
        self.row_of = np.full(self.n, -1, np.intp)  # friction row of each motor, -1 = none
        self.row_of[active] = np.arange(len(active))
        self.n_rows = len(active)
        self.all_active = self.n_rows == self.n
        kd = self.kd[active]
        self.offset_rows = kd * self.target_velocity[active] / dt
        pos = np.flatnonzero(self.kp[active] != 0.0)
        self.position_rows = pos
        self.position_qadr = self.qadr[active[pos]]
        self.position_gain = self.kp[active[pos]] / (dt * dt)
        self.position_target = self.target_position[active[pos]]
        self.offset_rows[pos] += self.position_gain * self.position_target
        self.has_offset = bool(np.any(self.offset_rows != 0.0)) or len(pos) > 0
        kdr = np.flatnonzero(kd != 1.0)
        self.kd_rows = kdr
        self.kd_dof = self.dof[active[kdr]]
        self.kd_factor = 1.0 - kd[kdr]

    def aref_offset(self, qpos: np.ndarray) -> np.ndarray:
        """The per-row offset of this step (without the kd != 1 term)."""
        if len(self.position_rows) == 0:
            return self.offset_rows
        out = self.offset_rows.copy()
        out[self.position_rows] -= self.position_gain * qpos[self.position_qadr]
        return out
