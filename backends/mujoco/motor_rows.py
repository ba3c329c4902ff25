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

A spherical joint's motor (``btMultiBodySphericalJointMotor::createConstraintRows``) is three
such rows, one per axis of the child's (inertial) frame, i.e. per dof of MuJoCo's ball joint,
each asking for

    v_new = v_free - kd v_free - erp kp e / dt,                |impulse| <= max_force dt

where e is Bullet's ``matrixToEulerXYZ`` of the rotation from the joint's quaternion to the
target, ``conj(q) * q*`` (:func:`spherical_error`), erp the solver's non-contact erp 0.2 and kd
what PyBullet calls its ``damping`` (its velocity gain and target velocity are read by
nothing: measured on 3.2.7, and read in the source). Its offset is computed from ``qpos`` at
every step, like a position row's. PyBullet gives every spherical joint that motor at load:
target the identity, kp 0.2, an impulse of 1000 N·m·s per step per axis.

The offset is the only per-step Python work of a velocity motor, and it is skipped when every
target is 0 (the brake). Coupled motors on one body are solved exactly like PyBullet's rows: in
one solve with the body's mass matrix, by MuJoCo's solver (with the contacts) and a polish, or,
when the motor rows are the only rows, by the backend's own active-set solve
(``solve.exact_motors``; see docs/mujoco_backend.md for the measurements).
"""

from __future__ import annotations

import numpy as np

from simbridge.spherical import motor_error

__all__ = [
    "MotorTable",
    "spherical_error",
    "SPHERICAL_ERP",
    "SPHERICAL_BRAKE_KP",
    "SPHERICAL_BRAKE_IMPULSE",
    "MOTOR_DMAX",
    "MOTOR_R_SCALE",
    "LIMIT_ERP",
    "LIMIT_DEEP",
    "LIMIT_MARGIN",
    "LIMIT_HARD_MARGIN",
]

MOTOR_DMAX = 0.9999  # the impedance of motor rows (dof_solimp[0:2]), MuJoCo's largest
# MuJoCo's hardest row still has a regulariser R = 1e-4 of its (approximate) inverse inertia, so
# a motor would reach only 1 - 1e-4 of the velocity change it asks for. Between mj_step1 and
# mj_step2 the backend scales the rows' R (and D = 1/R) by this factor, to 1e-6 of the inverse
# inertia, which the Newton solver takes without trouble (islands are disabled so the solver
# reads efc_R/efc_D directly); the polish then removes the last 1e-6 (solve.polish).
MOTOR_R_SCALE = 1e-2

# PyBullet's joint-limit row (btMultiBodyJointLimitConstraint::createConstraintRows): the row
# exists once the joint is at or past its limit, only pushes the joint back in (unilateral),
# asks for zero speed along it plus, while the penetration is under 0.04 (split impulse's
# threshold), a push-back at LIMIT_ERP * penetration / dt; deeper than that the row only stops
# outward motion (measured on raw PyBullet: docs/mujoco_backend.md, "Joint limits").
# The MuJoCo limit row is given that law: solref "direct" (-LIMIT_ERP / dt^2, -1 / dt) times
# the impedance, a margin of LIMIT_MARGIN so that a joint exactly at its limit is held, the
# rows hardened like the motor rows, and MuJoCo's position term K (pos - margin) replaced
# between mj_step1 and mj_step2 by PyBullet's (K pos under LIMIT_DEEP, none deeper or inside
# the margin).
# The engine setting limit_rule "hard" (backends/settings_mujoco.py) gives the rows PhysX's rule
# on arrival instead: a margin of LIMIT_HARD_MARGIN, so that every limited joint has its rows at
# every step, and inside the range (pos > 0) a position term of pos / dt^2: the row asks for
# J v' >= -pos / dt, so a joint arriving at its limit ends the step on it, not past it (PyBullet's
# law once at or past it, as PhysX's backend stands in for it there; physx/limits.py).
LIMIT_ERP = 0.2
LIMIT_DEEP = 0.04
LIMIT_MARGIN = 1e-12
LIMIT_HARD_MARGIN = 10.0  # m or rad: no joint travels that far in a step

# PyBullet's spherical joint motor (btMultiBodySphericalJointMotor): its position term is
# erp kp e / dt with the solver's non-contact erp (btContactSolverInfo::m_erp, 0.2, which
# PyBullet leaves as it is); the motor every spherical joint gets at load (PhysicsServer-
# CommandProcessor::createJointMotors): kp 0.2 towards the identity, 1000 N·m·s per step.
SPHERICAL_ERP = 0.2
SPHERICAL_BRAKE_KP = 0.2
SPHERICAL_BRAKE_IMPULSE = 1000.0


def spherical_error(
    qw: float, qx: float, qy: float, qz: float, tx: float, ty: float, tz: float, tw: float
) -> tuple[float, float, float]:
    """Bullet's error of a spherical motor from the joint quaternion q to the target t.

    The error is :func:`simbridge.spherical.motor_error`'s.

    Args:
        qw: The joint quaternion's w (MuJoCo's order: w, x, y, z).
        qx: Its x.
        qy: Its y.
        qz: Its z.
        tx: The target quaternion's x (order x, y, z, w).
        ty: Its y.
        tz: Its z.
        tw: Its w.

    Returns:
        The error about the three axes (rad).
    """
    return motor_error(qx, qy, qz, qw, tx, ty, tz, tw)


_NO_ROWS = np.zeros(0, dtype=np.intp)
_NO_VALUES = np.zeros(0)
_NO_ROWS.setflags(write=False)
_NO_VALUES.setflags(write=False)


class MotorTable:
    """Motor settings of every movable joint of the world, in dof order.

    The dof order is the order of MuJoCo's friction rows. Arrays are float64 of shape (n,).

    Args:
        n: How many motor slots (one per movable joint, three per spherical joint).
    """

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
        # spherical joints (set_balls): each one's first slot (its three are consecutive), the
        # qpos address of its quaternion (w, x, y, z) and its target (x, y, z, w); per slot
        # the ball it belongs to (-1: none)
        self.ball = np.zeros(0, dtype=np.intp)
        self.ball_qadr = np.zeros(0, dtype=np.intp)
        self.ball_target = np.zeros((0, 4))
        self.ball_of = np.full(n, -1, dtype=np.intp)
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
        # rows of spherical position motors: row, index into the balls' errors (3 per ball of
        # ball_pos_index, axis last) and erp kp / dt^2; the balls whose error is needed
        self.ball_rows = np.zeros(0, dtype=np.intp)
        self.ball_row_error = np.zeros(0, dtype=np.intp)
        self.ball_gain = np.zeros(0)
        self.ball_pos_index = np.zeros(0, dtype=np.intp)  # into ball
        self.ball_pos_qadr = np.zeros(0, dtype=np.intp)
        self.ball_pos_target = np.zeros(0)  # 4 per ball of ball_pos_index, x, y, z, w
        self.kd_rows = np.zeros(0, dtype=np.intp)  # rows with kd != 1 (need qacc_smooth)
        self.kd_dof = np.zeros(0, dtype=np.intp)
        self.kd_factor = np.zeros(0)  # 1 - kd
        self.n_rows = 0
        self.dof_rows = np.zeros(0, dtype=np.intp)  # dof of each row
        self.force_rows_slack = np.zeros(0)
        self._nv = 0
        self._unit_rows: np.ndarray | None = None
        self._minv_rows = np.zeros((0, 0))
        self.epoch = 0  # bumped by every refresh: caches of row numbers check it
        # bumped by a refresh that moves rows (the active motors or the position rows change):
        # the command hot paths' caches hold row numbers, and are dropped then
        self.layout = 0

    def set_balls(self, balls: list[tuple[int, int, np.ndarray]]) -> None:
        """Set the spherical joints.

        Args:
            balls: ``(first slot, qpos address of the quaternion, target)`` per spherical joint, in
                slot order; the target is a (4,) quaternion (x, y, z, w).
        """
        nb = len(balls)
        self.ball = np.array([b[0] for b in balls], dtype=np.intp)
        self.ball_qadr = np.array([b[1] for b in balls], dtype=np.intp)
        self.ball_target = np.array([b[2] for b in balls], dtype=float).reshape(nb, 4)
        self.ball_of = np.full(self.n, -1, dtype=np.intp)
        for b, first in enumerate(self.ball.tolist()):
            self.ball_of[first : first + 3] = b

    def refresh(self, dt: float, force: np.ndarray, nv: int) -> None:
        """Recompute the per-row arrays after a command.

        Args:
            dt: The time step (s).
            force: (n,) the force limit in use per slot (max_force, clamped to the effort limit when
                the profile enforces it; N·m or N).
            nv: The model's number of dofs.
        """
        active = np.flatnonzero(force > 0.0)
        k = len(active)
        self.active = active
        self.dof_rows = self.dof[active]
        self.force_rows_slack = force[active] * (1.0 - 1e-9)  # below this a row is not at its limit
        self._nv = nv
        self._unit_rows = None  # made on first use (the Python loop's solve)
        self.epoch += 1
        self.row_of = np.full(self.n, -1, np.intp)  # friction row of each motor, -1 = none
        self.row_of[active] = np.arange(k)
        self.n_rows = k
        self.all_active = k == self.n
        kd = self.kd[active]
        kp = self.kp[active]
        self.offset_rows = kd * self.target_velocity[active] / dt
        balls = self.ball_of[active]
        pos = np.flatnonzero((kp != 0.0) & (balls < 0))
        self.position_rows = pos
        if len(pos):
            at = active[pos]
            self.position_qadr = self.qadr[at]
            self.position_gain = kp[pos] / (dt * dt)
            self.position_target = self.target_position[at]
            self.offset_rows[pos] += self.position_gain * self.position_target
            self.has_offset = True
        else:
            self.position_qadr = _NO_ROWS
            self.position_gain = self.position_target = _NO_VALUES
            self.has_offset = bool(self.offset_rows.any())
        brows = np.flatnonzero((kp != 0.0) & (balls >= 0))
        self.ball_rows = brows
        if len(brows):
            which = balls[brows]
            used, where = np.unique(which, return_inverse=True)
            self.ball_pos_index = used
            self.ball_pos_qadr = self.ball_qadr[used]
            self.ball_pos_target = self.ball_target[used].ravel().copy()
            self.ball_row_error = 3 * where + (active[brows] - self.ball[which])
            self.ball_gain = SPHERICAL_ERP * kp[brows] / (dt * dt)
            self.has_offset = True
        else:
            self.ball_pos_index = self.ball_pos_qadr = self.ball_row_error = _NO_ROWS
            self.ball_gain = self.ball_pos_target = _NO_VALUES
        kdr = np.flatnonzero(kd != 1.0)
        self.kd_rows = kdr
        if len(kdr):
            self.kd_dof = self.dof_rows[kdr]
            self.kd_factor = 1.0 - kd[kdr]
        else:
            self.kd_dof, self.kd_factor = _NO_ROWS, _NO_VALUES

    @property
    def unit_rows(self) -> np.ndarray:
        """(rows, nv): row i is 1 at the dof of motor row i (the right-hand sides of
        ``mj_solveM`` for the rows of M^-1 the Python loop's solve needs)."""
        if self._unit_rows is None:
            k = len(self.active)
            self._unit_rows = np.zeros((k, self._nv))
            self._unit_rows[np.arange(k), self.dof_rows] = 1.0
            self._minv_rows = np.empty((k, self._nv))
        return self._unit_rows

    @property
    def minv_rows(self) -> np.ndarray:
        """(rows, nv) scratch for ``mj_solveM``'s answer (rows of M^-1)."""
        self.unit_rows  # noqa: B018 - made together
        return self._minv_rows

    def ball_errors(self, qpos: np.ndarray) -> np.ndarray:
        """The spherical position motors' errors (:func:`spherical_error`).

        Args:
            qpos: The model's ``qpos``.

        Returns:
            A (3 b,) array: 3 per ball of ``ball_pos_index`` (rad), axis last.
        """
        out: list[float] = []
        t = self.ball_pos_target.tolist()
        for i, a in enumerate(self.ball_pos_qadr.tolist()):
            q = qpos[a : a + 4].tolist()
            out.extend(spherical_error(*q, *t[4 * i : 4 * i + 4]))
        return np.array(out)

    def aref_offset(self, qpos: np.ndarray) -> np.ndarray:
        """The per-row offset of this step (without the kd != 1 term).

        Args:
            qpos: The model's ``qpos``.

        Returns:
            The (n_rows,) offset of each active row's reference acceleration.
        """
        if len(self.position_rows) == 0 and len(self.ball_rows) == 0:
            return self.offset_rows
        out = self.offset_rows.copy()
        if len(self.position_rows):
            out[self.position_rows] -= self.position_gain * qpos[self.position_qadr]
        if len(self.ball_rows):
            out[self.ball_rows] -= self.ball_gain * self.ball_errors(qpos)[self.ball_row_error]
        return out
