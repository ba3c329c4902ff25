"""Engine settings: each engine's own knobs, beyond the profile's entries.

A profile's entries (time step, solver iterations, friction, restitution ...) mean the same on
every backend. Engine settings are the knobs one engine has and users tune on it: PyBullet's
``setPhysicsEngineParameter`` entries (``erp``, ``contactSlop`` ...), MuJoCo's options and
contact parameters (``solref``, ``impratio`` ...), PhysX's offsets and iterations. They are
set per backend on a profile (:meth:`simbridge.Profile.with_engine`), in a scenario
(``[engines.mujoco]``) or on the command line (``--set mujoco.impratio=10``).

Each backend declares its settings in a module that imports no engine (registered with the
backend: :func:`simbridge.register` ``settings=``), so a scenario is validated when it is read.
A setting left unset keeps the value the backend uses today: nothing changes when none is set.
"""

from __future__ import annotations

import importlib
import math
import numbers
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from simbridge import profiles
from simbridge.exceptions import InvalidArgumentError, InvalidEngineSettingError, did_you_mean
from simbridge.registry import backend_spec

if TYPE_CHECKING:
    from simbridge.profiles import Profile

__all__ = [
    "Setting",
    "settings_for",
    "validate",
    "effective",
    "parse_assignment",
    "merge",
    "freeze",
    "thaw",
    "owners",
    "KINDS",
]

KINDS = ("float", "int", "bool", "choice", "floats")


@dataclass(frozen=True)
class Setting:
    """One engine setting.

    ``default`` is the value the backend uses when the setting is not given (under every
    profile), or a function of the profile where it depends on it (MuJoCo's contact ``solref``
    follows the time step); ``default_note`` then says so in words.
    """

    key: str
    kind: str  # one of KINDS
    default: Any
    meaning: str
    unit: str = ""
    low: float | None = None  # float / int / each of floats
    high: float | None = None
    low_open: bool = False  # low itself excluded
    choices: tuple[str, ...] = ()  # choice
    sizes: tuple[int, ...] = ()  # floats: the lengths accepted
    toward: str = ""  # "backend.key": the counterpart in another engine, where there is one
    default_note: str = ""

    def default_for(self, profile: Profile) -> Any:
        """The value the backend uses under ``profile`` when the setting is not given.

        Args:
            profile: The profile in force.

        Returns:
            ``default``, or ``default(profile)`` where it is a function of the profile.
        """
        if callable(self.default):
            return self.default(profile)
        return self.default

    def range_text(self) -> str:
        """The accepted values, in words.

        Returns:
            A phrase such as ``"a finite number >= 0"`` or ``"one of ['pyramidal', 'elliptic']"``.
        """
        if self.kind == "bool":
            return "true or false"
        if self.kind == "choice":
            return f"one of {list(self.choices)}"
        lo = "" if self.low is None else f"{'>' if self.low_open else '>='} {self.low:g}"
        hi = "" if self.high is None else f"<= {self.high:g}"
        bounds = " and ".join(b for b in (lo, hi) if b)
        if self.kind == "floats":
            n = " or ".join(str(s) for s in self.sizes)
            return f"{n} finite numbers" + (f", each {bounds}" if bounds else "")
        what = "an integer" if self.kind == "int" else "a finite number"
        return what + (f" {bounds}" if bounds else "")

    def default_text(self) -> str:
        """The default, in words.

        Returns:
            ``default_note`` where there is one, else the default as text (a tuple as a list).
        """
        if self.default_note:
            return self.default_note
        d = self.default
        return str(list(d)) if isinstance(d, tuple) else str(d)

    def check(self, backend: str, value: Any) -> Any:
        """``value`` checked against the setting's kind and range.

        Args:
            backend: The backend's name (for the message).
            value: The value given.

        Returns:
            ``value`` in its normal form (float, int, bool, str or a tuple of floats).

        Raises:
            InvalidEngineSettingError: naming the setting and its accepted values.
        """

        def bad() -> InvalidEngineSettingError:
            return InvalidEngineSettingError(
                backend, self.key, f"expected {self.range_text()}, got {value!r}"
            )

        if self.kind == "bool":
            if not isinstance(value, (bool, np.bool_)):
                raise bad()
            return bool(value)
        if self.kind == "choice":
            if not isinstance(value, str) or value not in self.choices:
                raise bad()
            return value
        if self.kind == "int":
            if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
                raise bad()
            out_i = int(value)
            if not self._within(out_i):
                raise bad()
            return out_i
        if self.kind == "float":
            x = _finite(value)
            if x is None or not self._within(x):
                raise bad()
            return x
        # floats
        if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
            raise bad()
        xs = [_finite(v) for v in value]
        if len(xs) not in self.sizes or any(x is None or not self._within(x) for x in xs):
            raise bad()
        return tuple(float(x) for x in xs if x is not None)

    def _within(self, x: float) -> bool:
        if self.low is not None and (x <= self.low if self.low_open else x < self.low):
            return False
        return self.high is None or x <= self.high

    def as_dict(self) -> dict[str, Any]:
        """The setting described for JSON.

        Returns:
            Its key, kind, default (in words where it depends on the profile), accepted values,
            unit, meaning and counterpart in another engine.
        """
        return {
            "key": self.key,
            "kind": self.kind,
            "default": self.default_text() if callable(self.default) else _jsonable(self.default),
            "accepts": self.range_text(),
            "unit": self.unit,
            "meaning": self.meaning,
            "toward": self.toward,
        }


def _finite(value: Any) -> float | None:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        return None
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        return None
    return x if math.isfinite(x) else None


def _jsonable(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value


_CACHE: dict[tuple[str, str], dict[str, Setting]] = {}
# a settings module's check_together(values, given) -> (key, detail) | None: settings that must
# agree with each other (PhysX's rest offset below its contact offset), given or at their
# defaults; ``given``: the keys set, so that the message blames one of them
_TOGETHER: dict[tuple[str, str], Any] = {}


def settings_for(backend: str) -> Mapping[str, Setting]:
    """Every engine setting a backend accepts. Imports no engine.

    Args:
        backend: A registered backend's name.

    Returns:
        The settings by key, in the backend's order (empty for a backend that declares none).

    Raises:
        UnknownBackendError: ``backend`` is not registered (the message lists those that are).
        TypeError: The backend's settings module declares something that is not a Setting.
    """
    spec = backend_spec(backend)
    cached = _CACHE.get((spec.name, spec.settings))
    if cached is not None:
        return dict(cached)
    found: dict[str, Setting] = {}
    if spec.settings:
        module_name, _, attr = spec.settings.partition(":")
        module = importlib.import_module(module_name)
        declared = getattr(module, attr or "SETTINGS")
        together = getattr(module, "check_together", None)
        if callable(together):
            _TOGETHER[(spec.name, spec.settings)] = together
        for s in declared:
            if not isinstance(s, Setting) or s.kind not in KINDS:
                raise TypeError(f"backend {backend!r}: {s!r} is not a Setting")
            found[s.key] = s
    _CACHE[(spec.name, spec.settings)] = found
    return dict(found)


def validate(backend: str, mapping: Mapping[str, Any]) -> dict[str, Any]:
    """Check settings for one backend.

    Args:
        backend: A registered backend's name.
        mapping: The settings given, ``{key: value}``.

    Returns:
        ``mapping``'s settings checked and in their normal form, keys in the backend's order.

    Raises:
        UnknownBackendError: ``backend`` is not registered.
        InvalidArgumentError: ``mapping`` is not a mapping.
        InvalidEngineSettingError (an InvalidProfileError): a key the backend does not have
            (the message lists the valid ones), a value outside its range (the message names
            the key and its accepted values), or settings that disagree with each other.
    """
    known = settings_for(backend)
    if not isinstance(mapping, Mapping):
        raise InvalidArgumentError(
            f"engine settings for {backend!r}", f"expected a table of key = value, got {mapping!r}"
        )
    for key in mapping:
        if key not in known:
            valid = ", ".join(known) if known else "none (this backend declares no settings)"
            others = owners(str(key), backend)
            if others:
                raise InvalidEngineSettingError(
                    backend,
                    str(key),
                    f"unknown setting: {key} is a {' and '.join(others)} setting; {backend}'s "
                    f"are: {valid}",
                )
            raise InvalidEngineSettingError(
                backend,
                str(key),
                f"unknown setting{did_you_mean(str(key), known)}; valid settings of "
                f"{backend!r}: {valid}",
            )
    checked = {key: known[key].check(backend, mapping[key]) for key in known if key in mapping}
    spec = backend_spec(backend)
    together = _TOGETHER.get((spec.name, spec.settings))
    if together is not None and checked:
        values = {k: s.default for k, s in known.items() if not callable(s.default)}
        problem = together({**values, **checked}, frozenset(checked))
        if problem is not None:
            raise InvalidEngineSettingError(backend, *problem)
    return checked


def owners(key: str, backend: str = "") -> list[str]:
    """The registered backends other than ``backend`` that have a setting ``key``.

    For the message of a key given to the wrong engine, or to none; a backend whose settings
    module cannot be read is skipped.

    Args:
        key: A setting's key.
        backend: The backend to leave out; none by default.

    Returns:
        Their names, in the registry's order.
    """
    from simbridge.registry import available_backends

    found = []
    for other in available_backends():
        if other == backend:
            continue
        try:
            if key in settings_for(other):
                found.append(other)
        except Exception:  # noqa: BLE001 - only a hint: a broken registration is reported elsewhere
            continue
    return found


def effective(backend: str, profile: Profile) -> dict[str, Any]:
    """Every setting of ``backend`` with the value it takes under ``profile``.

    Args:
        backend: A registered backend's name.
        profile: The profile in force.

    Returns:
        ``{key: value}``, JSON-able: the profile's own value where it sets one, the backend's
        default otherwise.
    """
    given = profile.engine(backend)
    return {
        key: _jsonable(given[key] if key in given else s.default_for(profile))
        for key, s in settings_for(backend).items()
    }


def parse_assignment(text: str) -> tuple[str, str, Any]:
    """Read one ``--set`` assignment. The setting itself is not checked here (see :func:`validate`).

    Args:
        text: ``"BACKEND.KEY=VALUE"``, the value read as TOML (``0.02``, ``true``,
            ``[0.01, 1]``), a bare word as a string (``cone=elliptic``).

    Returns:
        ``(backend, key, value)``: ``"mujoco.impratio=10"`` -> ``("mujoco", "impratio", 10)``.

    Raises:
        InvalidArgumentError: not ``BACKEND.KEY=VALUE``.
    """
    name, eq, raw = text.partition("=")
    backend, dot, key = name.strip().partition(".")
    if not eq or not dot or not backend or not key.strip() or not raw.strip():
        raise InvalidArgumentError(
            "--set", f"expected BACKEND.KEY=VALUE (mujoco.impratio=10), got {text!r}"
        )
    raw = raw.strip()
    try:
        value: Any = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    return backend, key.strip(), value


Frozen = tuple[tuple[str, tuple[tuple[str, Any], ...]], ...]


def freeze(engines: Any, argument: str = "engine_settings") -> Frozen:
    """Settings per backend checked with :func:`validate` and made hashable.

    Args:
        engines: ``{backend: {key: value}}``, or already frozen pairs.
        argument: The argument's name in messages.

    Returns:
        Sorted ``(backend, ((key, value), ...))`` pairs, backends with no setting left out.

    Raises:
        InvalidArgumentError: not a table of tables.
        UnknownBackendError, InvalidEngineSettingError: as :func:`validate`.
    """
    if isinstance(engines, Mapping):
        items = list(engines.items())
    else:
        try:
            items = [(b, dict(v)) for b, v in engines]
        except (TypeError, ValueError):
            raise InvalidArgumentError(
                argument, f"expected {{backend: {{key: value}}}}, got {engines!r}"
            ) from None
    out = []
    for backend, values in items:
        if not isinstance(values, Mapping):
            raise InvalidArgumentError(
                f"{argument}[{backend!r}]", f"expected a table of key = value, got {values!r}"
            )
        checked = validate(backend, values)
        if checked:
            out.append((backend, tuple(sorted(checked.items()))))
    return tuple(sorted(out))


def thaw(frozen: Frozen) -> dict[str, dict[str, Any]]:
    """:func:`freeze`'s pairs back as a table.

    Args:
        frozen: What :func:`freeze` returned.

    Returns:
        ``{backend: {key: value}}``, JSON-able (tuples as lists).
    """
    return {b: {k: _jsonable(v) for k, v in values} for b, values in frozen}


def merge(*layers: Mapping[str, Mapping[str, Any]] | None) -> dict[str, dict[str, Any]]:
    """Settings per backend, later layers on top of earlier ones (key by key).

    Args:
        *layers: ``{backend: {key: value}}`` tables, or None (skipped), lowest first.

    Returns:
        The merged ``{backend: {key: value}}``.
    """
    out: dict[str, dict[str, Any]] = {}
    for layer in layers:
        for backend, values in (layer or {}).items():
            out.setdefault(backend, {}).update(values)
    return out


profiles.ENGINE_SETTINGS_CHECK = freeze  # Profile(engines=...) and with_engine check here
