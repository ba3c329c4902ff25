"""Bound commands: a velocity or position command bound once to a body and its joints, whose
targets are written in place every step (``Sim.velocity_command``, ``Sim.position_command``).

::

    cmd = sim.velocity_command(robot, [2, 3, 6, 7], [-10, -10, 10, 10], max_force=50)
    for k in range(1000):
        cmd.targets[:] = policy(observation)   # in place: no call, no check, no allocation
        sim.step()                             # the step reads cmd.targets and cmd.max_force

The joints, shapes and values are checked once when the command is bound; every
``sim.step()`` then sends the arrays as they are, as if ``set_joint_velocity(body, joints,
cmd.targets, max_force=cmd.max_force)`` (or ``set_joint_position`` with the command's ``kp``
and ``kd``) were called just before it, with the same results bit for bit. A value that changed
is checked when the step reads it: a non-finite target or a negative or non-finite force raises
:class:`~simbridge.exceptions.InvalidArgumentError` from ``sim.step()`` before any step is taken.

While bound, the command owns its joints' motors: ``set_joint_velocity`` and
``set_joint_position`` on them (and a second bound command) are refused until
:meth:`BoundCommand.release`; torques and resets still apply. A world change (``load_urdf``,
even one that fails, ``remove``, ``reset``, ``close``) ends every bound command of the Sim: its
motors keep the command last sent, its arrays become read-only, and any use of it raises
:class:`~simbridge.exceptions.StaleCommandError`; bind a new one.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from simbridge.exceptions import InvalidArgumentError, StaleCommandError

__all__ = ["BoundCommand"]

_ARRAYS = ("targets", "max_force")


class BoundCommand:
    """A velocity or position command bound to a body's joints (see the module docstring).

    Attributes:
        targets: ``(n,)`` float64, the target of each joint: rad/s or m/s for a velocity
            command, rad or m for a position command (clamped to the joint's limits when sent,
            as PyBullet does). Write it in place (``cmd.targets[:] = x``, ``cmd.targets[i] =
            v``) or assign it (``cmd.targets = x``: copied in, shape checked).
        max_force: ``(n,)`` float64, the force limit of each joint's motor (N·m or N, >= 0),
            written the same way.
        mode: ``"velocity"`` or ``"position"``.
        body: the body id.
        joints: ``(n,)`` np.intp, read-only: the joint indices, in the order of the arrays.
        kp, kd: the position command's gains per joint (fixed when bound; a velocity command
            has kp 0 and kd 1).
        backend_handle: the backend's own record of the binding (None when it keeps none).
    """

    __slots__ = (
        *_ARRAYS,
        "mode",
        "body",
        "joints",
        "kp",
        "kd",
        "backend_handle",
        "_sim",
        "_why",
        "__weakref__",
    )

    targets: np.ndarray
    max_force: np.ndarray
    mode: str
    body: int
    joints: np.ndarray
    kp: list[float]
    kd: list[float]
    backend_handle: Any

    def __init__(
        self,
        sim: Any,
        mode: str,
        body: int,
        joints: np.ndarray,
        targets: list[float],
        max_force: list[float],
        kp: list[float],
        kd: list[float],
    ) -> None:
        """Made by ``Sim.velocity_command`` / ``Sim.position_command`` from checked values.

        Args:
            sim: The Sim's shared state (:class:`simbridge.sim.shared.Shared`) the command
                is bound in.
            mode: ``"velocity"`` or ``"position"``.
            body: The body's id.
            joints: (n,) ``np.intp`` indices of movable joints.
            targets: n targets (rad/s or m/s for velocity, rad or m for position).
            max_force: n force limits (N·m or N, >= 0).
            kp: n position gains (a velocity command: 0).
            kd: n velocity gains (a velocity command: 1).
        """
        init = object.__setattr__
        init(self, "mode", mode)
        init(self, "body", body)
        init(self, "joints", joints)
        init(self, "kp", kp)
        init(self, "kd", kd)
        init(self, "targets", np.array(targets, dtype=np.float64))
        init(self, "max_force", np.array(max_force, dtype=np.float64))
        init(self, "backend_handle", None)
        init(self, "_sim", sim)
        init(self, "_why", "")

    # ---------------------------------------------------------------- use

    def send(self) -> None:
        """Check the arrays and send them now, as a step does (the backend skips a command
        already in force).

        Raises:
            InvalidArgumentError: a non-finite target, or a negative or non-finite force.
            StaleCommandError: after a world change or :meth:`release`.
        """
        targets = self.targets.tolist()
        force = self.max_force.tolist()
        # a sum of floats is finite only if every one is (an overflow is told apart below)
        if not math.isfinite(sum(targets) + sum(force)) or (force and min(force) < 0.0):
            self._check(targets, force)
        backend = self._sim.backend
        if self.mode == "velocity":
            backend.set_joint_velocity(self.body, self.joints, targets, force)
        else:
            backend.set_joint_position(self.body, self.joints, targets, force, self.kp, self.kd)

    def _check(self, targets: list[float], force: list[float]) -> None:
        if not all(map(math.isfinite, targets)):
            raise InvalidArgumentError(
                "targets", f"values must be finite, got {self.targets!r} ({self._label()})"
            )
        if not all(map(math.isfinite, force)) or min(force) < 0.0:
            raise InvalidArgumentError(
                "max_force",
                f"values must be finite and >= 0, got {self.max_force!r} ({self._label()})",
            )

    def release(self) -> None:
        """Unbind: the arrays are no longer read and the joints take plain commands again;
        the motors keep the command last sent. Safe to call twice, and after a world change."""
        if self._why:
            return
        self._sim.release(self)
        self._end("it was released")

    @property
    def bound(self) -> bool:
        """True until :meth:`release` or a world change."""
        return not self._why

    def __repr__(self) -> str:
        state = "bound" if not self._why else f"stale: {self._why}"
        return f"BoundCommand({self._label()}, {state})"

    # ---------------------------------------------------------------- internals

    def _label(self) -> str:
        return f"{self.mode} command on body {self.body} joints {self.joints.tolist()}"

    def _end(self, why: str) -> None:
        """Make the command stale: arrays read-only, attribute access raises."""
        for name in _ARRAYS:
            arr = object.__getattribute__(self, name)
            arr.setflags(write=False)
            object.__delattr__(self, name)
        object.__setattr__(self, "_why", why)

    def __getattr__(self, name: str) -> Any:
        # reached only for an attribute that is not set: the arrays of a stale command
        if name in _ARRAYS:
            raise StaleCommandError(self._label(), self._why)
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def __setattr__(self, name: str, value: Any) -> None:
        if name == "backend_handle":
            object.__setattr__(self, name, value)
            return
        if name not in _ARRAYS:
            raise AttributeError(
                f"BoundCommand.{name} is fixed when the command is bound; bind a new command "
                "to change it (targets and max_force take new values)"
            )
        arr = getattr(self, name)  # StaleCommandError once stale
        try:
            new = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            raise InvalidArgumentError(
                name, f"expected a number or {len(arr)} numbers, got {value!r}"
            ) from None
        if new.ndim > 1 or (new.ndim == 1 and new.shape != arr.shape):
            raise InvalidArgumentError(
                name,
                f"expected a number or shape {arr.shape} for {len(arr)} joint(s), "
                f"got shape {new.shape}",
            )
        arr[:] = new
