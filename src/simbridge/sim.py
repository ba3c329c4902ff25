"""`Sim`: one robot-simulation interface, PyBullet's meaning, any engine.

::

    with simbridge.Sim("pybullet") as sim:          # or Sim("mujoco")
        plane = sim.load_urdf("plane.urdf")
        robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
        sim.set_joint_velocity(robot, [2, 3, 6, 7], [-10, -10, 10, 10], max_force=50)
        sim.step(240)
        print(sim.base_state(robot).position)

Conventions (every backend): SI units; quaternions (x, y, z, w); joint i moves link i; the base
is link -1; poses in the world frame. Commands: velocity and position commands persist until
replaced; a torque command lasts one step.
"""

from __future__ import annotations

import logging
import math
import os
import time as _time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ._version import __version__
from .backend import Backend
from .bound import BoundCommand
from .exceptions import (
    InvalidArgumentError,
    SimBusyError,
    SimClosedError,
    UnknownBodyError,
    UnknownJointError,
    UnknownLinkError,
)
from .profiles import Profile, get_profile
from .registry import available_backends, load_backend
from .types import (
    BaseState,
    BodyState,
    ContactPoint,
    DynamicsInfo,
    JointInfo,
    JointStateMultiDof,
    JointStates,
    JointType,
    LinkState,
    MotorMode,
    WorldState,
)

_F64 = np.dtype(np.float64)  # native float64: ``arr.dtype is _F64`` is the hot path's test

__all__ = ["Sim"]

JointsArg = int | str | Sequence[int | str] | np.ndarray
LinkArg = int | str


@dataclass
class _Body:
    name: str
    joint_names: list[str]
    link_names: list[str]
    joint_types: list[JointType]
    joint_index: dict[str, int]
    link_index: dict[str, int]
    cache: dict[Any, np.ndarray] = field(default_factory=dict)  # joints arg -> indices
    movable_cache: dict[Any, np.ndarray] = field(default_factory=dict)
    load: dict[str, Any] = field(default_factory=dict)  # how it was loaded (the manifest's)

    @property
    def has_spherical(self) -> bool:
        return JointType.SPHERICAL in self.joint_types


class _Closed:
    """Stands in for the backend after close(): any use raises SimClosedError."""

    def __getattr__(self, name: str) -> Any:
        raise SimClosedError()


def _vec(value: Any, n: int, argument: str) -> tuple[float, ...]:
    try:
        out = tuple(float(v) for v in value)
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


def _within(values: Sequence[float], argument: str) -> None:
    """Refuse a position or velocity past MAX_STATE_VALUE (see there)."""
    if values and max(map(abs, values)) > MAX_STATE_VALUE:
        raise InvalidArgumentError(
            argument,
            f"values must be within +-{MAX_STATE_VALUE:g} (m, rad, m/s or rad/s: MuJoCo takes "
            f"a state past it for a divergence), got {tuple(values)!r}",
        )


def _flag(value: Any, argument: str) -> bool:
    """A switch: a bool (or numpy bool), never a truthy string or number."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise InvalidArgumentError(argument, f"must be True or False (a bool), got {value!r}")


def _state_vec(value: Any, argument: str) -> tuple[float, ...]:
    """Three finite numbers within MAX_STATE_VALUE (a teleport's position or velocity)."""
    out = _vec(value, 3, argument)
    _within(out, argument)
    return out


def _quat(value: Any, argument: str, normalise: bool = False) -> tuple[float, float, float, float]:
    """A unit quaternion (x, y, z, w). One whose norm is off 1 by more than 1e-3 is refused,
    or with ``normalise`` (a spawn pose: PyBullet's loadURDF normalises) divided by its norm,
    with one warning on the ``simbridge.sim`` logger; a zero one is always refused."""
    q = _vec(value, 4, argument)
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


class Sim:
    """A simulated world on one backend.

    Args:
        backend: registered backend name: ``"pybullet"``, ``"mujoco"``, or a third-party one
            (see :func:`simbridge.available_backends`).
        gravity: world gravity (m/s²), set explicitly on every engine.
        timestep: fixed step (s).
        profile: ``"pybullet"`` (PyBullet's defaults on every engine), ``"urdf"`` (the file's
            values, nothing hidden) or a :class:`~simbridge.Profile`.
        gui: open the engine's viewer. Raises :class:`~simbridge.exceptions.DisplayError`
            without a display.

    Raises:
        UnknownBackendError: ``backend`` is not registered (the message lists those that are).
        BackendNotInstalledError: the engine is not installed (the message gives the pip line).
        InvalidArgumentError, InvalidProfileError: on a bad gravity, time step or profile.
    """

    def __init__(
        self,
        backend: str = "pybullet",
        *,
        gravity: Sequence[float] = (0.0, 0.0, -9.8),
        timestep: float = 1.0 / 240.0,
        profile: str | Profile = "pybullet",
        gui: bool = False,
    ) -> None:
        self._b: Backend = _Closed()  # type: ignore[assignment]
        self._commands: list[BoundCommand] = []  # bound commands, in binding order
        self._presend: list[BoundCommand] = []  # ... those the Sim sends before each step
        self._held: dict[int, dict[int, BoundCommand]] = {}  # body -> joint -> its command
        # id -> joint index arrays (from _joints) holding a spherical joint: the commands take
        # them to their multi-DoF path (kept alive here, so an id is never reused)
        self._multi_idx: dict[int, np.ndarray] = {}
        g = _vec(gravity, 3, "gravity")
        try:
            if isinstance(timestep, bool) or not isinstance(timestep, (int, float, np.number)):
                raise TypeError
            dt = float(timestep)
        except (TypeError, OverflowError):
            dt = math.nan
        if not math.isfinite(dt) or dt <= 0:
            raise InvalidArgumentError("timestep", f"must be a finite number > 0, got {timestep!r}")
        prof = get_profile(profile).with_(gravity=g, timestep=dt)
        cls = load_backend(backend)
        self.backend: str = backend
        self._bodies: dict[int, _Body] = {}
        self._b = cls(prof, _flag(gui, "gui"))
        self._dt = float(timestep)
        self._wall_start: float | None = None

    # ---------------------------------------------------------------- lifecycle

    def close(self) -> None:
        """Release the engine. Safe to call twice; any later use raises SimClosedError.
        While another thread steps the Sim it raises SimBusyError and the Sim stays open."""
        backend = self._b
        if isinstance(backend, _Closed):
            return
        try:
            backend.close()
        except SimBusyError:
            raise  # refused: nothing was released, the Sim stays usable
        except BaseException:
            self._b = _Closed()  # type: ignore[assignment]
            self._bodies.clear()
            self._end_commands("the Sim was closed")
            raise
        self._b = _Closed()  # type: ignore[assignment]
        self._bodies.clear()
        self._end_commands("the Sim was closed")

    def __enter__(self) -> Sim:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # noqa: BLE001 - never raise from a finaliser
            pass

    def __repr__(self) -> str:
        if isinstance(self._b, _Closed):  # a repr never raises, closed or not
            return f"Sim({getattr(self, 'backend', '?')!r}, closed)"
        return f"Sim({self.backend!r}, profile={self.profile.name!r}, t={self.time:.4f}s)"

    # ---------------------------------------------------------------- world

    @property
    def time(self) -> float:
        """Simulated time (s) since creation or the last reset."""
        return self._b.time

    @property
    def timestep(self) -> float:
        return self._dt

    @property
    def gravity(self) -> tuple[float, float, float]:
        return self._b.profile.gravity

    @property
    def profile(self) -> Profile:
        """The profile manifest in use (with this Sim's gravity and time step)."""
        return self._b.profile

    @property
    def closed(self) -> bool:
        return isinstance(self._b, _Closed)

    def manifest(self) -> dict[str, Any]:
        """Everything needed to reproduce a run: backend, engine version, profile entries, and
        what the backend could not reproduce exactly (``departures``)."""
        out: dict[str, Any] = {
            "simbridge_version": __version__,
            "profile": self.profile.as_dict(),
        }
        out.update(self._b.manifest())
        # each body's load: source, pose and loadURDF's options (global_scaling, ...)
        bodies: dict[int, dict[str, Any]] = {body: dict(b.load) for body, b in self._bodies.items()}
        out["bodies"] = bodies
        return out

    def load_urdf(
        self,
        source: str | os.PathLike[str],
        *,
        base_position: Sequence[float] = (0.0, 0.0, 0.0),
        base_orientation: Sequence[float] = (0.0, 0.0, 0.0, 1.0),
        fixed_base: bool = False,
        global_scaling: float = 1.0,
        self_collision: bool | str | None = None,
        inertia_source: str | None = None,
        merge_fixed_links: bool = False,
    ) -> int:
        """Load a robot and return its body id.

        Args:
            source: a file path; a name found on the search path (this package's robots, then
                pybullet_data; ``".urdf"`` may be left off); or URDF XML text.
                ``package://`` mesh URIs resolve against the URDF's own folder tree.
            base_position: where the root's URDF link frame goes (m, world).
            base_orientation: its orientation, (x, y, z, w); normalised (with a warning) when
                its norm is not 1, as PyBullet does.
            fixed_base: weld the root to the world.
            global_scaling: ``loadURDF``'s ``globalScaling``: every length of the file times
                this (> 0); masses and the file's inertia tensors are not scaled.
            self_collision: whether links of this body collide with each other: False
                (``"off"``), True (``"exclude_parent"``: ``URDF_USE_SELF_COLLISION``, a link
                never with its parent), ``"exclude_all_parents"``, ``"include_parent"``; None:
                the profile's ``self_collision`` entry.
            inertia_source: ``"collision_aabb"`` or ``"file"`` (``URDF_USE_INERTIA_FROM_FILE``)
                for this body; None: the profile's entry.
            merge_fixed_links: ``URDF_MERGE_FIXED_LINKS``: links on fixed joints merged into
                their parents (fewer joints and links, PyBullet's numbering).

        The options are listed per body in :meth:`manifest` and mean the same on every
        backend (:mod:`simbridge.load_options`).

        Raises:
            UrdfNotFoundError, UrdfParseError, UrdfStructureError, MeshNotFoundError,
            UnsupportedJointError: the message names the file, the line and the element.
            InvalidArgumentError: a bad pose or option.
        """
        pos = _vec(base_position, 3, "base_position")
        _within(pos, "base_position")
        orn = _quat(base_orientation, "base_orientation", normalise=True)
        fixed_base = _flag(fixed_base, "fixed_base")
        # loaded on first use
        from .load_options import apply_load_options, load_options
        from .urdf import check_file_inertia, parse_urdf, resolve_source

        options = load_options(
            self._b.profile,
            global_scaling=global_scaling,
            self_collision=self_collision,
            inertia_source=inertia_source,
            merge_fixed_links=merge_fixed_links,
        )
        model = parse_urdf(resolve_source(source))
        if options.inertia_source == "file":
            check_file_inertia(model)
        model = apply_load_options(model, options, bool(fixed_base))
        self._end_commands("load_urdf changed the world")
        body = self._b.load(model, pos, orn, bool(fixed_base), options)  # type: ignore[arg-type]
        names = [j.name for j in model.joints]
        links = [j.child for j in model.joints]
        types = [self._b.joint_info(body, i).type for i in range(len(names))]
        self._bodies[body] = _Body(
            model.name,
            names,
            links,
            types,
            {n: i for i, n in enumerate(names)},
            {n: i for i, n in enumerate(links)} | {model.base.name: -1},
            load={
                "source": model.source.display_name,
                "base_position": pos,
                "base_orientation": orn,
                "fixed_base": bool(fixed_base),
                **options.as_dict(),
            },
        )
        return body

    def load_mjcf(
        self, source: str | os.PathLike[str], *, self_collision: bool | str | None = None
    ) -> tuple[int, ...]:
        """Load every body of an MJCF file as ``p.loadMJCF`` does; return their ids.

        One body per top-level ``<worldbody>`` ``<body>`` or ``<geom>``, in the file's order,
        each with PyBullet's links, joints, numbering and names (a body with several joints
        gets massless links between them; see :mod:`simbridge.mjcf`). What PyBullet's importer
        does not read (joint damping and armature, ``<option>``, ``density``, actuators...) is
        not simulated on any backend; it is listed per body in :meth:`manifest` (``ignored``).

        Args:
            source: a file path, a name on the search path (``"mjcf/ant.xml"`` is found in
                pybullet_data) or MJCF text.
            self_collision: as :meth:`load_urdf`'s (``loadMJCF``'s flags); None: the profile's.

        Returns:
            The body ids, in PyBullet's order (``p.loadMJCF``'s tuple).

        Raises:
            UrdfNotFoundError, UrdfParseError, UrdfStructureError, MeshNotFoundError,
            UnsupportedJointError (``ball`` and nested ``free`` joints): the message names the
            file, the line and the element.
        """
        return self._load_scene(source, "mjcf", self_collision)

    def load_sdf(self, source: str | os.PathLike[str]) -> tuple[int, ...]:
        """Load every ``<model>`` of an SDF file as ``p.loadSDF`` does; return their ids.

        Each model is one body with PyBullet's links, joints and numbering (see
        :mod:`simbridge.sdf`), its base at the model's ``<pose>``; ``<static>1</static>`` fixes
        it. ``loadSDF`` takes no flags: links of one body never collide with each other.

        Args:
            source: a file path, a name on the search path (``"kuka_iiwa/model.sdf"``) or SDF
                text.

        Raises:
            UrdfNotFoundError, UrdfParseError, UrdfStructureError, MeshNotFoundError,
            UnsupportedJointError: the message names the file, the line and the element.
        """
        return self._load_scene(source, "sdf", False)

    def _load_scene(
        self, source: str | os.PathLike[str], kind: str, self_collision: bool | str | None
    ) -> tuple[int, ...]:
        from dataclasses import replace

        from .load_options import load_options
        from .scene_files import parse_scene

        options = load_options(self._b.profile, self_collision=self_collision)
        # PyBullet's MJCF and SDF importers take the collision-box inertia (loadSDF has no flag
        # for the file's; an MJCF body's file inertia is MuJoCo's to compute)
        options = replace(options, inertia_source="collision_aabb")
        bodies = parse_scene(source, kind)
        self._end_commands(f"load_{kind} changed the world")
        ids = self._b.load_scene(bodies, options)
        for body, model in zip(ids, bodies, strict=True):
            names = [j.name for j in model.joints]
            links = [j.child for j in model.joints]
            types = [self._b.joint_info(body, i).type for i in range(len(names))]
            self._bodies[body] = _Body(
                model.name,
                names,
                links,
                types,
                {n: i for i, n in enumerate(names)},
                {n: i for i, n in enumerate(links)} | {model.base.name: -1},
                load={
                    "source": model.source.display_name,
                    "format": kind,
                    "body_index": model.body_index,
                    "base_position": model.base_position,
                    "base_orientation": model.base_orientation,
                    "fixed_base": model.base.inertial.mass == 0.0,
                    **options.as_dict(),
                    "ignored": list(model.ignored),
                },
            )
        return tuple(ids)

    def remove(self, body: int) -> None:
        """Remove a body from the world."""
        self._body(body)
        self._end_commands("remove changed the world")
        self._b.remove(body)
        del self._bodies[body]

    def reset(self) -> None:
        """Remove every body and set time to 0 (``p.resetSimulation``)."""
        self._b.time  # noqa: B018 - raises SimClosedError after close()
        self._end_commands("reset changed the world")
        self._b.reset()
        self._bodies.clear()
        self._wall_start = None

    def bodies(self) -> list[int]:
        """Ids of the bodies in the world, in load order."""
        self._b.time  # noqa: B018 - raises SimClosedError after close()
        return list(self._bodies)

    def body_name(self, body: int) -> str:
        """The ``<robot name>`` of a body."""
        return self._body(body).name

    def step(self, n: int = 1, *, realtime: bool = False) -> None:
        """Advance ``n`` fixed steps.

        Args:
            n: number of steps (>= 0).
            realtime: pace the steps to the wall clock (the tutorial's ``time.sleep(1/240)``),
                keeping the pace across calls.

        Bound commands (:meth:`velocity_command`) are read when the call starts: a step(n)
        runs its n steps on those values.

        Raises:
            SimulationDivergedError: the state became NaN or infinite.
            InvalidArgumentError: a bound command holds a non-finite target or a negative or
                non-finite force (no step is taken).
        """
        if type(n) is int and n >= 0 and realtime is False:  # the hot path: one check, one call
            if self._presend:
                for command in self._presend:
                    command.send()
            self._b.step(n)
            self._wall_start = None
            return
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
            raise InvalidArgumentError("n", f"must be an integer >= 0, got {n!r}")
        realtime = _flag(realtime, "realtime")
        for command in self._presend:
            command.send()
        if not realtime:
            self._b.step(int(n))
            self._wall_start = None
            return
        if self._wall_start is None:
            self._wall_start = _time.perf_counter() - self._b.time
        for _ in range(int(n)):
            self._b.step(1)
            delay = self._wall_start + self._b.time - _time.perf_counter()
            if delay > 0:
                _time.sleep(delay)

    # ---------------------------------------------------------------- lookups

    def _body(self, body: int, argument: str = "body") -> _Body:
        if type(body) is int:  # the hot path
            found = self._bodies.get(body)
            if found is not None:
                return found
        elif isinstance(body, np.integer):
            found = self._bodies.get(int(body))
            if found is not None:
                return found
        else:  # True would be body 1, 1.0 too: an id is an int
            self._b.time  # noqa: B018 - raises SimClosedError after close()
            raise InvalidArgumentError(
                argument, f"a body id is an int (as load_urdf returns it), got {body!r}"
            )
        self._b.time  # noqa: B018 - raises SimClosedError after close()
        raise UnknownBodyError(body, self._bodies)

    def joint_index(self, body: int, joint: int | str) -> int:
        """The index of a joint given by index or name."""
        b = self._body(body)
        if isinstance(joint, str):
            try:
                return b.joint_index[joint]
            except KeyError:
                raise UnknownJointError(b.name, joint, b.joint_names) from None
        if isinstance(joint, (int, np.integer)) and not isinstance(joint, bool):
            if 0 <= joint < len(b.joint_names):
                return int(joint)
        raise UnknownJointError(b.name, joint, b.joint_names)

    def link_index(self, body: int, link: LinkArg) -> int:
        """The index of a link given by index or name (-1 or the root's name = base)."""
        b = self._body(body)
        if isinstance(link, str):
            try:
                return b.link_index[link]
            except KeyError:
                raise UnknownLinkError(b.name, link, b.link_names) from None
        if isinstance(link, (int, np.integer)) and not isinstance(link, bool):
            if -1 <= link < len(b.link_names):
                return int(link)
        raise UnknownLinkError(b.name, link, b.link_names)

    def _joints(self, body: int, joints: JointsArg | None, movable: bool) -> np.ndarray:
        """Resolve a joints argument to an index array (cached per body and argument)."""
        b = self._body(body)
        if type(joints) is np.ndarray:  # the hot path first
            key: Any = (joints.dtype.char, joints.tobytes())
        elif joints is None:
            key = None
        elif isinstance(joints, (int, str, np.integer)):
            key = joints
        elif isinstance(joints, np.ndarray):
            key = (joints.dtype.char, joints.tobytes())
        else:
            if isinstance(joints, (set, frozenset, dict)):  # no order: which target is whose?
                raise InvalidArgumentError(
                    "joints",
                    f"expected an index, a name or an ordered sequence of them (list, tuple, "
                    f"array), got a {type(joints).__name__}: {joints!r}",
                )
            try:
                key = tuple(joints)
                hash(key)
            except TypeError:
                raise InvalidArgumentError(
                    "joints", f"expected an index, a name or a sequence of them, got {joints!r}"
                ) from None
        cache = b.movable_cache if movable else b.cache
        try:
            return cache[key]
        except KeyError:
            pass
        if joints is None:
            idx = [i for i, t in enumerate(b.joint_types) if t != JointType.FIXED or not movable]
        elif isinstance(joints, (int, str, np.integer)):
            idx = [self.joint_index(body, joints)]
        else:
            items = joints.tolist() if isinstance(joints, np.ndarray) else list(joints)
            idx = [self.joint_index(body, j) for j in items]
            if len(set(idx)) != len(idx):
                raise InvalidArgumentError("joints", f"a joint is given twice in {joints!r}")
        if movable:
            for i in idx:
                if b.joint_types[i] == JointType.FIXED:
                    raise InvalidArgumentError(
                        "joints",
                        f"joint {b.joint_names[i]!r} (index {i}) of body {b.name!r} is fixed "
                        "and takes no command",
                    )
        arr = np.asarray(idx, dtype=np.intp)
        arr.setflags(write=False)
        if movable and any(b.joint_types[i] == JointType.SPHERICAL for i in idx):
            self._multi_idx[id(arr)] = arr
        cache[key] = arr
        return arr

    @classmethod
    def _checked_state(cls, value: Any, n: int, argument: str) -> list[float]:
        """Joint positions or velocities for a teleport: as :meth:`_values`, within
        MAX_STATE_VALUE."""
        values = cls._values(value, n, argument)
        _within(values, argument)
        return values

    @staticmethod
    def _values(value: Any, n: int, argument: str, nonneg: bool = False) -> list[float]:
        """Check a command argument: a number (broadcast) or n numbers, finite, maybe >= 0.
        Returns n Python floats.

        This is the hot path of every control loop: checks on a small list in plain Python
        beat numpy reductions (0.3 µs against 1.7 µs for 4 values) and keep the caches warm."""
        if type(value) is float or type(value) is int:
            if not math.isfinite(value):
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
            except (TypeError, ValueError):
                pass  # the general path below says what is wrong
        if values is None:
            try:
                arr = np.asarray(value, dtype=np.float64)
            except (TypeError, ValueError):
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

    # ---------------------------------------------------------------- tables

    def num_joints(self, body: int) -> int:
        """Number of joints (fixed ones included) = number of non-base links."""
        return len(self._body(body).joint_names)

    def joint_info(self, body: int, joint: int | str) -> JointInfo:
        """One row of the joint table (``p.getJointInfo``), by index or name."""
        return self._b.joint_info(body, self.joint_index(body, joint))

    def joints(self, body: int) -> list[JointInfo]:
        """The whole joint table, in index order."""
        return [self._b.joint_info(body, i) for i in range(self.num_joints(body))]

    def dynamics_info(self, body: int, link: LinkArg = -1) -> DynamicsInfo:
        """Mass, friction and inertia of a link as simulated (``p.getDynamicsInfo``)."""
        return self._b.dynamics_info(body, self.link_index(body, link))

    # ---------------------------------------------------------------- state

    def link_state(self, body: int, link: LinkArg) -> LinkState:
        """Pose and velocity of a link after the last step (base -1 allowed)."""
        return self._b.link_state(body, self.link_index(body, link))

    def base_state(self, body: int) -> BaseState:
        """The base's centre-of-mass pose and velocity (``getBasePositionAndOrientation``,
        ``getBaseVelocity``)."""
        self._body(body)
        return self._b.base_state(body)

    def joint_states(self, body: int, joints: JointsArg | None = None) -> JointStates:
        """Positions, velocities and motor forces of ``joints`` (default all), each (n,).

        A spherical joint reports its first coordinate, as ``p.getJointState`` does (its
        quaternion's x, its angular velocity's x, its motor torque about x); all of them:
        :meth:`joint_states_multi_dof`."""
        return self._b.joint_states(body, self._joints(body, joints, False))

    def joint_states_multi_dof(
        self, body: int, joints: JointsArg | None = None
    ) -> tuple[JointStateMultiDof, ...]:
        """Every coordinate of ``joints`` (default all), one
        :class:`~simbridge.types.JointStateMultiDof` per joint (``p.getJointStatesMultiDof``
        without the reaction forces): a spherical joint's quaternion (x, y, z, w), angular
        velocity and motor torques (3, about the child's inertial frame axes); a revolute or
        prismatic joint's 1-tuples; a fixed joint's empty tuples."""
        return tuple(self._b.joint_states_multi_dof(body, self._joints(body, joints, False)))

    def reset_joint_state_multi_dof(
        self, body: int, joints: JointsArg, positions: Any, velocities: Any = None
    ) -> None:
        """Teleport joints with all their coordinates (``p.resetJointStateMultiDof``; commands
        are kept). One joint: ``positions`` its coordinates (a spherical joint's quaternion
        x, y, z, w, normalised as PyBullet does; a revolute or prismatic joint's one number)
        and ``velocities`` likewise (3 for a spherical joint, in its child's frame; None:
        zeros). Several joints: a sequence of such per joint, in the order given.

        Raises:
            InvalidArgumentError: a fixed joint, a wrong number of coordinates, a value that
                is not finite, a quaternion of norm 0.
        """
        from .multi_dof import Q_SIZE, U_SIZE, quaternions

        idx = self._joints(body, joints, True)
        b = self._bodies[int(body)]
        one = isinstance(joints, (int, str, np.integer))
        given_q = [positions] if one else positions
        given_v = [velocities] if one else velocities
        try:
            if len(given_q) != len(idx) or (given_v is not None and len(given_v) != len(idx)):
                raise TypeError
        except TypeError:
            raise InvalidArgumentError(
                "positions/velocities", f"expected one entry per joint ({len(idx)}) of {joints!r}"
            ) from None
        qs: list[list[float]] = []
        vs: list[list[float]] = []
        for k, j in enumerate(idx.tolist()):
            jtype = int(b.joint_types[j])
            name = f"positions of joint {b.joint_names[j]!r}"
            if jtype == JointType.SPHERICAL:
                q = quaternions(given_q[k], 1, name)[0]
            else:
                q = self._checked_state(given_q[k], Q_SIZE[jtype], name)
            vel = None if given_v is None else given_v[k]
            vname = f"velocities of joint {b.joint_names[j]!r}"
            v = (
                [0.0] * U_SIZE[jtype]
                if vel is None
                else self._checked_state(vel, U_SIZE[jtype], vname)
            )
            if len(v) != U_SIZE[jtype]:
                raise InvalidArgumentError(vname, f"expected {U_SIZE[jtype]} numbers, got {vel!r}")
            qs.append(q)
            vs.append(v)
        self._b.reset_joint_state_multi_dof(body, idx, qs, vs)

    def _spherical_only(self, body: int, idx: np.ndarray) -> None:
        """A multi-DoF command names spherical joints only."""
        b = self._bodies[int(body)]
        other = [j for j in idx.tolist() if b.joint_types[j] != JointType.SPHERICAL]
        if other:
            raise InvalidArgumentError(
                "joints",
                f"joints {[b.joint_names[j] for j in other]} of body {b.name!r} are not "
                "spherical: command spherical joints apart from the others (their targets "
                "and forces have 3 or 4 values per joint)",
            )

    def _refuse_multi_dof(self, body: int, idx: np.ndarray, what: str) -> None:
        b = self._bodies[int(body)]
        multi = [b.joint_names[j] for j in idx.tolist() if b.joint_types[j] == JointType.SPHERICAL]
        if multi:
            raise InvalidArgumentError(
                "joints",
                f"spherical joints {multi} of body {b.name!r} take no {what}: use "
                "reset_joint_state_multi_dof for a teleport, set_joint_position / "
                "set_joint_velocity / set_joint_torque for commands",
            )

    def _multi_dof_motor(
        self,
        body: int,
        idx: np.ndarray,
        mode: MotorMode,
        target: Any,
        max_force: Any,
        kp: Any,
        kd: Any,
    ) -> None:
        """A velocity or position command on spherical joints (see :mod:`simbridge.multi_dof`)."""
        from .multi_dof import per_axis, quaternions

        self._spherical_only(body, idx)
        if self._held:
            self._refuse_held(body, idx)
        n = len(idx)
        if mode == MotorMode.VELOCITY:
            v = per_axis(target, n, 3, "target")
            if any(x != 0.0 for row in v for x in row):
                raise InvalidArgumentError(
                    "target",
                    f"a spherical joint takes a velocity target of 0 alone (a brake; "
                    f"max_force=0 releases it), got {target!r}: PyBullet's spherical motor "
                    "drives no other velocity (setJointMotorControlMultiDof refuses "
                    "VELOCITY_CONTROL and its POSITION_CONTROL reads no targetVelocity); use "
                    "set_joint_torque or a position target",
                )
            targets = [[0.0, 0.0, 0.0, 1.0]] * n
        else:
            targets = quaternions(target, n, "target")
        self._b.set_joint_motor_multi_dof(
            body,
            idx,
            mode,
            targets,
            per_axis(max_force, n, 3, "max_force", nonneg=True),
            per_axis(kp, n, 3, "kp", nonneg=True),
            per_axis(kd, n, 3, "kd", nonneg=True),
        )

    def reset_joint_state(
        self,
        body: int,
        joints: JointsArg,
        positions: Any,
        velocities: Any = 0.0,
    ) -> None:
        """Teleport movable joints to ``positions`` with ``velocities`` (``resetJointState``).
        A spherical joint takes :meth:`reset_joint_state_multi_dof` (PyBullet's
        ``resetJointState`` leaves one as it is: measured)."""
        idx = self._joints(body, joints, True)
        if self._multi_idx and id(idx) in self._multi_idx:
            self._refuse_multi_dof(body, idx, "reset_joint_state")
        n = len(idx)
        self._b.reset_joint_state(
            body,
            idx,
            self._checked_state(positions, n, "positions"),
            self._checked_state(velocities, n, "velocities"),
        )

    def reset_base_state(
        self,
        body: int,
        position: Sequence[float] | None = None,
        orientation: Sequence[float] | None = None,
        linear_velocity: Sequence[float] | None = None,
        angular_velocity: Sequence[float] | None = None,
    ) -> None:
        """Teleport the base (centre-of-mass frame, as ``resetBasePositionAndOrientation``).
        An argument left None keeps its current value: a pose alone keeps the base's velocity
        (``p.resetBasePositionAndOrientation`` zeroes it; pass zeros for that)."""
        self._body(body)
        self._b.reset_base_state(
            body,
            None if position is None else _state_vec(position, "position"),  # type: ignore[arg-type]
            None if orientation is None else _quat(orientation, "orientation"),
            None if linear_velocity is None else _state_vec(linear_velocity, "linear_velocity"),  # type: ignore[arg-type]
            None if angular_velocity is None else _state_vec(angular_velocity, "angular_velocity"),  # type: ignore[arg-type]
        )

    # ---------------------------------------------------------------- control

    def set_joint_velocity(
        self, body: int, joints: JointsArg, target: Any, *, max_force: Any
    ) -> None:
        """VELOCITY_CONTROL: drive ``joints`` towards ``target`` (rad/s or m/s) with at most
        ``max_force`` (N·m or N). Persists until replaced; ``max_force=0`` releases the joint
        (and removes the default brake).

        A spherical joint takes only the target 0 (PyBullet's spherical motor brakes; it drives
        no other velocity), and ``max_force`` per axis of the child's frame: a number, shape
        (3,), (n, 1) or (n, 3) (see :mod:`simbridge.multi_dof`); spherical joints are commanded
        apart from other joints."""
        idx = self._joints(body, joints, True)
        if self._multi_idx and id(idx) in self._multi_idx:
            return self._multi_dof_motor(body, idx, MotorMode.VELOCITY, target, max_force, 0, 1)
        if self._held:
            self._refuse_held(body, idx)
        n = len(idx)
        self._b.set_joint_velocity(
            body,
            idx,
            self._values(target, n, "target"),
            self._values(max_force, n, "max_force", nonneg=True),
        )

    def set_joint_position(
        self,
        body: int,
        joints: JointsArg,
        target: Any,
        *,
        max_force: Any,
        kp: Any = 0.1,
        kd: Any = 1.0,
    ) -> None:
        """POSITION_CONTROL with PyBullet's law: each step the motor asks for the velocity
        change ``kp * (target - q) / dt - kd * v`` (so it depends on dt), its force clamped to
        ``max_force``. Persists until replaced.

        A spherical joint takes a target quaternion (x, y, z, w; shape (4,) or (n, 4)) and
        PyBullet's spherical motor law: each axis of the child's frame asks for the velocity
        ``-kd v + 0.2 kp e / dt`` (e: the turn to the target as Bullet's XYZ Euler angles; kd is
        what PyBullet's ``setJointMotorControlMultiDof`` calls ``damping``), ``max_force``,
        ``kp`` and ``kd`` per axis (a number, (3,), (n, 1) or (n, 3)); see
        :mod:`simbridge.multi_dof`."""
        idx = self._joints(body, joints, True)
        if self._multi_idx and id(idx) in self._multi_idx:
            return self._multi_dof_motor(body, idx, MotorMode.POSITION, target, max_force, kp, kd)
        if self._held:
            self._refuse_held(body, idx)
        n = len(idx)
        self._b.set_joint_position(
            body,
            idx,
            self._values(target, n, "target"),
            self._values(max_force, n, "max_force", nonneg=True),
            self._values(kp, n, "kp", nonneg=True),
            self._values(kd, n, "kd", nonneg=True),
        )

    # ---------------------------------------------------------------- bound commands

    def velocity_command(
        self, body: int, joints: JointsArg, target: Any, *, max_force: Any
    ) -> BoundCommand:
        """A velocity command bound to ``joints``, for a tight control loop: sent now, then
        at every :meth:`step` from its own arrays, which are written in place::

            cmd = sim.velocity_command(robot, [2, 3, 6, 7], 0.0, max_force=50)
            for k in range(1000):
                cmd.targets[:] = policy(observation)   # rad/s or m/s, shape (4,)
                sim.step()

        Each step gives the results of ``set_joint_velocity(body, joints, cmd.targets,
        max_force=cmd.max_force)`` called just before it, bit for bit, without its per-call
        checks: the joints (known, movable, not driven by another bound command) and the
        arguments' shapes are checked here, once; the values are checked when a step reads
        them (a non-finite target or a negative or non-finite force raises
        InvalidArgumentError from ``step`` before any step). While bound, plain velocity and
        position commands on these joints are refused; :meth:`BoundCommand.release` frees
        them. ``load_urdf``, ``remove``, ``reset`` and ``close`` end every bound command
        (StaleCommandError on its next use). See :mod:`simbridge.bound`.

        Returns:
            a :class:`~simbridge.bound.BoundCommand`: ``targets`` and ``max_force`` are
            float64 arrays of shape (n,), n the number of joints, in the order given.
        """
        idx = self._joints(body, joints, True)
        self._refuse_multi_dof(body, idx, "a bound command")
        self._refuse_held(body, idx)
        n = len(idx)
        command = BoundCommand(
            self,
            "velocity",
            body,
            idx,
            self._values(target, n, "target"),
            self._values(max_force, n, "max_force", nonneg=True),
            [0.0] * n,
            [1.0] * n,
        )
        return self._bind(command)

    def position_command(
        self,
        body: int,
        joints: JointsArg,
        target: Any,
        *,
        max_force: Any,
        kp: Any = 0.1,
        kd: Any = 1.0,
    ) -> BoundCommand:
        """A position command bound to ``joints`` (rad or m; PyBullet's law with gains ``kp``
        and ``kd``, fixed here): sent now, then at every :meth:`step` from its own arrays, as
        :meth:`set_joint_position` called just before each step would, bit for bit. Checks,
        ownership and the end of the binding as for :meth:`velocity_command`."""
        idx = self._joints(body, joints, True)
        self._refuse_multi_dof(body, idx, "a bound command")
        self._refuse_held(body, idx)
        n = len(idx)
        command = BoundCommand(
            self,
            "position",
            body,
            idx,
            self._values(target, n, "target"),
            self._values(max_force, n, "max_force", nonneg=True),
            self._values(kp, n, "kp", nonneg=True),
            self._values(kd, n, "kd", nonneg=True),
        )
        return self._bind(command)

    def _bind(self, command: BoundCommand) -> BoundCommand:
        command.send()  # the first command, through the plain path
        held = self._held.setdefault(command.body, {})
        for j in command.joints.tolist():
            held[j] = command
        self._commands.append(command)
        try:
            stepped = self._b.bind_command(command)
        except BaseException:
            self._release_command(command)
            raise
        if not stepped:
            self._presend.append(command)
        return command

    def _refuse_held(self, body: int, idx: np.ndarray) -> None:
        held = self._held.get(body)
        if not held:
            return
        for j in idx.tolist():
            command = held.get(j)
            if command is not None:
                b = self._bodies[body]
                raise InvalidArgumentError(
                    "joints",
                    f"joint {b.joint_names[j]!r} (index {j}) of body {b.name!r} is driven by a "
                    f"bound {command.mode} command: write its targets, or release() it first",
                )

    def _release_command(self, command: BoundCommand) -> None:
        """Unbind one command (BoundCommand.release)."""
        if command in self._commands:
            self._commands.remove(command)
        if command in self._presend:
            self._presend.remove(command)
        held = self._held.get(command.body, {})
        for j in command.joints.tolist():
            if held.get(j) is command:
                del held[j]
        if not held:
            self._held.pop(command.body, None)
        if not isinstance(self._b, _Closed):
            self._b.unbind_command(command)

    def _end_commands(self, why: str) -> None:
        """A world change ends every bound command (unbound before the change)."""
        if not self._commands:
            return
        commands = self._commands
        for command in list(commands):
            self._release_command(command)
            command._end(why)

    def set_joint_torque(self, body: int, joints: JointsArg, torque: Any) -> None:
        """TORQUE_CONTROL: add ``torque`` (N·m or N) during the next step only (commands before
        one step add up, as in PyBullet). The joint's motor stays; release the default brake
        first with ``set_joint_velocity(..., max_force=0)``.

        A spherical joint takes 3 torques about the axes of its child's (inertial) frame:
        shape (3,) or (n, 3); spherical joints are commanded apart from other joints."""
        idx = self._joints(body, joints, True)
        if self._multi_idx and id(idx) in self._multi_idx:
            self._spherical_only(body, idx)
            from .multi_dof import per_axis

            n = len(idx)
            self._b.set_joint_torque_multi_dof(
                body, idx, per_axis(torque, n, 3, "torque", scalar=False)
            )
            return
        self._b.set_joint_torque(body, idx, self._values(torque, len(idx), "torque"))

    # ---------------------------------------------------------------- contacts and state

    def contact_points(
        self,
        body_a: int | None = None,
        body_b: int | None = None,
        *,
        link_a: LinkArg | None = None,
        link_b: LinkArg | None = None,
    ) -> tuple[ContactPoint, ...]:
        """The contact points of the last step (``p.getContactPoints``): all of them, those of
        ``body_a`` (as A), or those between ``body_a`` and ``body_b``; ``link_a``/``link_b``
        (index or name, -1 = base) narrow to one link of each. See
        :class:`~simbridge.types.ContactPoint` for the frames, signs and units.

        The contacts are those found at the start of the last step, with the forces that step
        applied; a teleport or ``set_state`` changes them only at the next step.

        Raises:
            UnknownBodyError, UnknownLinkError: a body or link that is not there.
            InvalidArgumentError: ``body_b`` without ``body_a`` (PyBullet answers that with
                nothing), or a link without its body.
        """
        if body_a is None and body_b is not None:
            raise InvalidArgumentError(
                "body_b",
                "give body_a too (PyBullet's getContactPoints filters by bodyB only "
                "together with bodyA); the points of one body are contact_points(body)",
            )
        if link_a is not None and body_a is None:
            raise InvalidArgumentError("link_a", "a link filter needs its body: give body_a")
        if link_b is not None and body_b is None:
            raise InvalidArgumentError("link_b", "a link filter needs its body: give body_b")
        la = lb = None
        if body_a is not None:
            self._body(body_a, "body_a")
            la = None if link_a is None else self.link_index(body_a, link_a)
        if body_b is not None:
            self._body(body_b, "body_b")
            lb = None if link_b is None else self.link_index(body_b, link_b)
        from .contacts import select

        return select(self._b.contact_points(), body_a, la, body_b, lb)

    def get_state(self, *, exact: bool = True) -> WorldState:
        """Everything :meth:`set_state` needs to put this world back: per body (load order)
        the base's centre-of-mass pose and velocities, every joint's position and velocity,
        the commands in force (motor mode, target, max force, gains) and the torques pending
        for the next step (a spherical joint's in full in ``BodyState.spherical``); the time.

        Args:
            exact: also keep the engine's own data (``WorldState.native``: MuJoCo's solver warm
                start, PyBullet's ``saveState`` with its contact caches, which costs about 2.6
                ms on r2d2), so that a restore into this same world steps bit for bit as the
                uninterrupted run. Without it the state is the portable one alone.

        Bound commands are sent first (as a step would), so the state holds their values.

        Raises:
            InvalidArgumentError: a bound command holds a bad value (as ``step`` would).
        """
        b = self._b
        for command in self._commands:  # a bound command's values are the ones in force
            command.send()
        native = b.snapshot() if _flag(exact, "exact") else None
        bodies = []
        for body, info in self._bodies.items():
            base = b.base_state(body)
            js = b.joint_states(body, self._joints(body, None, False))
            cmd = b.joint_commands(body)
            spherical = tuple(b.spherical_states(body)) if info.has_spherical else ()
            for e in spherical:  # the arrays hold a spherical joint's first coordinate and axis
                j = e.joint
                js.positions[j], js.velocities[j] = e.position[0], e.velocity[0]
                cmd.mode[j] = e.motor_mode
                cmd.target[j] = e.motor_target[0] if e.motor_mode == MotorMode.POSITION else 0.0
                cmd.max_force[j], cmd.kp[j], cmd.kd[j] = (
                    e.motor_max_force[0],
                    e.motor_kp[0],
                    e.motor_kd[0],
                )
                cmd.pending_torque[j] = e.pending_torque[0]
            bodies.append(
                BodyState(
                    body,
                    info.name,
                    tuple(info.joint_names),
                    base.position,
                    base.orientation,
                    base.linear_velocity,
                    base.angular_velocity,
                    np.array(js.positions, dtype=np.float64),
                    np.array(js.velocities, dtype=np.float64),
                    cmd.mode,
                    cmd.target,
                    cmd.max_force,
                    cmd.kp,
                    cmd.kd,
                    cmd.pending_torque,
                    spherical,
                )
            )
        return WorldState(self.backend, self._dt, b.time, tuple(bodies), native)

    def set_state(self, state: WorldState) -> None:
        """Put the world in ``state`` (from :meth:`get_state` of this Sim, or of another Sim,
        on any backend, with the same robots loaded in the same order): base poses and
        velocities, joint positions and velocities, the commands in force, pending torques and
        the time (to the nearest whole step of this Sim's time step).

        Into the world it was taken from (no load, remove or reset since) a state with its
        engine data restores bit-exactly; anywhere else, or after ``state.portable()``, what
        the engine keeps of its past (contact caches, solver warm start) stays out: see
        docs/state_and_contacts.md for each engine's one-step error after such a restore.
        ``joint_states(...).applied_torques`` describe the last step until the next one.
        Bound commands (:meth:`velocity_command`) end here, as at a world change: the state's
        commands replace them.

        Raises:
            InvalidArgumentError: not a WorldState; other robots or another load order (the
                message lists both); a value of the wrong shape, non-finite, a motor mode on a
                fixed joint; a velocity for a fixed base. Nothing is set then, but for the last,
                which the backend refuses when it reaches that body.
            SimClosedError: the Sim is closed.
        """
        b = self._b
        b.time  # noqa: B018 - raises SimClosedError after close()
        from .state import check_state

        checked = check_state(state, self._bodies)
        self._end_commands("set_state replaced the commands in force")
        exact = b.restore(state.native if state.backend == self.backend else None)
        for c in checked:
            if not exact:
                pos, orn, lin, ang = c.base
                b.reset_base_state(c.body, pos, orn, lin, ang)  # type: ignore[arg-type]
                movable = self._joints(c.body, None, True)
                if c.spherical:  # their own call below (a cached index array: backends key on it)
                    sph = {e.joint for e in c.spherical}
                    movable = self._joints(
                        c.body, [j for j in movable.tolist() if j not in sph], True
                    )
                if len(movable):
                    b.reset_joint_state(
                        c.body,
                        movable,
                        c.positions[movable].tolist(),
                        c.velocities[movable].tolist(),
                    )
            b.set_joint_commands(c.body, c.commands)
            if c.spherical:
                b.set_spherical_states(c.body, c.spherical, not exact)
        b.set_time(float(state.time))
        self._wall_start = None


def backends() -> list[str]:
    """Registered backend names."""
    return available_backends()
