"""The `Sim`'s MJCF read as MuJoCo reads it (``load_mjcf(source, semantics="mujoco")``) and
MuJoCo's own calls on it: actuators, ``qpos``/``qvel``, keyframes, sensors, sites.

A part of :class:`simbridge.Sim`: functions taking the Sim. The model's reading is
:mod:`simbridge.model.mjcf_native`; the backend side is ``Backend.mjcf_world`` and the calls
after it in :mod:`simbridge.backend`.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from simbridge.exceptions import (
    BackendUnsupportedError,
    InvalidArgumentError,
    UnknownObjectError,
)

if TYPE_CHECKING:
    from simbridge.model.mjcf_native import NativeMjcf

__all__ = [
    "NotGiven",
    "WHOLE_WORLD",
    "check_semantics",
    "load_native",
    "native_model",
    "refuse_after_native",
    "resolve",
    "values",
]

# why nothing else shares the world with such a model (the error's hint)
WHOLE_WORLD = (
    "a model read with semantics='mujoco' is the whole world (its <option>, ground, contacts "
    "and every body are MuJoCo's compiled model, stepped as one): reset() the Sim, or use "
    "another Sim"
)


class NotGiven:
    """A default the caller did not give (``Sim(gravity=..., timestep=...)``): under
    ``semantics="mujoco"`` the file's ``<option>`` wins over it.

    Args:
        value: The value in force when the caller gives none.
    """

    __slots__ = ("value",)

    def __init__(self, value: Any) -> None:
        self.value = value

    def __repr__(self) -> str:
        return f"{self.value!r} (or the MJCF's <option> under semantics='mujoco')"


def check_semantics(semantics: Any) -> str:
    """Check ``load_mjcf``'s ``semantics``.

    Args:
        semantics: What the caller gave.

    Returns:
        ``"pybullet"`` or ``"mujoco"``.

    Raises:
        InvalidArgumentError: Anything else; the message lists the valid choices.
    """
    from simbridge.model.mjcf_native import SEMANTICS

    if not isinstance(semantics, str) or semantics not in SEMANTICS:
        raise InvalidArgumentError(
            "semantics",
            f"expected one of {list(SEMANTICS)} ('pybullet': PyBullet's loadMJCF reading, on "
            f"every backend; 'mujoco': MuJoCo's compiler, the model as MuJoCo runs it), got "
            f"{semantics!r}",
        )
    return semantics


def refuse_after_native(sim: Any, call: str) -> None:
    """Refuse a load into a world that holds a model read with semantics='mujoco'.

    Args:
        sim: The Sim.
        call: The call refused (for the message).

    Raises:
        BackendUnsupportedError: When the Sim holds such a model.
    """
    if sim._native is not None:
        raise BackendUnsupportedError(
            sim.backend, f"{call} after an MJCF read with semantics='mujoco'", WHOLE_WORLD
        )


def load_native(sim: Any, source: str | os.PathLike[str]) -> tuple[int, ...]:
    """``load_mjcf(source, semantics="mujoco")``: see :meth:`simbridge.Sim.load_mjcf`.

    Args:
        sim: An empty Sim.
        source: A path, a name on the search path or MJCF text.

    Returns:
        The body ids (0, 1, ...), one per top-level body.

    Raises:
        BackendUnsupportedError: A backend without MuJoCo's reading, or a world that is not
            empty.
        UrdfNotFoundError, MjcfCompileError: As :func:`~simbridge.model.mjcf_native.compile_mjcf`.
    """
    from simbridge.backend import NATIVE_ONLY
    from simbridge.model.mjcf_native import compile_mjcf
    from simbridge.sim.lookups import _Body

    b = sim._b
    b.time  # noqa: B018 - raises SimClosedError after close()
    if "mujoco" not in type(b).semantics:
        raise BackendUnsupportedError(sim.backend, *NATIVE_ONLY)
    refuse_after_native(sim, "load_mjcf(semantics='mujoco')")
    if sim._bodies:
        raise BackendUnsupportedError(
            sim.backend,
            "load_mjcf(semantics='mujoco') into a world that already holds bodies "
            f"{list(sim._bodies)}",
            WHOLE_WORLD,
        )
    native = compile_mjcf(source)
    sim._end_commands("load_mjcf changed the world")
    new = b.mjcf_world(native, *sim._given)
    b.close()
    sim._b = new
    sim._native = native
    sim._dt = new.profile.timestep
    for i, body in enumerate(native.bodies):
        names = [r.name for r in body.table]
        links = [r.link_name for r in body.table]
        types = [r.type for r in body.table]
        sim._bodies[i] = _Body(
            body.name,
            names,
            links,
            types,
            {n: k for k, n in enumerate(names)},
            {n: k for k, n in enumerate(links)} | {body.name: -1},
            load={
                "source": native.display_name,
                "format": "mjcf",
                "semantics": "mujoco",
                "body_index": i,
                "fixed_base": body.free_joint < 0,
            },
        )
    return tuple(range(len(native.bodies)))


def native_model(sim: Any, call: str) -> NativeMjcf:
    """The model read with semantics='mujoco' the Sim holds.

    Args:
        sim: The Sim.
        call: The call that needs it (for the message).

    Returns:
        The model.

    Raises:
        BackendUnsupportedError: The Sim holds no such model.
    """
    sim._b.time  # noqa: B018 - raises SimClosedError after close()
    if sim._native is None:
        raise BackendUnsupportedError(
            sim.backend,
            f"{call} without a model read with semantics='mujoco'",
            "load one first: sim.load_mjcf(path, semantics='mujoco') (Sim('mujoco'))",
        )
    return sim._native


def resolve(names: Sequence[str], kind: str, item: Any) -> int:
    """An index of a MuJoCo object from its index or name.

    Args:
        names: The objects' names, in MuJoCo's order.
        kind: What they are, for the message (``"actuator"``).
        item: An int index or a name.

    Returns:
        The index.

    Raises:
        UnknownObjectError: A name that is not there or an index out of range (the message
            lists the valid ones).
    """
    if isinstance(item, (int, np.integer)) and not isinstance(item, bool):
        if 0 <= int(item) < len(names):
            return int(item)
    elif isinstance(item, str) and item in names:
        return names.index(item)
    raise UnknownObjectError(kind, item, names)


def values(given: Any, n: int, argument: str) -> np.ndarray:
    """Finite float64 values of one shape.

    Args:
        given: A number or a sequence or array of numbers.
        n: How many are expected.
        argument: The argument's name, for the message.

    Returns:
        (n,) float64.

    Raises:
        InvalidArgumentError: The wrong count, or a value that is not a finite number.
    """
    try:
        arr = np.array(given, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidArgumentError(argument, f"expected {n} numbers, got {given!r}") from None
    if arr.shape != (n,):
        raise InvalidArgumentError(argument, f"expected {n} numbers, got {arr.size}")
    if not np.isfinite(arr).all():
        raise InvalidArgumentError(argument, f"values must be finite, got {given!r}")
    return arr
