"""Argument checks of the `Sim` interface: vectors, quaternions, switches, command values and
spherical joints' per-axis values and target quaternions (:mod:`simbridge.spherical`),
each refused with an :class:`~simbridge.exceptions.InvalidArgumentError` naming the argument.

Every function returns plain Python floats (tuples or lists) ready for a backend; none touches
an engine. ``command_values`` is the hot path of every control loop (see there).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from simbridge.exceptions import InvalidArgumentError
from simbridge.sim.keywords import Missing

__all__ = [
    "MAX_STATE_VALUE",
    "JointsArg",
    "LinkArg",
    "LinksArg",
    "checked_state",
    "command_values",
    "flag",
    "per_axis",
    "quat",
    "quaternions",
    "state_vec",
    "vec",
    "within",
]

_F64 = np.dtype(np.float64)  # native float64: ``arr.dtype is _F64`` is the hot path's test

# A joints argument: an index, a name, or an ordered sequence (or array) of them.
JointsArg = int | str | Sequence[int | str] | np.ndarray
# A link argument: an index (-1 = base) or a name.
LinkArg = int | str
# A links argument: a link argument, or an ordered sequence (or array) of them.
LinksArg = int | str | Sequence[int | str] | np.ndarray


_TOO_LARGE = "values must be finite floats, got an integer past float's range (over 1.8e308)"


def vec(value: Any, n: int, argument: str) -> tuple[float, ...]:
    """``n`` finite numbers.

    Args:
        value: a sequence (or array) of numbers.
        n: how many it must hold.
        argument: the argument's name, for the message.

    Returns:
        ``n`` Python floats.

    Raises:
        InvalidArgumentError: not ``n`` numbers, or one not finite (or past float's range).
    """
    try:
        out = tuple(float(v) for v in value)
    except OverflowError:  # an int past float's range (10**400)
        raise InvalidArgumentError(argument, _TOO_LARGE) from None
    except (TypeError, ValueError):
        raise InvalidArgumentError(argument, f"expected {n} numbers, got {value!r}") from None
    if len(out) != n:
        raise InvalidArgumentError(argument, f"expected {n} numbers, got {len(out)}: {value!r}")
    if not all(math.isfinite(v) for v in out):
        raise InvalidArgumentError(argument, f"values must be finite, got {value!r}")
    return out


# A position or velocity past this (m, rad, m/s, rad/s) is refused where it is given (a spawn or
# a teleport): MuJoCo takes any joint position or velocity past 1e10 for a divergence (its
# mjMAXVAL) and puts the world back to its reference pose, and PyBullet reports link poses in
# float32, past 3.4e38 infinite (measured: a base teleported to 1e308 reads as NaN). No robot
# is 1e10 m away or moves that fast; a larger value can only be a mistake or a blow-up.
MAX_STATE_VALUE = 1e10


def within(values: Sequence[float], argument: str) -> None:
    """Refuse a position or velocity past MAX_STATE_VALUE (see there).

    Args:
        values: m, rad, m/s or rad/s.
        argument: the argument's name, for the message.

    Raises:
        InvalidArgumentError: a value's magnitude is past MAX_STATE_VALUE.
    """
    if values and max(map(abs, values)) > MAX_STATE_VALUE:
        raise InvalidArgumentError(
            argument,
            f"values must be within +-{MAX_STATE_VALUE:g} (m, rad, m/s or rad/s: MuJoCo takes "
            f"a state past it for a divergence), got {tuple(values)!r}",
        )


def flag(value: Any, argument: str) -> bool:
    """A switch: a bool (or numpy bool), never a truthy string or number.

    Args:
        value: the value given.
        argument: the argument's name, for the message.

    Returns:
        ``value`` as a Python bool.

    Raises:
        InvalidArgumentError: ``value`` is not a bool.
    """
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise InvalidArgumentError(argument, f"must be True or False (a bool), got {value!r}")


def state_vec(value: Any, argument: str) -> tuple[float, ...]:
    """Three finite numbers within MAX_STATE_VALUE (a teleport's position or velocity).

    Args:
        value: a sequence of 3 numbers (m, m/s or rad/s).
        argument: the argument's name, for the message.

    Returns:
        3 Python floats.

    Raises:
        InvalidArgumentError: not 3 finite numbers, or one past MAX_STATE_VALUE.
    """
    out = vec(value, 3, argument)
    within(out, argument)
    return out


def quat(value: Any, argument: str, normalise: bool = False) -> tuple[float, float, float, float]:
    """A unit quaternion (x, y, z, w). One whose norm is off 1 by more than 1e-3 is refused,
    or with ``normalise`` (a spawn pose: PyBullet's loadURDF normalises) divided by its norm,
    with one warning on the ``simbridge.sim`` logger; a zero one is always refused.

    Args:
        value: 4 numbers, (x, y, z, w).
        argument: the argument's name, for the message.
        normalise: divide a quaternion off unit length by its norm (with a warning).

    Returns:
        The quaternion (x, y, z, w), divided by its norm.

    Raises:
        InvalidArgumentError: not 4 finite numbers; a norm off 1 by more than 1e-3 without
            ``normalise``; a norm of 0.
    """
    q = vec(value, 4, argument)
    norm = math.sqrt(sum(c * c for c in q))
    if abs(norm - 1.0) > 1e-3:
        if not normalise or not norm > 0.0:
            raise InvalidArgumentError(
                argument,
                f"expected a unit quaternion (x, y, z, w), got {value!r} with norm {norm:.6g}",
            )
        unit = (q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm)
        logging.getLogger("simbridge.sim").warning(
            "%s %r has norm %.6g: normalised to (%s), as PyBullet does",
            argument,
            value,
            norm,
            ", ".join(f"{c:.6g}" for c in unit),
        )
        return unit
    return (q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm)


def checked_state(value: Any, n: int, argument: str) -> list[float]:
    """Joint positions or velocities for a teleport: as :func:`command_values`, within
    MAX_STATE_VALUE.

    Args:
        value: a number (every joint) or ``n`` numbers (rad or m, rad/s or m/s).
        n: the number of joints.
        argument: the argument's name, for the message.

    Returns:
        ``n`` Python floats.

    Raises:
        InvalidArgumentError: as :func:`command_values`, or a value past MAX_STATE_VALUE.
    """
    values = command_values(value, n, argument)
    within(values, argument)
    return values


def command_values(value: Any, n: int, argument: str, nonneg: bool = False) -> list[float]:
    """Check a command argument: a number (broadcast) or n numbers, finite, maybe >= 0.

    This is the hot path of every control loop: checks on a small list in plain Python, not
    numpy reductions (several times faster for a few values).

    Args:
        value: a number, or ``n`` numbers (list, tuple, ``(n,)`` array).
        n: the number of joints.
        argument: the argument's name, for the message.
        nonneg: refuse negative values (a force or gain).

    Returns:
        ``n`` Python floats.

    Raises:
        InvalidArgumentError: not a number or ``(n,)``; a value not finite (or an integer past
            float's range); a negative value with ``nonneg``.
        PyBulletKeywordError: ``value`` is a required argument's :class:`Missing` default.
    """
    if type(value) is float or type(value) is int:
        try:
            finite = math.isfinite(value)
        except OverflowError:  # an int past float's range (a try costs nothing in 3.11)
            raise InvalidArgumentError(argument, _TOO_LARGE) from None
        if not finite:
            raise InvalidArgumentError(argument, f"values must be finite, got {value!r}")
        if nonneg and value < 0:
            raise InvalidArgumentError(argument, f"values must be >= 0, got {value!r}")
        return [float(value)] * n
    values: list[float] | None = None
    vtype = type(value)
    if vtype is np.ndarray and value.dtype is _F64 and value.ndim == 1 and len(value) == n:
        values = value.tolist()
    elif vtype is list and len(value) == n and n:
        try:
            values = list(map(float, value))
        except (TypeError, ValueError, OverflowError):
            pass  # the general path below says what is wrong
    if values is None:
        try:
            arr = np.asarray(value, dtype=np.float64)
        except OverflowError:
            raise InvalidArgumentError(argument, _TOO_LARGE) from None
        except (TypeError, ValueError):
            if type(value) is Missing:  # a required argument not given
                raise value.error() from None
            raise InvalidArgumentError(
                argument, f"expected a number or {n} numbers, got {value!r}"
            ) from None
        if arr.ndim == 0:
            values = [float(arr)] * n
        elif arr.shape == (n,):
            values = arr.tolist()
        else:
            raise InvalidArgumentError(
                argument,
                f"expected a number or shape ({n},) for {n} joint(s), got shape {arr.shape}",
            )
    # a sum of floats is finite only if every one is (an inf or a nan survives the sum);
    # the exact test runs only when the sum is not finite (it may also overflow)
    if not math.isfinite(sum(values)) and not all(map(math.isfinite, values)):
        raise InvalidArgumentError(argument, f"values must be finite, got {value!r}")
    if nonneg and values and min(values) < 0:
        raise InvalidArgumentError(argument, f"values must be >= 0, got {value!r}")
    return values


def per_axis(
    value: Any, n: int, width: int, argument: str, *, nonneg: bool = False, scalar: bool = True
) -> list[list[float]]:
    """``value`` broadcast to (n, width) float64, finite (and >= 0): a list of n lists.

    Args:
        value: a number, ``(width,)`` (per axis), ``(n, 1)`` (per joint) or ``(n, width)``.
        n: the number of spherical joints.
        width: values per joint (3: one per axis of the child's frame).
        argument: the argument's name, for the message.
        nonneg: refuse negative values (a force or gain).
        scalar: whether one number may stand for all (not for a torque, whose axes matter).

    Returns:
        ``n`` lists of ``width`` Python floats.

    Raises:
        InvalidArgumentError: another shape, a value not finite, a negative one with
            ``nonneg``, one number where ``scalar`` is False.
        PyBulletKeywordError: ``value`` is a required argument's :class:`Missing` default.
    """
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        if type(value) is Missing:  # a required argument not given
            raise value.error() from None
        raise InvalidArgumentError(
            argument, f"expected numbers of shape ({width},) or ({n}, {width}), got {value!r}"
        ) from None
    if arr.ndim == 0 and not scalar:
        raise InvalidArgumentError(
            argument,
            f"a spherical joint takes {width} values (one per axis of the child's frame), "
            f"shape ({width},) or ({n}, {width}); got the single number {value!r}",
        )
    try:
        arr = np.broadcast_to(arr, (n, width))
    except ValueError:
        raise InvalidArgumentError(
            argument,
            f"expected a number, shape ({width},) (per axis), ({n}, 1) (per joint) or "
            f"({n}, {width}) for {n} spherical joint(s), got shape {arr.shape}",
        ) from None
    if not np.isfinite(arr).all():
        raise InvalidArgumentError(argument, f"values must be finite, got {value!r}")
    if nonneg and (arr < 0).any():
        raise InvalidArgumentError(argument, f"values must be >= 0, got {value!r}")
    return arr.tolist()


def quaternions(value: Any, n: int, argument: str) -> list[list[float]]:
    """``value`` as n unit quaternions (x, y, z, w): shape (4,) for one joint or (n, 4). A
    quaternion is divided by its norm, as PyBullet takes it (its motor and its reset normalise
    it); one whose norm is off 1 by more than 1e-3 is normalised with a warning on the
    ``simbridge.sim`` logger; a zero one is refused.

    Args:
        value: ``(4,)`` (one joint) or ``(n, 4)``.
        n: the number of spherical joints.
        argument: the argument's name, for the message.

    Returns:
        ``n`` unit quaternions, each a list (x, y, z, w).

    Raises:
        InvalidArgumentError: another shape, a value not finite, a quaternion of norm 0.
        PyBulletKeywordError: ``value`` is a required argument's :class:`Missing` default.
    """
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        if type(value) is Missing:  # a required argument not given
            raise value.error() from None
        raise InvalidArgumentError(
            argument, f"expected quaternions (x, y, z, w), got {value!r}"
        ) from None
    if arr.shape == (4,) and n == 1:
        arr = arr.reshape(1, 4)
    if arr.shape != (n, 4):
        raise InvalidArgumentError(
            argument,
            f"expected a quaternion (x, y, z, w) per spherical joint: shape "
            f"{'(4,) or ' if n == 1 else ''}({n}, 4), got shape {arr.shape}",
        )
    if not np.isfinite(arr).all():
        raise InvalidArgumentError(argument, f"values must be finite, got {value!r}")
    out = []
    for q in arr.tolist():
        norm = math.sqrt(sum(c * c for c in q))
        if not norm > 0.0:
            raise InvalidArgumentError(argument, f"a quaternion of norm 0: {q!r}")
        if abs(norm - 1.0) > 1e-3:
            logging.getLogger("simbridge.sim").warning(
                "%s %r has norm %.6g: normalised, as PyBullet does", argument, q, norm
            )
        out.append([c / norm for c in q])
    return out
