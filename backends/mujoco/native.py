"""An MJCF model run as MuJoCo runs it (``load_mjcf(source, semantics="mujoco")``).

:class:`NativeMujoco` holds the compiled model (:mod:`simbridge.model.mjcf_native`) as the
whole world and steps it with ``mujoco.mj_step``, nothing else: MuJoCo's integrator (RK4
included), actuators, damping, armature and contacts, bit for bit raw MuJoCo under the same
controls. No profile entry applies (no link damping, no default motors); the file's
``<option>`` gives gravity and the time step unless the Sim was given them. The reads are
simbridge's (centre-of-mass frames, quaternions x, y, z, w) computed from MuJoCo's data with
``mj_kinematics``/``mj_comPos``/``mj_comVel`` (and ``mj_forward`` for sensors), which write no
quantity ``mj_step`` reads: reading never changes a trajectory.

With ``gui`` MuJoCo's passive viewer shows the compiled model (:class:`~.window.Viewer`, the
window in a process of its own as for ``Sim("mujoco", gui=True)``): it takes each new state
after a ``step`` call or a write, and ``close()`` ends it.
"""

from __future__ import annotations

import threading
from typing import Any

import mujoco
import numpy as np

from simbridge.backend import Backend
from simbridge.exceptions import SimBusyError, SimulationDivergedError
from simbridge.model.mjcf_native import NativeBody, NativeMjcf, bad_coordinate, coordinate_name
from simbridge.profiles import Profile
from simbridge.types import (
    ContactPoint,
    JointStates,
    JointType,
    Quat,
    Vec3,
)

from .. import locking
from ..locking import exclusive, wait_for_lock
from ..mjcf_reads import MjcfReads
from .contacts import contact_points_of
from .window import Viewer, check_display

__all__ = ["NativeMujoco"]

_STATE = mujoco.mjtState.mjSTATE_INTEGRATION
# MuJoCo's warnings after which mj_step resets the data, and the vector whose address each
# one's lastinfo is (mj_checkPos, mj_checkVel, mj_checkAcc)
_BAD = (
    (mujoco.mjtWarning.mjWARN_BADQPOS, "qpos"),
    (mujoco.mjtWarning.mjWARN_BADQVEL, "qvel"),
    (mujoco.mjtWarning.mjWARN_BADQACC, "qacc"),
)


def _xyzw(q: np.ndarray) -> Quat:
    return (float(q[1]), float(q[2]), float(q[3]), float(q[0]))


def _wxyz(q: Quat) -> np.ndarray:
    return np.array((q[3], q[0], q[1], q[2]), dtype=np.float64)


def _v(a: np.ndarray) -> Vec3:
    return (float(a[0]), float(a[1]), float(a[2]))


class NativeMujoco(MjcfReads, Backend):
    """The world of one MJCF model as MuJoCo compiles and steps it.

    Args:
        profile: The Sim's profile; only its gravity and time step are read, and only where
            the Sim was given them.
        native: The compiled model; this backend takes its ``MjModel`` over.
        gravity: The gravity the caller gave the Sim (m/s², world), or None for the file's.
        timestep: The time step the caller gave the Sim (s), or None for the file's.
        gui: Whether to show the model in MuJoCo's passive viewer (a process of its own).

    Raises:
        DisplayError: With ``gui`` where no window can open.
    """

    name = "mujoco"

    def __init__(
        self,
        profile: Profile,
        native: NativeMjcf,
        gravity: Vec3 | None = None,
        timestep: float | None = None,
        gui: bool = False,
    ) -> None:
        if gui:
            check_display(self.name)
        m = native.model
        if gravity is not None:
            m.opt.gravity[:] = gravity
        if timestep is not None:
            m.opt.timestep = timestep
        super().__init__(
            profile.with_(gravity=_v(m.opt.gravity), timestep=float(m.opt.timestep)), gui
        )
        self.native = native
        self.m = m
        self.d = mujoco.MjData(m)
        # the window on the compiled model (its own process), shown each new state
        self._viewer: Viewer | None = Viewer(self.name, m, self.d) if gui else None
        self._bodies: dict[int, NativeBody] = dict(enumerate(native.bodies))
        self._stepping = threading.RLock()
        self._in_step = False
        self._closed = False
        self._stale = True
        self._left_by_step = False
        self._diverged: SimulationDivergedError | None = None
        self._geom_owners: tuple[list[int], list[int]] | None = None
        self._body_rows: tuple[np.ndarray, np.ndarray] | None = None  # per MuJoCo body
        # d.cfrc_ext: "zero" (no step since a reset or restore), "pending" (a step since,
        # mj_rnePostConstraint not run yet) or "ready"; _forces_asked: computed before
        # anything overwrites what the step left (the first body_external_forces sets it)
        self._forces = "zero"
        self._forces_asked = False
        # d.xpos as mj_step left it (xpos()): kept before a read refreshes the kinematics once
        # xpos() has been asked; _left_by_step: no write since the last step
        self._step_xpos: np.ndarray | None = None
        self._xpos_asked = False

    reading = locking.reading

    # ---------------------------------------------------------------- world

    @property
    def time(self) -> float:
        """See Backend.time. MuJoCo's ``d.time``."""
        if self._closed:
            from simbridge.exceptions import SimClosedError

            raise SimClosedError()
        return float(self.d.time)

    @exclusive
    def reset(self) -> None:
        """See Backend.reset. Never reached: the Sim replaces this backend at ``reset()``."""
        mujoco.mj_resetData(self.m, self.d)
        self._stale = True
        self._left_by_step = False
        self._forces = "zero"
        self._show()
        self._diverged = None

    def step(self, n: int) -> None:
        """See Backend.step.

        MuJoCo: ``mujoco.mj_step(m, d, nstep=n)``, the model's own integrator; MuJoCo's
        bad-position, bad-velocity or bad-acceleration warning (a value not finite or beyond
        1e10, after which it resets the data), or a state that turned non-finite, raises
        SimulationDivergedError naming the coordinate's joint and body.
        """
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        if self._in_step:
            lock.release()
            raise SimBusyError()
        self._in_step = True
        try:
            if self._diverged is not None:
                raise self._diverged
            if n <= 0:
                return
            d = self.d
            warned = [int(d.warning[w].number) for w, _ in _BAD]
            end = float(d.time) + n * float(self.m.opt.timestep)
            mujoco.mj_step(self.m, d, nstep=n)
            self._stale = True
            self._forces = "pending"
            self._left_by_step, self._step_xpos = True, None
            self._show()
            for (w, vector), before in zip(_BAD, warned, strict=True):
                if int(d.warning[w].number) != before:  # MuJoCo reset the data after it
                    where = coordinate_name(self.m, vector, int(d.warning[w].lastinfo))
                    # the reset put time at 0 and the steps after it went on from there: the
                    # (last) bad step ended at the end's time less theirs
                    dt = float(self.m.opt.timestep)
                    self._diverged = SimulationDivergedError(
                        self.name,
                        end - float(d.time) + dt,
                        f"MuJoCo's {where}",
                        why="was not finite or beyond 1e10 (mjMAXVAL): MuJoCo reset its data",
                    )
                    raise self._diverged
            bad = bad_coordinate(self.m, d.qpos, d.qvel)
            if bad is not None:
                self._diverged = SimulationDivergedError(
                    self.name, float(d.time), f"MuJoCo's {bad}", why="is not finite"
                )
                raise self._diverged
        finally:
            self._in_step = False
            lock.release()

    def close(self) -> None:
        """See Backend.close: the viewer, if any, ends (killed after ``CLOSE_WAIT_S``)."""
        self._closed = True
        viewer, self._viewer = self._viewer, None
        if viewer is not None:
            viewer.close()

    def _show(self) -> None:
        """Give the viewer, if any, the state as it stands (``d.qpos``)."""
        if self._viewer is not None:
            self._viewer.sync()

    def _sync(self) -> None:
        """Poses and velocities of the state as it stands (writes nothing mj_step reads)."""
        if self._stale:
            m, d = self.m, self.d
            self._keep_step_left()
            mujoco.mj_kinematics(m, d)
            mujoco.mj_comPos(m, d)
            mujoco.mj_comVel(m, d)
            self._stale = False

    @exclusive
    def contact_points(self) -> list[ContactPoint]:
        """See Backend.contact_points: MuJoCo's ``d.contact`` of the last step, as the
        MuJoCo backend gives it (:func:`~.contacts.contact_points_of`). A geom of a body that
        has no joint row of its own belongs to the nearest ancestor's link; the world's own
        geoms (the file's floor) to body -1, link -1."""
        if self._diverged is not None:
            raise self._diverged
        owner, link = self._owners()
        return contact_points_of(self.m, self.d, owner, link)

    def _owners(self) -> tuple[list[int], list[int]]:
        """Per geom: its simbridge body (-1: the world's) and link (-1: the base), as lists
        (:func:`~.contacts.contact_points_of` looks them up per contact)."""
        if self._geom_owners is None:
            m = self.m
            body_of, link_of = self._rows()
            self._geom_owners = (
                body_of[m.geom_bodyid].tolist(),
                link_of[m.geom_bodyid].tolist(),
            )
        return self._geom_owners

    def _keep_step_left(self) -> None:
        """Before the kinematics are refreshed: what the last step left that was asked for
        (``cfrc_ext``, ``xpos``), from the data as ``mj_step`` left it."""
        if self._forces_asked:
            self._post_step_forces()
        if self._xpos_asked and self._left_by_step and self._step_xpos is None:
            self._step_xpos = self.d.xpos.copy()

    @exclusive
    def xpos(self) -> np.ndarray:
        """See Backend.xpos: after a step, ``d.xpos`` as ``mj_step`` left it (kept before any
        read refreshes the kinematics once this has been asked; the first call after such a
        read gives the refreshed one); after a write, of the state written."""
        if self._diverged is not None:
            raise self._diverged
        self._xpos_asked = True
        if self._left_by_step:
            if self._step_xpos is not None:
                return self._step_xpos.copy()
            if self._stale:
                return self.d.xpos.copy()
        self._sync()
        return self.d.xpos.copy()

    def _post_step_forces(self) -> None:
        """``d.cfrc_ext`` of the last step: ``mj_rnePostConstraint`` once after it, on the
        contacts, constraint forces and kinematics ``mj_step`` left (RK4: its last stage's), as
        Gymnasium's MuJoCo envs call it after ``mj_step``."""
        if self._forces == "pending":
            mujoco.mj_rnePostConstraint(self.m, self.d)
            self._forces = "ready"

    @exclusive
    def body_external_forces(self) -> np.ndarray:
        """See Backend.body_external_forces: a copy of ``d.cfrc_ext`` after
        ``mj_rnePostConstraint`` (run once per step, before any read refreshes the kinematics
        once this has been asked; the first call after a read did is computed on the
        refreshed kinematics: its torques about the tree's centre of mass of the state, not of
        RK4's last stage)."""
        if self._diverged is not None:
            raise self._diverged
        self._forces_asked = True
        if self._forces == "zero":
            return np.zeros((self.m.nbody, 6))
        self._post_step_forces()
        return self.d.cfrc_ext.copy()

    def external_forces(self, body: int) -> np.ndarray:
        """See Backend.external_forces: MuJoCo's ``cfrc_ext`` (:meth:`body_external_forces`),
        each link's row the sum of its MuJoCo body's and those of the bodies without a joint
        row of their own that hang from it (their torques about the same point: the tree's
        centre of mass)."""
        rows = self.body_external_forces()
        body_of, link_of = self._rows()
        out = np.zeros((len(self._bodies[body].table) + 1, 6))
        mine = np.flatnonzero(body_of == body)
        np.add.at(out, link_of[mine] + 1, rows[mine])
        return out

    def _rows(self) -> tuple[np.ndarray, np.ndarray]:
        """Per MuJoCo body: its simbridge body (-1: the world's) and link (-1: the base)."""
        if self._body_rows is None:
            m = self.m
            body_of = np.full(m.nbody, -1, np.intp)
            link_of = np.full(m.nbody, -1, np.intp)
            for i, b in self._bodies.items():
                for row, mb in enumerate(b.link_bodies):
                    link_of[mb] = row
                for mb in range(1, m.nbody):
                    if m.body_rootid[mb] == b.body_id:
                        body_of[mb] = i
            for mb in range(1, m.nbody):  # a body without a row: its parent's link
                if link_of[mb] < 0 and m.body_parentid[mb] > 0:
                    link_of[mb] = link_of[m.body_parentid[mb]]
            self._body_rows = (body_of, link_of)
        return self._body_rows

    # ---------------------------------------------------------------- state
    # The joint table, base_state, link_state and dynamics_info are MjcfReads' (the other
    # engines' reads of this reading): they read this backend's own MjData, kept fresh by
    # _sync, through _com below.

    def _com(self, bid: int) -> tuple[Vec3, Quat, Vec3, Vec3]:
        """A MuJoCo body's centre-of-mass pose and velocity (world), from the backend's own
        ``MjData`` (MjcfReads' reads call it)."""
        d = self.d
        q = np.empty(4)
        mujoco.mju_mat2Quat(q, d.ximat[bid])
        vel = np.empty(6)
        mujoco.mj_objectVelocity(self.m, d, mujoco.mjtObj.mjOBJ_BODY, bid, vel, 0)
        return _v(d.xipos[bid]), _xyzw(q), _v(vel[3:]), _v(vel[:3])

    @exclusive
    def joint_states(self, body: int, joints: np.ndarray) -> JointStates:
        """See Backend.joint_states: ``qpos``/``qvel`` at each joint's address (a ball joint:
        its quaternion's x, as PyBullet's first coordinate), ``qfrc_actuator`` of the last
        step."""
        b, d = self._bodies[body], self.d
        n = len(joints)
        pos, vel, tau = np.zeros(n), np.zeros(n), np.zeros(n)
        for k, j in enumerate(joints.tolist()):
            row = b.table[j]
            qa = row.q_index + (1 if row.type == JointType.SPHERICAL else 0)
            pos[k] = d.qpos[qa]
            vel[k] = d.qvel[row.u_index]
            tau[k] = d.qfrc_actuator[row.u_index]
        return JointStates(pos, vel, tau)

    @exclusive
    def reset_joint_state(
        self, body: int, joints: np.ndarray, positions: list[float], velocities: list[float]
    ) -> None:
        """See Backend.reset_joint_state: writes ``qpos``/``qvel`` at the joints' addresses."""
        b, d = self._bodies[body], self.d
        for j, q, v in zip(joints.tolist(), positions, velocities, strict=True):
            row = b.table[j]
            d.qpos[row.q_index] = q
            d.qvel[row.u_index] = v
        self._stale = True
        self._left_by_step = False
        self._show()

    @exclusive
    def reset_base_state(
        self,
        body: int,
        position: Vec3 | None,
        orientation: Quat | None,
        linear_velocity: Vec3 | None,
        angular_velocity: Vec3 | None,
    ) -> None:
        """See Backend.reset_base_state: the free joint's ``qpos``/``qvel`` from the centre
        of mass's pose and velocity (MuJoCo's free joint holds the body frame's origin and
        its angular velocity in the body frame)."""
        b = self._bodies[body]
        if b.free_joint < 0:
            self.keep_fixed_base(body, position, orientation, linear_velocity, angular_velocity)
            return
        self._sync()
        m, d, bid = self.m, self.d, b.body_id
        qa, va = int(m.jnt_qposadr[b.free_joint]), int(m.jnt_dofadr[b.free_joint])
        com_pos, com_orn, lin, ang = self._com(bid)
        pos = np.array(position if position is not None else com_pos)
        qcom = _wxyz(orientation if orientation is not None else com_orn)
        qframe = np.empty(4)
        inv = np.empty(4)
        mujoco.mju_negQuat(inv, m.body_iquat[bid])
        mujoco.mju_mulQuat(qframe, qcom, inv)
        offset = np.empty(3)  # frame origin -> centre of mass, world
        mujoco.mju_rotVecQuat(offset, m.body_ipos[bid], qframe)
        w = np.array(angular_velocity if angular_velocity is not None else ang)
        v = np.array(linear_velocity if linear_velocity is not None else lin)
        d.qpos[qa : qa + 3] = pos - offset
        d.qpos[qa + 3 : qa + 7] = qframe
        d.qvel[va : va + 3] = v - np.cross(w, offset)
        local = np.empty(3)
        mujoco.mju_rotVecQuat(local, w, np.array((qframe[0], *(-qframe[1:]))))
        d.qvel[va + 3 : va + 6] = local
        self._stale = True
        self._left_by_step = False
        self._show()

    def _write(self, qpos: np.ndarray, qvel: np.ndarray) -> None:
        """Put ``d.qpos``/``d.qvel`` as given (MjcfReads' writes of a ball joint's state)."""
        self.d.qpos[:] = qpos
        self.d.qvel[:] = qvel
        self._stale = True
        self._left_by_step = False
        self._show()

    # ---------------------------------------------------------------- whole state

    @exclusive
    def snapshot(self) -> Any:
        """See Backend.snapshot: ``mj_getState`` (``mjSTATE_INTEGRATION``: time, qpos, qvel,
        act, warm start, ctrl, applied forces)."""
        state = np.empty(mujoco.mj_stateSize(self.m, _STATE))
        mujoco.mj_getState(self.m, self.d, state, _STATE)
        return (id(self.m), state)

    @exclusive
    def restore(self, native: Any) -> bool:
        """See Backend.restore: ``mj_setState`` for a snapshot of this model; otherwise a cold
        solver start."""
        self._forces = "zero"  # until the next step, however the state is set
        if not (isinstance(native, tuple) and len(native) == 2 and native[0] == id(self.m)):
            self.d.qacc_warmstart[:] = 0.0
            return False
        mujoco.mj_setState(self.m, self.d, native[1], _STATE)
        self._stale = True
        self._left_by_step = False
        self._show()
        return True

    @exclusive
    def set_time(self, time: float) -> None:
        """See Backend.set_time: ``d.time``, to the nearest whole step."""
        dt = float(self.m.opt.timestep)
        self.d.time = round(time / dt) * dt

    def manifest(self) -> dict[str, Any]:
        """See Backend.manifest: MuJoCo's reading, with the options in force."""
        m = self.m
        return {
            "backend": self.name,
            "engine_version": mujoco.__version__,
            "semantics": "mujoco",
            "model": self.native.display_name,
            "option": {
                "timestep": float(m.opt.timestep),
                "gravity": _v(m.opt.gravity),
                "integrator": mujoco.mjtIntegrator(int(m.opt.integrator)).name,
            },
            "sizes": {"nq": m.nq, "nv": m.nv, "nu": m.nu, "nbody": m.nbody},
            "departures": {
                "profile": "no profile entry applies under semantics='mujoco' but gravity "
                "and the time step the Sim was given: the model is MuJoCo's"
            },
        }

    # ---------------------------------------------------------------- MuJoCo's own calls

    @exclusive
    def set_actuator_controls(self, actuators: np.ndarray, values: list[float]) -> None:
        """See Backend.set_actuator_controls: ``d.ctrl`` (MuJoCo clamps it to ``ctrlrange``
        at each step)."""
        self.d.ctrl[actuators] = values

    @exclusive
    def actuator_controls(self) -> np.ndarray:
        """See Backend.actuator_controls: a copy of ``d.ctrl``."""
        return self.d.ctrl.copy()

    @exclusive
    def generalized_state(self) -> tuple[np.ndarray, np.ndarray]:
        """See Backend.generalized_state: copies of ``d.qpos``, ``d.qvel``."""
        return self.d.qpos.copy(), self.d.qvel.copy()

    @exclusive
    def set_generalized_state(self, qpos: np.ndarray | None, qvel: np.ndarray | None) -> None:
        """See Backend.set_generalized_state: writes ``d.qpos``/``d.qvel`` as given."""
        if qpos is not None:
            self.d.qpos[:] = qpos
        if qvel is not None:
            self.d.qvel[:] = qvel
        self._stale = True
        self._left_by_step = False
        self._show()

    @exclusive
    def reset_keyframe(self, key: int) -> None:
        """See Backend.reset_keyframe: ``mj_resetDataKeyframe`` (time, qpos, qvel, act,
        ctrl, mocap of the key)."""
        mujoco.mj_resetDataKeyframe(self.m, self.d, key)
        self._stale = True
        self._left_by_step = False
        self._forces = "zero"
        self._show()
        self._diverged = None

    @exclusive
    def sensor_data(self, sensor: int) -> np.ndarray:
        """See Backend.sensor_data: ``d.sensordata`` of the state as it stands
        (``mj_forward``, which leaves the next step's result unchanged)."""
        m, d = self.m, self.d
        if self._stale:
            self._keep_step_left()  # before mj_forward computes it all afresh
        mujoco.mj_forward(m, d)
        self._stale = False
        a, n = int(m.sensor_adr[sensor]), int(m.sensor_dim[sensor])
        return d.sensordata[a : a + n].copy()

    @exclusive
    def site_pose(self, site: int) -> tuple[Vec3, Quat]:
        """See Backend.site_pose: ``site_xpos`` and ``site_xmat`` as a quaternion."""
        self._sync()
        q = np.empty(4)
        mujoco.mju_mat2Quat(q, self.d.site_xmat[site])
        return _v(self.d.site_xpos[site]), _xyzw(q)
