"""`Sim` on MuJoCo 4: PyBullet's joint table, frames and command semantics on MuJoCo physics.

The ``Backend`` methods. One ``MjSpec`` holds the world (model.py builds each robot into it);
every ``load``/``remove`` edits it and recompiles with ``MjSpec.recompile``, which carries
``qpos``/``qvel``/time of the bodies already there across; robots.py then derives everything a
step needs (:class:`~.robots.Compiled`) and keeps each robot's motor settings across compiles.
A step runs the compiled loop (kernel.py, _mjkernel.c) or its Python reference (loop.py); both
report trouble as a status or an exception that this module turns into the Sim's errors.
Poses and velocities are recomputed lazily on the first read after a step (``mj_kinematics``,
``mj_comPos``, ``mj_comVel``), so the stepping loop pays nothing for them.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, NoReturn

import mujoco

from simbridge.backend import Backend
from simbridge.exceptions import (
    BackendUnsupportedError,
    EngineError,
    SimBusyError,
    SimulationDivergedError,
    UrdfStructureError,
)
from simbridge.model.build_plan import build_plan
from simbridge.model.joint_table import joint_table
from simbridge.model.load_options import LoadOptions
from simbridge.model.urdf import UrdfModel
from simbridge.profiles import Profile
from simbridge.types import (
    JointType,
    Quat,
    Vec3,
)

from .. import locking
from ..locking import exclusive, wait_for_lock
from . import departures as departure_texts
from . import kernel as kernel_loader
from . import model as build
from .commands import MotorCommands
from .contacts import ContactReads
from .loop import step_python
from .reads import _PY_BUSY, StateReads
from .robots import Compiled, Robot, compile_state, default_motors
from .window import Viewer, check_display
from .world import Snapshots

if TYPE_CHECKING:
    from simbridge.model.mjcf_native import NativeMjcf
    from simbridge.model.scene import SceneBody

__all__ = ["MujocoBackend"]

_log = logging.getLogger("simbridge.mujoco")


def _mujoco_warning(message: str) -> None:
    """MuJoCo's warnings go to Python logging, not to MUJOCO_LOG.TXT in the working folder.
    A divergence still raises SimulationDivergedError from ``step``."""
    _log.warning("MuJoCo: %s", message.strip())


if mujoco.get_mju_user_warning() is None:  # leave a handler the user installed alone
    mujoco.set_mju_user_warning(_mujoco_warning)

# Contact margin (m) of every pair: PyBullet's shapes from a URDF carry a 1 mm collision margin
# and rest that far apart; MuJoCo's pair margin makes its soft contact balance about as far
# out (measured: r2d2 rests with its base at z 0.4710 on PyBullet; see docs/mujoco_backend.md).
CONTACT_MARGIN = 0.001

# MuJoCo's compiler refuses a body tree deeper than 1023 bodies below the world ("depth limit
# exceeded in signature computation"), after spending tens of seconds on it: a robot whose
# joints nest deeper than this (its root is one body) is refused before any compile. Near the
# limit a chain is slow anyway (the figures: docs/limits.md, python bench/limits.py).
MAX_TREE_DEPTH = 1022


def tree_depth(model: UrdfModel) -> int:
    """The most joints on a path from the root to a link.

    Args:
        model: The parsed robot (joints in PyBullet's order: a parent before its children).

    Returns:
        The depth in joints (0: the root alone).
    """
    depth = {model.base.name: 0}
    for joint in model.joints:  # in PyBullet's order: a parent before its children
        depth[joint.child] = depth[joint.parent] + 1
    return max(depth.values())


# Sim.step(n) runs the compiled loop (which holds no GIL and sees no signal) this many steps
# at a time (about 12 ms on r2d2): Ctrl-C stops a long call between two chunks, with the time
# of the steps done; a call costs 0.1 us, nothing per step.
_STEP_CHUNK = 1000


class MujocoBackend(StateReads, MotorCommands, ContactReads, Snapshots, Backend):
    """`Sim` on MuJoCo 4 (see the module docstring and docs/mujoco_backend.md).

    Args:
        profile: The physics settings to reproduce (time step, gravity, solver, defaults).
        gui: Whether to open MuJoCo's passive viewer in a process of its own.

    Raises:
        BackendUnsupportedError: For a profile setting MuJoCo cannot reproduce
            (``Backend.refuse_unsupported``).
        DisplayError: With ``gui`` where no window can open.
    """

    name = "mujoco"
    semantics = ("pybullet", "mujoco")

    NATIVE_DEFAULTS = {
        "gravity": (0.0, 0.0, -9.81),
        "timestep": 0.002,
        "integrator": "Euler (semi-implicit)",
        "solver": "Newton, 100 iterations",
        "joint_brake": "none",
        "inertia_source": "file (MuJoCo's URDF importer)",
        "linear_damping": 0.0,
        "angular_damping": 0.0,
        "max_joint_velocity": None,
        "lateral_friction": 1.0,
        "rolling_friction": 0.005,
        "spinning_friction": 0.0001,
        "friction_combine": "max",
        "self_collision": True,
        "contact": "soft, solref (0.02, 1), solimp (0.9, 0.95, 0.001, 0.5, 2), margin 0",
    }

    def __init__(self, profile: Profile, gui: bool = False) -> None:
        super().__init__(profile, gui)
        self.refuse_unsupported()
        if gui:
            check_display(self.name)
        kernel_loader.warn_if_lost()
        self._dt = profile.timestep
        self._viewer: Viewer | None = None
        self._robots: dict[int, Robot] = {}
        # held by step() and by every call that touches the world (re-entrant: a call's own
        # nested calls pass, and so do a bound command's sends from inside step()); a call
        # from another thread meanwhile waits for it, or raises SimBusyError if it is a step
        # (_in_step): backends/locking.py, PyBullet's rules. The step loops run without the
        # GIL while they hold it: Sims in different threads still step in parallel.
        self._stepping = threading.RLock()
        self._in_step = False
        # the Python loop's mid-step mark, as the compiled loop's busy flag: a MuJoCo callback
        # of the step's own thread that calls the Sim is refused (the lock lets it through)
        self._py_stepping = threading.Lock()
        self._next_id = 0
        self._free_ids: list[int] = []  # removed ids, reused last-freed first (as PyBullet)
        self._steps = 0
        self._closed = False
        self._c: Compiled | None = None
        self._new_world()

    def mjcf_world(
        self, native: NativeMjcf, gravity: Vec3 | None, timestep: float | None
    ) -> Backend:
        """See Backend.mjcf_world.

        MuJoCo: :class:`~.native.NativeMujoco`, raw ``mj_step`` on the compiled model. With
        ``gui`` this world's viewer closes first and the model's opens (one window at a time);
        if the model's cannot open, this world's opens again.

        Raises:
            DisplayError: With ``gui``, the model's viewer did not open.
        """
        from .native import NativeMujoco

        if not self.gui:
            return NativeMujoco(self.profile, native, gravity, timestep)
        self._close_viewer()
        try:
            return NativeMujoco(self.profile, native, gravity, timestep, gui=True)
        except BaseException:
            self._open_viewer()
            raise

    # ---------------------------------------------------------------- set-up

    def _new_world(self) -> None:
        self._engine_error: str | None = None  # MuJoCo's error text once it raised one
        self._diverged: SimulationDivergedError | None = None  # raised again until reset()
        self._spec = build.new_world_spec(self.profile)
        self._meshes = build.MeshLibrary(self._spec)
        m = self._spec.compile()
        self._c = None  # no motor state to carry over into a new world
        self._compiled(m, mujoco.MjData(m))
        if self.gui:  # a new world: a new window on it
            self._close_viewer()
            self._open_viewer()

    def _compiled(self, m: Any, d: Any) -> None:
        """Derive the step state of a new compile, carrying the motor state across."""
        if self._c is not None:
            self._c.save_motor_state(self._robots)
        use_kernel = self._engine_error is None and self._diverged is None
        self._c = compile_state(m, d, self._robots, self.profile, use_kernel=use_kernel)

    @property
    def _w(self) -> Compiled:
        """The compiled world (always set between __init__ and close)."""
        assert self._c is not None
        return self._c

    @property
    def time(self) -> float:
        return self._steps * self._dt

    # ---------------------------------------------------------------- world

    def _check_idle(self) -> None:
        """Under the Sim's lock (which keeps other threads' steps out), a change from inside
        this Sim's own step (a MuJoCo callback of its thread, which the re-entrant lock lets
        through) is refused: the world is half-computed there."""
        if self._in_step:
            raise SimBusyError(_PY_BUSY)

    def _py_mark(self) -> None:
        """The Python loop's check_idle(): SimBusyError from inside its own step."""
        if self._py_stepping.locked():
            raise SimBusyError(_PY_BUSY)

    @exclusive
    def load(
        self,
        model: UrdfModel,
        base_position: Vec3,
        base_orientation: Quat,
        fixed_base: bool,
        options: LoadOptions,
    ) -> int:
        """See Backend.load.

        MuJoCo: the robot is built into the world's ``MjSpec`` and the world recompiled; a body tree
        deeper than ``MAX_TREE_DEPTH`` joints is refused (``BackendUnsupportedError``).
        """
        self._check_idle()
        depth = tree_depth(model)
        if depth > MAX_TREE_DEPTH:
            raise BackendUnsupportedError(
                self.name,
                f"{model.source.display_name}: a kinematic depth of {depth} joints",
                f"MuJoCo's compiler refuses a body tree deeper than {MAX_TREE_DEPTH + 1} bodies "
                f"(at most {MAX_TREE_DEPTH} joints from the root to any link)",
            )
        # every PyBullet rule resolved once (the inertia source and self-collision mode are the
        # options'); the builder only translates it
        plan = build_plan(
            model,
            self.profile,
            options,
            fixed_base=fixed_base,
            base_position=base_position,
            base_orientation=base_orientation,
        )
        body = self._free_ids[-1] if self._free_ids else self._next_id
        prefix = f"b{body}/"
        spec = self._spec
        meshes = self._meshes.mark()
        try:
            rspec = build.add_robot(spec, self._meshes, plan, prefix, self.profile)
            build.add_pairs(
                spec, rspec, [r.spec for r in self._robots.values()], self.profile, CONTACT_MARGIN
            )
            fixed = plan.fixed_base
            table = joint_table(model, fixed_base, rspec.inertials)
            movable = [j.index for j in table if j.type != JointType.FIXED]
            robot = Robot(body, model, rspec, table, fixed, movable)
            robot.motor_state = default_motors(model, movable, self.profile)
            self._robots[body] = robot
            self._recompile(model.source.display_name)
        except BaseException:
            self._robots.pop(body, None)
            self._drop_from_spec(prefix)
            self._meshes.rollback(meshes)
            self._recompile_quietly()
            raise
        if self._free_ids:
            self._free_ids.pop()
        else:
            self._next_id += 1
        if rspec.unlimited_spherical:
            _log.warning(
                "%s: spherical joints %s have PyBullet's swing/twist limit (<limit lower upper "
                "twist effort> all > 0), which the MuJoCo backend does not enforce: listed in "
                "manifest()['departures']",
                model.source.display_name,
                rspec.unlimited_spherical,
            )
        return body

    @exclusive
    def load_scene(self, bodies: Sequence[SceneBody], options: LoadOptions) -> list[int]:
        """See Backend.load_scene.

        MuJoCo: every body of the file under one hold of the Sim's lock.
        """
        return super().load_scene(bodies, options)

    def _drop_from_spec(self, prefix: str) -> None:
        spec = self._spec
        for pair in list(spec.pairs):
            if pair.name.startswith(prefix) or f"|{prefix}" in pair.name:
                spec.delete(pair)
        for b in list(spec.worldbody.bodies):
            if b.name.startswith(prefix):
                spec.delete(b)

    def _recompile_quietly(self) -> None:
        try:
            self._recompile("<restore>")
        except Exception:  # noqa: BLE001 - the original error is the one to report
            self._new_world_keep_state_lost()

    def _new_world_keep_state_lost(self) -> None:  # pragma: no cover - last resort
        self._robots.clear()
        self._new_world()

    @exclusive
    def remove(self, body: int) -> None:
        """See Backend.remove.

        MuJoCo: the body leaves the ``MjSpec`` and the world is recompiled.
        """
        self._check_idle()
        robot = self._robots.pop(body)
        self._w.save_motor_state(self._robots)
        self._drop_from_spec(robot.spec.prefix)
        self._free_ids.append(body)
        self._recompile("<remove>")

    reading = locking.reading

    def set_divergence_check(self, every_step: bool) -> None:
        """See Backend.set_divergence_check.

        MuJoCo: nothing to set: MuJoCo checks positions, speeds and accelerations at every step
        itself (mj_checkPos, mj_checkVel, mj_checkAcc), and both step loops stop after the step that
        raised such a warning.
        """

    @exclusive
    def reset(self) -> None:
        """See Backend.reset. MuJoCo: a new, empty ``MjSpec`` and world; the viewer closes."""
        self._check_idle()
        self._close_viewer()
        self._robots.clear()
        self._next_id = 0
        self._free_ids.clear()
        self._steps = 0
        self._new_world()

    def _recompile(self, file: str) -> None:
        """Compile the spec (keeping the state of bodies already there) and refresh indices."""
        w = self._w
        w.save_motor_state(self._robots)
        try:
            m, d = self._spec.recompile(w.m, w.d)
        except ValueError as exc:
            raise UrdfStructureError(file, "<robot>", f"MuJoCo cannot compile it: {exc}") from None
        self._compiled(m, d)
        if self.gui:  # the viewer holds the old model: reopen it on the new one
            self._close_viewer()
            self._open_viewer()

    # ---------------------------------------------------------------- stepping

    def step(self, n: int) -> None:
        """See Backend.step.

        MuJoCo: the compiled loop (_mjkernel.c) or its Python reference (loop.py); MuJoCo's warnings
        and a failed motor solve become ``SimulationDivergedError`` or ``EngineError``.
        """
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)  # another thread's call: waited for; its step: SimBusyError
        if self._in_step:  # this thread's own step, from a MuJoCo callback inside it
            lock.release()
            raise SimBusyError(_PY_BUSY)
        self._in_step = True  # a call from another thread meanwhile is refused, not waited
        try:
            c = self._w
            kernel = c.kernel
            if (
                n <= _STEP_CHUNK
                and kernel is not None
                and self._viewer is None
                and not c.pending_torque
            ):  # the hot path: one call into the compiled loop (_steps_of does the same)
                try:
                    status = kernel.step(n, False)
                except BaseException as exc:
                    if kernel.interrupted:
                        self._steps += kernel.steps_done
                        self._callback_failed(exc)
                    raise
                if n > 0:
                    self._steps += n
                    c.stale = c.motor_force_valid = c.motor_rows_valid = True
                if status:  # the loop stopped early: count only the steps that ran
                    self._steps += kernel.steps_done - n
                    self._kernel_status(status)
                return
            if n <= _STEP_CHUNK:
                self._steps_of(n)
                return
            while n > 0:  # in chunks: Ctrl-C is seen between them, time counts them, and
                chunk = min(n, _STEP_CHUNK)  # the lock keeps other threads out throughout
                self._steps_of(chunk)
                n -= chunk
        finally:
            self._in_step = False
            lock.release()

    def _steps_of(self, n: int) -> None:
        c = self._w
        kernel = c.kernel
        ran = None  # steps completed, where a call may have stopped early
        try:
            if kernel is not None and self._viewer is None and not c.pending_torque:
                status = kernel.step(n, False)  # the hot path: one call into the compiled loop
            elif kernel is None:
                if self._diverged is not None:
                    raise self._diverged
                if self._engine_error is not None:
                    raise EngineError(self.name, self.time, self._engine_error)
                status = self._python_steps(c, n)
            else:  # a pending torque (first step only) or a viewer to keep in step
                status = ran = 0
                for _ in range(n if self._viewer is not None else min(n, 1)):
                    status = kernel.step(1, c.pending_torque)
                    ran += kernel.steps_done
                    c.pending_torque = False
                    if status:  # a divergence or an error: the world stops here
                        break
                    if self._viewer is not None:
                        self._viewer.sync()
                if self._viewer is None and n > 1 and not status:
                    status = kernel.step(n - 1, False)
                    ran += kernel.steps_done
        except BaseException as exc:
            if kernel is not None and kernel.interrupted:
                self._steps += (ran or 0) + kernel.steps_done
                self._callback_failed(exc)
            raise
        if n > 0:
            self._steps += n
            c.stale = c.motor_force_valid = c.motor_rows_valid = True
        if status:  # the loop stopped early: count only the steps that ran
            if kernel is not None:
                self._steps += (kernel.steps_done if ran is None else ran) - n
            self._kernel_status(status)

    def _python_steps(self, c: Compiled, n: int) -> int:
        """``n`` steps of the Python loop, as the compiled loop's status: 3 after a singular
        motor solve, else 1, so that the caller looks at MuJoCo's warning counters (a warning
        in the last step ends the loop with all ``n`` done); the steps not run are taken off
        the count the caller adds.
        MuJoCo's errors, a callback's and Ctrl-C count the steps completed."""
        d = c.d
        start = d.time
        sync = self._viewer.sync if self._viewer is not None else None
        if not self._py_stepping.acquire(False):  # a MuJoCo callback of this very step
            raise SimBusyError(_PY_BUSY)
        try:
            done, singular = step_python(c, n, sync)
        except mujoco.FatalError as exc:
            self._steps += round((d.time - start) * c.inv_dt)  # completed
            self._engine_failed(str(exc))
        except Exception as exc:  # a MuJoCo callback raised mid-step
            self._steps += round((d.time - start) * c.inv_dt)
            self._callback_failed(exc)
            raise
        except KeyboardInterrupt:  # between two steps' calls: the steps done count
            self._steps += round((d.time - start) * c.inv_dt)
            c.stale = True
            raise
        finally:
            c.stale = True
            self._py_stepping.release()
        self._steps += done - n  # the caller counts n
        return 3 if singular else 1

    def _callback_failed(self, exc: BaseException) -> None:
        """A MuJoCo callback (``mjcb_*``, set by the user) raised mid-step: MuJoCo's data is
        half-computed, as after an engine error, so the world steps no more until reset();
        the callback's exception goes on to the caller."""
        self._engine_error = f"a MuJoCo callback raised {type(exc).__name__}: {exc}"
        self._w.kernel = None
        self._w.stale = True

    def _engine_failed(self, detail: str) -> NoReturn:
        """MuJoCo raised an error inside a step: its data is left half-computed (its stack
        marks unwound by a jump), so this world steps no more until reset()."""
        self._engine_error = detail
        self._w.kernel = None
        self._w.stale = True
        raise EngineError(self.name, self.time, detail)

    def _kernel_status(self, status: int) -> None:
        """1: a divergence warning may have been raised; 2, 3: the compiled loop's own errors;
        4: MuJoCo raised an error."""
        if status == 1:
            bad = self._w.bad_warnings()
            if bad is not None:
                what = ("positions (qpos)", "velocities (qvel)", "accelerations (qacc)")[bad]
                self._diverge(f"joint {what}")
            if self._w.kernel is not None:  # the compiled loop saw a count move: never unsaid
                self._diverge("joint positions, velocities or accelerations")
            return  # the Python loop asks after every call: nothing was raised
        if status == 4:
            self._engine_failed(self._w.kernel.last_error())
        # 2: the step stopped between MuJoCo's two halves; 3: the exact solve failed
        self._diverge(
            "motor rows (not MuJoCo's first friction rows)"
            if status == 2
            else "motor rows (singular solve)"
        )

    def _diverge(self, where: str) -> NoReturn:
        """The world left the simulation at this step (``where``). After a divergence warning
        MuJoCo has already put the state back to the model's reference pose; after the loop's
        own errors the step is half done. Either way it is not the simulation's world any more:
        every step and read refuses it, with this error, until reset() (PyBullet's world stays
        NaN, which reads as the same error there)."""
        self._diverged = SimulationDivergedError(self.name, self.time, where)
        self._w.kernel = None
        raise self._diverged

    @exclusive
    def close(self) -> None:
        """See Backend.close. MuJoCo: the viewer closes; the model and data are released."""
        if self._closed:
            return
        self._check_idle()
        self._closed = True
        self._close_viewer()
        self._robots.clear()
        self._c = None  # the engine's model and data go with it (Sim refuses every call now)

    # ---------------------------------------------------------------- viewer

    def _open_viewer(self) -> None:
        self._viewer = Viewer(self.name, self._w.m, self._w.d)

    def _close_viewer(self) -> None:
        if self._viewer is not None:
            try:
                self._viewer.close()
            finally:
                self._viewer = None

    # ---------------------------------------------------------------- description

    DEPARTURES = departure_texts.DEPARTURES
    HARD_LIMITS = departure_texts.HARD_LIMITS

    def manifest(self) -> dict[str, Any]:
        """See Backend.manifest. MuJoCo: the step loop in use, and each body's departures."""
        departures: dict[str, str] = dict(self.DEPARTURES)
        if self.profile.engine(self.name).get("limit_rule") == "hard":
            departures["joint limits"] = self.HARD_LIMITS
        departures.update(departure_texts.body_departures(self._robots.values()))
        return {
            "backend": self.name,
            "engine": "MuJoCo (generalized coordinates, soft convex contact, Newton solver)",
            "engine_version": mujoco.__version__,
            "native_defaults": self.NATIVE_DEFAULTS,
            "step_loop": (
                "compiled (backends/mujoco/_mjkernel.c)"
                if self._c is not None and self._c.kernel is not None
                else f"Python ({kernel_loader.reason()})"
            ),
            "departures": departures,
        }
