"""The PyBullet backend: the reference semantics, one physics client per `Sim`.

Under the "pybullet" profile this backend adds nothing: each call maps onto the PyBullet call a
tutorial user would write (``loadURDF``, ``getJointInfo``, ``setJointMotorControlArray``,
``stepSimulation``...), so a drive written against `Sim` is bit for bit the raw drive. The
"urdf" profile is reached with PyBullet's own switches (``URDF_USE_INERTIA_FROM_FILE``,
``changeDynamics``, the default motor's force set to the file's friction).

This module holds :class:`PyBulletBackend`, the world's lifecycle (connect, load, remove,
reset, close) and stepping with its divergence probe; the package's ``__init__`` lists the
other modules.
"""

from __future__ import annotations

import math
import os
import sys
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from importlib.metadata import PackageNotFoundError, version
from typing import TYPE_CHECKING, Any

from simbridge.backend import Backend
from simbridge.engine_output import captured
from simbridge.exceptions import (
    BackendUnsupportedError,
    DisplayError,
    SimulationDivergedError,
)
from simbridge.model.load_options import LoadOptions
from simbridge.model.scene import SceneBody
from simbridge.model.urdf import UrdfModel
from simbridge.profiles import Profile
from simbridge.types import (
    Quat,
    Vec3,
)

if TYPE_CHECKING:
    from simbridge.model.mjcf_native import NativeMjcf

from .. import locking
from .commands import MotorCommands
from .common import (
    _all_finite,
    _Body,
    _refuse_long_names,
    _x_display_problem,
    wait_for_lock,
)
from .contacts import ContactReads
from .model import ModelLoading
from .output import (
    _pybullet_gui_output,
    p,  # pybullet, imported with its banner captured
)
from .reads import StateReads
from .records import Records
from .render import Rendering
from .scene import Pending, named_table
from .window import Window
from .world import Snapshots

__all__ = ["PyBulletBackend"]

# Divergence: every state read checks the values it returns (a few float additions), so no
# read ever hands out a NaN or an infinity. Besides, every body is probed (one engine call each:
# its base pose, or its leaf joints for a fixed base) after the first step following a load or
# a teleport, and after every _CHECK_EVERY-th step, which keeps the check under 2 % of a step
# (the figures: bench/divergence.py's docstring). A divergence nobody reads is raised by step at
# most 7 steps late; Sim(divergence_check="every_step") probes after every step, for those who
# pay for it.
_CHECK_EVERY = 8
# What PyBullet 3.2.7 can read and set of one body (measured on chains and trees, fixed or free
# base): its state reads (getJointState(s), getLinkState, getBasePositionAndOrientation,
# getBaseVelocity) fail with "getJointState failed" & co. for every joint of a body with more
# than 127 joints (fixed ones included); and its state arrays hold 128 coordinates, the 7 of
# the base first (a fixed base too), so a movable joint past the 121st reads position and
# velocity 0 and takes no reset or motor, silently. Such bodies are refused when loaded.
MAX_BODY_JOINTS = 127
MAX_BODY_MOVABLE_JOINTS = 121


# PyBullet's removeBody keeps the body's collision shapes until the world is reset
# (resetSimulation frees them). When remove() empties the world after this many removals since
# the engine's world was new, and the ids PyBullet would hand out next are a new world's (0, 1,
# 2, ...: the bodies were removed last-loaded first), the engine's world is made new: nothing
# the Sim shows changes (ids, time, settings), and the memory stays bounded (the figures:
# docs/limits.md, python bench/soak.py).
RECYCLE_AFTER_REMOVALS = 32


# the probe's engine calls (bound once: a module attribute lookup less per call)
_base_pose = p.getBasePositionAndOrientation
_joint_state = p.getJointState
_joint_states = p.getJointStates

# Sim.load_urdf's self_collision -> loadURDF's flags (URDF_USE_SELF_COLLISION_EXCLUDE_PARENT
# is not read by PyBullet 3.2.7: excluding the parent is what URDF_USE_SELF_COLLISION does)
_SELF_COLLISION_FLAGS = {
    "off": 0,
    "exclude_parent": p.URDF_USE_SELF_COLLISION,
    "exclude_all_parents": (
        p.URDF_USE_SELF_COLLISION | p.URDF_USE_SELF_COLLISION_EXCLUDE_ALL_PARENTS
    ),
    "include_parent": p.URDF_USE_SELF_COLLISION | p.URDF_USE_SELF_COLLISION_INCLUDE_PARENT,
}


class PyBulletBackend(
    ModelLoading, StateReads, MotorCommands, ContactReads, Snapshots, Rendering, Backend
):
    """`Sim` on PyBullet (DIRECT, or GUI when asked).

    Args:
        profile: The physics settings to reproduce (time step, gravity, solver, defaults).
        gui: Whether to connect with ``p.GUI`` (PyBullet's own window) instead of ``p.DIRECT``.

    Raises:
        BackendUnsupportedError: For a profile setting PyBullet cannot reproduce
            (``Backend.refuse_unsupported``).
        DisplayError: With ``gui`` where no X display can be opened, or where PyBullet's GUI
            connection fails (PyBullet allows one GUI per process).
    """

    name = "pybullet"
    semantics = ("pybullet", "mujoco")
    _scene: Pending | None = None  # the MJCF/SDF file load_scene is loading

    NATIVE_DEFAULTS = {
        "gravity": (0.0, 0.0, 0.0),
        "timestep": 1.0 / 240.0,
        "solver_iterations": 50,
        "joint_brake": "velocity motor, target 0, max impulse 1 N·s per step",
        "inertia_source": "collision_aabb",
        "linear_damping": 0.04,
        "angular_damping": 0.04,
        "max_joint_velocity": 100.0,
        "lateral_friction": 0.5,
        "friction_combine": "product",
        "self_collision": False,
    }

    def __init__(self, profile: Profile, gui: bool = False) -> None:
        super().__init__(profile, gui)
        self._c = -1
        # held by step() and by every call that touches the world (re-entrant: a call's own
        # nested calls pass); a call from another thread meanwhile waits for it, or raises
        # SimBusyError if it is a step (_in_step): common.wait_for_lock
        self._stepping = threading.RLock()
        self._in_step = False
        self._closed = False  # a call that waited for the lock through close() is refused
        self._file_texts: dict[str, str] = {}  # URDF files loaded by path: their first text
        self._diverged: SimulationDivergedError | None = None  # raised again until reset()
        self._checked_at = 0.0  # the time of the last probe that found every body finite
        self.refuse_unsupported()
        if gui:
            if sys.platform.startswith("linux"):
                if not os.environ.get("DISPLAY"):
                    raise DisplayError(self.name, "DISPLAY is not set")
                problem = _x_display_problem()
                if problem:
                    raise DisplayError(self.name, problem)
            with captured(self.name, "opening the GUI", _pybullet_gui_output):
                self._c = p.connect(p.GUI)
            if self._c < 0:
                raise DisplayError(
                    self.name, "p.connect(p.GUI) failed (PyBullet allows one GUI per process)"
                )
            self._window: Window | None = Window(self._c)
        else:
            with captured(self.name, "connecting"):
                self._c = p.connect(p.DIRECT)
            self._window = None
        self._dt = profile.timestep
        self._steps = 0
        self._check_every = _CHECK_EVERY  # 1 under divergence_check="every_step"
        self._next_check = _CHECK_EVERY
        self._bodies: dict[int, _Body] = {}
        # the last velocity command sent: (joints, body, target, max_force). PyBullet's motor
        # keeps a command until another replaces it, so the same command again is not re-sent
        # (a control loop repeating it every step pays 1.4 us less); any other motor command,
        # load, remove or reset forgets it.
        self._last_velocity: tuple[Any, ...] | None = None
        self._records = Records()  # the commands given and saved states (state.py)
        # PyBullet's pool of body ids: the freed ones (a stack: the last freed is handed out
        # first), ids below _fresh handed out since the world was new, removals since then
        self._freed: list[int] = []
        self._fresh = 0
        self._removed = 0
        self._configure()

    def mjcf_world(
        self, native: NativeMjcf, gravity: Vec3 | None, timestep: float | None
    ) -> Backend:
        """See Backend.mjcf_world.

        PyBullet: :class:`~.native.NativePyBullet`, the compiled model built with
        ``p.createMultiBody``, MuJoCo's actuator, spring and damping forces as joint torques.

        With ``gui`` this world's GUI connection is handed over (PyBullet allows one GUI per
        process): the model is built in it, and this world, closed next, no longer owns it.
        If the model is refused, the connection stays this world's: refused by
        :func:`~simbridge.model.mjcf_native_plan.refuse_unsimulated`, untouched; refused while
        being built (a mesh among several geoms of one link), reset and configured again,
        the world's time kept (it held no body; its ``p.saveState`` states are gone with the
        reset).

        Raises:
            MjcfFeatureUnsupportedError: A feature only MuJoCo simulates.
        """
        from .native import NativePyBullet

        if not self.gui:
            return NativePyBullet(self.profile, native, gravity, timestep)
        from simbridge.model.mjcf_native_plan import refuse_unsimulated

        refuse_unsimulated(native, self.name)  # before the connection is touched
        with self._idle():
            try:
                new = NativePyBullet(self.profile, native, gravity, timestep, gui_client=self._c)
            except BaseException:
                steps = self._steps
                self._reset()  # the id pool, the records and the profile as after a reset
                self._steps, self._next_check = steps, steps + self._check_every
                if self._window is not None:
                    self._window = Window(self._c)
                raise
            self._c = -1  # the model's now: close() leaves it open
            return new

    def _configure(self) -> None:
        c = self._c
        p.setGravity(*self.profile.gravity, physicsClientId=c)
        p.setTimeStep(self._dt, physicsClientId=c)
        p.setPhysicsEngineParameter(
            numSolverIterations=self.profile.solver_iterations, physicsClientId=c
        )
        # the engine settings the profile sets (backends/settings_pybullet.py), and those alone: a
        # setting not given keeps PyBullet's own value
        settings = self.profile.engine(self.name)
        if settings:
            given = {k: int(v) if isinstance(v, bool) else v for k, v in settings.items()}
            p.setPhysicsEngineParameter(**given, physicsClientId=c)

    # ---------------------------------------------------------------- world

    @property
    def time(self) -> float:
        return self._steps * self._dt

    def load(
        self,
        model: UrdfModel,
        base_position: Vec3,
        base_orientation: Quat,
        fixed_base: bool,
        options: LoadOptions,
    ) -> int:
        """See Backend.load.

        PyBullet: ``p.loadURDF`` on the file itself (model.py); a body past PyBullet's joint counts
        (``MAX_BODY_JOINTS``, ``MAX_BODY_MOVABLE_JOINTS``) or with names too long for it is refused
        (``BackendUnsupportedError``).
        """
        movable = sum(j.type != "fixed" for j in model.joints)
        # the last movable joint's first position coordinate (its qIndex, after the base's 7)
        # must be under 128: measured, 121 one-coordinate joints load, 31 spherical ones (4
        # coordinates each: the 32nd's qIndex is 131 and reads nothing)
        sizes = [4 if j.type == "spherical" else 1 for j in model.joints if j.type != "fixed"]
        last_q = 7 + sum(sizes[:-1]) if sizes else 0
        if len(model.joints) > MAX_BODY_JOINTS or last_q > MAX_BODY_MOVABLE_JOINTS + 6:
            raise BackendUnsupportedError(
                self.name,
                f"{model.source.display_name}: a body with {len(model.joints)} joints "
                f"({movable} movable)",
                f"PyBullet reads no state of a body with more than {MAX_BODY_JOINTS} joints "
                "(getJointState, getLinkState and getBasePositionAndOrientation fail for every "
                f"joint of it), and no more than {MAX_BODY_MOVABLE_JOINTS} movable ones (its "
                "state arrays hold 128 coordinates, 7 of them the base's: past them a joint "
                "reads 0 and takes no reset or motor); merge fixed links "
                "(merge_fixed_links=True), split the robot, or use the 'mujoco' backend",
            )
        _refuse_long_names(model)
        with self._idle():
            if self._window is not None:
                with self._window.paused():
                    body = self._load(model, base_position, base_orientation, fixed_base, options)
                self._window.aim((b, info.free) for b, info in self._bodies.items())
            else:
                body = self._load(model, base_position, base_orientation, fixed_base, options)
            if body in self._freed:  # PyBullet's pool: the last freed id, or a fresh one
                self._freed.remove(body)
            self._fresh = max(self._fresh, body + 1)
            self._next_check = self._steps + 1  # a new model: probed after its first step
            return body

    def _load(
        self,
        model: UrdfModel,
        base_position: Vec3,
        base_orientation: Quat,
        fixed_base: bool,
        options: LoadOptions,
    ) -> int:
        self._last_velocity = None
        prof = self.profile
        # loadURDF's own options: PyBullet scales and merges the file it reads itself
        flags = _SELF_COLLISION_FLAGS[options.self_collision]
        if options.inertia_source == "file":
            flags |= p.URDF_USE_INERTIA_FROM_FILE
        if options.merge_fixed_links:
            flags |= p.URDF_MERGE_FIXED_LINKS
        scale = options.global_scaling
        src = model.source
        # PyBullet is given the file as the caller named it: it then finds the meshes where
        # the reader found them (the same rules from the same working directory). PyBullet
        # caches a file's contents by name for the connection's life: a name whose text
        # changed since it was first loaded here (a file edited, or another file under the
        # same relative name) goes through a fresh temporary name, its meshes made absolute
        given = src.given if src.given is not None else str(src.path)
        needs_rewrite = src.path is None or self._file_texts.setdefault(given, src.text) != src.text
        if isinstance(model, SceneBody):  # a body of an MJCF/SDF file: PyBullet's own importer
            assert self._scene is not None, "a SceneBody loads through load_scene"
            body = self._scene.body(self, model)
        elif not needs_rewrite:
            body = self._load_file(
                given,
                src.display_name,
                base_position,
                base_orientation,
                fixed_base,
                flags,
                scale,
            )
        else:
            body = self._load_text(model, base_position, base_orientation, fixed_base, flags, scale)
        self._apply_profile(body, model)
        table = [
            self._read_joint_info(body, i)
            for i in range(p.getNumJoints(body, physicsClientId=self._c))
        ]
        if isinstance(model, SceneBody):
            table = named_table(table, model)
        dyn = p.getDynamicsInfo(body, -1, physicsClientId=self._c)
        base_mass = dyn[0]
        free = not fixed_base and base_mass > 0
        info = self._bodies[body] = _Body(table, free, (dyn[3], dyn[4]))
        self._records.loaded(body)
        if prof.enforce_effort_limit:
            info.effort = [j.max_force if j.max_force > 0 else math.inf for j in table]
            self._clamp_brake(body, info, model)
        return body

    def load_scene(self, bodies: Sequence[SceneBody], options: LoadOptions) -> list[int]:
        """See Backend.load_scene.

        PyBullet: ``p.loadMJCF``/``p.loadSDF`` on the file itself (backends/pybullet/scene.py); each
        body then goes through ``load`` as a URDF's does.
        """
        self._scene = Pending(bodies, _SELF_COLLISION_FLAGS[options.self_collision])
        try:
            return super().load_scene(bodies, options)
        finally:
            self._scene.discard_unclaimed(self)
            self._scene = None

    @contextmanager
    def _idle(self) -> Iterator[None]:
        """Changing the world while another thread steps it would end that thread's loop with
        a raw pybullet.error (measured: close() from another thread mid-step): the change
        holds the stepping lock, or is refused."""
        if not self._stepping.acquire(False):
            wait_for_lock(self)
        try:
            yield
        finally:
            self._stepping.release()

    def remove(self, body: int) -> None:
        """See Backend.remove.

        PyBullet: ``p.removeBody``; an emptied world is renewed now and then.
        """
        with self._idle():
            self._last_velocity = None
            p.removeBody(body, physicsClientId=self._c)
            del self._bodies[body]
            self._records.removed(body)
            self._freed.append(body)
            self._removed += 1
            if (
                not self._bodies
                and self._removed >= RECYCLE_AFTER_REMOVALS
                and self._freed == list(range(self._fresh - 1, -1, -1))
            ):
                self._renew_world()

    def _renew_world(self) -> None:
        """An empty world made new (resetSimulation frees what removeBody keeps), with the
        same settings, time and next body ids; saved states of the old one are dropped."""
        self._last_velocity = None
        p.resetSimulation(physicsClientId=self._c)
        self._configure()
        self._records.reset()
        self._freed.clear()
        self._fresh = 0
        self._removed = 0

    def reset(self) -> None:
        """See Backend.reset. PyBullet: ``p.resetSimulation``, the profile applied again."""
        with self._idle():
            self._reset()

    def _reset(self) -> None:
        self._last_velocity = None
        p.resetSimulation(physicsClientId=self._c)
        self._diverged = None
        self._configure()
        self._bodies.clear()
        self._records.reset()
        self._freed.clear()
        self._fresh = 0
        self._removed = 0
        self._steps = 0
        self._next_check = self._check_every
        self._checked_at = 0.0

    reading = locking.reading

    def set_divergence_check(self, every_step: bool) -> None:
        """See Backend.set_divergence_check.

        PyBullet: the bodies probed after every step, else every 8th.
        """
        self._check_every = 1 if every_step else _CHECK_EVERY
        self._next_check = self._steps + self._check_every

    def step(self, n: int) -> None:
        """See Backend.step.

        PyBullet: ``p.stepSimulation`` ``n`` times, the bodies probed for a non-finite state at the
        divergence check's cadence.
        """
        if self._diverged is not None:  # the state is NaN: no step makes it a simulation
            raise self._diverged
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        self._in_step = True  # a call from another thread meanwhile is refused, not waited
        try:
            if n == 1:
                p.stepSimulation(physicsClientId=self._c)
                self._steps += 1
            else:  # in runs up to each probe: a divergence stops the call at most 7 steps late
                c = self._c
                left = n
                while left:
                    run = min(left, max(1, self._next_check - self._steps))
                    done = 0
                    try:
                        for _ in range(run):
                            p.stepSimulation(physicsClientId=c)
                            done += 1
                    finally:  # Ctrl-C between two steps: the time counts the steps done
                        self._steps += done
                    left -= run
                    if left and self._steps >= self._next_check:
                        self._probe()
            if self._steps >= self._next_check:
                self._probe()  # under the lock: no other thread steps between its calls
            if self._window is not None:
                self._window.follow((b, info.free) for b, info in self._bodies.items())
        finally:
            self._in_step = False
            lock.release()

    def _probe(self) -> None:
        """Probe every body for a non-finite state (one engine call per body that can move:
        a free base's pose; a fixed base's movable leaf joints, see _Body). The hot path of
        the check (its cost: bench/divergence.py's docstring): a sum of the numbers, which is
        finite only if each one is; the exact test in _probe_failed."""
        self._next_check = self._steps + self._check_every
        c = self._c
        isfinite = math.isfinite
        for body, info in self._bodies.items():
            if info.free:
                pos, orn = _base_pose(body, c)
                if not isfinite(pos[0] + pos[1] + pos[2] + orn[0] + orn[1] + orn[2] + orn[3]):
                    self._probe_failed(body, info)
            elif len(info.probe_joints) == 1:
                r = _joint_state(body, info.probe_joints[0], c)
                if not isfinite(r[0] + r[1] + r[3]):
                    self._probe_failed(body, info)
            elif info.probe_joints:
                for r in _joint_states(body, info.probe_joints, c):
                    if not isfinite(r[0] + r[1] + r[3]):
                        self._probe_failed(body, info)
        self._checked_at = self._steps * self._dt

    def _probe_failed(self, body: int, info: _Body) -> None:
        """A probe's sum was not finite: diverged, unless every number is finite (a sum of
        large finite numbers may overflow)."""
        c = self._c
        if info.free:
            pos, orn = _base_pose(body, c)
            if not _all_finite(pos, orn):
                self._diverge(f"body {body} base pose")
            return
        for j, r in zip(info.probe_joints, _joint_states(body, info.probe_joints, c), strict=True):
            if not _all_finite(r[:2], r[3:]):
                self._diverge(f"body {body} joint {j} state")

    def _diverge(self, where: str) -> None:
        """The world holds a non-finite value (``where``): it is refused from now on, by every
        step and state read, with this error, until reset()."""
        if self._diverged is None:
            if self.time > self._checked_at:
                where += f" (finite at the last check, t={self._checked_at:.6f} s)"
            self._diverged = SimulationDivergedError(self.name, self.time, where)
        raise self._diverged

    def close(self) -> None:
        """See Backend.close. PyBullet: ``p.disconnect``."""
        with self._idle():
            if self._c >= 0:
                try:
                    if self.gui:
                        with captured(self.name, "closing the GUI", _pybullet_gui_output):
                            p.disconnect(physicsClientId=self._c)
                    else:
                        p.disconnect(physicsClientId=self._c)
                except p.error:  # already disconnected (e.g. the GUI window was closed)
                    pass
                self._c = -1
            self._closed = True

    # ---------------------------------------------------------------- description

    def manifest(self) -> dict[str, Any]:
        """See Backend.manifest. PyBullet: the reference, with no departures."""
        try:
            engine_version = version("pybullet")
        except PackageNotFoundError:  # pragma: no cover
            engine_version = f"api {p.getAPIVersion()}"
        return {
            "backend": self.name,
            "engine": "PyBullet (Bullet Physics, Featherstone multibody, sequential impulse)",
            "engine_version": engine_version,
            "native_defaults": self.NATIVE_DEFAULTS,
            "departures": {},
        }
