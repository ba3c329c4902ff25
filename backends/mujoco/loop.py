"""The step loop in Python: the reference the compiled loop (_mjkernel.c) follows, step for step
and in the same order of arithmetic (tests/backends/mujoco/test_mujoco_kernel.py holds them
together).

Each step is ``mj_step1`` (positions, velocities, constraint rows), the layer's additions to the
rows and forces (PyBullet's motor offsets and hard rows: motor_rows.py; PyBullet's joint-limit rule;
link and joint damping: damping.py; torque commands), then ``mj_step2``, split when there are
motor rows or a speed clamp (``mj_fwdActuation``, ``mj_fwdAcceleration``, the kd term, the
exact solve or MuJoCo's solver and the polish: solve.py, the clamp, ``mj_Euler``).

Errors are not raised here: MuJoCo's own (``mujoco.FatalError``) and a callback's propagate
to the backend, which turns them into the Sim's errors and counts the steps done.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np

from . import solve
from .damping import clamp_acceleration
from .motor_rows import LIMIT_DEEP, MOTOR_R_SCALE
from .robots import BAD_WARNINGS, Compiled

__all__ = ["step_python"]


def step_python(c: Compiled, n: int, sync: Callable[[], None] | None = None) -> tuple[int, bool]:
    """``n`` steps of the world ``c`` by the Python step loop, the compiled loop's reference.

    It stops after a step in which MuJoCo raised a divergence warning (a bad position, speed or
    acceleration: MuJoCo has put the state back to the reference pose) or the polish found the free
    motor rows singular, as the compiled loop does (its status 1 and 3).

    Args:
        c: The compiled world.
        n: How many steps.
        sync: Called after each step (the viewer's), or None.

    Returns:
        The steps completed, and whether the motor rows' solve was singular.
    """
    m, d = c.m, c.d
    t = c.motors
    damping = c.damping
    step1, step2 = mujoco.mj_step1, mujoco.mj_step2
    k = t.n_rows
    counts = [d.warning[code] for code in BAD_WARNINGS]  # live views of MuJoCo's counters
    before = sum(w.number for w in counts)
    for done in range(1, n + 1):
        step1(m, d)
        if k:  # friction rows come first (no equality constraints)
            if t.has_offset:
                d.efc_aref[:k] += t.aref_offset(d.qpos)
            d.efc_R[:k] *= MOTOR_R_SCALE  # harden the motor rows (motor_rows.py)
            d.efc_D[:k] *= 1.0 / MOTOR_R_SCALE
        if d.nl:  # PyBullet's limit rows (motor_rows.py), after the friction rows
            lim = slice(d.nf, d.nf + d.nl)
            d.efc_R[lim] *= MOTOR_R_SCALE
            d.efc_D[lim] *= 1.0 / MOTOR_R_SCALE
            # MuJoCo's position term is K (pos - margin); PyBullet's is K pos for a
            # penetration (pos <= 0) under LIMIT_DEEP, none deeper (stop only) or inside
            # the margin
            pos = d.efc_pos[lim]
            shallow = (pos <= 0.0) & (pos > -LIMIT_DEEP)
            d.efc_aref[lim] += c.limit_k * (pos - d.efc_margin[lim])
            d.efc_aref[lim] -= np.where(shallow, c.limit_k * pos, 0.0)
            if c.limit_k_in:  # limit_rule "hard": inside the range, stop on the limit
                d.efc_aref[lim] -= np.where(pos > 0.0, c.limit_k_in * pos, 0.0)
        if damping is not None:
            damping.apply(d)
        if len(c.damp_dof):
            d.qfrc_applied[c.damp_dof] = c.damp_coef * d.qvel[c.damp_dof]
        if c.pending_torque:
            d.qfrc_applied[t.dof] += c.torque
        singular = False
        if k or c.clamp is not None:
            singular = not _step2_split(c, m, d, k)
        else:
            step2(m, d)
        if c.pending_torque:
            c.pending_torque = False
            d.qfrc_applied[t.dof] = 0.0
            c.torque[:] = 0.0
        if sync is not None:
            sync()
        if singular:
            return done, True
        if sum(w.number for w in counts) != before:
            return done, False
    return n, False


def _step2_split(c: Compiled, m: Any, d: Any, k: int) -> bool:
    """``mj_step2`` in pieces: the kd != 1 term needs ``qacc_smooth``; after the solve the
    motor rows are made exact (solve.polish) and the speeds clamped. False: the polish found
    the free motor rows singular (the step is still completed, as in the compiled loop)."""
    mujoco.mj_fwdActuation(m, d)
    mujoco.mj_fwdAcceleration(m, d)
    t = c.motors
    if len(t.kd_rows):
        d.efc_aref[t.kd_rows] += t.kd_factor * d.qacc_smooth[t.kd_dof]
    ok = True
    if not (k and solve.exact_motors(m, d, t, k)):
        mujoco.mj_fwdConstraint(m, d)
        if k:
            ok = solve.polish(m, d, t, k)
    if c.clamp is not None:  # PyBullet clamps every dof's speed at every step
        clamp_acceleration(d, c.dt, c.clamp)
    mujoco.mj_checkAcc(m, d)
    mujoco.mj_Euler(m, d)
    return ok
