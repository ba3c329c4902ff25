"""The `Sim`'s MJCF read as MuJoCo reads it (``load_mjcf(source, semantics="mujoco")``) and
MuJoCo's own calls on it: actuators, ``qpos``/``qvel``, keyframes, sensors, sites.

A part of :class:`simbridge.Sim`: functions of its :class:`~simbridge.sim.shared.Shared`
state, which holds the model (``native``) and how to make a new engine
(:class:`~simbridge.sim.shared.EngineRecipe`, with the gravity and time step the caller gave).
Loading such a model swaps the backend for the one ``Backend.mjcf_world`` makes, so the Sim's
hot paths test no flag; ``reset()`` swaps back to a new engine of the recipe. The model's
reading is :mod:`simbridge.model.mjcf_native`; the backend side is ``Backend.mjcf_world`` and
the calls after it in :mod:`simbridge.backend`.
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
from simbridge.sim.shared import BodyTable, Shared
from simbridge.types import ActuatorInfo, SiteState

if TYPE_CHECKING:
    from simbridge.model.mjcf_native import NativeMjcf

__all__ = [
    "NotGiven",
    "WHOLE_WORLD",
    "actuator_controls",
    "actuators",
    "check_semantics",
    "generalized_state",
    "leave",
    "load_native",
    "native_model",
    "refuse_after_native",
    "reset_keyframe",
    "resolve",
    "sensor",
    "set_actuator_controls",
    "set_qpos_qvel",
    "site",
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


def refuse_after_native(s: Shared, call: str) -> None:
    """Refuse a load into a world that holds a model read with semantics='mujoco'.

    Args:
        s: the Sim's shared state.
        call: the call refused (for the message).

    Raises:
        BackendUnsupportedError: when the world holds such a model.
    """
    if s.native is not None:
        raise BackendUnsupportedError(
            s.name, f"{call} after an MJCF read with semantics='mujoco'", WHOLE_WORLD
        )


def load_native(
    s: Shared, source: str | os.PathLike[str], self_collision: bool | str | None
) -> tuple[int, ...]:
    """``load_mjcf(source, semantics="mujoco")``: see :meth:`simbridge.Sim.load_mjcf`.

    Args:
        s: the Sim's shared state, its world empty.
        source: a path, a name on the search path or MJCF text.
        self_collision: must be None (the file's contact settings rule).

    Returns:
        The body ids (0, 1, ...), one per top-level body.

    Raises:
        InvalidArgumentError: ``self_collision`` given.
        BackendUnsupportedError: a backend without MuJoCo's reading, or a world that is not
            empty.
        UrdfNotFoundError, MjcfCompileError: as :func:`~simbridge.model.mjcf_native.compile_mjcf`.
    """
    from simbridge.backend import NATIVE_ONLY
    from simbridge.model.mjcf_native import compile_mjcf

    if self_collision is not None:
        raise InvalidArgumentError(
            "self_collision",
            "under semantics='mujoco' the file's contype/conaffinity and <contact> "
            "decide which geoms collide: give None",
        )
    b = s.backend
    b.time  # noqa: B018 - raises SimClosedError after close()
    if "mujoco" not in type(b).semantics:
        raise BackendUnsupportedError(s.name, *NATIVE_ONLY)
    refuse_after_native(s, "load_mjcf(semantics='mujoco')")
    if s.bodies:
        raise BackendUnsupportedError(
            s.name,
            "load_mjcf(semantics='mujoco') into a world that already holds bodies "
            f"{list(s.bodies)}",
            WHOLE_WORLD,
        )
    recipe = s.recipe
    assert recipe is not None  # made with the engine
    native = compile_mjcf(source)
    s.end_commands("load_mjcf changed the world")
    new = b.mjcf_world(native, recipe.gravity, recipe.timestep)
    b.close()
    s.backend = new
    s.native = native
    s.dt = new.profile.timestep
    for i, body in enumerate(native.bodies):
        names = [r.name for r in body.table]
        links = [r.link_name for r in body.table]
        types = [r.type for r in body.table]
        s.bodies[i] = BodyTable(
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


def leave(s: Shared) -> None:
    """Drop the model read with semantics='mujoco' (``reset()``): the backend becomes a new
    engine of the Sim's recipe, with the Sim's own gravity and time step, and the old one is
    closed. The caller ends the bound commands and clears the bodies. With ``gui`` the old
    engine closes first, its window with it (one window at a time: PyBullet allows one GUI per
    process), and the new engine opens its own.

    Args:
        s: the Sim's shared state, holding such a model.

    Raises:
        Whatever making the engine raises (the model is kept then; with ``gui`` it is
        closed, and so is the Sim).
    """
    recipe = s.recipe
    assert recipe is not None  # made with the engine
    old = s.backend
    if old.gui:
        old.close()
    s.backend = recipe.make()
    s.native = None
    s.dt = s.backend.profile.timestep
    old.close()


def native_model(s: Shared, call: str) -> NativeMjcf:
    """The model read with semantics='mujoco' the world holds.

    Args:
        s: the Sim's shared state.
        call: the call that needs it (for the message).

    Returns:
        The model.

    Raises:
        BackendUnsupportedError: the world holds no such model.
        SimClosedError: the Sim is closed.
    """
    s.backend.time  # noqa: B018 - raises SimClosedError after close()
    if s.native is None:
        raise BackendUnsupportedError(
            s.name,
            f"{call} without a model read with semantics='mujoco'",
            "load one first: sim.load_mjcf(path, semantics='mujoco')",
        )
    return s.native


def actuators(s: Shared) -> tuple[ActuatorInfo, ...]:
    """:meth:`simbridge.Sim.actuators` on the Sim's shared state.

    Args:
        s: the Sim's shared state.

    Returns:
        The model's actuators, in MuJoCo's order.

    Raises:
        BackendUnsupportedError: no model read with semantics='mujoco' is loaded.
    """
    return native_model(s, "actuators()").actuators


def set_actuator_controls(s: Shared, controls: Any, which: Any) -> None:
    """:meth:`simbridge.Sim.set_actuator_controls` on the Sim's shared state.

    Args:
        s: the Sim's shared state.
        controls: one value per actuator named, or per actuator of the model.
        which: the method's ``actuators``: None (all), an index or a name, or a sequence.

    Raises:
        BackendUnsupportedError: no model read with semantics='mujoco' is loaded.
        UnknownObjectError: an actuator the model does not have.
        InvalidArgumentError: the wrong number of controls, or one not finite.
    """
    names = [a.name for a in native_model(s, "set_actuator_controls").actuators]
    if which is None:
        idx = np.arange(len(names), dtype=np.intp)
    else:
        many = not isinstance(which, (str, int, np.integer))
        items = list(which) if many else [which]
        idx = np.array([resolve(names, "actuator", a) for a in items], dtype=np.intp)
    s.backend.set_actuator_controls(idx, values(controls, len(idx), "controls").tolist())


def actuator_controls(s: Shared) -> np.ndarray:
    """:meth:`simbridge.Sim.actuator_controls` on the Sim's shared state.

    Args:
        s: the Sim's shared state.

    Returns:
        (nu,) float64, a copy of MuJoCo's ``ctrl``.

    Raises:
        BackendUnsupportedError: no model read with semantics='mujoco' is loaded.
    """
    native_model(s, "actuator_controls()")
    return s.backend.actuator_controls()


def generalized_state(s: Shared, call: str) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo's ``qpos`` and ``qvel`` (:meth:`simbridge.Sim.qpos`, :meth:`simbridge.Sim.qvel`).

    Args:
        s: the Sim's shared state.
        call: the call that reads them (for the message).

    Returns:
        Copies of ``qpos`` (nq,) and ``qvel`` (nv,), float64, MuJoCo's order.

    Raises:
        BackendUnsupportedError: no model read with semantics='mujoco' is loaded.
    """
    native_model(s, call)
    return s.backend.generalized_state()


def set_qpos_qvel(s: Shared, qpos: Any, qvel: Any) -> None:
    """:meth:`simbridge.Sim.set_qpos_qvel` on the Sim's shared state; every bound command
    ends.

    Args:
        s: the Sim's shared state.
        qpos, qvel: as the method's (None keeps one).

    Raises:
        BackendUnsupportedError: no model read with semantics='mujoco' is loaded.
        InvalidArgumentError: a wrong length or a value not finite.
    """
    m = native_model(s, "set_qpos_qvel").model
    q = None if qpos is None else values(qpos, m.nq, "qpos")
    v = None if qvel is None else values(qvel, m.nv, "qvel")
    s.end_commands("set_qpos_qvel changed the world")
    s.backend.set_generalized_state(q, v)


def reset_keyframe(s: Shared, key: int | str) -> None:
    """:meth:`simbridge.Sim.reset_keyframe` on the Sim's shared state; every bound command
    ends.

    Args:
        s: the Sim's shared state.
        key: the keyframe's index or name.

    Raises:
        BackendUnsupportedError: no model read with semantics='mujoco' is loaded.
        UnknownObjectError: a keyframe the model does not have.
    """
    k = resolve(native_model(s, "reset_keyframe").keyframes, "keyframe", key)
    s.end_commands("reset_keyframe changed the world")
    s.backend.reset_keyframe(k)


def sensor(s: Shared, which: int | str) -> np.ndarray:
    """:meth:`simbridge.Sim.sensor` on the Sim's shared state.

    Args:
        s: the Sim's shared state.
        which: the sensor's index or name.

    Returns:
        (dim,) float64, MuJoCo's values in its units and frames.

    Raises:
        BackendUnsupportedError: no model read with semantics='mujoco' is loaded.
        UnknownObjectError: a sensor the model does not have.
    """
    return s.backend.sensor_data(resolve(native_model(s, "sensor").sensors, "sensor", which))


def site(s: Shared, which: int | str) -> SiteState:
    """:meth:`simbridge.Sim.site` on the Sim's shared state.

    Args:
        s: the Sim's shared state.
        which: the site's index or name.

    Returns:
        Its position (m, world) and orientation (x, y, z, w).

    Raises:
        BackendUnsupportedError: no model read with semantics='mujoco' is loaded.
        UnknownObjectError: a site the model does not have.
    """
    pos, orn = s.backend.site_pose(resolve(native_model(s, "site").sites, "site", which))
    return SiteState(pos, orn)


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
