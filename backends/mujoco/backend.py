"""`Sim` on MuJoCo 4: PyBullet's joint table, frames and command semantics on MuJoCo physics.

The ``Backend`` methods. One ``MjSpec`` holds the world (model.py builds each robot into it);
every ``load``/``remove`` edits it and recompiles with ``MjSpec.recompile``, which carries
``qpos``/``qvel``/time of the bodies already there across; world.py then derives everything a
step needs (:class:`~.world.Compiled`) and keeps each robot's motor settings across compiles.
A step runs the compiled loop (kernel.py, _mjkernel.c) or its Python reference (loop.py); both
report trouble as a status or an exception that this module turns into the Sim's errors.
Poses and velocities are recomputed lazily on the first read after a step (``mj_kinematics``,
``mj_comPos``, ``mj_comVel``), so the stepping loop pays nothing for them.
"""

from __future__ import annotations

import logging
from typing import Any

import mujoco
import numpy as np

from simbridge import kinematics as K
from simbridge.backend import Backend
from simbridge.exceptions import (
    EngineError,
    SimBusyError,
    SimulationDivergedError,
    UrdfStructureError,
)
from simbridge.profiles import Profile
from simbridge.types import (
    BaseState,
    DynamicsInfo,
    JointInfo,
    JointStates,
    JointType,
    LinkState,
    Quat,
    Vec3,
)
from simbridge.urdf import UrdfModel

from . import kernel as kernel_loader
from . import model as build
from .loop import step_python
from .viewer import Viewer, check_display
from .world import Compiled, Robot, compile_state, default_motors

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

# Sim.step(n) runs the compiled loop (which holds no GIL and sees no signal) this many steps
# at a time (about 12 ms on r2d2): Ctrl-C stops a long call between two chunks, with the time
# of the steps done; a call costs 0.1 us, nothing per step.
_STEP_CHUNK = 1000


class MujocoBackend(Backend):
    """`Sim` on MuJoCo 4 (see the module docstring and docs/mujoco_backend.md)."""

    name = "mujoco"

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
        self._chunking = False  # a step(n) in chunks is under way (another thread's, maybe)
        self._next_id = 0
        self._free_ids: list[int] = []  # removed ids, reused last-freed first (as PyBullet)
        self._steps = 0
        self._closed = False
        self._c: Compiled | None = None
        self._new_world()

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
        """Changing the world while another thread steps it would race the compiled loop."""
        if self._chunking:
            raise SimBusyError()
        kernel = self._c.kernel if self._c is not None else None
        if kernel is not None:
            kernel.check_idle()  # SimBusyError while it steps

    def load(
        self, model: UrdfModel, base_position: Vec3, base_orientation: Quat, fixed_base: bool
    ) -> int:
        self._check_idle()
        body = self._free_ids[-1] if self._free_ids else self._next_id
        prefix = f"b{body}/"
        spec = self._spec
        meshes = self._meshes.mark()
        try:
            rspec = build.add_robot(
                spec,
                self._meshes,
                model,
                prefix,
                base_position,
                base_orientation,
                fixed_base,
                self.profile,
            )
            skip = build.adjacent_links(model) if self.profile.self_collision else None
            build.add_pairs(
                spec,
                rspec,
                [r.spec for r in self._robots.values()],
                self.profile,
                CONTACT_MARGIN,
                skip,
            )
            fixed = K.is_fixed_base(model, fixed_base)
            table = K.joint_table(model, fixed_base, rspec.inertials)
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
        return body

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

    def remove(self, body: int) -> None:
        self._check_idle()
        robot = self._robots.pop(body)
        self._w.save_motor_state(self._robots)
        self._drop_from_spec(robot.spec.prefix)
        self._free_ids.append(body)
        self._recompile("<remove>")

    def reset(self) -> None:
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
        c = self._w
        kernel = c.kernel
        if (
            n <= _STEP_CHUNK
            and kernel is not None
            and self._viewer is None
            and not c.pending_torque
            and not self._chunking
        ):  # the hot path: one call into the compiled loop (_steps_of does the same, slower)
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
            if status:
                if status >= 2:  # a call stopped early: count only the steps that ran
                    self._steps += kernel.steps_done - n
                self._kernel_status(status)
            return
        if self._chunking:  # another thread is between two chunks of its step(n)
            raise SimBusyError()
        if n <= _STEP_CHUNK:
            self._steps_of(n)
            return
        self._chunking = True  # in chunks: Ctrl-C is seen between them, time counts them,
        try:  # and the world stays refused to other threads between them
            while n > 0:
                chunk = min(n, _STEP_CHUNK)
                self._steps_of(chunk)
                n -= chunk
        finally:
            self._chunking = False

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
                    status = max(status, kernel.step(1, c.pending_torque))
                    ran += kernel.steps_done
                    c.pending_torque = False
                    if status >= 2:  # an error, not a warning: the world stops here
                        break
                    if self._viewer is not None:
                        self._viewer.sync()
                if self._viewer is None and n > 1 and status < 2:
                    status = max(status, kernel.step(n - 1, False))
                    ran += kernel.steps_done
        except BaseException as exc:
            if kernel is not None and kernel.interrupted:
                self._steps += (ran or 0) + kernel.steps_done
                self._callback_failed(exc)
            raise
        if n > 0:
            self._steps += n
            c.stale = c.motor_force_valid = c.motor_rows_valid = True
        if status:
            if status >= 2:  # a call stopped early: count only the steps that ran
                self._steps += (kernel.steps_done if ran is None else ran) - n
            self._kernel_status(status)

    def _python_steps(self, c: Compiled, n: int) -> int:
        """``n`` steps of the Python loop; 1: look at MuJoCo's warnings (it does not count
        them). MuJoCo's errors, a callback's and Ctrl-C count the steps completed."""
        d = c.d
        start = d.time
        sync = self._viewer.sync if self._viewer is not None else None
        try:
            step_python(c, n, sync)
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
        return 1

    def _callback_failed(self, exc: BaseException) -> None:
        """A MuJoCo callback (``mjcb_*``, set by the user) raised mid-step: MuJoCo's data is
        half-computed, as after an engine error, so the world steps no more until reset();
        the callback's exception goes on to the caller."""
        self._engine_error = f"a MuJoCo callback raised {type(exc).__name__}: {exc}"
        self._w.kernel = None
        self._w.stale = True

    def _engine_failed(self, detail: str) -> None:
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
            self._check_warnings()
            return
        if status == 4:
            self._engine_failed(self._w.kernel.last_error())
        if status == 2:
            raise SimulationDivergedError(
                self.name, self.time, "motor rows (not MuJoCo's first friction rows)"
            )
        raise SimulationDivergedError(self.name, self.time, "motor rows (singular solve)")

    def _check_warnings(self) -> None:
        bad = self._w.bad_warnings()
        if bad is not None:
            what = ("positions (qpos)", "velocities (qvel)", "accelerations (qacc)")[bad]
            # MuJoCo has already put the state back to the model's reference pose: that
            # world is not the simulation's any more, so it refuses steps and reads until
            # reset() (PyBullet's world stays NaN, which reads as the same error there)
            self._diverged = SimulationDivergedError(self.name, self.time, f"joint {what}")
            self._w.kernel = None
            raise self._diverged

    def close(self) -> None:
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

    # ---------------------------------------------------------------- tables

    def joint_info(self, body: int, joint: int) -> JointInfo:
        return self._robots[body].table[joint]

    def num_joints(self, body: int) -> int:
        return len(self._robots[body].table)

    def dynamics_info(self, body: int, link: int) -> DynamicsInfo:
        robot = self._robots[body]
        ine = robot.spec.inertials[link + 1]
        lateral, rolling, spinning, restitution = build._contact_values(
            robot.model.link(link), self.profile
        )
        return DynamicsInfo(
            ine.mass,
            lateral,
            ine.diagonal,
            ine.position,
            ine.orientation,
            restitution,
            rolling,
            spinning,
        )

    # ---------------------------------------------------------------- state

    def _fresh(self) -> None:
        c = self._w
        if c.stale:
            m, d = c.m, c.d
            mujoco.mj_kinematics(m, d)
            mujoco.mj_comPos(m, d)
            mujoco.mj_comVel(m, d)
            c.stale = False

    def _com_pose_velocity(self, bid: int) -> tuple[Vec3, Quat, Vec3, Vec3]:
        d = self._w.d
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, d.ximat[bid])
        vel = np.empty(6)
        mujoco.mj_objectVelocity(self._w.m, d, mujoco.mjtObj.mjOBJ_BODY, bid, vel, 0)
        pos = d.xipos[bid]
        return (
            (float(pos[0]), float(pos[1]), float(pos[2])),
            (float(quat[1]), float(quat[2]), float(quat[3]), float(quat[0])),
            (float(vel[3]), float(vel[4]), float(vel[5])),
            (float(vel[0]), float(vel[1]), float(vel[2])),
        )

    def _state_of(self, bid: int, body: int) -> list[float]:
        """Centre-of-mass pose and velocity, then link-frame pose, of MuJoCo body ``bid``
        (20 floats, quaternions x, y, z, w), after the lazy refresh."""
        c = self._w
        kernel = c.kernel
        if kernel is not None:
            finite = kernel.body_state(bid, c.stale, c.state_out)
            if finite is None:
                self._engine_failed(kernel.last_error())
            c.stale = False
            if not finite:
                raise SimulationDivergedError(self.name, self.time, f"body {body} pose")
            return c.state_out.tolist()  # type: ignore[no-any-return]
        if self._diverged is not None:
            raise self._diverged
        self._fresh()
        d = c.d
        self._check_finite(d.xipos[bid], body)
        com_pos, com_orn, lin, ang = self._com_pose_velocity(bid)
        fp = d.xpos[bid]
        fq = d.xquat[bid]
        return [
            *com_pos,
            *com_orn,
            *lin,
            *ang,
            float(fp[0]),
            float(fp[1]),
            float(fp[2]),
            float(fq[1]),
            float(fq[2]),
            float(fq[3]),
            float(fq[0]),
        ]

    def link_state(self, body: int, link: int) -> LinkState:
        robot = self._robots[body]
        v = self._state_of(int(robot.body_ids[link + 1]), body)
        ine = robot.spec.inertials[link + 1]
        frame = ((v[13], v[14], v[15]), (v[16], v[17], v[18], v[19]))
        if link == -1 and robot.spec.base_offset is not None:  # body frame = the COM frame
            frame = K.transform_multiply(frame, robot.spec.base_offset)
        return LinkState(
            (v[0], v[1], v[2]),
            (v[3], v[4], v[5], v[6]),
            ine.position,
            ine.orientation,
            frame[0],  # type: ignore[arg-type]
            frame[1],  # type: ignore[arg-type]
            (v[7], v[8], v[9]),
            (v[10], v[11], v[12]),
        )

    def base_state(self, body: int) -> BaseState:
        v = self._state_of(int(self._robots[body].body_ids[0]), body)
        return BaseState(
            (v[0], v[1], v[2]), (v[3], v[4], v[5], v[6]), (v[7], v[8], v[9]), (v[10], v[11], v[12])
        )

    def _check_finite(self, values: np.ndarray, body: int) -> None:
        if not np.isfinite(values).all():
            raise SimulationDivergedError(self.name, self.time, f"body {body} pose")

    def _joint_cache(self, robot: Robot, joints: np.ndarray) -> tuple[np.ndarray, ...]:
        key = id(joints)
        hit = robot.cache.get(key)
        if hit is not None and hit[0] is joints:
            return hit
        movable = robot.qadr[joints] >= 0
        qadr = robot.qadr[joints][movable]
        dof = robot.dofadr[joints][movable]
        pos_of = np.full(len(robot.table), -1, np.intp)
        pos_of[robot.movable] = robot.motor_index
        motor = pos_of[joints][movable]
        entry = (joints, movable, qadr, dof, motor, bool(movable.all()))
        robot.cache[key] = entry
        return entry

    def _torque_rows(self, joints: np.ndarray, movable: np.ndarray, motor: np.ndarray) -> tuple:
        """Motor rows of ``joints`` under the current motor set (cached per motor epoch):
        (rows, positions in the answer, every joint has a row)."""
        t = self._w.motors
        hit = self._w.torque_map.get(id(joints))
        if hit is not None and hit[0] is joints and hit[1] == t.epoch:
            return hit[2:]  # type: ignore[no-any-return]
        rows = t.row_of[motor]
        on = rows >= 0
        rows = rows[on]
        entry = (joints, t.epoch, rows, np.flatnonzero(movable)[on], len(rows) == len(joints))
        self._w.torque_map[id(joints)] = entry
        return entry[2:]

    def joint_states(self, body: int, joints: np.ndarray) -> JointStates:
        c = self._w
        kernel = c.kernel
        if kernel is not None:
            kernel.check_idle()  # no torn reads of a world stepping in another thread
        elif self._diverged is not None:
            raise self._diverged
        robot = self._robots[body]
        _, movable, qadr, dof, motor, all_movable = self._joint_cache(robot, joints)
        d = c.d
        n = len(joints)
        if c.motor_force_valid and c.motor_rows_valid:
            rows, where, full = self._torque_rows(joints, movable, motor)
            torque = d.efc_force[rows] if full else np.zeros(n)
            if not full:
                torque[where] = d.efc_force[rows]
        else:
            torque = np.zeros(n)
        if all_movable:
            return JointStates(d.qpos[qadr], d.qvel[dof], torque)
        pos = np.zeros(n)
        vel = np.zeros(n)
        pos[movable] = d.qpos[qadr]
        vel[movable] = d.qvel[dof]
        return JointStates(pos, vel, torque)

    def reset_joint_state(
        self, body: int, joints: np.ndarray, positions: list[float], velocities: list[float]
    ) -> None:
        self._check_idle()
        robot = self._robots[body]
        _, _, qadr, dof, _, _ = self._joint_cache(robot, joints)
        c = self._w
        c.d.qpos[qadr] = positions
        c.d.qvel[dof] = velocities
        c.stale = True
        c.motor_force_valid = False

    def reset_base_state(
        self,
        body: int,
        position: Vec3 | None,
        orientation: Quat | None,
        linear_velocity: Vec3 | None,
        angular_velocity: Vec3 | None,
    ) -> None:
        robot = self._robots[body]
        if robot.free_qadr < 0:
            self.refuse_fixed_base_velocity(body, linear_velocity, angular_velocity)
        cur = self.base_state(body)
        pos = cur.position if position is None else position
        orn = cur.orientation if orientation is None else orientation
        lin = cur.linear_velocity if linear_velocity is None else linear_velocity
        ang = cur.angular_velocity if angular_velocity is None else angular_velocity
        ine = robot.spec.inertials[0]
        # link frame = COM frame * inverse(inertial frame)
        fpos, forn = K.transform_multiply(
            (pos, orn), K.transform_inverse((ine.position, ine.orientation))
        )
        d, m = self._w.d, self._w.m
        if robot.free_qadr >= 0:
            # the free base's body frame: its centre-of-mass frame, or the link frame when the
            # two coincide (base_offset None)
            bpos, born = (pos, orn) if robot.spec.base_offset is not None else (fpos, forn)
            a = robot.free_qadr
            d.qpos[a : a + 3] = bpos
            d.qpos[a + 3 : a + 7] = K.xyzw_to_wxyz(born)
            # MuJoCo: linear velocity of the frame origin (world), angular in the body frame
            v_origin = np.asarray(lin) + np.cross(ang, np.subtract(bpos, pos))
            w_local = K.quat_rotate(K.quat_conjugate(born), ang)
            v = robot.free_dofadr
            d.qvel[v : v + 3] = v_origin
            d.qvel[v + 3 : v + 6] = w_local
        else:
            bid = int(robot.body_ids[0])
            m.body_pos[bid] = fpos
            m.body_quat[bid] = K.xyzw_to_wxyz(forn)
            robot.spec.root.pos = list(fpos)
            robot.spec.root.quat = list(K.xyzw_to_wxyz(forn))
        self._w.stale = True

    # ---------------------------------------------------------------- control

    def _motor_slots(self, body: int, joints: np.ndarray) -> np.ndarray:
        return self._joint_cache(self._robots[body], joints)[4]

    def set_joint_velocity(
        self, body: int, joints: np.ndarray, target: list[float], max_force: list[float]
    ) -> None:
        c = self._w
        t = c.motors
        fast = c.fast.get(id(joints))
        if fast is not None and fast[0] is joints and fast[1] == t.epoch and fast[2] == body:
            # Hot path: the same joints, still velocity motors with kd 1, all rows present.
            if target == fast[6] and max_force == fast[7]:
                return  # the command in force already
            if min(max_force) > 0.0:
                kernel = c.kernel
                if kernel is not None:  # the same writes in C (_mjkernel.c set_velocity)
                    kernel.set_velocity(fast[8], target, max_force)
                else:
                    rows, inv_dt = fast[4], c.inv_dt
                    t.target_velocity[fast[3]] = target
                    t.max_force[fast[3]] = max_force
                    c.m.dof_frictionloss[fast[5]] = max_force
                    t.offset_rows[rows] = [v * inv_dt for v in target]
                    t.force_rows_slack[rows] = [f * (1.0 - 1e-9) for f in max_force]
                t.has_offset = True
                c.fast[id(joints)] = (*fast[:6], target, max_force, fast[8])
                return
        idx = self._motor_slots(body, joints)
        t.target_velocity[idx] = target
        t.max_force[idx] = max_force
        t.kp[idx] = 0.0
        t.kd[idx] = 1.0
        c.refresh_motors()
        rows = t.row_of[idx]
        if t.n_special == 0 and not self.profile.enforce_effort_limit and (rows >= 0).all():
            dofs = t.dof[idx]
            c.fast[id(joints)] = (
                joints,
                t.epoch,
                body,
                idx,
                rows,
                dofs,
                list(target),
                list(max_force),
                np.ascontiguousarray(np.stack([idx, rows, dofs]), dtype=np.intp),
            )

    def set_joint_position(
        self,
        body: int,
        joints: np.ndarray,
        target: list[float],
        max_force: list[float],
        kp: list[float],
        kd: list[float],
    ) -> None:
        idx = self._motor_slots(body, joints)
        c = self._w
        t = c.motors
        model = self._robots[body].model
        target = [  # PyBullet clamps a position target to the joint's limits (measured)
            min(max(q, model.joints[j].lower), model.joints[j].upper)
            if model.joints[j].has_limit
            else q
            for q, j in zip(target, joints.tolist(), strict=True)
        ]
        t.target_velocity[idx] = 0.0
        t.target_position[idx] = target
        t.max_force[idx] = max_force
        t.kp[idx] = kp
        t.kd[idx] = kd
        c.refresh_motors()

    def set_joint_torque(self, body: int, joints: np.ndarray, torque: list[float]) -> None:
        idx = self._motor_slots(body, joints)
        c = self._w
        t = c.motors
        if self.profile.enforce_effort_limit:
            c.torque[idx] += np.clip(torque, -t.effort[idx], t.effort[idx])  # each command
        else:
            c.torque[idx] += torque  # commands before one step add up, as in PyBullet
        c.pending_torque = True

    # ---------------------------------------------------------------- description

    DEPARTURES = {
        "contact": (
            "soft contact (pair solref (2 dt, 1), 1 mm margin standing in for PyBullet's 1 mm "
            "collision margin) instead of PyBullet's sequential-impulse contact: r2d2 rests at "
            "z 0.47100 (PyBullet 0.47099); turning in place on 4 skidding wheels it hops up to "
            "4 mm (PyBullet 0.3 mm; raw MuJoCo also hops)"
        ),
        "cylinder": (
            "collision cylinders are true cylinders; PyBullet collides with a 32-gon prism "
            "(its radius varies by 0.5 %)"
        ),
        "restitution": "MuJoCo has no restitution: <contact restitution> is reported, not applied",
        "rolling/spinning friction": (
            "MuJoCo's rolling and torsional friction (condim 6/4) with Bullet's combination "
            "rule; the models differ (all 0 under both profiles unless <contact> says so)"
        ),
        "joint limits": (
            "PyBullet's limit rule (stop outward motion; within 0.04 of the limit push back at "
            "0.2 depth/dt, deeper only stop) on MuJoCo's limit rows, hardened but not polished: "
            "a slider reset past its limit ends within 4.7e-7 m of PyBullet's"
        ),
        "motors": (
            "motor rows solved exactly (MuJoCo row hardened, then its shortfall removed); "
            "PyBullet's 50 solver iterations leave coupled motor rows up to 7e-4 rad/s short "
            "(double pendulum, measured)"
        ),
        "speed clamp": (
            "applied to the velocity after the solve, at every step, as PyBullet does; "
            "on a free base to the centre of mass's velocity (as PyBullet) and to the angular "
            "velocity in the base's frame (PyBullet: the world frame)"
        ),
        "joint axis": (
            "MuJoCo normalises a non-unit <axis>; PyBullet moves |axis| rad per unit of q "
            "(none of pybullet_data's joints that load has one of length != 1 by more than 1e-6)"
        ),
    }

    def manifest(self) -> dict[str, Any]:
        departures: dict[str, str] = dict(self.DEPARTURES)
        bounded = [r for r in self._robots.values() if r.spec.bounded_links]
        for r in bounded:
            departures[f"body {r.id} mass bound"] = build.mass_bound_note(r.spec)
        for r in self._robots.values():
            if r.spec.skipped_shapes:
                departures[f"body {r.id} shapes left out"] = (
                    f"{r.spec.skipped_shapes}: meshes without a finite vertex or a readable "
                    "triangle (PyBullet loads them without a shape too)"
                )
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
