"""The motor and joint-limit rows made exact: PyBullet's rows ask for an exact acceleration,
MuJoCo's keep a regulariser.

:func:`exact_motors` solves the rows directly when they are the only constraint rows (no
contact), :func:`polish` removes the shortfall MuJoCo's solver leaves on the motor rows
otherwise. The compiled loop (_mjkernel.c) does the same arithmetic in the same order.

No BLAS or LAPACK: ``np.linalg.solve`` and ``@`` give other last bits on other OpenBLAS kernels
(what was measured: docs/mujoco_backend.md, "The Python loop is the reference"). Every product
and solve here is written as element-wise numpy operations or scalar arithmetic, each sum taken
term by term in the compiled loop's order, so the Python loop gives the same bits on every
processor, and the compiled loop's bits (tests/test_same_results.py).
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from .motor_rows import MotorTable

__all__ = ["exact_motors", "polish"]

_LIMIT_JOINT = int(mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT)


def lu_solve(a: np.ndarray, b: np.ndarray) -> np.ndarray | None:
    """``x`` with ``a x = b`` by LU with partial pivoting.

    The compiled loop's ``lu_solve`` step for step (the first largest pivot, the row updates element
    by element, the back substitution summed left to right), so the bits are the same on every
    processor.

    Args:
        a: The (n, n) matrix (copied, not changed).
        b: The (n,) right-hand side (copied, not changed).

    Returns:
        The (n,) solution, or None for a singular matrix.
    """
    a = np.array(a, dtype=np.float64)  # copies: both are overwritten
    x = np.array(b, dtype=np.float64)
    n = len(x)
    for c in range(n):
        p, best = c, abs(float(a[c, c]))
        for r in range(c + 1, n):
            v = abs(float(a[r, c]))
            if v > best:
                p, best = r, v
        if not best > 0.0:
            return None
        if p != c:
            a[[c, p]] = a[[p, c]]
            x[c], x[p] = x[p], x[c]
        f = a[c + 1 :, c] / a[c, c]
        rows = np.flatnonzero(f != 0.0)
        if len(rows):
            fr = f[rows]
            a[c + 1 + rows, c + 1 :] -= fr[:, None] * a[c, c + 1 :]
            x[c + 1 + rows] -= fr * x[c]
    u = a.tolist()
    xs = x.tolist()
    for r in range(n - 1, -1, -1):
        s = xs[r]
        row = u[r]
        for j in range(r + 1, n):
            s -= row[j] * xs[j]
        xs[r] = s / row[r]
    return np.array(xs)


def _combine(start: np.ndarray, coef: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """``start + sum_i coef[i] rows[i]``, the terms added one by one in the order of i (the
    compiled loop's order; a BLAS product sums in its own)."""
    out = np.array(start, dtype=np.float64)
    for i in range(len(coef)):
        out += coef[i] * rows[i]
    return out


def _jac_entry(m: Any, d: Any, r: int, dof: int) -> float:
    """The Jacobian entry of constraint row r at dof (efc_J is dense below 60 dofs unless the
    model says otherwise)."""
    if not mujoco.mj_isSparse(m):
        return float(d.efc_J[r * m.nv + dof])
    adr, nnz = d.efc_J_rowadr[r], d.efc_J_rownnz[r]
    cols = d.efc_J_colind[adr : adr + nnz]
    hit = np.flatnonzero(cols == dof)
    return float(d.efc_J[adr + hit[0]]) if len(hit) else 0.0


def _rows(m: Any, d: Any, t: MotorTable, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rows' dofs, their Jacobian signs and their rows of ``M^-1`` (shapes (n,), (n,),
    (n, nv)): a motor row is +1 at its dof, a limit row +-1 at its joint's dof."""
    n = d.nefc
    if n == k:
        y = t.minv_rows
        mujoco.mj_solveM(m, d, y, t.unit_rows)  # rows of M^-1 for the motor dofs
        return t.dof_rows, np.ones(k), y
    dofs = np.concatenate([t.dof_rows, m.jnt_dofadr[d.efc_id[k:n]]])
    sign = np.ones(n)
    sign[k:] = [_jac_entry(m, d, r, int(dofs[r])) for r in range(k, n)]
    unit = np.zeros((n, m.nv))
    unit[np.arange(n), dofs] = 1.0
    y = np.zeros((n, m.nv))
    mujoco.mj_solveM(m, d, y, unit)
    return dofs, sign, y


def _start_limits_free(
    m: Any,
    d: Any,
    k: int,
    dofs: np.ndarray,
    sign: np.ndarray,
    am: np.ndarray,
    hi: np.ndarray,
    side: np.ndarray,
) -> None:
    """Frees, in ``side``, each limit row the first round would free, the motor row on its
    dof at the bound pushing into the limit (one solve less a step for a joint held on its
    limit): with the motor row free at the start, the dof accelerates at the motor's aref, so
    the limit row's need is known before any solve; it must pass the loop's freeing tolerance
    taken with every motor at its force bound (what round-off in its acceleration scales
    with)."""
    n = len(side)
    aref = d.efc_aref[:n]
    motor_of = np.full(m.nv, -1, dtype=np.intp)
    motor_of[dofs[:k][::-1]] = np.arange(k - 1, -1, -1)  # the first motor row per dof
    mr = motor_of[dofs[k:]]
    has = mr >= 0
    bound = np.abs(aref[k:]) + np.abs(sign[k:] * d.qacc_smooth[dofs[k:]])
    for c in range(k):  # summed in the compiled loop's order
        bound += np.abs(am[k:, c]) * hi[c]
    need = has & (aref[k:] - sign[k:] * aref[np.where(has, mr, 0)] > 1e-9 * bound)
    side[k:][need] = 0.0
    side[mr[need]] = np.where(sign[k:][need] > 0.0, -1.0, 1.0)


def _solve_free(
    am: np.ndarray, b: np.ndarray, side: np.ndarray, hi: np.ndarray, lo: np.ndarray
) -> np.ndarray | None:
    """The rows' forces with the rows at a bound (``side`` +-1) held there and the free ones
    (``side`` 0) solved for, or None for a singular free block."""
    free = side == 0
    x = np.where(side > 0, hi, np.where(side < 0, lo, 0.0))
    if free.any():
        rhs = b[free]  # a copy: b[free] - A_FC x_C, term by term in column order
        for col in np.flatnonzero(~free):
            rhs -= am[free, col] * x[col]
        solved = lu_solve(am[np.ix_(free, free)], rhs)
        if solved is None:
            return None
        x[free] = solved
    return x


def _overshoot(
    d: Any,
    k: int,
    dofs: np.ndarray,
    sign: np.ndarray,
    am: np.ndarray,
    b: np.ndarray,
    x: np.ndarray,
    side: np.ndarray,
) -> np.ndarray:
    """How far past its aref each row at a bound drives its acceleration (0 for the free rows
    and those within round-off), so that freeing it is due."""
    n = len(side)
    aref = d.efc_aref[:n]
    free = side == 0
    smooth = sign * d.qacc_smooth[dofs]
    acc = smooth.copy()
    terms = np.abs(aref) + np.abs(smooth)  # what round-off in acc scales with
    for j in range(n):
        term = am[:, j] * x[j]
        acc += term
        terms += np.abs(term)
    scale = np.abs(b) + np.abs(np.diag(am)) * np.abs(x)
    # a limit row at zero force is freed only past round-off: a joint resting at its
    # limit under a holding motor leaves it at zero (freeing it there is degenerate)
    tol = np.concatenate([1e-12 * scale[:k], 1e-9 * terms[k:]])
    over_aref = side * (acc - aref)  # > 0: a row at a bound overshoots its aref
    return np.where(~free & (over_aref > tol), over_aref, 0.0)


def _free_row(
    k: int,
    dofs: np.ndarray,
    sign: np.ndarray,
    side: np.ndarray,
    overshoot: np.ndarray,
    freed: int,
) -> None:
    """Frees row ``freed`` in ``side``, and moves the rows on its dof that freeing it makes
    inconsistent."""
    was = side[freed]
    side[freed] = 0.0
    same = dofs == dofs[freed]
    if freed >= k:  # freed with every other limit row that overshoots (one solve
        # for the joints that reach their limits together, not one each); a limit
        # row needed on the dof of a free motor row: both would ask for the same
        # dof's acceleration (a singular block), so the motor cannot reach its target
        # past the limit and pushes into the limit at its force bound (the bound
        # opposite the limit's push: the only consistent one; the sign of its free
        # force is not it where the motor brakes a joint that gravity drives into the
        # limit, and that cycled)
        for lim in (np.flatnonzero(overshoot[k:] > 0.0) + k).tolist():
            side[lim] = 0.0
            on_dof = (dofs[:k] == dofs[lim]) & (side[:k] == 0)
            side[:k][on_dof] = -1.0 if sign[lim] > 0.0 else 1.0
    else:
        held = same[k:] & (side[k:] == 0)  # free limit rows on the motor's dof
        if held.any() and was == sign[k:][held][0]:
            # a motor pushing the way its limit pushes, asking for less: the limit
            # holds the dof's acceleration, so only the other bound is consistent
            # (freed, it went back to this one and cycled)
            side[freed] = -was
        else:  # a motor pushing into its limit, asking to leave it, takes the dof
            # over: the limit row goes back to zero force (freed again if needed)
            side[k:][held] = -1.0


def exact_motors(m: Any, d: Any, t: MotorTable, k: int) -> bool:
    """When the motor rows and joint-limit rows are the only constraint rows (no contact),
    solve them exactly instead of running MuJoCo's solver and polishing: PyBullet's rows
    are the box-constrained problem ``A x = b`` on the free rows, ``x`` at a bound on the
    others (+-max_force for a motor, [0, inf) for a limit, which only pushes; A the rows'
    block of J M^-1 J^T, each row +-1 at one dof; b = aref - J qacc_smooth), found by an
    active set: the free row furthest past a bound goes to it; a row at a bound whose
    acceleration overshoots its aref is freed. Motor rows start free, limit rows at zero.
    The compiled loop does the same (_mjkernel.c exact_motors).

    Args:
        m: The ``mujoco.MjModel``.
        d: The ``mujoco.MjData``, after ``mj_fwdAcceleration`` (its ``efc_*`` rows built).
        t: The motor rows' table.
        k: How many motor rows (the first ``k`` constraint rows).

    Returns:
        True with ``efc_force``, ``qfrc_constraint`` and ``qacc`` written; False (other
        rows, no convergence, a singular block) leaves the step to MuJoCo's solver.
    """
    n = d.nefc
    if d.ne or d.nf != k or (n > k and (d.efc_type[k:n] != _LIMIT_JOINT).any()):
        return False
    dofs, sign, y = _rows(m, d, t, k)
    am = sign[:, None] * sign[None, :] * y[:, dofs]
    aref = d.efc_aref[:n]
    hi = np.concatenate([d.efc_frictionloss[:k], np.full(n - k, np.inf)])
    lo = np.concatenate([-hi[:k], np.zeros(n - k)])
    b = aref - sign * d.qacc_smooth[dofs]
    scale_over = np.concatenate([hi[:k], np.abs(b[k:]) / np.diag(am)[k:] + 1e-300])
    side = np.concatenate([np.zeros(k), -np.ones(n - k)])  # 0 free, +-1 at hi/lo
    if n > k:
        _start_limits_free(m, d, k, dofs, sign, am, hi, side)
    for _ in range(4 * n + 4):
        x = _solve_free(am, b, side, hi, lo)
        if x is None:
            return False
        free = side == 0
        with np.errstate(invalid="ignore"):
            up = np.where(free, (x - hi) / scale_over, 0.0)
            down = np.where(free, (lo - x) / scale_over, 0.0)
        past = np.maximum(np.nan_to_num(up, nan=0.0), down)
        worst = int(np.argmax(past))
        if past[worst] > 1e-12:
            side[worst] = 1.0 if up[worst] > down[worst] else -1.0
            continue
        overshoot = _overshoot(d, k, dofs, sign, am, b, x, side)
        freed = int(np.argmax(overshoot))
        if overshoot[freed] > 0.0:
            _free_row(k, dofs, sign, side, overshoot, freed)
            continue
        break
    else:
        return False
    qacc = d.qacc
    qacc[:] = _combine(d.qacc_smooth, x * sign, y)
    free_motor = side[:k] == 0
    qacc[dofs[:k][free_motor]] = aref[:k][free_motor]  # their own accelerations, exactly
    d.efc_force[:n] = x
    d.qfrc_constraint[:] = 0.0
    np.add.at(d.qfrc_constraint, dofs, sign * x)
    return True


def polish(m: Any, d: Any, t: MotorTable, k: int) -> bool:
    """Make every motor row that is not at its force limit reach exactly its acceleration.

    The acceleration each row asks for is its ``efc_aref``, as PyBullet's motor row reaches it:
    MuJoCo's rows keep a regulariser R > 0, so its solution falls short by about R/(A+R) of the
    change. The shortfall r of the free rows is removed with the forces A^-1 r through M^-1 (A the
    rows' inverse inertia); rows at their force limit stay there. The contacts do not see this last
    correction (it is 1e-6 of the motor force).

    Args:
        m: The ``mujoco.MjModel``.
        d: The ``mujoco.MjData``, after MuJoCo's constraint solve; its ``qacc`` and the motor rows'
            ``efc_force`` are written.
        t: The motor rows' table.
        k: How many motor rows (the first ``k`` constraint rows).

    Returns:
        True; False when the free rows' block is singular (nothing is changed; the compiled
        loop's status 3).
    """
    y = t.minv_rows
    mujoco.mj_solveM(m, d, y, t.unit_rows)  # rows of M^-1 for the motor dofs
    force = d.efc_force[:k]
    qacc = d.qacc
    dofs = t.dof_rows
    short = d.efc_aref[:k] - qacc[dofs]
    free = np.abs(force) < t.force_rows_slack
    if not free.any():
        return True
    rows = np.flatnonzero(free)
    sub = y[rows]
    delta = lu_solve(sub[:, dofs[rows]], short[rows])
    if delta is None:
        return False
    qacc += _combine(np.zeros(m.nv), delta, sub)
    qacc[dofs[rows]] = d.efc_aref[:k][rows]  # the rows' own accelerations, without round-off
    force[rows] += delta
    return True
