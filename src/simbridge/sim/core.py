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

This module holds the Sim's construction, lifecycle, loading and stepping; its other methods
live in parts composed here, one job each: :mod:`simbridge.sim.lookups` (ids, names, tables,
state reads), :mod:`simbridge.sim.control` (teleports, motor and bound commands),
:mod:`simbridge.sim.multi_dof` (spherical joints), :mod:`simbridge.sim.world` (contacts,
get_state and set_state), :mod:`simbridge.sim.pictures` (pictures); the argument checks are
:mod:`simbridge.sim.arguments`.
"""

from __future__ import annotations

import math
import os
import time as _time
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from simbridge._version import __version__
from simbridge.backend import Backend
from simbridge.bound import BoundCommand
from simbridge.engine_settings import effective as effective_settings
from simbridge.exceptions import (
    InvalidArgumentError,
    NotOfferedError,
    SimBusyError,
    SimNotCopyableError,
)
from simbridge.profiles import Profile, get_profile
from simbridge.registry import available_backends, load_backend
from simbridge.sim.arguments import flag, quat, vec, within
from simbridge.sim.control import Control
from simbridge.sim.lookups import Lookups, _Body, _Closed
from simbridge.sim.multi_dof import MultiDof
from simbridge.sim.native import NotGiven
from simbridge.sim.pictures import Pictures
from simbridge.sim.world import WorldStates

if TYPE_CHECKING:
    from simbridge.model.mjcf_native import NativeMjcf
    from simbridge.model.urdf_model import UrdfModel
    from simbridge.types import ActuatorInfo, SiteState

__all__ = ["DIVERGENCE_CHECKS", "Sim"]

DIVERGENCE_CHECKS = ("periodic", "every_step")  # Sim(divergence_check=...)
# Sim(gravity=..., timestep=...) not given: these, or the <option> of an MJCF read with
# semantics="mujoco"
DEFAULT_GRAVITY = NotGiven((0.0, 0.0, -9.8))
DEFAULT_TIMESTEP = NotGiven(1.0 / 240.0)


class Sim(Control, MultiDof, WorldStates, Pictures, Lookups):
    """A simulated world on one backend.

    Args:
        backend: registered backend name: ``"pybullet"``, ``"mujoco"``, or a third-party one
            (see :func:`simbridge.available_backends`).
        gravity: world gravity (m/s²), set explicitly on every engine; (0, 0, -9.8) when not
            given, except under an MJCF read with ``semantics="mujoco"``, whose
            ``<option gravity>`` then wins.
        timestep: fixed step (s); 1/240 when not given, except under an MJCF read with
            ``semantics="mujoco"``, whose ``<option timestep>`` then wins.
        profile: ``"pybullet"`` (PyBullet's defaults on every engine), ``"urdf"`` (the file's
            values, nothing hidden) or a :class:`~simbridge.Profile`.
        gui: open the engine's viewer. Raises :class:`~simbridge.exceptions.DisplayError`
            without a display.
        divergence_check: when a non-finite state (NaN or infinite) is found.
            ``"periodic"`` (the default): every state read checks what it returns, and the
            world after every 8th step at most (MuJoCo: after every step, free); a divergence
            nobody reads is raised by ``step`` at most 7 steps late. ``"every_step"``: the
            step that made the state non-finite raises; on PyBullet it costs one engine read
            per body per step (1.01-1.09x a step: ``python bench/divergence.py``). Either way
            :class:`~simbridge.exceptions.SimulationDivergedError`, and every read and step
            refuses the world until ``reset()``.
        engine_settings: this backend's own settings (``{"impratio": 10}`` on MuJoCo), on
            top of those the profile sets (:meth:`~simbridge.Profile.with_engine`);
            ``simbridge settings BACKEND`` and :func:`simbridge.engine_settings.settings_for`
            list them. None set: the backend's defaults.

    Raises:
        UnknownBackendError: ``backend`` is not registered (the message lists those that are).
        BackendNotInstalledError: the engine is not installed (the message gives the pip line).
        InvalidArgumentError, InvalidProfileError: on a bad gravity, time step or profile.
    """

    def __init__(
        self,
        backend: str = "pybullet",
        *,
        gravity: Sequence[float] | NotGiven = DEFAULT_GRAVITY,
        timestep: float | NotGiven = DEFAULT_TIMESTEP,
        profile: str | Profile = "pybullet",
        gui: bool = False,
        divergence_check: str = "periodic",
        engine_settings: Mapping[str, Any] | None = None,
    ) -> None:
        self._b: Backend = _Closed()  # type: ignore[assignment]
        self._commands: list[BoundCommand] = []  # bound commands, in binding order
        self._presend: list[BoundCommand] = []  # ... those the Sim sends before each step
        self._held: dict[int, dict[int, BoundCommand]] = {}  # body -> joint -> its command
        # id -> joint index arrays (from _joints) holding a spherical joint: the commands take
        # them to their multi-DoF path (kept alive here, so an id is never reused)
        self._multi_idx: dict[int, np.ndarray] = {}
        self._native: NativeMjcf | None = None  # an MJCF read with semantics="mujoco"
        gravity_given, timestep_given = (
            (not isinstance(gravity, NotGiven)),
            (not isinstance(timestep, NotGiven)),
        )
        if isinstance(gravity, NotGiven):
            gravity = gravity.value
        if isinstance(timestep, NotGiven):
            timestep = timestep.value
        g = vec(gravity, 3, "gravity")
        try:
            if isinstance(timestep, bool) or not isinstance(timestep, (int, float, np.number)):
                raise TypeError
            dt = float(timestep)
        except (TypeError, OverflowError):
            dt = math.nan
        if not math.isfinite(dt) or dt <= 0:
            raise InvalidArgumentError("timestep", f"must be a finite number > 0, got {timestep!r}")
        if divergence_check not in DIVERGENCE_CHECKS:
            raise InvalidArgumentError(
                "divergence_check",
                f"expected one of {list(DIVERGENCE_CHECKS)}, got {divergence_check!r}",
            )
        prof = get_profile(profile).with_(gravity=g, timestep=dt)
        if engine_settings:  # on top of those the profile sets
            prof = prof.with_engine(backend, **engine_settings)
        cls = load_backend(backend)
        self.backend: str = backend
        self._bodies: dict[int, _Body] = {}
        self.divergence_check: str = divergence_check
        # what a new engine is made of (reset() after a model read with semantics="mujoco"),
        # and the values the caller gave (that model's <option> gives the others)
        self._make = (cls, prof, flag(gui, "gui"))
        self._given: tuple[tuple[float, ...] | None, float | None] = (
            g if gravity_given else None,
            dt if timestep_given else None,
        )
        self._b = self._new_engine()
        self._dt = dt
        self._wall_start: float | None = None

    def _new_engine(self) -> Backend:
        """A new engine of this Sim's backend, profile and divergence check."""
        cls, prof, gui = self._make
        engine = cls(prof, gui)
        try:
            engine.set_divergence_check(self.divergence_check == "every_step")
        except BaseException:
            engine.close()
            raise
        return engine

    # ---------------------------------------------------------------- lifecycle

    def __getattr__(self, name: str) -> Any:
        # only for a name the class lacks: a PyBullet name gets simbridge's in its message
        from simbridge.sim.pybullet_names import equivalent, not_offered

        found = equivalent(name)
        if found is None:
            missing = not_offered(name)
            if missing is not None:
                raise NotOfferedError(name, *missing)
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        raise AttributeError(
            f"{type(self).__name__!r} object has no attribute {name!r}; simbridge's "
            f"equivalent of PyBullet's {found[0]} is {found[1]} (README: 'The interface')"
        )

    def __reduce_ex__(self, protocol: Any) -> Any:
        """copy.copy, copy.deepcopy and pickle all come here: refused (SimNotCopyableError)."""
        raise SimNotCopyableError()

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
            "divergence_check": self.divergence_check,
        }
        out.update(self._b.manifest())
        # every engine setting of this backend with the value in force (simbridge.engine_settings)
        out.setdefault("engine_settings", effective_settings(self.backend, self.profile))
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
        **pybullet: Any,
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
        backend (:mod:`simbridge.model.load_options`).

        Raises:
            UrdfNotFoundError, UrdfParseError, UrdfStructureError, MeshNotFoundError,
            UnsupportedJointError: the message names the file, the line and the element.
            InvalidArgumentError: a bad pose or option.
            PyBulletKeywordError: a keyword it does not take (PyBullet's ``basePosition``,
                ``useFixedBase``, ``flags``...: the message names simbridge's).
        """
        if pybullet:
            from simbridge.sim.keywords import keyword_error

            raise keyword_error(self.load_urdf, pybullet)
        from simbridge.sim.native import refuse_after_native

        refuse_after_native(self, "load_urdf")
        pos = vec(base_position, 3, "base_position")
        within(pos, "base_position")
        orn = quat(base_orientation, "base_orientation", normalise=True)
        fixed_base = flag(fixed_base, "fixed_base")
        # loaded on first use
        from simbridge.model.load_options import apply_load_options, load_options
        from simbridge.model.urdf import (
            check_file_inertia,
            parse_urdf,
            resolve_source,
            warn_missing_inertials,
        )

        options = load_options(
            self._b.profile,
            global_scaling=global_scaling,
            self_collision=self_collision,
            inertia_source=inertia_source,
            merge_fixed_links=merge_fixed_links,
        )
        model = parse_urdf(resolve_source(source))
        warn_missing_inertials(model)
        if options.inertia_source == "file":
            check_file_inertia(model)
        model = apply_load_options(model, options, bool(fixed_base))
        self._end_commands("load_urdf changed the world")
        body = self._b.load(model, pos, orn, bool(fixed_base), options)  # type: ignore[arg-type]
        self._record(
            body,
            model,
            {
                "source": model.source.display_name,
                "base_position": pos,
                "base_orientation": orn,
                "fixed_base": bool(fixed_base),
                **options.as_dict(),
            },
        )
        return body

    def _record(self, body: int, model: UrdfModel, load: dict[str, Any]) -> None:
        """Keep a loaded body's names and indices (from the backend's joint table) and how it
        was loaded (``load``: the manifest's entry)."""
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
            load=load,
        )

    def load_mjcf(
        self,
        source: str | os.PathLike[str],
        *,
        self_collision: bool | str | None = None,
        semantics: str = "pybullet",
    ) -> tuple[int, ...]:
        """Load every body of an MJCF file; return their ids.

        ``semantics="pybullet"`` (the default): as ``p.loadMJCF`` reads it, on every backend.
        One body per top-level ``<worldbody>`` ``<body>`` or ``<geom>``, in the file's order,
        each with PyBullet's links, joints, numbering and names (a body with several joints
        gets massless links between them; see :mod:`simbridge.model.mjcf`). What PyBullet's
        importer does not read (joint damping and armature, ``<option>``, ``density``,
        actuators...) is not simulated on any backend; it is listed per body in
        :meth:`manifest` (``ignored``).

        ``semantics="mujoco"``: the model as MuJoCo's compiler reads it and as ``mj_step``
        runs it (``<default>`` classes, ``<option>``, ``<include>``, actuators, damping,
        armature, contacts, keyframes, sensors, sites: all MuJoCo's), on the ``"mujoco"``
        backend. One body per top-level ``<worldbody>`` ``<body>`` (a free joint: a floating
        base; none: a fixed one), its joints in MuJoCo's order and names (the mapping:
        :mod:`simbridge.model.mjcf_native`); the file's ``<option>`` gravity and time step
        win over the Sim's unless the Sim was given them; no profile entry applies (no link
        damping, no default motors): the model's actuators drive it
        (:meth:`set_actuator_controls`). The model is the whole world: nothing loads with it
        or after it until :meth:`reset`.

        Args:
            source: a file path, a name on the search path (``"mjcf/ant.xml"`` is found in
                pybullet_data) or MJCF text.
            self_collision: as :meth:`load_urdf`'s (``loadMJCF``'s flags); None: the profile's.
                Under ``semantics="mujoco"`` the file's contact settings rule: give None.
            semantics: ``"pybullet"`` or ``"mujoco"``.

        Returns:
            The body ids, in PyBullet's order (``p.loadMJCF``'s tuple), or in MuJoCo's order
            of the top-level bodies.

        Raises:
            UrdfNotFoundError, UrdfParseError, UrdfStructureError, MeshNotFoundError,
            UnsupportedJointError (``ball`` and nested ``free`` joints): under "pybullet", the
                message names the file, the line and the element.
            MjcfCompileError: under "mujoco", MuJoCo's own message with the file and line.
            BackendUnsupportedError: "mujoco" on a backend other than MuJoCo, into a world that
                holds bodies, or any load after such a model.
            InvalidArgumentError: another ``semantics``, or ``self_collision`` with "mujoco".
        """
        from simbridge.sim.native import check_semantics, load_native

        if check_semantics(semantics) == "mujoco":
            if self_collision is not None:
                raise InvalidArgumentError(
                    "self_collision",
                    "under semantics='mujoco' the file's contype/conaffinity and <contact> "
                    "decide which geoms collide: give None",
                )
            return load_native(self, source)
        return self._load_scene(source, "mjcf", self_collision)

    def load_sdf(self, source: str | os.PathLike[str]) -> tuple[int, ...]:
        """Load every ``<model>`` of an SDF file as ``p.loadSDF`` does; return their ids.

        Each model is one body with PyBullet's links, joints and numbering (see
        :mod:`simbridge.model.sdf`), its base at the model's ``<pose>``;
        ``<static>1</static>`` fixes it. ``loadSDF`` takes no flags: links of one body never
        collide with each other.

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

        from simbridge.model.load_options import load_options
        from simbridge.model.scene_reader import parse_scene
        from simbridge.sim.native import refuse_after_native

        refuse_after_native(self, f"load_{kind}")
        options = load_options(self._b.profile, self_collision=self_collision)
        # PyBullet's MJCF and SDF importers take the collision-box inertia (loadSDF has no flag
        # for the file's; an MJCF body's file inertia is MuJoCo's to compute)
        options = replace(options, inertia_source="collision_aabb")
        bodies = parse_scene(source, kind)
        self._end_commands(f"load_{kind} changed the world")
        ids = self._b.load_scene(bodies, options)
        for body, model in zip(ids, bodies, strict=True):
            self._record(
                body,
                model,
                {
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
        if self._native is not None:  # back to an empty world of the Sim's own settings
            old = self._b
            self._b = self._new_engine()
            self._native = None
            self._dt = self._b.profile.timestep
            old.close()
        else:
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

    # ---------------------------------------------------------------- MuJoCo's reading

    def actuators(self) -> tuple[ActuatorInfo, ...]:
        """The model's actuators (``load_mjcf(..., semantics="mujoco")``), in MuJoCo's order.

        Returns:
            One :class:`~simbridge.types.ActuatorInfo` each: name, the joint it drives,
            gear, ctrlrange, forcerange, gain and bias.

        Raises:
            BackendUnsupportedError: No model read with semantics='mujoco' is loaded.
        """
        from simbridge.sim.native import native_model

        return native_model(self, "actuators()").actuators

    def set_actuator_controls(
        self, controls: float | Sequence[float] | np.ndarray, actuators: Any = None
    ) -> None:
        """Write the model's actuator controls (MuJoCo's ``ctrl``); they hold until written
        again, and MuJoCo clamps them to ``ctrlrange`` where it is limited.

        Args:
            controls: One value per actuator named, or per actuator of the model when
                ``actuators`` is None (a Gymnasium action, for one).
            actuators: None (all, in MuJoCo's order), an index or a name, or a sequence of
                them.

        Raises:
            BackendUnsupportedError: No model read with semantics='mujoco' is loaded.
            UnknownObjectError: An actuator the model does not have.
            InvalidArgumentError: The wrong number of controls, or one not finite.
        """
        from simbridge.sim.native import native_model, resolve, values

        names = [a.name for a in native_model(self, "set_actuator_controls").actuators]
        if actuators is None:
            idx = np.arange(len(names), dtype=np.intp)
        else:
            many = not isinstance(actuators, (str, int, np.integer))
            items = list(actuators) if many else [actuators]
            idx = np.array([resolve(names, "actuator", a) for a in items], dtype=np.intp)
        self._b.set_actuator_controls(idx, values(controls, len(idx), "controls").tolist())

    def actuator_controls(self) -> np.ndarray:
        """The actuator controls in force (MuJoCo's ``ctrl``).

        Returns:
            (nu,) float64, a copy.

        Raises:
            BackendUnsupportedError: No model read with semantics='mujoco' is loaded.
        """
        from simbridge.sim.native import native_model

        native_model(self, "actuator_controls()")
        return self._b.actuator_controls()

    def qpos(self) -> np.ndarray:
        """MuJoCo's generalized positions, in its order and conventions (a free joint:
        position, then quaternion w, x, y, z).

        Returns:
            (nq,) float64, a copy.

        Raises:
            BackendUnsupportedError: No model read with semantics='mujoco' is loaded.
        """
        from simbridge.sim.native import native_model

        native_model(self, "qpos()")
        return self._b.generalized_state()[0]

    def qvel(self) -> np.ndarray:
        """MuJoCo's generalized velocities (a free joint: the body frame origin's linear
        velocity, world, then the angular velocity in the body frame).

        Returns:
            (nv,) float64, a copy.

        Raises:
            BackendUnsupportedError: No model read with semantics='mujoco' is loaded.
        """
        from simbridge.sim.native import native_model

        native_model(self, "qvel()")
        return self._b.generalized_state()[1]

    def set_qpos_qvel(
        self,
        qpos: Sequence[float] | np.ndarray | None = None,
        qvel: Sequence[float] | np.ndarray | None = None,
    ) -> None:
        """Set MuJoCo's ``qpos`` and ``qvel`` as given (Gymnasium's ``set_state``); None
        keeps one. Nothing else changes (controls, time, the solver's warm start).

        Args:
            qpos: (nq,) finite values, MuJoCo's order, or None.
            qvel: (nv,) finite values, or None.

        Raises:
            BackendUnsupportedError: No model read with semantics='mujoco' is loaded.
            InvalidArgumentError: A wrong length or a value not finite.
        """
        from simbridge.sim.native import native_model, values

        m = native_model(self, "set_qpos_qvel").model
        q = None if qpos is None else values(qpos, m.nq, "qpos")
        v = None if qvel is None else values(qvel, m.nv, "qvel")
        self._end_commands("set_qpos_qvel changed the world")
        self._b.set_generalized_state(q, v)

    def reset_keyframe(self, key: int | str) -> None:
        """Put the world in one of the model's ``<keyframe>`` states (``mj_resetDataKeyframe``:
        time, qpos, qvel, act, ctrl of the key).

        Args:
            key: The keyframe's index or name.

        Raises:
            BackendUnsupportedError: No model read with semantics='mujoco' is loaded.
            UnknownObjectError: A keyframe the model does not have.
        """
        from simbridge.sim.native import native_model, resolve

        k = resolve(native_model(self, "reset_keyframe").keyframes, "keyframe", key)
        self._end_commands("reset_keyframe changed the world")
        self._b.reset_keyframe(k)

    def sensor(self, sensor: int | str) -> np.ndarray:
        """One of the model's sensors, for the state as it stands now.

        Args:
            sensor: The sensor's index or name.

        Returns:
            (dim,) float64, MuJoCo's values in its units and frames.

        Raises:
            BackendUnsupportedError: No model read with semantics='mujoco' is loaded.
            UnknownObjectError: A sensor the model does not have.
        """
        from simbridge.sim.native import native_model, resolve

        return self._b.sensor_data(resolve(native_model(self, "sensor").sensors, "sensor", sensor))

    def site(self, site: int | str) -> SiteState:
        """One of the model's sites, as it stands now.

        Args:
            site: The site's index or name.

        Returns:
            Its position (m, world) and orientation (x, y, z, w).

        Raises:
            BackendUnsupportedError: No model read with semantics='mujoco' is loaded.
            UnknownObjectError: A site the model does not have.
        """
        from simbridge.sim.native import native_model, resolve
        from simbridge.types import SiteState

        pos, orn = self._b.site_pose(resolve(native_model(self, "site").sites, "site", site))
        return SiteState(pos, orn)

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
        realtime = flag(realtime, "realtime")
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


# The methods the Sim takes from its parts say Sim.NAME in their errors (a missing argument's
# TypeError names the function's __qualname__): the name users call, not the part's.
for _part in (Control, MultiDof, WorldStates, Pictures, Lookups):
    for _name, _member in vars(_part).items():
        if not _name.startswith("_") and callable(_member) and hasattr(_member, "__qualname__"):
            _member.__qualname__ = f"Sim.{_name}"


def backends() -> list[str]:
    """Registered backend names."""
    return available_backends()
