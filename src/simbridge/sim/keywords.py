"""The error of a Sim call given a keyword it does not take, PyBullet's name of an argument most
often (``sim.load_urdf("r2d2.urdf", basePosition=[0, 0, 1])``), or missing a required one.

The calls take such keywords in a ``**`` catch-all and raise :func:`keyword_error` when it is
not empty: one test on the command path, the message built only when it raises. A required
argument's default is a :class:`Missing` (so that a PyBullet keyword given in its place is
named rather than Python's "missing argument"): the argument checks raise its error when they
meet it, which costs the normal flow nothing."""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from typing import Any

from simbridge.exceptions import PyBulletKeywordError, did_you_mean

__all__ = ["Missing", "PYBULLET_KEYWORDS", "keyword_error"]


class Missing:
    """The default of a required argument of a Sim call: an argument check that meets it
    raises :meth:`error`, Python's "missing argument" as a PyBulletKeywordError.

    Args:
        call: The Sim call's name (``"set_joint_velocity"``).
        argument: The required argument's name.
        keyword_only: Whether the argument is keyword-only (the message says which kind).
    """

    __slots__ = ("call", "argument", "keyword_only")

    def __init__(self, call: str, argument: str, keyword_only: bool = False) -> None:
        self.call = call
        self.argument = argument
        self.keyword_only = keyword_only

    def __repr__(self) -> str:
        return f"<not given: Sim.{self.call}() requires {self.argument}>"

    def error(self) -> PyBulletKeywordError:
        """Python's "missing argument" error for this argument.

        Returns:
            A :class:`~simbridge.exceptions.PyBulletKeywordError` naming ``Sim.call()`` and
            the argument (for the caller to raise).
        """
        kind = "keyword-only" if self.keyword_only else "positional"
        return PyBulletKeywordError(
            f"Sim.{self.call}()", f"missing 1 required {kind} argument: {self.argument!r}"
        )


_CLIENT = "none: a Sim is its own connection (one Sim per PyBullet client)"
_BODY = "body (the first argument)"
_JOINTS = "joints (the second argument: an index, a name or a list of them)"
_MAX_VELOCITY = (
    "none: simbridge has no per-motor speed cap; the profile's max_joint_velocity clamps every "
    "joint speed (Sim(profile='pybullet+max_joint_velocity=50'))"
)

# a call's keywords in PyBullet's names -> simbridge's name, or "none: ..." (what instead)
PYBULLET_KEYWORDS: dict[str, dict[str, str]] = {
    "load_urdf": {
        "fileName": "source (the first argument)",
        "basePosition": "base_position",
        "baseOrientation": "base_orientation",
        "useFixedBase": "fixed_base",
        "globalScaling": "global_scaling",
        "useMaximalCoordinates": "none: every backend loads reduced coordinates",
        "flags": "keywords for PyBullet's URDF_* flags: self_collision "
        "(URDF_USE_SELF_COLLISION...), inertia_source (URDF_USE_INERTIA_FROM_FILE), "
        "merge_fixed_links (URDF_MERGE_FIXED_LINKS)",
        "physicsClientId": _CLIENT,
    },
    "set_joint_velocity": {
        "bodyUniqueId": _BODY,
        "bodyIndex": _BODY,
        "jointIndex": _JOINTS,
        "jointIndices": _JOINTS,
        "controlMode": "none: set_joint_velocity is VELOCITY_CONTROL",
        "targetVelocity": "target",
        "targetVelocities": "target",
        "force": "max_force",
        "forces": "max_force",
        "maxVelocity": _MAX_VELOCITY,
        "physicsClientId": _CLIENT,
    },
    "set_joint_position": {
        "bodyUniqueId": _BODY,
        "bodyIndex": _BODY,
        "jointIndex": _JOINTS,
        "jointIndices": _JOINTS,
        "controlMode": "none: set_joint_position is POSITION_CONTROL",
        "targetPosition": "target",
        "targetPositions": "target",
        "targetVelocity": "none: the position law drives towards velocity 0 (kd damps it)",
        "force": "max_force",
        "forces": "max_force",
        "positionGain": "kp",
        "positionGains": "kp",
        "velocityGain": "kd",
        "velocityGains": "kd",
        "maxVelocity": _MAX_VELOCITY,
        "physicsClientId": _CLIENT,
    },
    "set_joint_torque": {
        "bodyUniqueId": _BODY,
        "bodyIndex": _BODY,
        "jointIndex": _JOINTS,
        "jointIndices": _JOINTS,
        "controlMode": "none: set_joint_torque is TORQUE_CONTROL",
        "force": "torque",
        "forces": "torque",
        "physicsClientId": _CLIENT,
    },
    "reset_joint_state": {
        "bodyUniqueId": _BODY,
        "jointIndex": _JOINTS,
        "jointIndices": _JOINTS,
        "targetValue": "positions",
        "targetValues": "positions",
        "targetVelocity": "velocities",
        "targetVelocities": "velocities",
        "physicsClientId": _CLIENT,
    },
}


def keyword_error(method: Any, extra: Mapping[str, Any]) -> PyBulletKeywordError:
    """The error of a call of ``method`` (a bound Sim method) given the keywords ``extra`` it
    does not take: each one and simbridge's name for it (or the closest), then the valid
    keywords.

    Args:
        method: the bound Sim method called (its name and signature make the message).
        extra: the keywords given that it does not take, by name.

    Returns:
        The :class:`~simbridge.exceptions.PyBulletKeywordError` to raise.
    """
    call = f"Sim.{method.__name__}()"
    valid = [
        p.name
        for p in inspect.signature(method).parameters.values()  # a bound method: no self
        if p.kind is not p.VAR_KEYWORD
    ]
    known = PYBULLET_KEYWORDS.get(method.__name__, {})
    parts = []
    for key in extra:
        ours = known.get(key)
        if ours is None:
            parts.append(f"got an unexpected keyword argument {key!r}{did_you_mean(key, valid)}")
        elif ours.startswith("none:"):
            parts.append(f"got PyBullet's keyword {key!r}, which has no counterpart ({ours[6:]})")
        else:
            parts.append(f"got PyBullet's keyword {key!r}: simbridge's is {ours}")
    return PyBulletKeywordError(call, "; ".join(parts) + f"; valid keywords: {', '.join(valid)}")
