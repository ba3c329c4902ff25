"""`Sim` on MuJoCo 4: PyBullet's joint table, frames and command semantics on MuJoCo physics.

One ``MjSpec`` holds the world; every ``load``/``remove`` edits it and recompiles with
``MjSpec.recompile``, which carries ``qpos``/``qvel``/time of the bodies already there across;
this backend carries its own state (motor settings, pending torques) by joint. Each step is
``mj_step1`` (positions, velocities, constraint rows), the layer's additions (motor offsets,
link damping, joint damping, torques: see mujoco_motors.py and mujoco_damping.py), then
``mj_step2``; when there are motors or a speed clamp, the
step is split further (``mj_fwdActuation``, ``mj_fwdAcceleration``, adjust,
``mj_fwdConstraint``, ``mj_Euler``).
Poses and velocities are recomputed lazily on the first read after a step (``mj_kinematics``,
``mj_comPos``, ``mj_comVel``), so the stepping loop pays nothing for them.
"""

from __future__ import annotations

import logging
import os
import sys
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from simbridge import kinematics as K
from simbridge.backend import Backend
from simbridge.exceptions import (
    DisplayError,
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

from . import mujoco_build as build
from . import mujoco_kernel
from .mujoco_damping import LinkDamping, clamp_acceleration
from .mujoco_motors import LIMIT_DEEP, LIMIT_ERP, MOTOR_DMAX, MOTOR_R_SCALE, MotorTable

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
_BAD = (
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
    mujoco.mjtWarning.mjWARN_BADQACC,
)


@dataclass
class _Robot:
    id: int
    model: UrdfModel
    spec: build.RobotSpec
    table: list[JointInfo]
    fixed: bool
    movable: list[int]  # joint indices
    # motor settings by movable joint (kept across recompiles); columns as MotorTable
    motor_state: dict[str, np.ndarray] = field(default_factory=dict)
    # compiled indices (refreshed after every compile)
    body_ids: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.intp))
    qadr: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.intp))  # per joint
    dofadr: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.intp))  # per joint
    motor_index: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.intp))
    free_qadr: int = -1
    free_dofadr: int = -1
    cache: dict[int, tuple[np.ndarray, ...]] = field(default_factory=dict)


# Sim.step(n) runs the compiled loop (which holds no GIL and sees no signal) this many steps
# at a time (about 12 ms on r2d2): Ctrl-C stops a long call between two chunks, with the time
# of the steps done; a call costs 0.1 us, nothing per step.
_STEP_CHUNK = 1000


_LIMIT_JOINT = int(mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT)


def _jac_entry(m: Any, d: Any, r: int, dof: int) -> float:
    """The Jacobian entry of constraint row r at dof (efc_J is dense below 60 dofs unless the
    model says otherwise)."""
    if not mujoco.mj_isSparse(m):
        return float(d.efc_J[r * m.nv + dof])
    adr, nnz = d.efc_J_rowadr[r], d.efc_J_rownnz[r]
    cols = d.efc_J_colind[adr : adr + nnz]
    hit = np.flatnonzero(cols == dof)
    return float(d.efc_J[adr + hit[0]]) if len(hit) else 0.0


_MOTOR_FIELDS = ("target_velocity", "target_position", "kp", "kd", "max_force", "effort")


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
        self._viewer: Any = None
        if gui:
            if sys.platform.startswith("linux") and not (
                os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
            ):
                raise DisplayError(self.name, "neither DISPLAY nor WAYLAND_DISPLAY is set")
        self._dt = profile.timestep
        self._inv_dt = 1.0 / profile.timestep
        self._limit_k = LIMIT_ERP / profile.timestep / profile.timestep  # limit rows: K
        self._robots: dict[int, _Robot] = {}
        self._chunking = False  # a step(n) in chunks is under way (another thread's, maybe)
        self._next_id = 0
        self._free_ids: list[int] = []  # removed ids, reused last-freed first (as PyBullet)
        self._steps = 0
        self._closed = False
        self._new_world()

    # ---------------------------------------------------------------- set-up

    def _new_world(self) -> None:
        self._engine_error: str | None = None  # MuJoCo's error text once it raised one
        self._diverged: SimulationDivergedError | None = None  # raised again until reset()
        self._spec = build.new_world_spec(self.profile)
        self._meshes = build.MeshLibrary(self._spec)
        self._m = self._spec.compile()
        self._d = mujoco.MjData(self._m)
        self._after_compile()
        if self.gui:  # a new world: a new window on it
            self._close_viewer()
            self._open_viewer()

    @property
    def _link_damped(self) -> bool:
        return self.profile.linear_damping != 0.0 or self.profile.angular_damping != 0.0

    @property
    def time(self) -> float:
        return self._steps * self._dt

    # ---------------------------------------------------------------- world

    def _check_idle(self) -> None:
        """Changing the world while another thread steps it would race the compiled loop."""
        if getattr(self, "_chunking", False):
            raise SimBusyError()
        kernel = getattr(self, "_kernel", None)
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
            robot = _Robot(
                body,
                model,
                rspec,
                table,
                fixed,
                [j.index for j in table if j.type != JointType.FIXED],
            )
            robot.motor_state = self._default_motors(model, robot.movable)
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

    def _default_motors(self, model: UrdfModel, movable: list[int]) -> dict[str, np.ndarray]:
        """The motor every movable joint starts with: PyBullet's brake (velocity 0, impulse
        1 N·s per step) or, under joint_brake "urdf_friction", the file's friction."""
        joints = [model.joints[j] for j in movable]
        n = len(joints)
        if self.profile.joint_brake == "pybullet":
            brake = np.full(n, 1.0 / self._dt)
        else:
            brake = np.array([j.friction for j in joints], dtype=float)
        effort = np.full(n, np.inf)
        if self.profile.enforce_effort_limit:
            effort = np.array([j.effort if j.effort > 0 else np.inf for j in joints], float)
        return {
            "target_velocity": np.zeros(n),
            "target_position": np.zeros(n),
            "kp": np.zeros(n),
            "kd": np.ones(n),
            "max_force": brake,
            "effort": effort,
            "torque": np.zeros(n),
        }

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
        self._save_motor_state()
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
        self._save_motor_state()
        spec = self._spec
        try:
            m, d = spec.recompile(self._m, self._d)
        except ValueError as exc:
            raise UrdfStructureError(file, "<robot>", f"MuJoCo cannot compile it: {exc}") from None
        self._m, self._d = m, d
        self._after_compile()
        self._steps_since_check = 0
        if self.gui:  # the viewer holds the old model: reopen it on the new one
            self._close_viewer()
            self._open_viewer()

    def _save_motor_state(self) -> None:
        table = getattr(self, "_motors", None)
        if table is None:
            return
        for robot in self._robots.values():
            idx = robot.motor_index
            if len(idx) != len(robot.movable):
                continue  # compiled before this robot existed
            for key in _MOTOR_FIELDS:
                robot.motor_state[key] = getattr(table, key)[idx].copy()
            robot.motor_state["torque"] = self._torque[idx].copy()  # pending for the next step

    def _after_compile(self) -> None:
        m, d = self._m, self._d
        dofs: list[int] = []
        qadrs: list[int] = []
        owners: list[tuple[_Robot, int]] = []
        for robot in self._robots.values():
            names = robot.spec.body_names
            robot.body_ids = np.array(
                [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, n) for n in names], np.intp
            )
            qadr = np.full(len(robot.table), -1, np.intp)
            dofadr = np.full(len(robot.table), -1, np.intp)
            for j, jname in enumerate(robot.spec.joint_names):
                if jname is None:
                    continue
                jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, jname)
                qadr[j] = m.jnt_qposadr[jid]
                dofadr[j] = m.jnt_dofadr[jid]
            robot.qadr, robot.dofadr = qadr, dofadr
            if robot.spec.free_joint is not None:
                jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, robot.spec.free_joint)
                robot.free_qadr = int(m.jnt_qposadr[jid])
                robot.free_dofadr = int(m.jnt_dofadr[jid])
            for k, j in enumerate(robot.movable):
                dofs.append(int(dofadr[j]))
                qadrs.append(int(qadr[j]))
                owners.append((robot, k))
            robot.cache.clear()
        # motors in dof order = the order of MuJoCo's friction rows
        order = np.argsort(np.asarray(dofs, dtype=np.intp), kind="stable")
        table = MotorTable(len(dofs))
        table.dof = np.asarray(dofs, np.intp)[order]
        table.qadr = np.asarray(qadrs, np.intp)[order]
        position_of = np.empty(len(order), np.intp)
        position_of[order] = np.arange(len(order))
        for robot in self._robots.values():
            robot.motor_index = np.zeros(len(robot.movable), np.intp)
        for w, (robot, k) in enumerate(owners):
            slot = position_of[w]
            robot.motor_index[k] = slot
            for key in _MOTOR_FIELDS:
                getattr(table, key)[slot] = robot.motor_state[key][k]
        self._motors = table
        # joint damping applied explicitly, as PyBullet's server does each step
        damp = np.zeros(len(dofs))
        if self.profile.apply_joint_damping:
            for w, (robot, k) in enumerate(owners):
                damp[position_of[w]] = robot.model.joints[robot.movable[k]].damping
        self._damp_dof = table.dof[damp != 0.0]
        self._damp_coef = -damp[damp != 0.0]
        self._pending_torque = False
        self._damping = None
        if self._link_damped and self._robots and m.nbody > 1:
            self._damping = LinkDamping(
                m, 1, self.profile.linear_damping, self.profile.angular_damping
            )
        self._clamp = self.profile.max_joint_velocity
        self._torque = np.zeros(table.n)
        for robot in self._robots.values():  # torques set before a load or remove still apply
            self._torque[robot.motor_index] = robot.motor_state["torque"]
        self._pending_torque = bool(self._torque.any())
        self._fast: dict[int, tuple[Any, ...]] = {}  # set_joint_velocity's hot-path cache
        self._motor_rows_valid = False
        self._kernel = self._new_kernel()
        self._state_out = np.empty(20)
        self._torque_map: dict[int, tuple[Any, ...]] = {}  # joint_states' motor-row cache
        self._refresh_motors()
        self._warnings = [d.warning[w].number for w in _BAD]
        self._stale = True
        self._motor_force_valid = False

    def _refresh_motors(self) -> None:
        """Push the motor table into the model (frictionloss, solref) after a command."""
        t, m = self._motors, self._m
        force = np.minimum(t.max_force, t.effort)
        m.dof_frictionloss[t.dof] = force
        m.dof_solref[t.dof, 0] = 0.0
        m.dof_solref[t.dof, 1] = -t.kd * MOTOR_DMAX * self._inv_dt
        before = t.active
        t.refresh(self._dt, force, m.nv)
        if self._kernel is not None:
            self._kernel.bind_motors(
                t.offset_rows,
                t.position_rows,
                t.position_qadr,
                t.position_gain,
                t.kd_rows,
                t.kd_dof,
                t.kd_factor,
                t.dof_rows,
                t.force_rows_slack,
            )
        if len(before) != len(t.active) or (before != t.active).any():
            self._motor_rows_valid = False  # the last solve's rows belong to the old set

    def _new_kernel(self) -> Any:
        """The compiled step loop bound to this compile's model and arrays (None: step in
        Python; mujoco_kernel.reason() says why)."""
        cls = mujoco_kernel.kernel_class()
        if cls is None or self._engine_error is not None or self._diverged is not None:
            return None
        m, d = self._m, self._d
        kernel = cls(m, d, m._address, d._address, mujoco_kernel.functions(), self._dt)
        kernel.bind_commands(self._motors.target_velocity, self._motors.max_force)
        damping = self._damping
        empty = np.zeros(0)
        kernel.bind_world(
            damping.first if damping is not None else 0,
            damping.lin_gain if damping is not None else empty,
            damping.ang_gain if damping is not None else empty,
            self._damp_dof,
            self._damp_coef,
            self._motors.dof,
            self._torque,
            self._clamp,
            MOTOR_R_SCALE,
            self._limit_k,
            LIMIT_DEEP,
        )
        return kernel

    # ---------------------------------------------------------------- stepping

    def step(self, n: int) -> None:
        kernel = self._kernel
        if (
            n <= _STEP_CHUNK
            and kernel is not None
            and self._viewer is None
            and not self._pending_torque
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
                self._stale = self._motor_force_valid = self._motor_rows_valid = True
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
        kernel = self._kernel
        ran = None  # steps completed, where a call may have stopped early
        try:
            if kernel is not None and self._viewer is None and not self._pending_torque:
                status = kernel.step(n, False)  # the hot path: one call into the compiled loop
            elif kernel is None:
                if self._diverged is not None:
                    raise self._diverged
                if self._engine_error is not None:
                    raise EngineError(self.name, self.time, self._engine_error)
                start = self._d.time
                try:
                    self._step_python(n)
                except mujoco.FatalError as exc:
                    self._steps += round((self._d.time - start) * self._inv_dt)  # completed
                    self._engine_failed(str(exc))
                except Exception as exc:  # a MuJoCo callback raised mid-step, as below
                    self._steps += round((self._d.time - start) * self._inv_dt)
                    self._callback_failed(exc)
                    raise
                except KeyboardInterrupt:  # between two steps' calls: the steps done count
                    self._steps += round((self._d.time - start) * self._inv_dt)
                    self._stale = True
                    raise
                status = 1  # the Python loop does not count warnings: look at them
            else:  # a pending torque (first step only) or a viewer to keep in step
                status = ran = 0
                for _ in range(n if self._viewer is not None else min(n, 1)):
                    status = max(status, kernel.step(1, self._pending_torque))
                    ran += kernel.steps_done
                    self._pending_torque = False
                    if status >= 2:  # an error, not a warning: the world stops here
                        break
                    if self._viewer is not None:
                        self._sync_viewer()
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
            self._stale = self._motor_force_valid = self._motor_rows_valid = True
        if status:
            if status >= 2:  # a call stopped early: count only the steps that ran
                self._steps += (kernel.steps_done if ran is None else ran) - n
            self._kernel_status(status)

    def _callback_failed(self, exc: BaseException) -> None:
        """A MuJoCo callback (``mjcb_*``, set by the user) raised mid-step: MuJoCo's data is
        half-computed, as after an engine error, so the world steps no more until reset();
        the callback's exception goes on to the caller."""
        self._engine_error = f"a MuJoCo callback raised {type(exc).__name__}: {exc}"
        self._kernel = None
        self._stale = True

    def _engine_failed(self, detail: str) -> None:
        """MuJoCo raised an error inside a step: its data is left half-computed (its stack
        marks unwound by a jump), so this world steps no more until reset()."""
        self._engine_error = detail
        self._kernel = None
        self._stale = True
        raise EngineError(self.name, self.time, detail)

    def _kernel_status(self, status: int) -> None:
        """1: a divergence warning may have been raised; 2, 3: the compiled loop's own errors;
        4: MuJoCo raised an error."""
        if status == 1:
            self._check_warnings()
            return
        if status == 4:
            self._engine_failed(self._kernel.last_error())
        if status == 2:
            raise SimulationDivergedError(
                self.name, self.time, "motor rows (not MuJoCo's first friction rows)"
            )
        raise SimulationDivergedError(self.name, self.time, "motor rows (singular solve)")

    def _check_warnings(self) -> None:
        w = self._d.warning
        for i, code in enumerate(_BAD):
            if w[code].number != self._warnings[i]:
                self._warnings = [w[c].number for c in _BAD]
                what = ("positions (qpos)", "velocities (qvel)", "accelerations (qacc)")[i]
                # MuJoCo has already put the state back to the model's reference pose: that
                # world is not the simulation's any more, so it refuses steps and reads until
                # reset() (PyBullet's world stays NaN, which reads as the same error there)
                self._diverged = SimulationDivergedError(self.name, self.time, f"joint {what}")
                self._kernel = None
                raise self._diverged

    def _step_python(self, n: int) -> None:
        """The step loop in Python: the reference the compiled loop (_mjkernel.c) follows."""
        m, d = self._m, self._d
        t = self._motors
        damping = self._damping
        step1, step2 = mujoco.mj_step1, mujoco.mj_step2
        k = t.n_rows
        for _ in range(n):
            step1(m, d)
            if k:  # friction rows come first (no equality constraints)
                if t.has_offset:
                    d.efc_aref[:k] += t.aref_offset(d.qpos)
                d.efc_R[:k] *= MOTOR_R_SCALE  # harden the motor rows (mujoco_motors.py)
                d.efc_D[:k] *= 1.0 / MOTOR_R_SCALE
            if d.nl:  # PyBullet's limit rows (mujoco_motors.py), after the friction rows
                lim = slice(d.nf, d.nf + d.nl)
                d.efc_R[lim] *= MOTOR_R_SCALE
                d.efc_D[lim] *= 1.0 / MOTOR_R_SCALE
                # MuJoCo's position term is K (pos - margin); PyBullet's is K pos for a
                # penetration (pos <= 0) under LIMIT_DEEP, none deeper (stop only) or inside
                # the margin
                pos = d.efc_pos[lim]
                shallow = (pos <= 0.0) & (pos > -LIMIT_DEEP)
                d.efc_aref[lim] += self._limit_k * (pos - d.efc_margin[lim])
                d.efc_aref[lim] -= np.where(shallow, self._limit_k * pos, 0.0)
            if damping is not None:
                damping.apply(d)
            if len(self._damp_dof):
                d.qfrc_applied[self._damp_dof] = self._damp_coef * d.qvel[self._damp_dof]
            if self._pending_torque:
                d.qfrc_applied[t.dof] += self._torque
            if k or self._clamp is not None:
                self._step2_split(m, d, k)
            else:
                step2(m, d)
            if self._pending_torque:
                self._pending_torque = False
                d.qfrc_applied[t.dof] = 0.0
                self._torque[:] = 0.0
            if self._viewer is not None:
                self._sync_viewer()

    def _step2_split(self, m: Any, d: Any, k: int) -> None:
        """``mj_step2`` in pieces: the kd != 1 term needs ``qacc_smooth``; after the solve the
        motor rows are made exact (``_polish``) and the speeds clamped."""
        mujoco.mj_fwdActuation(m, d)
        mujoco.mj_fwdAcceleration(m, d)
        t = self._motors
        if len(t.kd_rows):
            d.efc_aref[t.kd_rows] += t.kd_factor * d.qacc_smooth[t.kd_dof]
        if not (k and self._exact_motors(m, d, k)):
            mujoco.mj_fwdConstraint(m, d)
            if k:
                self._polish(m, d, k)
        if self._clamp is not None:  # PyBullet clamps every dof's speed at every step
            clamp_acceleration(d, self._dt, self._clamp)  # type: ignore[arg-type]
        mujoco.mj_checkAcc(m, d)
        mujoco.mj_Euler(m, d)

    def _exact_motors(self, m: Any, d: Any, k: int) -> bool:
        """When the motor rows and joint-limit rows are the only constraint rows (no contact),
        solve them exactly instead of running MuJoCo's solver and polishing: PyBullet's rows
        are the box-constrained problem ``A x = b`` on the free rows, ``x`` at a bound on the
        others (+-max_force for a motor, [0, inf) for a limit, which only pushes; A the rows'
        block of J M^-1 J^T, each row +-1 at one dof; b = aref - J qacc_smooth), found by an
        active set: the free row furthest past a bound goes to it; a row at a bound whose
        acceleration overshoots its aref is freed. Motor rows start free, limit rows at zero.
        Writes efc_force, qfrc_constraint and qacc; False (other rows, no convergence, a
        singular block) leaves the step to MuJoCo's solver. The compiled loop does the same
        (_mjkernel.c exact_motors)."""
        n = d.nefc
        if d.ne or d.nf != k or (n > k and (d.efc_type[k:n] != _LIMIT_JOINT).any()):
            return False
        t = self._motors
        if n == k:
            y = t.minv_rows
            mujoco.mj_solveM(m, d, y, t.unit_rows)  # rows of M^-1 for the motor dofs
            dofs = t.dof_rows
            sign = np.ones(k)
        else:
            dofs = np.concatenate([t.dof_rows, m.jnt_dofadr[d.efc_id[k:n]]])
            sign = np.ones(n)
            sign[k:] = [_jac_entry(m, d, r, int(dofs[r])) for r in range(k, n)]
            unit = np.zeros((n, m.nv))
            unit[np.arange(n), dofs] = 1.0
            y = np.zeros((n, m.nv))
            mujoco.mj_solveM(m, d, y, unit)
        am = sign[:, None] * sign[None, :] * y[:, dofs]
        aref = d.efc_aref[:n]
        hi = np.concatenate([d.efc_frictionloss[:k], np.full(n - k, np.inf)])
        lo = np.concatenate([-hi[:k], np.zeros(n - k)])
        b = aref - sign * d.qacc_smooth[dofs]
        scale_over = np.concatenate([hi[:k], np.abs(b[k:]) / np.diag(am)[k:] + 1e-300])
        side = np.concatenate([np.zeros(k), -np.ones(n - k)])
        x = np.zeros(n)
        for _ in range(4 * n + 4):
            free = side == 0
            x = np.where(side > 0, hi, np.where(side < 0, lo, 0.0))
            if free.any():
                rhs = b[free] - am[np.ix_(free, ~free)] @ x[~free]
                try:
                    x[free] = np.linalg.solve(am[np.ix_(free, free)], rhs)
                except np.linalg.LinAlgError:
                    return False
            with np.errstate(invalid="ignore"):
                up = np.where(free, (x - hi) / scale_over, 0.0)
                down = np.where(free, (lo - x) / scale_over, 0.0)
            past = np.maximum(np.nan_to_num(up, nan=0.0), down)
            worst = int(np.argmax(past))
            if past[worst] > 1e-12:
                side[worst] = 1.0 if up[worst] > down[worst] else -1.0
                continue
            smooth = sign * d.qacc_smooth[dofs]
            acc = smooth + am @ x
            scale = np.abs(b) + np.abs(np.diag(am)) * np.abs(x)
            # a limit row at zero force is freed only past round-off: a joint resting at its
            # limit under a holding motor leaves it at zero (freeing it there is degenerate)
            terms = np.abs(aref) + np.abs(smooth) + np.abs(am * x[None, :]).sum(axis=1)
            tol = np.concatenate([1e-12 * scale[:k], 1e-9 * terms[k:]])
            over_aref = side * (acc - aref)  # > 0: a row at a bound overshoots its aref
            overshoot = np.where(~free & (over_aref > tol), over_aref, 0.0)
            freed = int(np.argmax(overshoot))
            if overshoot[freed] > 0.0:
                side[freed] = 0.0
                same = dofs == dofs[freed]
                if freed >= k:  # a limit row needed on the dof of a free motor row: both would
                    # ask for the same dof's acceleration (a singular block), so the motor
                    # cannot hold its target against the limit and goes to the bound its force
                    # pushes towards
                    for r in np.flatnonzero(same[:k] & (side[:k] == 0)):
                        side[r] = 1.0 if x[r] > 0.0 else -1.0
                else:  # a motor row freed on the dof of a free limit row takes the dof over:
                    # the limit row goes back to zero force (freed again if still needed)
                    side[k:][same[k:] & (side[k:] == 0)] = -1.0
                continue
            break
        else:
            return False
        qacc = d.qacc
        qacc[:] = d.qacc_smooth + (x * sign) @ y
        free_motor = side[:k] == 0
        qacc[dofs[:k][free_motor]] = aref[:k][free_motor]  # their own accelerations, exactly
        d.efc_force[:n] = x
        d.qfrc_constraint[:] = 0.0
        np.add.at(d.qfrc_constraint, dofs, sign * x)
        return True

    def _polish(self, m: Any, d: Any, k: int) -> None:
        """Make every motor row that is not at its force limit reach exactly the acceleration
        it asks for (``efc_aref``), as PyBullet's motor row does: MuJoCo's rows keep a
        regulariser R > 0, so its solution falls short by about R/(A+R) of the change. The
        shortfall r of the free rows is removed with the forces A^-1 r through M^-1 (A the
        rows' inverse inertia); rows at their force limit stay there. The contacts do not
        see this last correction (it is 1e-6 of the motor force)."""
        t = self._motors
        y = t.minv_rows
        mujoco.mj_solveM(m, d, y, t.unit_rows)  # rows of M^-1 for the motor dofs
        force = d.efc_force[:k]
        qacc = d.qacc
        dofs = t.dof_rows
        short = d.efc_aref[:k] - qacc[dofs]
        free = np.abs(force) < t.force_rows_slack
        if free.all():
            delta = np.linalg.solve(y[:, dofs], short)
            qacc += delta @ y
            qacc[dofs] = d.efc_aref[:k]  # the rows' own accelerations, without round-off
            force += delta
        elif free.any():
            rows = np.flatnonzero(free)
            sub = y[rows]
            delta = np.linalg.solve(sub[:, dofs[rows]], short[rows])
            qacc += delta @ sub
            qacc[dofs[rows]] = d.efc_aref[:k][rows]
            force[rows] += delta

    def close(self) -> None:
        if self._closed:
            return
        self._check_idle()
        self._closed = True
        self._close_viewer()
        self._robots.clear()
        self._m = self._d = None  # type: ignore[assignment]

    # ---------------------------------------------------------------- viewer

    def _open_viewer(self) -> None:
        try:
            import mujoco.viewer

            self._viewer = mujoco.viewer.launch_passive(self._m, self._d)
        except Exception as exc:  # noqa: BLE001 - any failure to open a window
            self._viewer = None
            raise DisplayError(self.name, f"mujoco.viewer.launch_passive failed: {exc}") from None

    def _sync_viewer(self) -> None:
        v = self._viewer
        if v.is_running():
            v.sync()

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
        if self._stale:
            m, d = self._m, self._d
            mujoco.mj_kinematics(m, d)
            mujoco.mj_comPos(m, d)
            mujoco.mj_comVel(m, d)
            self._stale = False

    def _com_pose_velocity(self, bid: int) -> tuple[Vec3, Quat, Vec3, Vec3]:
        d = self._d
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, d.ximat[bid])
        vel = np.empty(6)
        mujoco.mj_objectVelocity(self._m, d, mujoco.mjtObj.mjOBJ_BODY, bid, vel, 0)
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
        kernel = self._kernel
        if kernel is not None:
            finite = kernel.body_state(bid, self._stale, self._state_out)
            if finite is None:
                self._engine_failed(kernel.last_error())
            self._stale = False
            if not finite:
                raise SimulationDivergedError(self.name, self.time, f"body {body} pose")
            return self._state_out.tolist()  # type: ignore[no-any-return]
        if self._diverged is not None:
            raise self._diverged
        self._fresh()
        d = self._d
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

    def _joint_cache(self, robot: _Robot, joints: np.ndarray) -> tuple[np.ndarray, ...]:
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
        t = self._motors
        hit = self._torque_map.get(id(joints))
        if hit is not None and hit[0] is joints and hit[1] == t.epoch:
            return hit[2:]  # type: ignore[no-any-return]
        rows = t.row_of[motor]
        on = rows >= 0
        rows = rows[on]
        entry = (joints, t.epoch, rows, np.flatnonzero(movable)[on], len(rows) == len(joints))
        self._torque_map[id(joints)] = entry
        return entry[2:]

    def joint_states(self, body: int, joints: np.ndarray) -> JointStates:
        kernel = self._kernel
        if kernel is not None:
            kernel.check_idle()  # no torn reads of a world stepping in another thread
        elif self._diverged is not None:
            raise self._diverged
        robot = self._robots[body]
        _, movable, qadr, dof, motor, all_movable = self._joint_cache(robot, joints)
        d = self._d
        n = len(joints)
        if self._motor_force_valid and self._motor_rows_valid:
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
        self._d.qpos[qadr] = positions
        self._d.qvel[dof] = velocities
        self._stale = True
        self._motor_force_valid = False

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
        d, m = self._d, self._m
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
        self._stale = True

    # ---------------------------------------------------------------- control

    def _motor_slots(self, body: int, joints: np.ndarray) -> np.ndarray:
        return self._joint_cache(self._robots[body], joints)[4]

    def set_joint_velocity(
        self, body: int, joints: np.ndarray, target: list[float], max_force: list[float]
    ) -> None:
        t = self._motors
        fast = self._fast.get(id(joints))
        if fast is not None and fast[0] is joints and fast[1] == t.epoch and fast[2] == body:
            # Hot path: the same joints, still velocity motors with kd 1, all rows present.
            if target == fast[6] and max_force == fast[7]:
                return  # the command in force already
            if min(max_force) > 0.0:
                kernel = self._kernel
                if kernel is not None:  # the same writes in C (_mjkernel.c set_velocity)
                    kernel.set_velocity(fast[8], target, max_force)
                else:
                    rows, inv_dt = fast[4], self._inv_dt
                    t.target_velocity[fast[3]] = target
                    t.max_force[fast[3]] = max_force
                    self._m.dof_frictionloss[fast[5]] = max_force
                    t.offset_rows[rows] = [v * inv_dt for v in target]
                    t.force_rows_slack[rows] = [f * (1.0 - 1e-9) for f in max_force]
                t.has_offset = True
                self._fast[id(joints)] = (*fast[:6], target, max_force, fast[8])
                return
        idx = self._motor_slots(body, joints)
        t.target_velocity[idx] = target
        t.max_force[idx] = max_force
        t.kp[idx] = 0.0
        t.kd[idx] = 1.0
        self._refresh_motors()
        rows = t.row_of[idx]
        if t.n_special == 0 and not self.profile.enforce_effort_limit and (rows >= 0).all():
            dofs = t.dof[idx]
            self._fast[id(joints)] = (
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
        t = self._motors
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
        self._refresh_motors()

    def set_joint_torque(self, body: int, joints: np.ndarray, torque: list[float]) -> None:
        idx = self._motor_slots(body, joints)
        t = self._motors
        if self.profile.enforce_effort_limit:
            self._torque[idx] += np.clip(torque, -t.effort[idx], t.effort[idx])  # each command
        else:
            self._torque[idx] += torque  # commands before one step add up, as in PyBullet
        self._pending_torque = True

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
                "compiled (backends/_mjkernel.c)"
                if self._kernel is not None
                else f"Python ({mujoco_kernel.reason()})"
            ),
            "departures": departures,
        }
