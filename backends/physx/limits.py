"""PyBullet's joint-limit rows for a joint past its limit (a part of :class:`PhysxBackend`).

PyBullet's limit row (btMultiBodyJointLimitConstraint) exists once a joint is at or past its
limit, only pushes the joint back in and asks for zero speed along it plus, while the
penetration ``d`` is under :data:`LIMIT_DEEP`, a push-back at ``LIMIT_ERP d / dt``; deeper, it
only stops outward motion.

PhysX's articulation limit puts a joint found past it back on the limit within the step and
keeps most of the correction as speed, and none of PhysX's own settings gives PyBullet's law
(the measurements, raw PyBullet's and each PhysX setting's: docs/physx_backend.md, "Joint
limits").

While a joint is past its limit the backend stands in for the row. Before the step, PhysX's
limit on the violated side is moved to where the row lets the joint be after it, ``q + vt dt``
(``vt``: ``-LIMIT_ERP d / dt`` past the upper limit, ``+`` past the lower one, 0 deeper than
:data:`LIMIT_DEEP`): whatever would leave the joint further out is stopped there, as by the
row. After the step, where that limit held the joint (it ends on the bound, or short of it: PhysX
moves a joint it finds past a limit 0.8 of the way when other forces act on it, and keeps 0.8 of
the correction as speed), the joint is put on the bound at the row's speed ``vt``; where the
joint went further in on its own, it is left as PhysX left it (the row did not act). Once the
joint is back within its range its limit is PhysX's own again. Only a write of the joint state
(the load, ``reset_joint_state``, a restore) can leave a joint past its limit here: a robot is
looked at after one, and steps as before unless a joint is past its limit.

The fix after the step is an impulse on the held joints: on a fixed base it moves the rest of
the chain through the inverse mass matrix (PhysX's articulation at q, SAPIEN's Pinocchio model),
as PyBullet's row impulse does (how close that comes, and written to the held joint alone:
docs/physx_backend.md); on a floating base it is written to the held joints alone (the base's
share is not reproduced).

Departure: a joint that arrives at its limit from inside is PhysX's (stopped on the limit;
PyBullet's row, made only once a step starts at or past the limit, lets it pass by up to a
step's travel and pushes it back).

The engine setting ``limit_rule`` (backends/settings_physx.py) chooses: ``"hard"`` (the default,
all of the above) or ``"pybullet"``, PyBullet's rule on arrival too. Under ``"pybullet"`` PhysX's
own limits are moved :data:`LIMIT_CLEAR` out of the joint's range at the load, beyond any step's
travel, so that a joint inside its range at the start of a step moves freely through the step
(as no PyBullet row exists then), and the row above stands in from every step that starts at or
past a limit (``>=``: PyBullet makes the row at zero penetration too); the robot is looked at
every step. A joint that would travel more than :data:`LIMIT_CLEAR` past its limit in one step
is stopped there (PyBullet: nowhere).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .robots import Robot

__all__ = ["LimitRows", "LIMIT_ERP", "LIMIT_DEEP", "LIMIT_CLEAR", "LIMIT_RULES"]

LIMIT_ERP = 0.2  # PyBullet's push-back per step, a fraction of the penetration
LIMIT_DEEP = 0.04  # m or rad: deeper than this the row only stops outward motion
# m or rad: under limit_rule "pybullet", PhysX's own limits this far out of the joint's range
# (no joint travels that far in a step: 2400 rad/s at 1/240 s)
LIMIT_CLEAR = 10.0
LIMIT_RULES = ("hard", "pybullet")  # backends/settings_physx.py's limit_rule


def limit_rows(robot: Robot, rule: str = "hard") -> None:
    """Record ``robot``'s limited 1-DoF joints.

    Each one's dof, PhysX joint and limits as PhysX holds them (float32, so that a joint reset
    exactly at a limit is at it, not past), in ``robot.limit_rows`` and ``robot.limit_of``.

    Args:
        robot: The robot, just built.
        rule: ``"hard"``, PhysX's limits as they are; ``"pybullet"``: PhysX's limits moved
            :data:`LIMIT_CLEAR` out, and the robot looked at every step.
    """
    rows = []
    limit_of = [(-np.inf, np.inf)] * len(robot.table)
    for j in robot.movable:
        joint = robot.joints[j]
        if j in robot.balls or joint is None:
            continue
        lo, hi = (float(x) for x in joint.limit[0])
        if np.isfinite(lo) and np.isfinite(hi):
            rows.append((int(robot.dof[j]), joint, lo, hi))
            limit_of[j] = (lo, hi)
    robot.limit_rows = rows
    robot.limit_of = limit_of
    if rule == "pybullet" and rows:
        robot.limit_clear = LIMIT_CLEAR
        for _, joint, lo, hi in rows:
            joint.limit = np.array([[lo - LIMIT_CLEAR, hi + LIMIT_CLEAR]], dtype=np.float32)
        robot.past_limit = True  # never let go: every step is looked at


class LimitRows:
    """The joint-limit methods (a part of :class:`PhysxBackend`)."""

    if TYPE_CHECKING:
        _dt: float

        def _refresh_active(self) -> None: ...

    def _check_limits(self, robot: Robot) -> None:
        """After a write of ``robot``'s joint state: does a joint now start past its limit
        (or does a moved limit wait to be put back)?"""
        if not robot.limit_rows or robot.static:
            return
        q = robot.built.articulation.qpos.tolist()  # plain floats: cheaper than numpy here
        past = bool(robot.moved)
        for d, _, lo, hi in robot.limit_rows:
            x = q[d]
            if x < lo or x > hi:
                past = True
                break
        if past and not robot.past_limit:  # let go at the next step when nothing is past
            robot.past_limit = True
            self._refresh_active()

    def _limit_rows(self, robot: Robot) -> None:
        """PyBullet's limit rows for this step on the joints past their limits (see above):
        PhysX's limit on the violated side moved to ``q + vt dt``. Under limit_rule "pybullet"
        (``limit_clear`` > 0) on the joints at their limits too, PhysX's limits elsewhere
        ``limit_clear`` out of the range."""
        q = robot.built.articulation.qpos
        dt = self._dt
        held = robot.held
        moved = robot.moved
        clear = robot.limit_clear
        at = clear > 0.0  # PyBullet's rule: a row at zero penetration too
        for i, (d, joint, lo, hi) in enumerate(robot.limit_rows):
            x = float(q[d])
            if x > hi or (at and x >= hi):
                depth = x - hi
                vt = -LIMIT_ERP * depth / dt if depth < LIMIT_DEEP else 0.0
                bound = np.float32(x + vt * dt)
                joint.limit = np.array([[lo - clear, bound]], dtype=np.float32)
                side = 1.0
            elif x < lo or (at and x <= lo):
                depth = lo - x
                vt = LIMIT_ERP * depth / dt if depth < LIMIT_DEEP else 0.0
                bound = np.float32(x + vt * dt)
                joint.limit = np.array([[bound, hi + clear]], dtype=np.float32)
                side = -1.0
            else:
                if i in moved:
                    joint.limit = np.array([[lo - clear, hi + clear]], dtype=np.float32)
                    moved.discard(i)
                continue
            moved.add(i)
            held.append((d, float(bound), vt, side, 2.0 * float(np.spacing(bound))))
        if not held and not at:
            robot.past_limit = False
            self._refresh_active()

    def _limit_rows_after(self, robot: Robot) -> None:
        """After the step: where PhysX's moved limit held a joint (it ends on the bound, or
        short of it), the joint on the bound at the row's speed ``vt`` (PhysX keeps 0.8 of a
        correction as speed, the row asks for all of it), the rest of a fixed-base chain moved
        as those joints' impulses move it; where the joint went further in on its own, as
        PhysX left it."""
        art = robot.built.articulation
        q = art.qpos
        v = art.qvel
        fixes = []  # (dof, position change, speed change) of each joint the limit held
        for d, bound, vt, side, ulps in robot.held:
            x = float(q[d])
            if side * (x - bound) < -ulps:  # further in than the bound: the joint's own motion
                continue
            if x != bound or float(v[d]) != vt:
                fixes.append((d, bound - x, vt - float(v[d])))
        if not fixes:
            robot.held = []
            return
        rows = [f[0] for f in fixes]
        dx = np.array([f[1] for f in fixes])
        du = np.array([f[2] for f in fixes])
        if robot.fixed and len(q) > len(rows):
            # the change through the chain, as impulses on those joints move it: with the
            # inverse mass matrix W (PhysX's articulation at q, through SAPIEN's Pinocchio
            # model), impulses l with W[K, K] l = change move every joint by W[:, K] l
            if robot.pinocchio is None:
                robot.pinocchio = art.create_pinocchio_model()
            w = np.linalg.inv(robot.pinocchio.compute_generalized_mass_matrix(q))
            wk = w[np.ix_(rows, rows)]
            dq = w[:, rows] @ np.linalg.solve(wk, dx)
            dv = w[:, rows] @ np.linalg.solve(wk, du)
        else:  # a floating base: those joints alone
            dq = np.zeros(len(q))
            dv = np.zeros(len(q))
            dq[rows] = dx
            dv[rows] = du
        q = (q + dq).astype(np.float32)
        v = (v + dv).astype(np.float32)
        for d, x, u in zip(rows, dx, du, strict=True):  # on the bound at the row's speed
            q[d] = np.float32(float(art.qpos[d]) + x)
            v[d] = np.float32(float(art.qvel[d]) + u)
        if dx.any():  # a write of the positions makes PhysX derive the link poses afresh
            art.qpos = q
        art.qvel = v
        robot.held = []
