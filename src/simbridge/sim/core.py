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

The `Sim` is its public methods, each documented here, over one
:class:`~simbridge.sim.shared.Shared` object (the backend, the bodies' tables, the bound
commands in force) that its parts take: :mod:`~simbridge.sim.lookups` (ids, names, joint-index
arrays), :mod:`~simbridge.sim.loading` (URDF, MJCF, SDF), :mod:`~simbridge.sim.control`
(teleports, bound commands), :mod:`~simbridge.sim.multi_dof` (spherical joints),
:mod:`~simbridge.sim.world` (contacts, ``get_state`` and ``set_state``),
:mod:`~simbridge.sim.pictures` (``render``) and :mod:`~simbridge.sim.native` (an MJCF read as
MuJoCo reads it: actuators, ``qpos``/``qvel``, keyframes, sensors, sites); the argument checks
are :mod:`~simbridge.sim.arguments`. A method delegates to its part, but for the hot path of a
control loop (``step``, the ``set_joint_*`` commands, the state reads), written here against
the shared object: a call more would cost those 2-4% (``python bench/ab.py``).

This module is longer than the others (about 1,400 lines, half of them docstrings) for one
reason: it is the whole public interface, and each method's docstring is its contract.
"""

from __future__ import annotations

import math
import os
import time as _time
from collections.abc import Mapping, Sequence
from math import inf as _INF
from math import isfinite
from typing import Any

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
from simbridge.sim import control, loading, multi_dof, native, pictures, world
from simbridge.sim.arguments import _F64, JointsArg, LinkArg, LinksArg, command_values, flag, vec
from simbridge.sim.keywords import Missing, keyword_error
from simbridge.sim.lookups import body_table, joint_index, joint_indices, link_index, link_indices
from simbridge.sim.native import NotGiven
from simbridge.sim.shared import EngineRecipe, Shared
from simbridge.types import (
    ActuatorInfo,
    BaseState,
    ContactPoint,
    DynamicsInfo,
    JointInfo,
    JointStateMultiDof,
    JointStates,
    LinkState,
    LinkStates,
    MotorMode,
    SiteState,
    WorldState,
)

__all__ = ["DIVERGENCE_CHECKS", "Sim"]

DIVERGENCE_CHECKS = ("periodic", "every_step")  # Sim(divergence_check=...)
# Sim(gravity=..., timestep=...) not given: these, or the <option> of an MJCF read with
# semantics="mujoco"
DEFAULT_GRAVITY = NotGiven((0.0, 0.0, -9.8))
DEFAULT_TIMESTEP = NotGiven(1.0 / 240.0)

# required arguments' defaults: a PyBullet keyword given in their place is named, not missed
_RESET_POSITIONS = Missing("reset_joint_state", "positions")
_VELOCITY_TARGET = Missing("set_joint_velocity", "target")
_VELOCITY_MAX_FORCE = Missing("set_joint_velocity", "max_force", keyword_only=True)
_POSITION_TARGET = Missing("set_joint_position", "target")
_POSITION_MAX_FORCE = Missing("set_joint_position", "max_force", keyword_only=True)
_TORQUE = Missing("set_joint_torque", "torque")


class Sim:
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
            per body per step (its cost: ``python bench/divergence.py``). Either way
            :class:`~simbridge.exceptions.SimulationDivergedError`, and every read and step
            refuses the world until ``reset()``.
        engine_settings: this backend's own settings (``{"impratio": 10}`` on MuJoCo), on
            top of those the profile sets (:meth:`~simbridge.Profile.with_engine`);
            ``simbridge settings BACKEND`` and :func:`simbridge.engine_settings.settings_for`
            list them. None set: the backend's defaults.

    Attributes:
        backend: the backend's registered name.
        divergence_check: ``"periodic"`` or ``"every_step"``, as given.

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
        # what the parts share; closed (its backend a stand-in) until the engine is made
        self._s = s = Shared()
        self._wall_start: float | None = None  # realtime pacing: wall clock at time 0
        gravity_given = not isinstance(gravity, NotGiven)
        timestep_given = not isinstance(timestep, NotGiven)
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
        # how a new engine is made (reset() after a model read with semantics="mujoco"), and
        # the values the caller gave (that model's <option> gives the others)
        s.recipe = EngineRecipe(
            cls,
            prof,
            flag(gui, "gui"),
            divergence_check == "every_step",
            prof.gravity if gravity_given else None,
            dt if timestep_given else None,
        )
        s.backend = s.recipe.make()
        s.name = backend
        s.dt = dt
        self.divergence_check: str = divergence_check

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
            f"equivalent of PyBullet's {found[0]} is {found[1]} (docs/sim.md: 'The interface')"
        )

    def __reduce_ex__(self, protocol: Any) -> Any:
        """copy.copy, copy.deepcopy and pickle all come here: refused.

        Raises:
            SimNotCopyableError: always (a Sim holds a live engine).
        """
        raise SimNotCopyableError()

    @property
    def _b(self) -> Backend:
        """The backend object (after close, a stand-in raising SimClosedError): the door the
        backends' own ``inspect`` modules open; nothing else reads it."""
        return self._s.backend

    def close(self) -> None:
        """Release the engine. Safe to call twice; any later use raises SimClosedError.

        Raises:
            SimBusyError: another thread is stepping the Sim; it stays open.
        """
        s = self._s
        if s.closed:
            return
        try:
            s.backend.close()
        except SimBusyError:
            raise  # refused: nothing was released, the Sim stays usable
        except BaseException:
            s.close()
            raise
        s.close()

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
        if self._s.closed:  # a repr never raises, closed or not
            return f"Sim({getattr(self, 'backend', '?')!r}, closed)"
        return f"Sim({self.backend!r}, profile={self.profile.name!r}, t={self.time:.4f}s)"

    # ---------------------------------------------------------------- world

    @property
    def time(self) -> float:
        """Simulated time (s) since creation or the last reset (SimClosedError after close)."""
        return self._s.backend.time

    @property
    def timestep(self) -> float:
        """The fixed step (s)."""
        return self._s.dt

    @property
    def gravity(self) -> tuple[float, float, float]:
        """World gravity (m/s², world frame) (SimClosedError after close)."""
        return self._s.backend.profile.gravity

    @property
    def profile(self) -> Profile:
        """The profile manifest in use, with this Sim's gravity and time step
        (SimClosedError after close)."""
        return self._s.backend.profile

    @property
    def closed(self) -> bool:
        """True after :meth:`close`."""
        return self._s.closed

    def manifest(self) -> dict[str, Any]:
        """Everything needed to reproduce a run.

        Returns:
            A JSON-ready dict: ``simbridge_version``, ``profile`` (its entries),
            ``divergence_check``, the backend's own entries (engine and version, and
            ``departures``: what it could not reproduce exactly), ``engine_settings`` (every
            setting of this backend with the value in force) and ``bodies`` (body id -> its
            source, pose and load options).

        Raises:
            SimClosedError: the Sim is closed.
        """
        s = self._s
        out: dict[str, Any] = {
            "simbridge_version": __version__,
            "profile": self.profile.as_dict(),
            "divergence_check": self.divergence_check,
        }
        out.update(s.backend.manifest())
        # every engine setting of this backend with the value in force (simbridge.engine_settings)
        out.setdefault("engine_settings", effective_settings(self.backend, self.profile))
        # each body's load: source, pose and loadURDF's options (global_scaling, ...)
        bodies: dict[int, dict[str, Any]] = {body: dict(b.load) for body, b in s.bodies.items()}
        out["bodies"] = bodies
        return out

    # ---------------------------------------------------------------- loading

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

        The options are listed per body in :meth:`manifest` and mean the same on every
        backend (:mod:`simbridge.model.load_options`). A load ends every bound command.

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
            **pybullet: refused: a PyBullet keyword gets simbridge's name in the error.

        Returns:
            The new body's id (an int).

        Raises:
            UrdfNotFoundError: no file, no name on the search path, no URDF text.
            UrdfParseError: XML that does not parse (file, line, column, element).
            UrdfStructureError: what PyBullet refuses too (file, line, element).
            MeshNotFoundError: a mesh found nowhere PyBullet looks (file, line, every
                path tried).
            UnsupportedJointError: the message names the file, the line and the element.
            InvalidArgumentError: a bad pose or option.
            PyBulletKeywordError: a keyword it does not take (PyBullet's ``basePosition``,
                ``useFixedBase``, ``flags``...: the message names simbridge's).
        """
        if pybullet:
            raise keyword_error(self.load_urdf, pybullet)
        return loading.load_urdf(
            self._s,
            source,
            base_position,
            base_orientation,
            fixed_base,
            {
                "global_scaling": global_scaling,
                "self_collision": self_collision,
                "inertia_source": inertia_source,
                "merge_fixed_links": merge_fixed_links,
            },
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
        backend; PyBullet and PhysX build the same compiled model and step it themselves,
        MuJoCo's actuator, spring, damping, armature and soft-limit forces computed for them,
        each feature they do not reproduce a named departure in :meth:`manifest`
        (docs/mjcf_mujoco_reading.md). One body per top-level ``<worldbody>`` ``<body>`` (a
        free joint: a floating base; none: a fixed one), its joints in MuJoCo's order and
        names (the mapping: :mod:`simbridge.model.mjcf_native`); the file's ``<option>``
        gravity and time step win over the Sim's unless the Sim was given them; no profile
        entry applies (no link damping, no default motors): the model's actuators drive it
        (:meth:`set_actuator_controls`). The model is the whole world: nothing loads with it
        or after it until :meth:`reset`. A Sim made with ``gui=True`` shows it in the engine's
        own window (MuJoCo's viewer on the compiled model; PyBullet and PhysX draw MuJoCo's
        visible geoms in their colours: docs/mjcf_mujoco_reading.md, "The window").

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
            UrdfNotFoundError: no file, no name on the search path, no URDF text.
            UrdfParseError: XML that does not parse (file, line, column, element).
            UrdfStructureError: what PyBullet refuses too (file, line, element).
            MeshNotFoundError: a mesh found nowhere PyBullet looks (file, line, every
                path tried).
            UnsupportedJointError: ``ball`` and nested ``free`` joints under "pybullet"; the
                message names the file, the line and the element.
            MjcfCompileError: under "mujoco", MuJoCo's own message with the file and line.
            BackendUnsupportedError: "mujoco" on a backend without that reading, into a world
                that holds bodies, or any load after such a model.
            DisplayError: under "mujoco" with ``gui=True`` on MuJoCo, its viewer did not open
                on the model (the Sim's world keeps its own).
            MjcfFeatureUnsupportedError: under "mujoco" on PyBullet or PhysX, a feature only
                MuJoCo simulates (``<tendon>``, ``<equality>``, flex, ``<pair>``...), named
                with its element.
            InvalidArgumentError: another ``semantics``, or ``self_collision`` with "mujoco".
        """
        if native.check_semantics(semantics) == "mujoco":
            return native.load_native(self._s, source, self_collision)
        return loading.load_scene(self._s, source, "mjcf", self_collision)

    def load_sdf(self, source: str | os.PathLike[str]) -> tuple[int, ...]:
        """Load every ``<model>`` of an SDF file as ``p.loadSDF`` does; return their ids.

        Each model is one body with PyBullet's links, joints and numbering (see
        :mod:`simbridge.model.sdf`), its base at the model's ``<pose>``;
        ``<static>1</static>`` fixes it. ``loadSDF`` takes no flags: links of one body never
        collide with each other.

        Args:
            source: a file path, a name on the search path (``"kuka_iiwa/model.sdf"``) or SDF
                text.

        Returns:
            The body ids, in the file's order.

        Raises:
            UrdfNotFoundError: no file, no name on the search path, no URDF text.
            UrdfParseError: XML that does not parse (file, line, column, element).
            UrdfStructureError: what PyBullet refuses too (file, line, element).
            MeshNotFoundError: a mesh found nowhere PyBullet looks (file, line, every
                path tried).
            UnsupportedJointError: the message names the file, the line and the element.
        """
        return loading.load_scene(self._s, source, "sdf", False)

    def remove(self, body: int) -> None:
        """Remove a body from the world (``p.removeBody``); every bound command ends.

        Args:
            body: a body id.

        Raises:
            UnknownBodyError: no such body.
            InvalidArgumentError: ``body`` is not an int.
            SimClosedError: the Sim is closed.
        """
        s = self._s
        body_table(s, body)
        s.end_commands("remove changed the world")
        s.backend.remove(body)
        del s.bodies[body]

    def reset(self) -> None:
        """Remove every body and set time to 0 (``p.resetSimulation``); every bound command
        ends.

        Raises:
            SimClosedError: the Sim is closed.
        """
        s = self._s
        s.backend.time  # noqa: B018 - raises SimClosedError after close()
        s.end_commands("reset changed the world")
        if s.native is None:
            s.backend.reset()
        else:  # back to an empty world of the Sim's own engine and settings
            native.leave(s)
        s.bodies.clear()
        self._wall_start = None

    def bodies(self) -> list[int]:
        """Ids of the bodies in the world.

        Returns:
            The body ids, in load order.

        Raises:
            SimClosedError: the Sim is closed.
        """
        s = self._s
        s.backend.time  # noqa: B018 - raises SimClosedError after close()
        return list(s.bodies)

    def body_name(self, body: int) -> str:
        """The ``<robot name>`` of a body.

        Args:
            body: a body id.

        Returns:
            The name the file gave it.

        Raises:
            UnknownBodyError: no such body.
            InvalidArgumentError: ``body`` is not an int.
        """
        return body_table(self._s, body).name

    # ---------------------------------------------------------------- MuJoCo's reading

    def actuators(self) -> tuple[ActuatorInfo, ...]:
        """The model's actuators (``load_mjcf(..., semantics="mujoco")``), in MuJoCo's order.

        Returns:
            One :class:`~simbridge.types.ActuatorInfo` each: name, the joint it drives,
            gear, ctrlrange, forcerange, gain and bias.

        Raises:
            BackendUnsupportedError: no model read with semantics='mujoco' is loaded.
        """
        return native.actuators(self._s)

    def set_actuator_controls(
        self, controls: float | Sequence[float] | np.ndarray, actuators: Any = None
    ) -> None:
        """Write the model's actuator controls (MuJoCo's ``ctrl``); they hold until written
        again, and MuJoCo clamps them to ``ctrlrange`` where it is limited.

        Args:
            controls: one value per actuator named, or per actuator of the model when
                ``actuators`` is None (a Gymnasium action, for one).
            actuators: None (all, in MuJoCo's order), an index or a name, or a sequence of
                them.

        Raises:
            BackendUnsupportedError: no model read with semantics='mujoco' is loaded.
            UnknownObjectError: an actuator the model does not have.
            InvalidArgumentError: the wrong number of controls, or one not finite.
        """
        native.set_actuator_controls(self._s, controls, actuators)

    def actuator_controls(self) -> np.ndarray:
        """The actuator controls in force (MuJoCo's ``ctrl``).

        Returns:
            (nu,) float64, a copy.

        Raises:
            BackendUnsupportedError: no model read with semantics='mujoco' is loaded.
        """
        return native.actuator_controls(self._s)

    def qpos(self) -> np.ndarray:
        """MuJoCo's generalized positions, in its order and conventions (a free joint:
        position, then quaternion w, x, y, z).

        Returns:
            (nq,) float64, a copy.

        Raises:
            BackendUnsupportedError: no model read with semantics='mujoco' is loaded.
        """
        return native.generalized_state(self._s, "qpos()")[0]

    def qvel(self) -> np.ndarray:
        """MuJoCo's generalized velocities (a free joint: the body frame origin's linear
        velocity, world, then the angular velocity in the body frame).

        Returns:
            (nv,) float64, a copy.

        Raises:
            BackendUnsupportedError: no model read with semantics='mujoco' is loaded.
        """
        return native.generalized_state(self._s, "qvel()")[1]

    def xpos(self) -> np.ndarray:
        """MuJoCo's ``d.xpos`` (each MuJoCo body's frame origin) of a model read with
        semantics='mujoco', as Gymnasium's MuJoCo envs read it.

        MuJoCo: after a step, ``d.xpos`` as ``mj_step`` left it; under RK4 that is the last
        stage's kinematics, which lag the final state (Ant-v5's forward velocity reads it);
        after a write, of the state written. PyBullet, PhysX: of the state as it stands.

        Returns:
            ``(nbody, 3)`` float64 (m, world), MuJoCo's body order (row 0: the world).

        Raises:
            BackendUnsupportedError: no model read with semantics='mujoco' is loaded.
        """
        native.native_model(self._s, "xpos()")
        return self._s.backend.xpos()

    def body_external_forces(self) -> np.ndarray:
        """MuJoCo's ``cfrc_ext`` after the last step (what Gymnasium's Ant-v5 observes): the
        contact wrench on each MuJoCo body of a model read with semantics='mujoco'.

        MuJoCo: ``d.cfrc_ext`` as ``mj_rnePostConstraint`` computes it after ``mj_step`` (as
        Gymnasium's MuJoCo envs call it; under RK4 on the contacts and kinematics of the last
        stage). PyBullet, PhysX: from their contact points (:meth:`contact_points`), each on
        the MuJoCo body its link reads; a MuJoCo body without a joint of its own shares its
        parent's link, so its contacts count on that body (docs/state_and_contacts.md).

        Returns:
            ``(nbody, 6)`` float64, MuJoCo's body order (row 0: the world, zeros): torque
            (N m) then force (N), world frame, the torque about the centre of mass of the
            body's tree (``subtree_com[rootid]``); zeros before the first step after a reset,
            a restore (``set_state``) or a keyframe.

        Raises:
            BackendUnsupportedError: no model read with semantics='mujoco' is loaded.
        """
        native.native_model(self._s, "body_external_forces()")
        return self._s.backend.body_external_forces()

    def set_qpos_qvel(
        self,
        qpos: Sequence[float] | np.ndarray | None = None,
        qvel: Sequence[float] | np.ndarray | None = None,
    ) -> None:
        """Set MuJoCo's ``qpos`` and ``qvel`` as given (Gymnasium's ``set_state``); None
        keeps one. Nothing else changes (controls, time, the solver's warm start); every
        bound command ends.

        Args:
            qpos: (nq,) finite values, MuJoCo's order, or None.
            qvel: (nv,) finite values, or None.

        Raises:
            BackendUnsupportedError: no model read with semantics='mujoco' is loaded.
            InvalidArgumentError: a wrong length or a value not finite.
        """
        native.set_qpos_qvel(self._s, qpos, qvel)

    def reset_keyframe(self, key: int | str) -> None:
        """Put the world in one of the model's ``<keyframe>`` states (``mj_resetDataKeyframe``:
        time, qpos, qvel, act, ctrl of the key); every bound command ends.

        Args:
            key: the keyframe's index or name.

        Raises:
            BackendUnsupportedError: no model read with semantics='mujoco' is loaded.
            UnknownObjectError: a keyframe the model does not have.
        """
        native.reset_keyframe(self._s, key)

    def sensor(self, sensor: int | str) -> np.ndarray:
        """One of the model's sensors, for the state as it stands now.

        Args:
            sensor: the sensor's index or name.

        Returns:
            (dim,) float64, MuJoCo's values in its units and frames.

        Raises:
            BackendUnsupportedError: no model read with semantics='mujoco' is loaded.
            UnknownObjectError: a sensor the model does not have.
        """
        return native.sensor(self._s, sensor)

    def site(self, site: int | str) -> SiteState:
        """One of the model's sites, as it stands now.

        Args:
            site: the site's index or name.

        Returns:
            Its position (m, world) and orientation (x, y, z, w).

        Raises:
            BackendUnsupportedError: no model read with semantics='mujoco' is loaded.
            UnknownObjectError: a site the model does not have.
        """
        return native.site(self._s, site)

    # ---------------------------------------------------------------- stepping

    def step(self, n: int = 1, *, realtime: bool = False) -> None:
        """Advance ``n`` fixed steps.

        Bound commands (:meth:`velocity_command`) are read when the call starts: a step(n)
        runs its n steps on those values.

        Args:
            n: number of steps (>= 0).
            realtime: pace the steps to the wall clock (the tutorial's ``time.sleep(1/240)``),
                keeping the pace across calls.

        Raises:
            SimulationDivergedError: the state became NaN or infinite.
            InvalidArgumentError: ``n`` is not an integer >= 0; a bound command holds a
                non-finite target or a negative or non-finite force (no step is taken).
            SimClosedError: the Sim is closed.
        """
        if type(n) is int and n >= 0 and realtime is False:  # the hot path: one check, one call
            s = self._s
            if s.presend:
                for command in s.presend:
                    command.send()
            s.backend.step(n)
            self._wall_start = None
            return
        self._step_checked(n, realtime)

    def _step_checked(self, n: Any, realtime: Any) -> None:
        """:meth:`step` off its hot path: the arguments checked, realtime pacing."""
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
            raise InvalidArgumentError("n", f"must be an integer >= 0, got {n!r}")
        realtime = flag(realtime, "realtime")
        s = self._s
        for command in s.presend:
            command.send()
        b = s.backend
        if not realtime:
            b.step(int(n))
            self._wall_start = None
            return
        if self._wall_start is None:
            self._wall_start = _time.perf_counter() - b.time
        for _ in range(int(n)):
            b.step(1)
            delay = self._wall_start + b.time - _time.perf_counter()
            if delay > 0:
                _time.sleep(delay)

    # ---------------------------------------------------------------- lookups and tables

    def joint_index(self, body: int, joint: int | str) -> int:
        """The index of a joint given by index or name.

        Args:
            body: a body id.
            joint: an index (0 to n - 1) or a joint name.

        Returns:
            The joint's index.

        Raises:
            UnknownJointError: no such joint (the message lists the body's joints).
            UnknownBodyError: no such body.
        """
        return joint_index(self._s, body, joint)

    def link_index(self, body: int, link: LinkArg) -> int:
        """The index of a link given by index or name (-1 or the root's name: the base).

        Args:
            body: a body id.
            link: an index (-1 to n - 1) or a link name.

        Returns:
            The link's index, -1 for the base.

        Raises:
            UnknownLinkError: no such link (the message lists the body's links).
            UnknownBodyError: no such body.
        """
        return link_index(self._s, body, link)

    def _joints(self, body: int, joints: JointsArg | None, movable: bool) -> np.ndarray:
        """The cached joint-index array a command or read passes to the backend (tests check
        the backends' plans by its identity): :func:`~simbridge.sim.lookups.joint_indices`."""
        return joint_indices(self._s, body, joints, movable)

    def num_joints(self, body: int) -> int:
        """Number of joints (fixed ones included) = number of non-base links.

        Args:
            body: a body id.

        Returns:
            The number of joints.

        Raises:
            UnknownBodyError: no such body.
        """
        return len(body_table(self._s, body).joint_names)

    def joint_info(self, body: int, joint: int | str) -> JointInfo:
        """One row of the joint table (``p.getJointInfo``).

        Args:
            body: a body id.
            joint: an index or a joint name.

        Returns:
            A :class:`~simbridge.types.JointInfo` (PyBullet's fields, by name or position).

        Raises:
            UnknownBodyError, UnknownJointError: no such body or joint.
        """
        s = self._s
        return s.backend.joint_info(body, joint_index(s, body, joint))

    def joints(self, body: int) -> list[JointInfo]:
        """The whole joint table, in index order.

        Args:
            body: a body id.

        Returns:
            One :class:`~simbridge.types.JointInfo` per joint.

        Raises:
            UnknownBodyError: no such body.
        """
        s = self._s
        return [s.backend.joint_info(body, i) for i in range(self.num_joints(body))]

    def dynamics_info(self, body: int, link: LinkArg = -1) -> DynamicsInfo:
        """Mass, friction and inertia of a link as simulated (``p.getDynamicsInfo``).

        Args:
            body: a body id.
            link: an index or a link name; -1: the base.

        Returns:
            A :class:`~simbridge.types.DynamicsInfo` (kg, the inertia's principal moments in
            kg·m² about the link's inertial frame).

        Raises:
            UnknownBodyError, UnknownLinkError: no such body or link.
        """
        s = self._s
        return s.backend.dynamics_info(body, link_index(s, body, link))

    # ---------------------------------------------------------------- state reads

    def link_state(self, body: int, link: LinkArg) -> LinkState:
        """Pose and velocity of a link after the last step (base -1 allowed).

        Args:
            body: a body id.
            link: an index or a link name; -1: the base.

        Returns:
            A :class:`~simbridge.types.LinkState`: the centre of mass's and the link frame's
            poses (m, quaternion x, y, z, w; world) and velocities (m/s, rad/s; world).

        Raises:
            UnknownBodyError, UnknownLinkError: no such body or link.
            SimulationDivergedError: the state is not finite.
        """
        s = self._s
        return s.backend.link_state(body, link_index(s, body, link))

    def link_states(self, body: int, links: LinksArg | None = None) -> LinkStates:
        """Poses and velocities of several links at once: :meth:`link_state` of each, read in
        one pass (PyBullet's ``getLinkStates``; MuJoCo's and PhysX's links in one loop).

        Row k holds the very floats ``link_state(body, links[k])`` returns.

        Args:
            body: a body id.
            links: an index or a link name (-1 or the root's name: the base), an ordered
                sequence of them or an integer array; None: every link, the base first
                (rows -1, 0, ..., n - 1: row k is link k - 1).

        Returns:
            A :class:`~simbridge.types.LinkStates`: ``(n, 3)`` positions (m) and velocities
            (m/s, rad/s) and ``(n, 4)`` quaternions (x, y, z, w), float64, world frame (the
            local inertial frames in the link frame), one row per link in the order given.

        Raises:
            UnknownBodyError, UnknownLinkError: no such body or link.
            InvalidArgumentError: a link given twice, or an unordered ``links``.
            SimulationDivergedError: the state is not finite.
        """
        s = self._s
        return s.backend.link_states(body, link_indices(s, body, links))

    def base_state(self, body: int) -> BaseState:
        """The base's centre-of-mass pose and velocity (``getBasePositionAndOrientation``,
        ``getBaseVelocity``).

        Args:
            body: a body id.

        Returns:
            A :class:`~simbridge.types.BaseState`: position (m), orientation (x, y, z, w),
            linear (m/s) and angular (rad/s) velocity, all in the world frame.

        Raises:
            UnknownBodyError: no such body.
            SimulationDivergedError: the state is not finite.
        """
        s = self._s
        body_table(s, body)
        return s.backend.base_state(body)

    def joint_states(self, body: int, joints: JointsArg | None = None) -> JointStates:
        """Positions, velocities and motor forces of ``joints``.

        A spherical joint reports its first coordinate, as ``p.getJointState`` does (its
        quaternion's x, its angular velocity's x, its motor torque about x); all of them:
        :meth:`joint_states_multi_dof`.

        Args:
            body: a body id.
            joints: an index, a name, an ordered sequence of them or an integer array; None:
                every joint.

        Returns:
            A :class:`~simbridge.types.JointStates` of ``(n,)`` float64 arrays, in the order
            given: positions (rad or m), velocities (rad/s or m/s), applied motor torques (N·m
            or N).

        Raises:
            UnknownBodyError, UnknownJointError: no such body or joint.
            InvalidArgumentError: a joint given twice, or an unordered ``joints``.
            SimulationDivergedError: the state is not finite.
        """
        s = self._s
        return s.backend.joint_states(body, joint_indices(s, body, joints, False))

    def joint_states_multi_dof(
        self, body: int, joints: JointsArg | None = None
    ) -> tuple[JointStateMultiDof, ...]:
        """Every coordinate of ``joints`` (``p.getJointStatesMultiDof`` without the reaction
        forces).

        Args:
            body: a body id.
            joints: as :meth:`joint_states`'s; None: every joint.

        Returns:
            One :class:`~simbridge.types.JointStateMultiDof` per joint: a spherical joint's
            quaternion (x, y, z, w), angular velocity (rad/s) and motor torques (N·m; 3, about
            the child's inertial frame axes); a revolute or prismatic joint's 1-tuples; a fixed
            joint's empty tuples.

        Raises:
            UnknownBodyError, UnknownJointError, InvalidArgumentError: as :meth:`joint_states`.
        """
        return multi_dof.joint_states_multi_dof(self._s, body, joints)

    # ---------------------------------------------------------------- teleports

    def reset_joint_state(
        self,
        body: int,
        joints: JointsArg,
        positions: Any = _RESET_POSITIONS,
        velocities: Any = 0.0,
        **pybullet: Any,
    ) -> None:
        """Teleport movable joints (``resetJointState``); commands are kept.

        A spherical joint takes :meth:`reset_joint_state_multi_dof` (PyBullet's
        ``resetJointState`` leaves one as it is: measured).

        Args:
            body: a body id.
            joints: an index, a name, an ordered sequence of them or an integer array.
            positions: rad or m: a number (every joint) or one per joint.
            velocities: rad/s or m/s, likewise.
            **pybullet: refused: a PyBullet keyword (``targetValue``...) gets simbridge's name.

        Raises:
            InvalidArgumentError: a fixed or spherical joint; a value of the wrong shape, not
                finite, or past 1e10.
            UnknownBodyError, UnknownJointError: no such body or joint.
            PyBulletKeywordError: a PyBullet keyword.
        """
        if pybullet:
            raise keyword_error(self.reset_joint_state, pybullet)
        control.reset_joint_state(self._s, body, joints, positions, velocities)

    def reset_joint_state_multi_dof(
        self, body: int, joints: JointsArg, positions: Any, velocities: Any = None
    ) -> None:
        """Teleport joints with all their coordinates (``p.resetJointStateMultiDof``;
        commands are kept).

        Args:
            body: a body id.
            joints: one joint (index or name), or several (a sequence).
            positions: for one joint its coordinates (a spherical joint's quaternion x, y, z,
                w, normalised as PyBullet does; a revolute or prismatic joint's one number, rad
                or m); for several, a sequence of such, in the order given.
            velocities: likewise (3 for a spherical joint, rad/s in its child's frame); None:
                zeros.

        Raises:
            InvalidArgumentError: a fixed joint, a wrong number of coordinates, a value that
                is not finite, a quaternion of norm 0.
            UnknownBodyError, UnknownJointError: no such body or joint.
        """
        multi_dof.reset_joint_state_multi_dof(self._s, body, joints, positions, velocities)

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
        (``p.resetBasePositionAndOrientation`` zeroes it; pass zeros for that).

        Args:
            body: a body id.
            position: m, world.
            orientation: (x, y, z, w), world.
            linear_velocity: m/s, world.
            angular_velocity: rad/s, world.

        Raises:
            InvalidArgumentError: a value of the wrong shape, not finite or past 1e10, a
                quaternion of norm 0, a velocity for a fixed base.
            UnknownBodyError: no such body.
        """
        control.reset_base_state(
            self._s, body, position, orientation, linear_velocity, angular_velocity
        )

    # ---------------------------------------------------------------- motor commands
    # The hot path of every control loop, written here against the shared object: the joints
    # already resolved (the body's cache of index arrays), a float64 array of targets and one
    # force; anything else, or a value to refuse, takes the checks of every command
    # (joint_indices, command_values), which give the same results and errors. A call into a
    # part from here would cost each command 2-4% on MuJoCo.

    def set_joint_velocity(
        self,
        body: int,
        joints: JointsArg,
        target: Any = _VELOCITY_TARGET,
        *,
        max_force: Any = _VELOCITY_MAX_FORCE,
        **pybullet: Any,
    ) -> None:
        """VELOCITY_CONTROL: drive ``joints`` towards ``target`` with at most ``max_force``.

        Persists until replaced; ``max_force=0`` releases the joint (and removes the default
        brake). A spherical joint takes only the target 0 (PyBullet's spherical motor brakes;
        it drives no other velocity), and ``max_force`` per axis of the child's frame: a
        number, shape (3,), (n, 1) or (n, 3) (see :mod:`simbridge.spherical`); spherical
        joints are commanded apart from other joints.

        Args:
            body: a body id.
            joints: an index, a name, an ordered sequence of them or an integer array.
            target: rad/s or m/s: a number (every joint) or ``(n,)``.
            max_force: N·m or N, >= 0: a number or ``(n,)``.
            **pybullet: refused: a PyBullet keyword (``force``...) gets simbridge's name.

        Raises:
            InvalidArgumentError: a fixed joint, a joint a bound command holds, a value of the
                wrong shape, not finite, or a negative force.
            UnknownBodyError, UnknownJointError: no such body or joint.
            PyBulletKeywordError: a PyBullet keyword, or ``target``/``max_force`` missing.
        """
        if pybullet:
            raise keyword_error(self.set_joint_velocity, pybullet)
        s = self._s
        b = s.bodies.get(body) if type(body) is int else None
        idx = None
        if b is not None:
            if type(joints) is np.ndarray:
                idx = b.movable_cache.get((joints.dtype.char, joints.tobytes()))
            elif type(joints) is list:
                try:
                    idx = b.movable_cache.get(tuple(joints))
                except TypeError:  # an unhashable item: joint_indices says what is wrong
                    pass
        if idx is None:
            idx = joint_indices(s, body, joints, True)
        if s.multi_idx and id(idx) in s.multi_idx:
            multi_dof.motor(s, body, idx, MotorMode.VELOCITY, target, max_force, 0, 1)
            return
        if s.held:
            s.refuse_held(body, idx)
        n = len(idx)
        if (
            type(target) is np.ndarray
            and target.dtype is _F64
            and target.ndim == 1
            and len(target) == n
        ):
            targets = target.tolist()
            if not isfinite(sum(targets)):  # an inf or a NaN (or an overflowing sum)
                targets = command_values(target, n, "target")
        else:
            targets = command_values(target, n, "target")
        if type(max_force) is float and 0.0 <= max_force < _INF:
            forces = [max_force] * n
        else:
            forces = command_values(max_force, n, "max_force", nonneg=True)
        s.backend.set_joint_velocity(body, idx, targets, forces)

    def set_joint_position(
        self,
        body: int,
        joints: JointsArg,
        target: Any = _POSITION_TARGET,
        *,
        max_force: Any = _POSITION_MAX_FORCE,
        kp: Any = 0.1,
        kd: Any = 1.0,
        **pybullet: Any,
    ) -> None:
        """POSITION_CONTROL with PyBullet's law; persists until replaced.

        Each step the motor asks for the velocity change ``kp * (target - q) / dt - kd * v``
        (so it depends on dt), its force clamped to ``max_force``.

        A spherical joint takes a target quaternion (x, y, z, w; shape (4,) or (n, 4)) and
        PyBullet's spherical motor law: each axis of the child's frame asks for the velocity
        ``-kd v + 0.2 kp e / dt`` (e: the turn to the target as Bullet's XYZ Euler angles; kd is
        what PyBullet's ``setJointMotorControlMultiDof`` calls ``damping``), ``max_force``,
        ``kp`` and ``kd`` per axis (a number, (3,), (n, 1) or (n, 3)); see
        :mod:`simbridge.spherical`.

        Args:
            body: a body id.
            joints: an index, a name, an ordered sequence of them or an integer array.
            target: rad or m: a number (every joint) or ``(n,)``.
            max_force: N·m or N, >= 0: a number or ``(n,)``.
            kp: position gain (>= 0), a number or ``(n,)``.
            kd: velocity gain (>= 0), a number or ``(n,)``.
            **pybullet: refused: a PyBullet keyword (``positionGain``...) gets simbridge's
                name.

        Raises:
            InvalidArgumentError: a fixed joint, a joint a bound command holds, a value of the
                wrong shape, not finite, or a negative force or gain.
            UnknownBodyError, UnknownJointError: no such body or joint.
            PyBulletKeywordError: a PyBullet keyword, or ``target``/``max_force`` missing.
        """
        if pybullet:
            raise keyword_error(self.set_joint_position, pybullet)
        s = self._s
        b = s.bodies.get(body) if type(body) is int else None
        idx = None
        if b is not None:
            if type(joints) is np.ndarray:
                idx = b.movable_cache.get((joints.dtype.char, joints.tobytes()))
            elif type(joints) is list:
                try:
                    idx = b.movable_cache.get(tuple(joints))
                except TypeError:  # an unhashable item: joint_indices says what is wrong
                    pass
        if idx is None:
            idx = joint_indices(s, body, joints, True)
        if s.multi_idx and id(idx) in s.multi_idx:
            multi_dof.motor(s, body, idx, MotorMode.POSITION, target, max_force, kp, kd)
            return
        if s.held:
            s.refuse_held(body, idx)
        n = len(idx)
        if (
            type(target) is np.ndarray
            and target.dtype is _F64
            and target.ndim == 1
            and len(target) == n
        ):
            targets = target.tolist()
            if not isfinite(sum(targets)):  # an inf or a NaN (or an overflowing sum)
                targets = command_values(target, n, "target")
        else:
            targets = command_values(target, n, "target")
        if type(max_force) is float and 0.0 <= max_force < _INF:
            forces = [max_force] * n
        else:
            forces = command_values(max_force, n, "max_force", nonneg=True)
        if type(kp) is float and 0.0 <= kp < _INF:
            kps = [kp] * n
        else:
            kps = command_values(kp, n, "kp", nonneg=True)
        if type(kd) is float and 0.0 <= kd < _INF:
            kds = [kd] * n
        else:
            kds = command_values(kd, n, "kd", nonneg=True)
        s.backend.set_joint_position(body, idx, targets, forces, kps, kds)

    def set_joint_torque(
        self,
        body: int,
        joints: JointsArg,
        torque: Any = _TORQUE,
        **pybullet: Any,
    ) -> None:
        """TORQUE_CONTROL: add ``torque`` during the next step only.

        Commands before one step add up, as in PyBullet. The joint's motor stays; release the
        default brake first with ``set_joint_velocity(..., max_force=0)``. A spherical joint
        takes 3 torques about the axes of its child's (inertial) frame: shape (3,) or (n, 3);
        spherical joints are commanded apart from other joints.

        Args:
            body: a body id.
            joints: an index, a name, an ordered sequence of them or an integer array.
            torque: N·m or N: a number (every joint) or ``(n,)``.
            **pybullet: refused: a PyBullet keyword (``force``...) gets simbridge's name.

        Raises:
            InvalidArgumentError: a fixed joint, a value of the wrong shape or not finite.
            UnknownBodyError, UnknownJointError: no such body or joint.
            PyBulletKeywordError: a PyBullet keyword, or ``torque`` missing.
        """
        if pybullet:
            raise keyword_error(self.set_joint_torque, pybullet)
        s = self._s
        b = s.bodies.get(body) if type(body) is int else None
        idx = None
        if b is not None:
            if type(joints) is np.ndarray:
                idx = b.movable_cache.get((joints.dtype.char, joints.tobytes()))
            elif type(joints) is list:
                try:
                    idx = b.movable_cache.get(tuple(joints))
                except TypeError:  # an unhashable item: joint_indices says what is wrong
                    pass
        if idx is None:
            idx = joint_indices(s, body, joints, True)
        if s.multi_idx and id(idx) in s.multi_idx:
            multi_dof.torque(s, body, idx, torque)
            return
        n = len(idx)
        if (
            type(torque) is np.ndarray
            and torque.dtype is _F64
            and torque.ndim == 1
            and len(torque) == n
        ):
            torques = torque.tolist()
            if not isfinite(sum(torques)):  # an inf or a NaN (or an overflowing sum)
                torques = command_values(torque, n, "torque")
        else:
            torques = command_values(torque, n, "torque")
        s.backend.set_joint_torque(body, idx, torques)

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

        Args:
            body: a body id.
            joints: an index, a name, an ordered sequence of them or an integer array (no
                spherical joint).
            target: rad/s or m/s: a number or ``(n,)``.
            max_force: N·m or N, >= 0: a number or ``(n,)``.

        Returns:
            a :class:`~simbridge.bound.BoundCommand`: ``targets`` and ``max_force`` are
            float64 arrays of shape (n,), n the number of joints, in the order given.

        Raises:
            InvalidArgumentError: a fixed or spherical joint, a joint another bound command
                holds, a value of the wrong shape, not finite, or a negative force.
            UnknownBodyError, UnknownJointError: no such body or joint.
        """
        return control.bound_command(
            self._s, "velocity", body, joints, target, max_force, None, None
        )

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
        """A position command bound to ``joints``: sent now, then at every :meth:`step` from
        its own arrays, as :meth:`set_joint_position` called just before each step would, bit
        for bit. Checks, ownership and the end of the binding as for
        :meth:`velocity_command`.

        Args:
            body: a body id.
            joints: as :meth:`velocity_command`'s.
            target: rad or m: a number or ``(n,)``.
            max_force: N·m or N, >= 0: a number or ``(n,)``.
            kp: position gain (>= 0; PyBullet's law), a number or ``(n,)``, fixed here.
            kd: velocity gain (>= 0), likewise.

        Returns:
            a :class:`~simbridge.bound.BoundCommand` (``targets``, ``max_force``: ``(n,)``
            float64).

        Raises:
            InvalidArgumentError, UnknownBodyError, UnknownJointError: as
                :meth:`velocity_command`'s, and a negative gain.
        """
        return control.bound_command(self._s, "position", body, joints, target, max_force, kp, kd)

    # ---------------------------------------------------------------- contacts and state

    def contact_points(
        self,
        body_a: int | None = None,
        body_b: int | None = None,
        *,
        link_a: LinkArg | None = None,
        link_b: LinkArg | None = None,
    ) -> tuple[ContactPoint, ...]:
        """The contact points of the last step (``p.getContactPoints``).

        All of them, those of ``body_a`` (as A), or those between ``body_a`` and ``body_b``;
        ``link_a``/``link_b`` narrow to one link of each. The contacts are those found at the
        start of the last step, with the forces that step applied; a teleport or
        ``set_state`` changes them only at the next step.

        Args:
            body_a: a body id; None: every contact.
            body_b: a body id (with ``body_a``); None: any.
            link_a: a link of ``body_a`` (index or name, -1 = base); None: any.
            link_b: a link of ``body_b``, likewise.

        Returns:
            :class:`~simbridge.types.ContactPoint` records (see it for the frames, signs and
            units), the asked body (and link) as A.

        Raises:
            UnknownBodyError, UnknownLinkError: a body or link that is not there.
            InvalidArgumentError: ``body_b`` without ``body_a`` (PyBullet answers that with
                nothing), or a link without its body.
        """
        return world.contact_points(self._s, body_a, body_b, link_a, link_b)

    def external_forces(self, body: int) -> np.ndarray:
        """The contact wrench on each link of ``body`` in the last step, as MuJoCo's
        ``cfrc_ext`` holds it (com-based).

        Per link: the torque then the force the contacts of the last step put on it, world
        frame, the torque about the centre of mass of the whole body (MuJoCo's
        ``subtree_com`` of the body's root). A contact between two links of the body counts on
        both, opposite. MuJoCo (an MJCF read as MuJoCo reads it): ``d.cfrc_ext`` after
        ``mj_rnePostConstraint`` (its torsional and rolling friction included), each link the
        sum of its MuJoCo bodies; otherwise (PyBullet, PhysX, MuJoCo under a URDF) from
        :meth:`contact_points`: each point's normal and friction forces at the middle of its
        two positions (docs/state_and_contacts.md: how each engine's forces depart). Only
        computed when asked: nothing is added to ``step``.

        Args:
            body: a body id.

        Returns:
            ``(links + 1, 6)`` float64: row 0 the base, row ``i + 1`` link ``i``; columns
            torque x, y, z (N m), force x, y, z (N).

        Raises:
            UnknownBodyError: a body that is not there.
            BackendUnsupportedError: a backend without contact points.
        """
        return world.external_forces(self._s, body)

    def get_state(self, *, exact: bool = True) -> WorldState:
        """Everything :meth:`set_state` needs to put this world back.

        Per body (load order) the base's centre-of-mass pose and velocities, every joint's
        position and velocity, the commands in force (motor mode, target, max force, gains)
        and the torques pending for the next step (a spherical joint's in full in
        ``BodyState.spherical``); the time. Bound commands are sent first (as a step would),
        so the state holds their values.

        Args:
            exact: also keep the engine's own data (``WorldState.native``: MuJoCo's solver warm
                start, PyBullet's ``saveState`` with its contact caches, which costs about 2.6
                ms on r2d2), so that a restore into this same world steps bit for bit as the
                uninterrupted run. Without it the state is the portable one alone.

        Returns:
            A :class:`~simbridge.types.WorldState`.

        Raises:
            InvalidArgumentError: a bound command holds a bad value (as ``step`` would).
            SimClosedError: the Sim is closed.
        """
        return world.get_state(self._s, exact)

    def set_state(self, state: WorldState) -> None:
        """Put the world in ``state``: base poses and velocities, joint positions and
        velocities, the commands in force, pending torques and the time (to the nearest whole
        step of this Sim's time step).

        Into the world it was taken from (no load, remove or reset since) a state with its
        engine data restores bit-exactly; anywhere else, or after ``state.portable()``, what
        the engine keeps of its past (contact caches, solver warm start) stays out: see
        docs/state_and_contacts.md for each engine's one-step error after such a restore.
        ``joint_states(...).applied_torques`` describe the last step until the next one.
        Bound commands (:meth:`velocity_command`) end here, as at a world change: the state's
        commands replace them.

        Args:
            state: from :meth:`get_state` of this Sim, or of another Sim, on any backend, with
                the same robots loaded in the same order.

        Raises:
            InvalidArgumentError: not a WorldState; other robots or another load order (the
                message lists both); a value of the wrong shape, non-finite, a motor mode on a
                fixed joint; a velocity for a fixed base. Nothing is set then, but for the last,
                which the backend refuses when it reaches that body.
            SimClosedError: the Sim is closed.
        """
        world.set_state(self._s, state)

    # ---------------------------------------------------------------- pictures

    def render(
        self,
        width: int = 320,
        height: int = 240,
        *,
        eye: Sequence[float],
        target: Sequence[float],
        up: Sequence[float] = (0.0, 0.0, 1.0),
        fov: float = 50.0,
    ) -> np.ndarray:
        """Draw the world as it stands, seen from ``eye`` looking at ``target``.

        Args:
            width: the picture's width in pixels (1 to 4096).
            height: its height in pixels (1 to 4096).
            eye: where the camera is (m, world).
            target: what it looks at (m, world; apart from ``eye``).
            up: the direction that points up in the picture (world; not along eye - target).
            fov: vertical field of view in degrees (more than 0, less than 180).

        Returns:
            A (height, width, 3) ``uint8`` RGB array.

        Raises:
            InvalidArgumentError: a size, point, direction or angle out of range.
            BackendUnsupportedError: a backend that draws no pictures (the PyBullet backend
                draws them on the CPU, on any machine).
        """
        return pictures.render(self._s, width, height, eye, target, up, fov)


def backends() -> list[str]:
    """Registered backend names.

    Returns:
        The names, as :func:`simbridge.available_backends` gives them.
    """
    return available_backends()
