"""Every error simbridge raises.

One base class, :class:`SimbridgeError`; each subclass builds its message from the context it was
given (the file, element, argument, and the valid choices), so a message always says what was
wrong and what would have been right. Subclasses also derive from the matching built-in
(``ValueError``, ``KeyError``-like lookups derive from ``LookupError``) so generic handlers work.

Over 600 lines on purpose: one hierarchy in one module, where a caller finds every error the
core and the backends raise, each documenting its constructor (compare's own errors are in
:mod:`simbridge.compare.errors`).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence

__all__ = [
    "SimbridgeError",
    "BackendError",
    "UnknownBackendError",
    "BackendNotInstalledError",
    "BackendUnsupportedError",
    "MjcfFeatureUnsupportedError",
    "DisplayError",
    "UrdfError",
    "UrdfNotFoundError",
    "UrdfParseError",
    "UrdfStructureError",
    "MeshNotFoundError",
    "MjcfCompileError",
    "UnsupportedJointError",
    "UnknownBodyError",
    "UnknownJointError",
    "UnknownLinkError",
    "UnknownObjectError",
    "InvalidArgumentError",
    "InvalidProfileError",
    "InvalidEngineSettingError",
    "SimulationDivergedError",
    "EngineError",
    "SimBusyError",
    "SimClosedError",
    "SimNotCopyableError",
    "NotOfferedError",
    "PyBulletKeywordError",
    "StaleCommandError",
    "SlowStepWarning",
    "InitialPenetrationWarning",
]


def did_you_mean(name: str, valid: Iterable[str]) -> str:
    """The hint that ends a lookup error's sentence.

    Args:
        name: The name asked for.
        valid: The names that exist.

    Returns:
        ``" (did you mean 'r2d2'?)"`` for the valid name closest to ``name``, or ``""``.
    """
    import difflib

    close = difflib.get_close_matches(name, list(valid), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _choices(valid: Iterable[object], limit: int = 40) -> str:
    items = [repr(v) for v in valid]
    if len(items) > limit:
        items = items[:limit] + [f"... ({len(items) - limit} more)"]
    return "[" + ", ".join(items) + "]"


def _rebuilt(cls: type[BaseException], args: tuple[object, ...], state: dict[str, object]):
    """An error of class ``cls`` as pickled: its message and attributes, its ``__init__`` not
    called again (:meth:`SimbridgeError.__reduce__`)."""
    err = None
    for base in cls.__mro__:  # the built-in base whose layout it has (OSError's, for one)
        if base.__module__ == "builtins":
            try:
                err = base.__new__(cls)  # type: ignore[call-overload]
                break
            except TypeError:
                continue
    assert err is not None  # BaseException.__new__ takes every exception class
    err.args = args
    err.__dict__.update(state)
    return err


class SimbridgeError(Exception):
    """Base class of every simbridge error.

    Every one pickles (an error raised in a worker process reaches the process that waits for
    it): the message and the attributes travel, not the arguments its ``__init__`` takes.
    """

    def __reduce__(self) -> tuple[object, ...]:
        return (_rebuilt, (type(self), self.args, dict(self.__dict__)))


# ---------------------------------------------------------------- backends


class BackendError(SimbridgeError):
    """A backend could not be found, loaded or used."""


class UnknownBackendError(BackendError, LookupError):
    """A backend name that is not registered.

    Args:
        name: The name asked for.
        available: The registered names (listed in the message, the closest suggested).
    """

    def __init__(self, name: str, available: Iterable[str]):
        self.name = name
        self.available = sorted(available)
        super().__init__(
            f"unknown backend {name!r}{did_you_mean(name, self.available)}; available backends: "
            f"{_choices(self.available)}"
        )


class BackendNotInstalledError(BackendError, ImportError):
    """A registered backend whose engine package does not import.

    Args:
        backend: The backend's name.
        module: The Python module that failed to import.
        pip_name: What to ``pip install`` to get it.
        cause: The import's own error.
    """

    def __init__(self, backend: str, module: str, pip_name: str, cause: BaseException):
        self.backend = backend
        super().__init__(
            f"backend {backend!r} needs the Python package {module!r}, which is not importable "
            f"({cause}); install it with: pip install {pip_name}"
        )


class BackendUnsupportedError(BackendError, NotImplementedError):
    """The backend cannot do what was asked (never silently ignored).

    Args:
        backend: The backend's name.
        what: What it does not support (``"contact points"``).
        hint: What to do instead, appended after a colon; none by default.
    """

    def __init__(self, backend: str, what: str, hint: str = ""):
        msg = f"backend {backend!r} does not support {what}"
        super().__init__(msg + (f": {hint}" if hint else ""))


class MjcfFeatureUnsupportedError(BackendUnsupportedError):
    """An MJCF feature that only MuJoCo simulates, in a model read with semantics='mujoco' on
    another engine (a tendon, an equality constraint, a flex body...): refused, never dropped.

    Args:
        file: The model's file (or ``<MJCF text>``).
        backend: The backend's name.
        feature: The feature as the file writes it (``"<tendon>"``).
        element: The first element of it in the model (its name, or ``#<id>``).
        reason: Why the engine cannot simulate it.
    """

    def __init__(self, file: str, backend: str, feature: str, element: str, reason: str):
        self.feature = feature
        self.element = element
        super().__init__(
            backend,
            f"{feature} ({element!r} in {file}) under semantics='mujoco' ({reason})",
            "only the 'mujoco' backend simulates it: Sim('mujoco'), or remove the element",
        )


class DisplayError(BackendError, RuntimeError):
    """A window (``gui=True``) that cannot open.

    Args:
        backend: The backend's name.
        detail: Why it cannot.
    """

    def __init__(self, backend: str, detail: str):
        super().__init__(
            f"backend {backend!r} cannot open a window: {detail}. "
            "Run with gui=False on a machine without a display, or set DISPLAY."
        )


# ---------------------------------------------------------------- URDF


class UrdfError(SimbridgeError, ValueError):
    """A URDF could not be found, read or understood."""


class UrdfNotFoundError(UrdfError, FileNotFoundError):
    """A robot or scene file found nowhere it was looked for.

    Args:
        source: What was asked for (a path, a name on the search path).
        searched: Every place looked, in order, each once.
        kind: The file's kind in the message (``"URDF"``, ``"MJCF"``, ``"SDF"``).
        hint: What follows the sentence (`` (did you mean '...'?)``:
            :func:`simbridge.model.urdf_source.not_found`).
    """

    def __init__(self, source: str, searched: Iterable[str], kind: str = "URDF", hint: str = ""):
        self.source = source
        super().__init__(
            f"{kind} {source!r} is neither a file, a name on the search path, nor {kind} text"
            f"{hint}; searched: {_choices(searched)}"
        )


class UrdfParseError(UrdfError):
    """A file that is not well-formed XML.

    Args:
        file: The file's path.
        detail: The XML parser's complaint.
        kind: The file's kind in the message (``"URDF"``, ``"MJCF"``, ``"SDF"``).
    """

    def __init__(self, file: str, detail: str, kind: str = "URDF"):
        self.file = file
        super().__init__(f"{file}: malformed {kind} XML: {detail}")


def _at(file: str, line: int | None) -> str:
    """``file:line`` where the line is known (1-based), else ``file``."""
    return file if line is None else f"{file}:{line}"


class UrdfStructureError(UrdfError):
    """Well-formed XML that is not a valid robot (no links, a cycle, a missing parent...).

    Args:
        file: The file's path.
        element: The element to blame (``"joint 'hip'"``).
        detail: What is wrong with it.
        line: The element's line in the file (1-based), None where no one line is to blame.
    """

    def __init__(self, file: str, element: str, detail: str, line: int | None = None):
        self.file = file
        self.element = element
        self.line = line
        super().__init__(f"{_at(file, line)}: {element}: {detail}")


class MjcfCompileError(UrdfError):
    """An MJCF file MuJoCo's compiler refuses (``load_mjcf(..., semantics="mujoco")``).

    Args:
        file: The file's path (or ``<MJCF text>``).
        detail: MuJoCo's own message, on one line.
        line: The line MuJoCo names (1-based), None where it names none.
    """

    def __init__(self, file: str, detail: str, line: int | None = None):
        self.file = file
        self.line = line
        super().__init__(f"{_at(file, line)}: MuJoCo's compiler refuses the MJCF: {detail}")


class MeshNotFoundError(UrdfError, FileNotFoundError):
    """A mesh file found nowhere PyBullet looks.

    Args:
        file: The robot file's path.
        element: The element that names the mesh.
        filename: The mesh's name as written in the file.
        tried: Every path tried, in PyBullet's order (see
            :func:`simbridge.model.urdf_source.resolve_mesh`), made absolute from the working
            directory.
        line: The element's line in the file (1-based), or None.
    """

    def __init__(
        self,
        file: str,
        element: str,
        filename: str,
        tried: Sequence[str | os.PathLike[str]],
        line: int | None = None,
    ):
        self.file = file
        self.mesh_uri = filename
        self.line = line
        self.tried = [os.fspath(t) for t in tried]
        super().__init__(
            f"{_at(file, line)}: {element}: mesh file {filename!r} not found; tried "
            f"{len(self.tried)} paths, in PyBullet's order (the name as written from the "
            f"working directory, the file's folder and those above it, ./ ../ ../../): "
            f"{_choices(self.tried)}"
        )


class UnsupportedJointError(UrdfError):
    """A joint type simbridge (or PyBullet) cannot build.

    Args:
        file: The robot file's path.
        joint: The joint's name.
        joint_type: Its type as written.
        supported: The types that are.
        line: The joint's line in the file (1-based), or None.
        reason: Why it is not supported, in parentheses after the type; none by default.
    """

    def __init__(
        self,
        file: str,
        joint: str,
        joint_type: str,
        supported: Iterable[str],
        line: int | None = None,
        reason: str = "",
    ):
        self.line = line
        why = f" ({reason})" if reason else ""
        super().__init__(
            f"{_at(file, line)}: joint {joint!r}: joint type {joint_type!r} is not supported"
            f"{why}; supported types: {_choices(supported)}"
        )


# ---------------------------------------------------------------- lookups and arguments


class UnknownBodyError(SimbridgeError, LookupError):
    """A body id that is not in the Sim.

    Args:
        body: What was given.
        valid: The ids of the bodies in the Sim.
    """

    def __init__(self, body: object, valid: Iterable[int]):
        super().__init__(f"unknown body {body!r}; bodies in this Sim: {_choices(valid)}")


def _body_label(body_name: str, body: int | None, source: str | None) -> str:
    """``body 1 ('physics', r2d2.urdf)``: the id, the name inside the file, the file; without
    an id, ``body 'physics'``."""
    if body is None:
        return f"body {body_name!r}"
    where = f", {os.path.basename(source)}" if source else ""
    return f"body {body} ({body_name!r}{where})"


class UnknownJointError(SimbridgeError, LookupError):
    """A joint index or name that the body does not have.

    Args:
        body_name: The robot's name inside its file.
        joint: The index or name given.
        valid_names: The body's joint names, in index order.
        body: The body's id, when known.
        source: The body's file, when known (its base name goes in the message).
    """

    def __init__(
        self,
        body_name: str,
        joint: object,
        valid_names: Iterable[str],
        *,
        body: int | None = None,
        source: str | None = None,
    ):
        names = list(valid_names)
        label = _body_label(body_name, body, source)
        if not names:
            super().__init__(f"{label} has no joint {joint!r}: it has no joints")
            return
        hint = did_you_mean(joint, names) if isinstance(joint, str) else ""
        super().__init__(
            f"{label} has no joint {joint!r}{hint}; valid joints are indices "
            f"0..{len(names) - 1} or names {_choices(names)}"
        )


class UnknownLinkError(SimbridgeError, LookupError):
    """A link index or name that the body does not have.

    Args:
        body_name: The robot's name inside its file.
        link: The index or name given.
        valid_names: The body's link names, in index order.
        body: The body's id, when known.
        source: The body's file, when known (its base name goes in the message).
    """

    def __init__(
        self,
        body_name: str,
        link: object,
        valid_names: Iterable[str],
        *,
        body: int | None = None,
        source: str | None = None,
    ):
        names = list(valid_names)
        hint = did_you_mean(link, names) if isinstance(link, str) else ""
        super().__init__(
            f"{_body_label(body_name, body, source)} has no link {link!r}{hint}; valid links "
            f"are -1 (base), indices 0..{len(names) - 1} or names {_choices(names)}"
        )


class UnknownObjectError(SimbridgeError, LookupError):
    """An actuator, sensor, site or keyframe the MuJoCo model does not have
    (``load_mjcf(..., semantics="mujoco")``'s calls).

    Args:
        kind: What was asked for (``"actuator"``).
        item: The index or name given.
        valid_names: The model's names of that kind, in MuJoCo's order.
    """

    def __init__(self, kind: str, item: object, valid_names: Iterable[str]):
        names = list(valid_names)
        self.kind = kind
        if not names:
            super().__init__(f"the model has no {kind} {item!r}: it has no {kind}s")
            return
        hint = did_you_mean(item, names) if isinstance(item, str) else ""
        super().__init__(
            f"the model has no {kind} {item!r}{hint}; valid {kind}s are indices "
            f"0..{len(names) - 1} or names {_choices(names)}"
        )


class InvalidArgumentError(SimbridgeError, ValueError):
    """An argument outside what the call accepts.

    Args:
        argument: The argument's name.
        detail: What is wrong and what would be right.
    """

    def __init__(self, argument: str, detail: str):
        self.argument = argument
        super().__init__(f"argument {argument!r}: {detail}")


class InvalidProfileError(SimbridgeError, ValueError):
    """A profile name that does not exist.

    Args:
        profile: What was given.
        valid: The profile names.
    """

    def __init__(self, profile: object, valid: Iterable[str]):
        valid = list(valid)
        hint = did_you_mean(profile, valid) if isinstance(profile, str) else ""
        super().__init__(f"unknown profile {profile!r}{hint}; valid profiles: {_choices(valid)}")


class InvalidEngineSettingError(InvalidProfileError):
    """An engine setting that is not one of the backend's, or a value outside its range.

    Args:
        backend: The backend's name.
        key: The setting's key.
        detail: What is wrong and what would be right.
    """

    def __init__(self, backend: str, key: str, detail: str):
        self.backend = backend
        self.key = key
        SimbridgeError.__init__(self, f"engine setting {backend}.{key}: {detail}")


# ---------------------------------------------------------------- running


class SimulationDivergedError(SimbridgeError, FloatingPointError):
    """The world's state turned non-finite (or, for a model read with semantics='mujoco',
    bad as MuJoCo's own ``mj_step`` judges it: beyond 1e10 in magnitude).

    Args:
        backend: The backend's name.
        time: The simulated time when it was noticed (s).
        where: What is not finite (``"body 0 joint velocities"``).
        why: What is wrong with it (default ``"is not finite"``).
    """

    def __init__(self, backend: str, time: float, where: str, *, why: str = "is not finite"):
        self.where = where
        super().__init__(
            f"simulation on backend {backend!r} diverged at t={time:.6f} s: {where} {why}"
        )


class EngineError(BackendError, RuntimeError):
    """The engine itself stopped with an error (MuJoCo's ``mju_error``: a world too large for
    its memory, say). The world's state is then undefined: the Sim refuses to step further
    until ``reset()``.

    Args:
        backend: The backend's name.
        time: The simulated time when it stopped (s).
        detail: The engine's message.
    """

    def __init__(self, backend: str, time: float, detail: str):
        self.detail = detail
        super().__init__(
            f"backend {backend!r} stopped with an engine error at t={time:.6f} s: {detail}; "
            "the world's state is undefined: reset() or close this Sim"
        )


class SimBusyError(SimbridgeError, RuntimeError):
    """A call reached a Sim while it was stepping in another thread (another thread's call
    that is not a step is waited for). A Sim takes one call at a time; Sims in different
    threads step in parallel (MuJoCo's compiled loop releases the GIL).

    Args:
        detail: The whole message; by default one that says the Sim is stepping.
    """

    def __init__(self, detail: str | None = None) -> None:
        super().__init__(
            detail
            or "this Sim is busy in another thread (stepping); a Sim takes one call at a time "
            "(give each thread its own Sim)"
        )


class SimClosedError(SimbridgeError, RuntimeError):
    """A call to a Sim after ``close()``."""

    def __init__(self) -> None:
        super().__init__("this Sim is closed; create a new one")


class SimNotCopyableError(SimbridgeError, TypeError):
    """``copy.copy``, ``copy.deepcopy`` or ``pickle`` of a Sim: it holds an engine connection,
    which neither copies nor pickles (a shallow copy shared it: closing the copy broke the
    original)."""

    def __init__(self) -> None:
        super().__init__(
            "a Sim holds an engine connection and cannot be copied or pickled: carry a world "
            "with sim.get_state() (a WorldState, which pickles) into another Sim loaded alike "
            "(sim.set_state()), or build a new Sim"
        )


class NotOfferedError(SimbridgeError, AttributeError):
    """A PyBullet function the Sim does not offer (yet), asked for by its PyBullet name
    (``sim.applyExternalForce``) or in snake case: says so, and what to use instead where
    something exists (:data:`simbridge.sim.pybullet_names.NOT_OFFERED`).

    Args:
        attribute: The attribute asked for.
        pybullet_name: PyBullet's name of the function.
        instead: What to use instead, or ``""`` when nothing does it yet.
    """

    def __init__(self, attribute: str, pybullet_name: str, instead: str):
        self.attribute = attribute
        self.pybullet_name = pybullet_name
        self.instead = instead
        what = f"instead: {instead}" if instead else "nothing in simbridge does this yet"
        super().__init__(
            f"'Sim' object has no attribute {attribute!r}: simbridge does not offer PyBullet's "
            f"{pybullet_name} yet; {what}"
        )


class PyBulletKeywordError(SimbridgeError, TypeError):
    """A Sim call given a keyword it does not take (often PyBullet's name of one of its
    arguments, ``basePosition``), or missing a required argument: ``detail`` names the keyword
    and simbridge's name for it, or the valid keywords.

    Args:
        call: The call (``"Sim.load_urdf()"``), the message's subject.
        detail: The rest of the message.
    """

    def __init__(self, call: str, detail: str):
        self.call = call
        super().__init__(f"{call} {detail}")


class StaleCommandError(SimbridgeError, RuntimeError):
    """A bound command (``Sim.velocity_command``, ``Sim.position_command``) used after it was
    released or after a world change (load_urdf, remove, reset, close) ended it.

    Args:
        command: What the command is (``"velocity command"``).
        why: What ended it.
    """

    def __init__(self, command: str, why: str) -> None:
        super().__init__(
            f"the {command} is no longer bound: {why}; bind a new one "
            "(sim.velocity_command / sim.position_command)"
        )


class SlowStepWarning(UserWarning):
    """A backend runs a slower path than it was installed for (the MuJoCo backend's compiled
    step loop is missing or was built against another MuJoCo): same results, more time."""


class InitialPenetrationWarning(UserWarning):
    """A model read with semantics='mujoco' whose geoms overlap at ``qpos0`` in an engine with
    rigid contacts: the engine pushes them apart within a step where MuJoCo's soft contacts
    ease them out over many, and the run may diverge (the pairs and depths are the manifest's
    departure ``initial_penetration``)."""


_MOVED_TO_COMPARE = frozenset(
    {
        "ScenarioError",
        "TrajectoryFileError",
        "CacheEntryMissingError",
        "JobError",
        "EngineNotInStudyError",
        "ExtraNotInstalledError",
    }
)
"""compare's errors, which now live in :mod:`simbridge.compare.errors`; importable from here
for one release, with a ``DeprecationWarning``."""


def __getattr__(name: str) -> type[SimbridgeError]:
    """A compare error by its old path: imported from :mod:`simbridge.compare.errors` on first
    use, with a ``DeprecationWarning`` (the core imports nothing of compare otherwise).

    Raises:
        AttributeError: ``name`` is not one of the moved errors.
    """
    if name not in _MOVED_TO_COMPARE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib
    import warnings

    warnings.warn(
        f"simbridge.exceptions.{name} moved to simbridge.compare.errors.{name}; the old path "
        "goes in the next release",
        DeprecationWarning,
        stacklevel=2,
    )
    # by name, not an import statement: the core does not depend on compare
    errors = importlib.import_module("simbridge.compare.errors")
    cls: type[SimbridgeError] = getattr(errors, name)
    return cls
