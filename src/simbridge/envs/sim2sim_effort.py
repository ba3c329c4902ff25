"""Torque saturation and joint-limit hits of ``simbridge sim2sim`` (:class:`EffortProbe`),
counted through the Sim's reads alone: saturation over every physics step of an episode, limit
hits over its control steps.

- **Saturated**: a physics step where at least one action joint's applied effort is at its
  effort limit, within compare's :data:`~simbridge.compare.run.events.SATURATION_TOLERANCE`
  (relative). The applied effort is the motor force of that step as the engine reads it
  (``Sim.joint_states(...).applied_torques``) in the position and velocity modes, and the torque
  the env commanded in the torque and PD modes: that is what the engine applies, and every
  engine reads 0 there (``applied_torques`` is the motor's force alone, as PyBullet's
  ``appliedJointMotorTorque``: tests/conformance/test_applied_torques.py).
  A joint's effort limit is the task's ``max_force`` (the position and velocity motors' force
  bound, the torque and PD modes' clip), or the joint table's ``max_force`` (the file's effort
  limit) where that is positive and smaller. Under the ``actuator`` mode (an MJCF read as
  MuJoCo reads it) the effort is the actuator's control as the env wrote it and its limit the
  larger bound of the actuator's ``ctrlrange`` (none where the control is not limited).
- **At a limit**: a control step after which at least one movable joint of the action robot
  with a position limit (lower < upper; not a continuous joint) is within compare's
  :data:`~simbridge.compare.run.events.LIMIT_TOLERANCE` of it or past it, as compare's
  ``joint_limit`` event counts it (1% of the range where that is smaller). The positions are
  the env's own read of the step (the one its observation shares), so this costs no engine
  call; a joint that touches a limit between two control steps and leaves it is not counted.

Saturation costs one ``joint_states`` read per physics step in the position and velocity modes
(none in the torque and PD modes, where the env knows the torque it commanded).
"""

from __future__ import annotations

import numpy as np

from simbridge.envs.env import SimEnv
from simbridge.types import JointType

__all__ = ["EffortProbe"]


class EffortProbe:
    """Counts saturated and at-limit physics steps of ``env`` while installed.

    Args:
        env: the env; :meth:`install` sets its ``physics_hook``.

    Attributes:
        effort_limit: ``(n,)`` N·m or N, each action joint's effort limit (task's order); the
            actuator mode: each actuator's control bound.
        limited: the engine's joint indices of the action robot's position-limited joints.
        lower: ``(k,)`` their lower limits (rad or m).
        upper: ``(k,)`` their upper limits.
    """

    def __init__(self, env: SimEnv) -> None:
        from simbridge.compare.run.events import LIMIT_TOLERANCE, SATURATION_TOLERANCE

        self.env = env
        sim, w = env.sim, env.world
        table = {j.index: j for j in sim.joints(w.body)}
        if env.task.action.mode == "actuator":  # the control against its ctrlrange's bound
            ranges = {u.name: u.ctrl_range for u in sim.actuators()}
            bounds = [ranges[a] for a in env.task.action.joints]
            self.effort_limit = np.array(
                [np.inf if r is None else max(abs(r[0]), abs(r[1])) for r in bounds],
                dtype=np.float64,
            )
        else:
            task_limit = np.broadcast_to(
                np.asarray(env.task.action.max_force, dtype=np.float64), (len(w.joints),)
            )
            file_limit = np.array([table[int(i)].max_force for i in w.joints], dtype=np.float64)
            self.effort_limit = np.where(
                (file_limit > 0) & (file_limit < task_limit), file_limit, task_limit
            )
        self._threshold = self.effort_limit * (1.0 - SATURATION_TOLERANCE)
        limited = [
            j for j in table.values() if j.type != JointType.FIXED and j.lower_limit < j.upper_limit
        ]
        self.limited = np.array([j.index for j in limited], dtype=np.int64)
        self.lower = np.array([j.lower_limit for j in limited], dtype=np.float64)
        self.upper = np.array([j.upper_limit for j in limited], dtype=np.float64)
        self._tol = np.minimum(LIMIT_TOLERANCE, 0.01 * (self.upper - self.lower))
        self._limited_key = tuple(int(i) for i in self.limited)
        self._last: tuple[np.ndarray | None, bool] = (None, False)
        self.steps = self.saturated = self.control_steps = self.at_limit = 0

    def install(self) -> EffortProbe:
        """Count from now on: the env's ``physics_hook`` set to this probe.

        Returns:
            The probe.
        """
        self.env.physics_hook = self.after_step
        return self

    def remove(self) -> None:
        """Stop counting (the env steps as before)."""
        if self.env.physics_hook == self.after_step:
            self.env.physics_hook = None

    def start(self) -> None:
        """Zero the counts (an episode's start)."""
        self.steps = self.saturated = self.control_steps = self.at_limit = 0

    def after_step(self, torque: np.ndarray | None) -> None:
        """Count the last physics step: its applied efforts and joint positions.

        Args:
            torque: ``(n,)`` the torques the env commanded for the step (the torque and PD
                modes); None: the engine's motors set them, read back.
        """
        self.steps += 1
        if torque is not None and torque is self._last[0]:  # the torque mode's held torque
            self.saturated += self._last[1]
            return
        if torque is None:
            w = self.env.world
            torque = self.env.sim.joint_states(w.body, w.joints).applied_torques
        hit = bool(np.any(np.abs(torque) >= self._threshold))
        self._last = (torque, hit)
        self.saturated += hit

    def after_control_step(self) -> None:
        """Count the control step just taken (``env.step``): its joints against their limits."""
        self.control_steps += 1
        if self.limited.size:
            q = self.env.world.joint_states(self._limited_key)[0]
            hit = (q <= self.lower + self._tol) | (q >= self.upper - self._tol)
            self.at_limit += bool(np.any(hit))

    def shares(self) -> tuple[float, float]:
        """The shares counted since :meth:`start`.

        Returns:
            ``(saturated, at_limit)``: the share of the physics steps saturated and of the
            control steps at a limit, each in [0, 1] (0 before a step).
        """
        return self.saturated / max(self.steps, 1), self.at_limit / max(self.control_steps, 1)
