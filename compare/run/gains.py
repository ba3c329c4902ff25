"""The same position controller at another time step: PyBullet's position gains converted so
that the controller's continuous-time behaviour is held fixed.

PyBullet's position law (every engine's here: ``Sim.set_joint_position``) asks each step for
the velocity change ``kp * (target - q) / dt - kd * v``. The step is in the law, so the same
``kp`` and ``kd`` are another controller at another step: unsaturated, the error ``e`` and
``u = dt * v`` obey ``e' = (1 - kp) e - (1 - kd) u``, ``u' = kp e + (1 - kd) u`` each step,
a matrix ``M`` whose trace is ``2 - kp - kd`` and whose determinant is ``1 - kd``. Halve the
step with the same gains and the error decays per step as fast as before, in half the time:
twice as stiff (kuka-reach's own error, dt against dt/2, measured in
tests/compare/run/test_gains.py).

:func:`held_gains` gives the gains at ``dt' = r * dt`` whose matrix has the eigenvalues of
``M`` to the power ``r`` (``r`` steps of ``dt'`` then do what one step of ``dt`` did, for
the error's every mode): ``kd' = 1 - (1 - kd)^r`` and ``kp' = 2 - kd' - (l1^r + l2^r)``, where
``l1``, ``l2`` are ``M``'s eigenvalues (complex ones as ``2 rho^r cos(r theta)``). With
PyBullet's default ``kd = 1``: ``kp' = 1 - (1 - kp)^r`` (0.1 at 1/240 s is 0.0513 at 1/480 s).

Gains whose law has no such equivalent, a mode that flips sign each step (``kp > 1`` with
``kd = 1``; ``kd > 1``; a negative real eigenvalue), raise :class:`GainsChangeWithStep`: the
controller changes with the step, and a comparison of the two steps measures the controller,
not the integration.
"""

from __future__ import annotations

import cmath
import inspect
import math
from typing import Any

import numpy as np

from simbridge.exceptions import SimbridgeError

__all__ = ["held_gains", "GainsChangeWithStep", "HeldGains", "DEFAULT_KP", "DEFAULT_KD"]


def _defaults() -> tuple[float, float]:
    from simbridge import Sim

    params = inspect.signature(Sim.set_joint_position).parameters
    return float(params["kp"].default), float(params["kd"].default)


DEFAULT_KP, DEFAULT_KD = _defaults()
"""``Sim.set_joint_position``'s own gains (PyBullet's ``positionGain`` 0.1 and
``velocityGain`` 1), read from its signature."""


class GainsChangeWithStep(SimbridgeError):
    """Position gains whose law has no equivalent at another time step (a mode of the error
    flips sign each step): the controller changes with the step."""


def held_gains(kp: float, kd: float, ratio: float) -> tuple[float, float]:
    """``(kp', kd')``: the gains at ``ratio`` times the step that make the same controller as
    ``kp``, ``kd`` at the step (see the module's docstring). ``ratio == 1`` gives them back
    as they are.

    Raises:
        GainsChangeWithStep: no such gains (a mode flipping sign each step).
    """
    kp, kd, ratio = float(kp), float(kd), float(ratio)
    if ratio == 1.0:
        return kp, kd
    det = 1.0 - kd
    tr = 2.0 - kp - kd
    disc = tr * tr - 4.0 * det
    if det < 0.0 or (disc >= 0.0 and (tr - math.sqrt(disc)) / 2.0 < 0.0):
        raise GainsChangeWithStep(
            f"kp = {kp:g}, kd = {kd:g}: the position law's error flips sign each step (a "
            "negative mode), so no gains at another step make the same controller"
        )
    if disc >= 0.0:
        root = math.sqrt(disc)
        l1, l2 = (tr + root) / 2.0, (tr - root) / 2.0
        trace = l1**ratio + l2**ratio
    else:
        rho, theta = cmath.polar(complex(tr / 2.0, math.sqrt(-disc) / 2.0))
        trace = 2.0 * rho**ratio * math.cos(ratio * theta)
    kd_new = 1.0 - det**ratio
    kp_new = 2.0 - kd_new - trace
    return max(kp_new, 0.0), kd_new


class HeldGains:
    """A :class:`simbridge.Sim` whose position commands (``set_joint_position``,
    ``position_command``) take gains written for the step ``written_for`` and send
    :func:`held_gains` at the Sim's step; every other call is the Sim's own."""

    def __init__(self, sim: Any, ratio: float, where: str = "", written_for: str = ""):
        self._sim = sim
        self._ratio = float(ratio)
        self._where = where
        self._written_for = written_for
        self._cache: dict[tuple[float, float], tuple[float, float]] = {}
        self._checked: set[tuple[int, str]] = set()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._sim, name)

    def __repr__(self) -> str:
        return f"HeldGains({self._sim!r}, ratio={self._ratio:g})"

    def _convert(self, kp: Any, kd: Any) -> tuple[Any, Any]:
        try:
            return self._held(kp, kd)
        except GainsChangeWithStep as exc:
            at = f"{self._where}: " if self._where else ""
            written = f" written for {self._written_for} s" if self._written_for else ""
            raise GainsChangeWithStep(
                f"{at}position gains{written}: {exc}. The controller changes with the time "
                "step, so a run at another step (dt/2 for the own error, --timestep, --resolve) "
                "would measure another controller, not the integration; gains with "
                "0 <= kp <= 1 and PyBullet's kd = 1 have an equivalent at every step"
            ) from None

    def _held(self, kp: Any, kd: Any) -> tuple[Any, Any]:
        if isinstance(kp, (int, float)) and isinstance(kd, (int, float)):
            key = (float(kp), float(kd))
            out = self._cache.get(key)
            if out is None:
                out = self._cache[key] = held_gains(key[0], key[1], self._ratio)
            return out
        kps, kds = np.broadcast_arrays(np.asarray(kp, dtype=float), np.asarray(kd, dtype=float))
        pairs = [
            held_gains(p, d, self._ratio) for p, d in zip(kps.ravel(), kds.ravel(), strict=True)
        ]
        shape = kps.shape
        return (
            np.array([p for p, _ in pairs]).reshape(shape),
            np.array([d for _, d in pairs]).reshape(shape),
        )

    def _refuse_spherical(self, body: int, joints: Any) -> None:
        """PyBullet's spherical motor law (``-kd v + 0.2 kp e / dt`` as the velocity) is not
        the revolute one, and its modes flip sign each step with its default gains: no gains
        at another step make the same controller."""
        key = (body, repr(joints))
        if key in self._checked:
            return
        from simbridge.types import JointType

        items = joints if isinstance(joints, (list, tuple, np.ndarray)) else [joints]
        for j in items:
            index = self._sim.joint_index(body, j) if isinstance(j, str) else int(j)
            if self._sim.joint_info(body, index).type == JointType.SPHERICAL:
                at = f"{self._where}: " if self._where else ""
                raise GainsChangeWithStep(
                    f"{at}a position command on spherical joint {index} "
                    f"({self._sim.joint_info(body, index).name!r}): PyBullet's spherical motor "
                    "law has no equivalent at another time step, so a run at another step "
                    "(dt/2 for the own error, --timestep, --resolve) would measure another "
                    "controller; command it at the scenario's own step, or by torque"
                )
        self._checked.add(key)

    def set_joint_position(
        self,
        body: int,
        joints: Any,
        target: Any = None,
        *,
        kp: Any = DEFAULT_KP,
        kd: Any = DEFAULT_KD,
        **kw: Any,
    ) -> None:
        self._refuse_spherical(body, joints)
        kp, kd = self._convert(kp, kd)
        if target is None:
            self._sim.set_joint_position(body, joints, kp=kp, kd=kd, **kw)
        else:
            self._sim.set_joint_position(body, joints, target, kp=kp, kd=kd, **kw)

    def position_command(
        self,
        body: int,
        joints: Any,
        target: Any,
        *,
        kp: Any = DEFAULT_KP,
        kd: Any = DEFAULT_KD,
        **kw: Any,
    ) -> Any:
        self._refuse_spherical(body, joints)
        kp, kd = self._convert(kp, kd)
        return self._sim.position_command(body, joints, target, kp=kp, kd=kd, **kw)
