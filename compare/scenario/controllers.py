"""Closed-loop controllers in scenarios: :class:`ControllerSpec` names one, :func:`load_object`
finds it, and :class:`PhaseControl` runs it inside :func:`simbridge.compare.run`.

A controller is a class (or any callable returning an object) with a ``step`` method::

    class GoTo:
        def __init__(self, goal=(0.0, 2.0), speed=9.0):   # the scenario's params, as keywords
            self.goal, self.speed = goal, speed

        def start(self, sim, robots, time):   # optional: robots = {scenario robot name: body id}
            self.robot = robots["r2d2"]

        def step(self, sim, time):            # before every `every`-th step of its phase
            x, y, _ = sim.base_state(self.robot).position
            sim.set_joint_velocity(self.robot, [2, 3, 6, 7], -self.speed, max_force=10)

It is made fresh when its phase starts (in every run, each ensemble member included), told the
robots' body ids by their scenario names, then called before the first step of the phase and
every ``every`` steps after, with the :class:`simbridge.Sim` and the time (s since the run
started). It reads the world and commands joints through the Sim alone, and returns None.

A reference is ``"file.py:Name"`` (a file, relative to the scenario's folder, or absolute) or
``"package.module:Name"`` (imported from ``sys.path``). Only the reference travels to the
ensemble's worker processes, which import it again: no controller object is ever pickled.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import inspect
import math
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

from ..errors import ScenarioError

if TYPE_CHECKING:
    import simbridge

Trajectory = Any  # simbridge.compare.run.Trajectory: run.py imports this module, not the reverse

__all__ = [
    "ControllerSpec",
    "ControllerError",
    "ControlSim",
    "PhaseControl",
    "absolute_ref",
    "load_object",
    "reference_of",
    "search_rule",
]

_FILE_MODULE_PREFIX = "simbridge_user_"
"""sys.modules names of the files loaded by path: ``simbridge_user_<stem>_<hash of the path>``."""


# ---------------------------------------------------------------- references


def _is_file_ref(left: str) -> bool:
    return left.endswith(".py") or "/" in left or "\\" in left


def search_rule(ref: str, base: Path | None) -> str:
    """How ``ref`` is looked for, in words (for error messages)."""
    left = ref.rpartition(":")[0]
    if _is_file_ref(left):
        where = f"the scenario's folder {str(base)!r}" if base is not None else "the current folder"
        return (
            "a reference 'file.py:Name' names a Python file, relative to " + where + " unless "
            "absolute; 'package.module:Name' names a module imported from sys.path"
        )
    return (
        "a reference 'package.module:Name' names a module imported from sys.path ("
        + ", ".join(repr(p) for p in sys.path[:6])
        + (", ..." if len(sys.path) > 6 else "")
        + "); 'file.py:Name' names a Python file beside the scenario"
    )


class RefError(Exception):
    """A reference that cannot be resolved: the reason, the path tried, the search rule."""


def _load_file(path: Path) -> ModuleType:
    stat = path.stat()
    digest = hashlib.sha1(str(path).encode("utf-8")).hexdigest()[:10]
    stem = "".join(ch if ch.isalnum() else "_" for ch in path.stem)
    name = f"{_FILE_MODULE_PREFIX}{stem}_{digest}"
    module = sys.modules.get(name)
    stamp = (stat.st_mtime_ns, stat.st_size)
    if module is not None and getattr(module, "__simbridge_stamp__", None) == stamp:
        return module
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:  # pragma: no cover - a .py file always has one
        raise RefError(f"cannot load {str(path)!r} as Python")
    module = importlib.util.module_from_spec(spec)
    module.__simbridge_stamp__ = stamp  # type: ignore[attr-defined]
    sys.modules[name] = module  # dataclasses and pickling inside the file look it up here
    try:
        spec.loader.exec_module(module)
    except BaseException as exc:
        sys.modules.pop(name, None)
        raise RefError(f"importing {str(path)!r} failed: {type(exc).__name__}: {exc}") from exc
    return module


def absolute_ref(ref: str, base: Path | None = None) -> str:
    """``ref`` with a relative file made absolute (against ``base``, else the current folder);
    a module reference as it is."""
    left, sep, attr = ref.rpartition(":")
    if not sep or not _is_file_ref(left):
        return ref
    path = Path(left).expanduser()
    if not path.is_absolute():
        path = (base if base is not None else Path.cwd()) / path
    return f"{path.resolve()}:{attr}"


def load_object(ref: str, base: Path | None = None) -> Any:
    """The object ``ref`` names: ``"file.py:Name"`` (relative to ``base``, the scenario's
    folder, else the current folder) or ``"package.module:Name"`` (``Name`` may be dotted).

    Raises:
        RefError: a malformed reference, a file or module that cannot be found or imported, or
            a missing name; the message gives the path tried and the search rule.
    """
    if not isinstance(ref, str) or ref.count(":") < 1:
        raise RefError(f"expected 'file.py:Name' or 'package.module:Name', got {ref!r}")
    left, _, attr = ref.rpartition(":")
    if not left or not attr or not all(part.isidentifier() for part in attr.split(".")):
        raise RefError(f"expected 'file.py:Name' or 'package.module:Name', got {ref!r}")
    if _is_file_ref(left):
        path = Path(left).expanduser()
        if not path.is_absolute():
            path = (base if base is not None else Path.cwd()) / path
        path = path.resolve()
        if not path.is_file():
            raise RefError(f"no such file {str(path)!r} ({search_rule(ref, base)})")
        module = _load_file(path)
        where = str(path)
    else:
        try:
            module = importlib.import_module(left)
        except ModuleNotFoundError as exc:
            if exc.name is not None and left.startswith(exc.name):
                raise RefError(f"no module named {exc.name!r} ({search_rule(ref, base)})") from None
            raise RefError(
                f"importing module {left!r} failed: {type(exc).__name__}: {exc}"
            ) from exc
        except BaseException as exc:
            raise RefError(
                f"importing module {left!r} failed: {type(exc).__name__}: {exc}"
            ) from exc
        where = f"module {left!r} ({getattr(module, '__file__', None) or 'built in'})"
    obj: Any = module
    for part in attr.split("."):
        try:
            obj = getattr(obj, part)
        except AttributeError:
            names = sorted(n for n in vars(module) if not n.startswith("_"))
            raise RefError(
                f"{where} has no {attr!r}; it defines: {', '.join(names) or 'nothing public'}"
            ) from None
    return obj


def _defining_file(obj: Any) -> str | None:
    """The source file ``obj`` was defined in, found without importing anything."""
    module = sys.modules.get(getattr(obj, "__module__", "") or "")
    file = getattr(module, "__file__", None)
    if file:
        return str(file)
    code = getattr(obj, "__code__", None)  # a function
    if code is not None:
        return str(code.co_filename)
    for member in vars(obj).values() if inspect.isclass(obj) else ():  # a class: its methods
        code = getattr(getattr(member, "__func__", member), "__code__", None)
        if code is not None:
            return str(code.co_filename)
    return None


def _importable_as(modname: str, file: str | None) -> bool:
    """Whether ``import modname`` (what a worker would do) finds the file ``obj`` came from."""
    if modname in ("__main__", "__mp_main__") or modname.startswith(_FILE_MODULE_PREFIX):
        return False
    try:
        spec = importlib.util.find_spec(modname)
    except (ImportError, ValueError):
        return False
    if spec is None or not spec.origin or not Path(spec.origin).is_file():
        return False  # not found, or a namespace package (a bare folder), or built in
    return file is None or Path(spec.origin).resolve() == Path(file).resolve()


def reference_of(obj: Any) -> str:
    """The reference a worker process can import ``obj`` (a class or function) by:
    ``module:qualname`` when ``import module`` finds the file it came from, else
    ``/its/file.py:qualname`` (a script's own objects, a file loaded by path, a module loaded
    under another name).

    Raises:
        RefError: ``obj`` is defined inside a function, or in no file.
    """
    qual = getattr(obj, "__qualname__", None)
    modname = getattr(obj, "__module__", None)
    if not isinstance(qual, str) or not isinstance(modname, str):
        raise RefError(f"{obj!r} is not a class or a function")
    if "<locals>" in qual or "<lambda>" in qual:
        raise RefError(
            f"{qual} is defined inside a function: define it at the top level of a module, so "
            "that every run (and the ensemble's worker processes) can import it"
        )
    file = _defining_file(obj)
    if _importable_as(modname, file):
        return f"{modname}:{qual}"
    if not file or not Path(file).is_file():
        raise RefError(
            f"{qual} is defined in {modname}, which has no file (an interactive session or "
            "a script read from stdin): put it in a file and name it 'file.py:Name'"
        )
    return f"{Path(file).resolve()}:{qual}"


# ---------------------------------------------------------------- the spec


@dataclass(frozen=True)
class ControllerSpec:
    """A phase's controller: what to make, with which parameters, how often to call it.

    ``ref`` is ``"file.py:Name"`` (relative to the scenario's folder) or
    ``"package.module:Name"``; ``params`` the keyword arguments ``Name(**params)`` is made with
    (TOML values: numbers, strings, booleans, lists, tables); ``every`` the control period in
    steps (1: before every step)."""

    ref: str
    params: dict[str, Any] = field(default_factory=dict)
    every: int = 1

    @classmethod
    def of(
        cls,
        controller: Any,
        params: Mapping[str, Any] | None = None,
        every: int | None = None,
    ) -> ControllerSpec:
        """A spec from a reference string, a class or factory function (its reference is
        found with :func:`reference_of`), or a spec (``params``/``every`` replace its own).

        Raises:
            InvalidArgumentError: an instance (a controller is made fresh for every run: pass
                its class and ``params``), a local class, a bad ``every`` or ``params``.
        """
        from simbridge.exceptions import InvalidArgumentError

        if isinstance(controller, ControllerSpec):
            ref, p, e = controller.ref, dict(controller.params), controller.every
        elif isinstance(controller, str):
            ref, p, e = controller, {}, 1
        elif inspect.isclass(controller) or inspect.isfunction(controller):
            try:
                ref = reference_of(controller)
            except RefError as exc:
                raise InvalidArgumentError("controller", str(exc)) from None
            p, e = {}, 1
        else:
            raise InvalidArgumentError(
                "controller",
                f"expected a class, a factory function, a 'file.py:Name' or "
                f"'package.module:Name' reference, or a ControllerSpec, got {controller!r} (a "
                "controller is made fresh for every run: pass its class and params=)",
            )
        if params is not None:
            if not isinstance(params, Mapping) or not all(isinstance(k, str) for k in params):
                raise InvalidArgumentError(
                    "params", f"expected a mapping of keyword names to values, got {params!r}"
                )
            p = dict(params)
        if every is not None:
            e = every
        if isinstance(e, bool) or not isinstance(e, int) or e < 1:
            raise InvalidArgumentError("every", f"expected an integer >= 1 (steps), got {e!r}")
        return cls(ref, p, e)

    @property
    def name(self) -> str:
        """The short name used in messages: ``goto.py:GoTo`` (a file's name without its
        folder)."""
        left, _, attr = self.ref.rpartition(":")
        if _is_file_ref(left):
            return f"{Path(left).name}:{attr}"
        return self.ref


class ControllerError(ScenarioError):
    """A controller failed: it could not be made, raised, returned something, commanded a joint
    that does not exist, sent NaN, or touched what a controller may not.

    ``controller`` (its reference), ``phase`` (name), ``time`` (s, the control step's time),
    and ``trajectory``: the run recorded up to the last completed step (a
    :class:`~simbridge.compare.Trajectory`; None when the failure came before any run)."""

    def __init__(
        self,
        file: str,
        key: str | None,
        controller: str,
        phase: str,
        time: float,
        detail: str,
    ):
        self.controller = controller
        self.phase = phase
        self.time = time
        self.trajectory: Trajectory | None = None
        super().__init__(
            file, key, f"controller {controller} in phase {phase!r} at t = {time:.6g} s: {detail}"
        )

    def __reduce__(self) -> Any:  # picklable (ensemble workers report errors as text anyway)
        return (
            _rebuild_error,
            (self.file, self.key, self.controller, self.phase, self.time, str(self)),
        )


def _rebuild_error(
    file: str, key: str | None, controller: str, phase: str, time: float, message: str
) -> ControllerError:
    err = ControllerError.__new__(ControllerError)
    Exception.__init__(err, message)
    err.file, err.key, err.line = file, key, None
    err.controller, err.phase, err.time, err.trajectory = controller, phase, time, None
    return err


# ---------------------------------------------------------------- what the controller sees

_MODE_CODE = {"velocity": 1, "position": 2, "torque": 3}
_FORBIDDEN = {
    "step": "steps the world (the run steps it; the controller is called before each step)",
    "close": "closes the world",
    "reset": "resets the world",
    "load_urdf": "loads a body",
    "load_mjcf": "loads bodies",
    "load_sdf": "loads bodies",
    "remove": "removes a body",
    "set_state": "sets the world's state",
    "reset_base_state": "teleports a base",
    "reset_joint_state": "teleports a joint",
}


class ControllerMisuse(Exception):
    """Raised by :class:`ControlSim` for a call a controller may not make."""


class ControlSim:
    """The :class:`simbridge.Sim` as a controller sees it: every reading and command of the Sim,
    forwarded; what would change the world other than by commanding joints (``step``,
    ``reset``, ``load_urdf``, ``set_state``, the ``reset_*_state`` teleports, ``close``)
    refused. Plain commands (``set_joint_velocity``, ``set_joint_position``,
    ``set_joint_torque``) are also noted, so that the run records their targets and holds a
    torque until the next control step."""

    def __init__(self, sim: simbridge.Sim, note: Callable[..., None]):
        object.__setattr__(self, "_sim", sim)
        object.__setattr__(self, "_note", note)

    def __getattr__(self, name: str) -> Any:
        if name in _FORBIDDEN:
            raise ControllerMisuse(
                f"called sim.{name}(), which {_FORBIDDEN[name]}: a controller reads the world "
                "and commands joints only"
            )
        return getattr(self._sim, name)

    def __setattr__(self, name: str, value: Any) -> None:
        raise ControllerMisuse(f"set sim.{name}: a controller may not change the Sim's attributes")

    def __repr__(self) -> str:
        return f"ControlSim({self._sim!r})"

    def set_joint_velocity(self, body: int, joints: Any, target: Any, *, max_force: Any) -> None:
        self._sim.set_joint_velocity(body, joints, target, max_force=max_force)
        self._note(body, joints, "velocity", target, max_force=max_force)

    def set_joint_position(
        self, body: int, joints: Any, target: Any, *, max_force: Any, kp: Any = 0.1, kd: Any = 1.0
    ) -> None:
        self._sim.set_joint_position(body, joints, target, max_force=max_force, kp=kp, kd=kd)
        self._note(body, joints, "position", target, max_force=max_force, kp=kp, kd=kd)

    def set_joint_torque(self, body: int, joints: Any, torque: Any) -> None:
        self._sim.set_joint_torque(body, joints, torque)
        self._note(body, joints, "torque", torque)


# ---------------------------------------------------------------- running one


class PhaseControl:
    """One phase's controller in one run: made with :meth:`start`, called with
    :meth:`before_step` before every step of the phase, after the phase's own commands (it
    calls the controller on control steps; in between it re-sends the last call's torques, and
    its velocity and position commands on joints the phase's commands also drive, so that the
    controller's command holds until its next call), and :meth:`record` after each step writes
    the held commands' targets into the recording.

    Every failure is a :class:`ControllerError` naming the controller, the phase and the
    time."""

    def __init__(
        self,
        spec: ControllerSpec,
        *,
        phase: str,
        key: str,
        file: str,
        base: Path | None,
        sim: simbridge.Sim,
        robots: Mapping[str, int],
        columns: Callable[[int, list[int]], tuple[Any, list[int]] | None],
        stopped: Callable[[str, int, int], Trajectory] | None = None,
        overridden: set[tuple[int, int]] | None = None,
    ):
        self.spec = spec
        self.phase = phase
        self.key = key
        self.file = file
        self.base = base
        self.sim = sim
        self.robots = dict(robots)
        self.columns = columns
        self.stopped = stopped
        self.first = 0  # the phase's first row
        self.row = 0  # rows recorded so far in the run, less one
        self.view = ControlSim(sim, self._note)
        self.obj: Any = None
        # (body, joint) -> mode code, target, max_force (NaN: a torque)
        self.held: dict[tuple[int, int], tuple[int, float, float]] = {}
        self.overridden = set(overridden or ())  # (body, joint) the phase's commands drive
        # the last call's commands: (mode, body, joint indices, values, keyword arguments)
        self.sent: list[tuple[str, int, list[int], list[float], dict[str, Any]]] = []
        self.resend: list[tuple[str, int, list[int], list[float], dict[str, Any]]] = []
        self.calls = 0
        self.time = 0.0

    def error(self, time: float, detail: str) -> ControllerError:
        """The ControllerError, carrying the run recorded so far."""
        err = ControllerError(self.file, self.key, self.spec.name, self.phase, time, detail)
        if self.stopped is not None:
            err.trajectory = self.stopped(self.phase, self.first, self.row)
        return err

    def _note(self, body: int, joints: Any, mode: str, target: Any, **kw: Any) -> None:
        if isinstance(joints, (int, str)) or not hasattr(joints, "__iter__"):
            items = [joints]
        else:
            items = list(joints)
        idx = [self.sim.joint_index(body, j) for j in items]
        values = (
            [float(v) for v in target]
            if hasattr(target, "__iter__")
            else [float(target)] * len(idx)
        )
        self.sent.append((mode, body, idx, values, kw))
        code = _MODE_CODE[mode]
        mf: Any = kw.get("max_force")
        if mf is None:  # a torque: no motor limit
            forces = [math.nan] * len(idx)
        elif hasattr(mf, "__iter__"):
            forces = [float(x) for x in mf]
        else:
            forces = [float(mf)] * len(idx)
        for j, v, force in zip(idx, values, forces, strict=False):
            self.held[(body, j)] = (code, float(v), force)

    def start(self, row: int, time: float) -> None:
        """Make the controller (``factory(**params)``) and call its ``start``, if it has one,
        at the phase's first row ``row`` and ``time`` (s)."""
        self.time = time
        self.first = self.row = row
        try:
            factory = load_object(self.spec.ref, self.base)
        except RefError as exc:
            raise self.error(time, str(exc)) from None
        if not callable(factory):
            raise self.error(time, f"{self.spec.ref} is not a class or a factory function")
        try:
            obj = factory(**self.spec.params)
        except Exception as exc:
            raise self.error(
                time,
                f"making it with params {self.spec.params!r} raised {type(exc).__name__}: {exc}",
            ) from exc
        step = getattr(obj, "step", None)
        if not callable(step):
            raise self.error(
                time,
                f"{type(obj).__name__} has no step(sim, time) method (a controller is called "
                "as controller.step(sim, time) before each control step)",
            )
        self.obj = obj
        begin = getattr(obj, "start", None)
        if begin is not None:
            self._call(begin, "start", time, self.view, dict(self.robots), time)

    def _call(self, fn: Callable[..., Any], what: str, time: float, *args: Any) -> None:
        self.sent = []
        try:
            out = fn(*args)
        except ControllerMisuse as exc:
            raise self.error(time, str(exc)) from None
        except Exception as exc:
            raise self.error(time, f"{what}() raised {type(exc).__name__}: {exc}") from exc
        if out is not None:
            raise self.error(
                time,
                f"{what}() returned {out!r}; a controller acts through the Sim "
                "(set_joint_velocity, set_joint_position, set_joint_torque) and returns None",
            )
        self.resend = [
            c
            for c in self.sent
            if c[0] == "torque" or any((c[1], j) in self.overridden for j in c[2])
        ]

    def before_step(self, i: int, time: float) -> None:
        """Before step ``i`` (0-based, in the phase) at ``time`` (s), after the phase's own
        commands: call the controller on a control step; else hold its last call's commands (a
        zero-order hold): re-send its torques (a torque lasts one step), and its velocity and
        position commands on joints the phase's commands have just overwritten (elsewhere they
        persist in the engine by themselves)."""
        self.row = self.first + i
        if i % self.spec.every == 0:
            self.time = time
            self.calls += 1
            self._call(self.obj.step, "step", time, self.view, time)
            return
        sim = self.sim
        for mode, body, idx, values, kw in self.resend:
            if mode == "torque":
                sim.set_joint_torque(body, idx, values)
            elif mode == "velocity":
                sim.set_joint_velocity(body, idx, values, **kw)
            else:
                sim.set_joint_position(body, idx, values, **kw)

    def record(self, row: int) -> None:
        """Write the targets (and the max_force, where the recording keeps one) of the
        commands the controller holds into row ``row``."""
        for (body, joint), (code, value, force) in self.held.items():
            found = self.columns(body, [joint])
            if found is None:
                continue
            rec, cols = found
            rec.targets[row, cols[0]] = value
            rec.modes[row, cols[0]] = code
            held_force = getattr(rec, "held_force", None)
            if held_force is not None:  # persists past the phase, as the engine's motor does
                held_force[cols[0]] = force
                rec.max_forces[row, cols[0]] = force
