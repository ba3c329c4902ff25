"""Profiles: every default on which the engines differ, made explicit.

A profile is a frozen manifest. Each backend reads it and configures its engine so that the
same value means the same thing everywhere; where an engine cannot reproduce a value exactly
the backend says so in :meth:`simbridge.Sim.manifest` (``departures``).

``"pybullet"``
    PyBullet's own defaults, reproduced on every backend: the default joint brake, link damping
    0.04, the 100 rad/s speed clamp, inertia of the collision bounding box, friction 0.5 combined
    as a product.
``"urdf"``
    What the file says and nothing hidden: the file's inertia, its ``<dynamics>`` damping and
    friction, no brake beyond the file's friction, no link damping, no speed clamp.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable
from dataclasses import asdict, dataclass, fields, replace
from typing import Any, Literal

import numpy as np

from simbridge.exceptions import InvalidArgumentError, InvalidProfileError, did_you_mean

__all__ = ["Profile", "PROFILES", "get_profile", "derived_profile"]


# Engine settings are checked by simbridge.engine_settings (against the backends' declared
# settings, found through the registry), which sets this when it is imported (simbridge's
# __init__ imports it): the profiles stay below the registry in the import graph.
ENGINE_SETTINGS_CHECK: Callable[[Any, str], Any] | None = None


@dataclass(frozen=True)
class Profile:
    """The manifest of engine defaults a Sim runs with.

    Every field has one meaning on every backend; ``ENTRY_DOCS`` gives it in words.
    """

    name: str
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.8)
    timestep: float = 1.0 / 240.0
    integrator: str = "semi-implicit Euler"
    solver_iterations: int = 50
    joint_brake: Literal["pybullet", "urdf_friction"] = "pybullet"
    inertia_source: Literal["collision_aabb", "file"] = "collision_aabb"
    linear_damping: float = 0.04
    angular_damping: float = 0.04
    max_joint_velocity: float | None = 100.0
    apply_joint_damping: bool = True
    lateral_friction: float = 0.5
    rolling_friction: float = 0.0
    spinning_friction: float = 0.0
    restitution: float = 0.0
    friction_combine: Literal["product"] = "product"
    restitution_combine: Literal["product"] = "product"
    read_urdf_contact: bool = True
    self_collision: bool = False
    enforce_effort_limit: bool = False
    enforce_velocity_limit: bool = False
    contact_model: Literal["stiff"] = "stiff"
    # engine settings per backend (simbridge.engine_settings), checked and frozen: a mapping
    # {backend: {key: value}} given here is stored as sorted (backend, ((key, value), ...))
    engines: Any = ()

    def __post_init__(self) -> None:
        """Every entry checked when the profile is made: a bad value is an InvalidArgumentError
        naming it, before any engine starts (a wrong type used to surface from inside an
        engine, after a connection was opened)."""
        for f in fields(self):
            if f.name != "engines":
                _check_entry(f.name, getattr(self, f.name))
        if self.engines or not isinstance(self.engines, tuple):
            assert ENGINE_SETTINGS_CHECK is not None  # set by simbridge.engine_settings
            object.__setattr__(
                self, "engines", ENGINE_SETTINGS_CHECK(self.engines, "profile.engines")
            )

    def with_(self, **changes: Any) -> Profile:
        """A copy with some entries changed.

        Args:
            **changes: Entries by name (``gravity``, ``timestep`` ...).

        Returns:
            The new profile (checked as any profile is made).
        """
        return replace(self, **changes)

    def with_engine(self, backend: str, **settings: Any) -> Profile:
        """A copy with engine settings of ``backend`` set (on top of those already set).

        ``profile.with_engine("mujoco", solref=(0.01, 1.0), impratio=10)``;
        :func:`simbridge.engine_settings.settings_for` lists each backend's.

        Args:
            backend: A registered backend's name.
            **settings: The settings by key.

        Returns:
            The new profile.

        Raises:
            UnknownBackendError: ``backend`` is not registered.
            InvalidProfileError: an unknown key (the valid ones listed) or a bad value.
        """
        merged = {b: dict(v) for b, v in self.engines}
        merged[backend] = {**merged.get(backend, {}), **settings}
        return replace(self, engines=merged)

    def engine(self, backend: str) -> dict[str, Any]:
        """The engine settings this profile sets for ``backend``.

        Args:
            backend: A backend's name.

        Returns:
            ``{key: value}``, only those set (empty by default).
        """
        for name, values in self.engines:
            if name == backend:
                return dict(values)
        return {}

    def engine_settings(self) -> dict[str, dict[str, Any]]:
        """Every engine setting this profile sets, by backend.

        Returns:
            ``{backend: {key: value}}``, JSON-able (tuples as lists).
        """
        return {
            b: {k: list(v) if isinstance(v, tuple) else v for k, v in values}
            for b, values in self.engines
        }

    def as_dict(self) -> dict[str, Any]:
        """The entries, JSON-able.

        Returns:
            Every entry by name; ``engines`` only where some engine setting is set.
        """
        out = asdict(replace(self, engines=()))
        del out["engines"]
        if self.engines:
            out["engines"] = self.engine_settings()
        return out

    def __str__(self) -> str:
        width = max(len(f.name) for f in fields(self))
        lines = [f"profile {self.name!r}"]
        for f in fields(self):
            if f.name == "name" or (f.name == "engines" and not self.engines):
                continue
            value = getattr(self, f.name)
            lines.append(f"  {f.name:<{width}}  {value!s:<22} {ENTRY_DOCS.get(f.name, '')}")
        return "\n".join(lines)


ENTRY_DOCS: dict[str, str] = {
    "gravity": "world gravity, m/s^2 (PyBullet native 0, MuJoCo native -9.81; always set)",
    "timestep": "fixed step, s (PyBullet native 1/240, MuJoCo native 0.002; always set)",
    "integrator": "velocity first, then position with the new velocity (PyBullet's scheme)",
    "solver_iterations": "constraint solver iterations (PyBullet 50, MuJoCo native 100)",
    "joint_brake": (
        "force holding an uncommanded revolute/prismatic joint until a command replaces it: "
        "'pybullet' = velocity motor, target 0, impulse 1 N·s per step (1/dt N·m); "
        "'urdf_friction' = the file's <dynamics friction>"
    ),
    "inertia_source": (
        "'collision_aabb' = URDF mass with the solid-box inertia of the collision bounding box "
        "(PyBullet without URDF_USE_INERTIA_FROM_FILE); 'file' = the <inertia> element"
    ),
    "linear_damping": "per-link linear velocity damping, PyBullet's law (MuJoCo native none)",
    "angular_damping": "per-link angular velocity damping, PyBullet's law (MuJoCo native none)",
    "max_joint_velocity": "every joint speed clamped to this, rad/s or m/s (None = no clamp)",
    "apply_joint_damping": "apply <dynamics damping> as -damping * velocity",
    "lateral_friction": "sliding friction of a link without <contact> (MuJoCo native 1.0)",
    "rolling_friction": "rolling friction of a link without <contact> (MuJoCo native 0.005)",
    "spinning_friction": "spinning friction of a link without <contact> (MuJoCo native 1e-4)",
    "restitution": "restitution of a link without <contact> (MuJoCo has none)",
    "friction_combine": "pair value = product of the two links' (MuJoCo native: max)",
    "restitution_combine": "pair value = product of the two links'",
    "read_urdf_contact": "read <contact> lateral/rolling/spinning friction, restitution",
    "self_collision": "links of one robot collide with each other (MuJoCo native: yes)",
    "enforce_effort_limit": "<limit effort> clamps motor force (MuJoCo native: yes)",
    "enforce_velocity_limit": "<limit velocity> clamps speed",
    "engines": "engine settings per backend beyond these entries (simbridge settings)",
    "contact_model": (
        "'stiff' = each engine's contact made as rigid as it stays stable: PyBullet's "
        "defaults; MuJoCo solref (2*dt, 1) (MuJoCo native (0.02, 1), soft)"
    ),
}

_CHOICES: dict[str, tuple[str, ...]] = {
    "joint_brake": ("pybullet", "urdf_friction"),
    "inertia_source": ("collision_aabb", "file"),
}
_NONNEGATIVE = (
    "linear_damping",
    "angular_damping",
    "lateral_friction",
    "rolling_friction",
    "spinning_friction",
    "restitution",
)
_FLAGS = (
    "apply_joint_damping",
    "read_urdf_contact",
    "self_collision",
    "enforce_effort_limit",
    "enforce_velocity_limit",
)
_NAMES = ("name", "integrator", "friction_combine", "restitution_combine", "contact_model")


def _number(value: Any) -> float | None:
    """value as a finite float, or None (bools are not numbers here)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        return None
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        return None
    return x if math.isfinite(x) else None


def _check_entry(name: str, value: Any) -> None:
    def bad(detail: str) -> InvalidArgumentError:
        return InvalidArgumentError(f"profile.{name}", f"{detail}, got {value!r}")

    if name in _CHOICES:
        if value not in _CHOICES[name]:
            raise bad(f"must be one of {list(_CHOICES[name])}")
    elif name in _NONNEGATIVE:
        x = _number(value)
        if x is None or x < 0:
            raise bad("must be a finite number >= 0")
    elif name in _FLAGS:
        if not isinstance(value, (bool, np.bool_)):
            raise bad("must be True or False")
    elif name in _NAMES:
        if not isinstance(value, str):
            raise bad("must be a string")
    elif name == "timestep":
        x = _number(value)
        if x is None or x <= 0:
            raise bad("must be a finite number > 0")
    elif name == "max_joint_velocity":
        if value is not None and ((x := _number(value)) is None or x <= 0):
            raise bad("must be None (no clamp) or a finite number > 0")
    elif name == "solver_iterations":
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
            raise bad("must be an integer >= 1")
        if value < 1:
            raise bad("must be an integer >= 1")
    elif name == "gravity":
        try:
            ok = len(value) == 3 and all(_number(v) is not None for v in value)
        except TypeError:
            ok = False
        if not ok:
            raise bad("must be three finite numbers")


PROFILES: dict[str, Profile] = {
    "pybullet": Profile(name="pybullet"),
    "urdf": Profile(
        name="urdf",
        joint_brake="urdf_friction",
        inertia_source="file",
        linear_damping=0.0,
        angular_damping=0.0,
        max_joint_velocity=None,
    ),
}


def get_profile(profile: str | Profile) -> Profile:
    """The named profile, or ``profile`` itself when it already is one.

    A name may carry changes after the profile's: ``"pybullet+lateral_friction=0.9"`` is the
    ``pybullet`` profile with that entry changed, and once engine settings exist
    ``"pybullet+mujoco.impratio=10"`` sets one (:func:`derived_profile`). Such a name travels
    wherever a profile name does (worker processes, saved trajectories) and is the profile's
    name.

    Args:
        profile: A name in :data:`PROFILES`, a derived name, or a :class:`Profile`.

    Returns:
        The profile.

    Raises:
        InvalidProfileError: an unknown name (the valid ones listed).
        InvalidArgumentError: a derived name with a malformed or unknown change.
    """
    if isinstance(profile, Profile):
        return profile
    if isinstance(profile, str) and SPEC_SEPARATOR in profile:
        return _parse_derived(profile)
    try:
        return PROFILES[profile]
    except (KeyError, TypeError):
        raise InvalidProfileError(profile, PROFILES) from None


SPEC_SEPARATOR = "+"
"""Separates a profile's name from the changes made to it (:func:`derived_profile`)."""


def _literal(text: str) -> Any:
    """A change's value: a Python literal (number, bool, None, tuple), ``true``/``false`` as
    TOML and ``--set`` write them, or else the text."""
    import ast

    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


def _value_text(value: Any) -> str:
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (list, tuple)):
        return "(" + ",".join(_value_text(v) for v in value) + ("," if len(value) == 1 else ")")
    return str(value) if isinstance(value, str) else repr(value)


def derived_profile(base: str, changes: dict[str, Any]) -> str:
    """The name of profile ``base`` with ``changes`` made, checked here: a bad entry or value
    raises as :func:`get_profile` would.

    Args:
        base: A profile's name.
        changes: Entries (``{"lateral_friction": 0.9}``) or engine settings
            (``{"mujoco.impratio": 10}``) to change.

    Returns:
        The derived name: ``"pybullet+lateral_friction=0.9"``.
    """
    name = base
    for key, value in changes.items():
        name += f"{SPEC_SEPARATOR}{key}={_value_text(value)}"
    get_profile(name)
    return name


def _parse_derived(spec: str) -> Profile:
    base, *parts = spec.split(SPEC_SEPARATOR)
    prof = get_profile(base)
    # the time step and gravity are the scenario's (a Sim sets both on its profile)
    entries = {f.name for f in fields(Profile)} - {"name", "engines", "timestep", "gravity"}
    changes: dict[str, Any] = {}
    for part in parts:
        key, eq, text = part.partition("=")
        key = key.strip()
        if not eq or not key:
            raise InvalidArgumentError(
                "profile", f"expected NAME+KEY=VALUE+..., got {spec!r} (part {part!r})"
            )
        value = _literal(text.strip())
        if "." in key:
            backend, setting = key.split(".", 1)
            with_engine = getattr(prof, "with_engine", None)
            if with_engine is None:
                raise InvalidArgumentError("profile", f"engine settings are not supported: {key!r}")
            prof = with_engine(backend, **{setting: value})
        elif key in entries:
            changes[key] = value
        else:
            raise InvalidArgumentError(
                "profile",
                f"unknown entry {key!r}{did_you_mean(key, entries)} in {spec!r}; valid: "
                f"{sorted(entries)}",
            )
    return replace(prof, name=spec, **changes)
