"""The reads of an MJCF model read as MuJoCo reads it on an engine that is not MuJoCo: the
joint table, MuJoCo's bodies (centres of mass, frames, velocities) and the joint states, all
computed by MuJoCo's own functions from the engine's state (the mirror of
``backends/mjcf_engine.py``), so that a read means on every engine what it means on the MuJoCo
backend; and the writes of one joint's or the base's state. A part of :class:`MjcfOnEngine`
(no engine is imported here).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from simbridge.exceptions import BackendUnsupportedError
from simbridge.model.mjcf_native import NativeBody
from simbridge.transforms import quat_multiply, quat_rotate
from simbridge.types import (
    BaseState,
    DynamicsInfo,
    JointCommands,
    JointInfo,
    JointStateMultiDof,
    JointStates,
    JointType,
    LinkState,
    MotorMode,
    Quat,
    SphericalJointState,
    Vec3,
)

from .locking import exclusive

if TYPE_CHECKING:
    from simbridge.model.mjcf_mirror import Mirror

__all__ = ["MjcfReads"]


def _xyzw(q: np.ndarray) -> Quat:
    return (float(q[1]), float(q[2]), float(q[3]), float(q[0]))


def _wxyz(q: Quat) -> np.ndarray:
    return np.array((q[3], q[0], q[1], q[2]), dtype=np.float64)


def _v(a: Any) -> Vec3:
    return (float(a[0]), float(a[1]), float(a[2]))


def _conj(q: Quat) -> Quat:
    return (-q[0], -q[1], -q[2], q[3])


_COMMANDS = (
    "PyBullet's joint motors and torques under semantics='mujoco'",
    "drive the model's own actuators: Sim.set_actuator_controls",
)


class MjcfReads:
    """The joint table, reads, state writes and refused PyBullet commands of an MJCF read as
    MuJoCo reads it: :class:`~.mjcf_engine.MjcfOnEngine`'s and the MuJoCo backend's
    :class:`~.mujoco.native.NativeMujoco`'s."""

    name: ClassVar[str]
    m: Any
    d: Any
    mirror: Mirror
    _bodies: dict[int, NativeBody]

    if TYPE_CHECKING:  # MjcfOnEngine's and Backend's

        def _sync(self) -> None: ...

        def _write(self, qpos: np.ndarray, qvel: np.ndarray) -> None: ...

        def refuse_fixed_base_velocity(
            self, body: int, linear: Vec3 | None, angular: Vec3 | None
        ) -> None: ...

    # ---------------------------------------------------------------- tables

    def joint_info(self, body: int, joint: int) -> JointInfo:
        """See Backend.joint_info (the rows of :mod:`simbridge.model.mjcf_native`)."""
        return self._bodies[body].table[joint]

    def num_joints(self, body: int) -> int:
        """See Backend.num_joints: one row per MuJoCo joint but the free one."""
        return len(self._bodies[body].table)

    def _link_body(self, body: int, link: int) -> int:
        """The MuJoCo body id a link reads (-1: a massless root's base)."""
        b = self._bodies[body]
        if link < 0:
            return -1 if b.massless_root else b.body_id
        return b.link_bodies[link]

    def dynamics_info(self, body: int, link: int) -> DynamicsInfo:
        """See Backend.dynamics_info: MuJoCo's body mass and inertia, as on the MuJoCo
        backend; the friction of the body's first geom."""
        m = self.m
        bid = self._link_body(body, link)
        if bid < 0:
            return DynamicsInfo(
                0.0, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0, 0, 0, 1.0), 0.0, 0.0, 0.0
            )
        g = int(m.body_geomadr[bid])
        fr = m.geom_friction[g] if g >= 0 else np.zeros(3)
        return DynamicsInfo(
            float(m.body_mass[bid]),
            float(fr[0]),
            _v(m.body_inertia[bid]),
            _v(m.body_ipos[bid]),
            _xyzw(m.body_iquat[bid]),
            0.0,
            float(fr[2]),
            float(fr[1]),
        )

    @exclusive
    def body_centre_of_mass(self, body: int) -> np.ndarray:
        """See Backend.body_centre_of_mass: MuJoCo's ``subtree_com`` of the body's top-level
        MuJoCo body (bodies without a joint row of their own included), of the engine's
        state."""
        self._sync()
        return np.array(self.d.subtree_com[self._bodies[body].body_id])

    # ---------------------------------------------------------------- state (MuJoCo's reads)

    def _com(self, bid: int) -> tuple[Vec3, Quat, Vec3, Vec3]:
        """A MuJoCo body's centre-of-mass pose and velocity (world), from the mirror."""
        pos, q, lin, ang = self.mirror.body_com(bid)
        return _v(pos), (float(q[0]), float(q[1]), float(q[2]), float(q[3])), _v(lin), _v(ang)

    @exclusive
    def base_state(self, body: int) -> BaseState:
        """See Backend.base_state: the top-level body's centre of mass (a massless root: the
        body's frame at qpos0, at rest)."""
        self._sync()
        b = self._bodies[body]
        if b.massless_root:
            m = self.m
            return BaseState(
                _v(m.body_pos[b.body_id]),
                _xyzw(m.body_quat[b.body_id]),
                (0.0, 0.0, 0.0),
                (0.0, 0.0, 0.0),
            )
        return BaseState(*self._com(b.body_id))

    @exclusive
    def link_state(self, body: int, link: int) -> LinkState:
        """See Backend.link_state: the MuJoCo body of row ``link``, from the engine's state."""
        self._sync()
        m, d = self.m, self.d
        bid = self._link_body(body, link)
        pos, orn, lin, ang = self._com(bid)
        return LinkState(
            pos,
            orn,
            _v(m.body_ipos[bid]),
            _xyzw(m.body_iquat[bid]),
            _v(d.xpos[bid]),
            _xyzw(d.xquat[bid]),
            lin,
            ang,
        )

    @exclusive
    def joint_states(self, body: int, joints: np.ndarray) -> JointStates:
        """See Backend.joint_states: ``qpos``/``qvel`` at each joint's address (a ball joint:
        its quaternion's x), and the actuator force MuJoCo's formulas gave the last step."""
        self._sync()
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
        """See Backend.reset_joint_state: ``qpos``/``qvel`` at the joints' addresses."""
        self._sync()
        q, v = self.d.qpos.copy(), self.d.qvel.copy()
        b = self._bodies[body]
        for j, p, w in zip(joints.tolist(), positions, velocities, strict=True):
            row = b.table[j]
            q[row.q_index] = p
            v[row.u_index] = w
        self._write(q, v)

    def keep_fixed_base(
        self,
        body: int,
        position: Vec3 | None,
        orientation: Quat | None,
        linear_velocity: Vec3 | None,
        angular_velocity: Vec3 | None,
    ) -> None:
        """A fixed base keeps the file's place: a pose asked for that is the one it has
        (``Sim.set_state`` of a state of this model, on any engine) is accepted and changes
        nothing; another is refused.

        Args:
            body: The body's id.
            position: The base's centre of mass asked for (m, world), or None.
            orientation: Its orientation asked for (x, y, z, w), or None.
            linear_velocity: Its linear velocity asked for (m/s, world), or None.
            angular_velocity: Its angular velocity asked for (rad/s, world), or None.

        Raises:
            InvalidArgumentError: A velocity that is not 0.
            BackendUnsupportedError: A pose that is not the base's own (within 1e-9).
        """
        self.refuse_fixed_base_velocity(body, linear_velocity, angular_velocity)
        base = self.base_state(body)
        same = (position is None or np.allclose(position, base.position, rtol=0, atol=1e-9)) and (
            orientation is None
            or min(
                float(np.abs(np.subtract(orientation, base.orientation)).max()),
                float(np.abs(np.add(orientation, base.orientation)).max()),
            )
            <= 1e-9
        )
        if not same:
            raise BackendUnsupportedError(
                self.name,
                "moving a fixed base of a model read with semantics='mujoco'",
                "its place is the file's",
            )

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
        of mass's pose and velocity (as the MuJoCo backend does)."""
        b = self._bodies[body]
        if b.free_joint < 0:
            self.keep_fixed_base(body, position, orientation, linear_velocity, angular_velocity)
            return
        self._sync()
        m, d, bid = self.m, self.d, b.body_id
        qa, va = int(m.jnt_qposadr[b.free_joint]), int(m.jnt_dofadr[b.free_joint])
        com_pos, com_orn, lin, ang = self._com(bid)
        pos = np.array(position if position is not None else com_pos)
        qcom = orientation if orientation is not None else com_orn
        qframe = quat_multiply(qcom, _conj(_xyzw(m.body_iquat[bid])))
        offset = np.array(quat_rotate(qframe, _v(m.body_ipos[bid])))
        w = np.array(angular_velocity if angular_velocity is not None else ang)
        v = np.array(linear_velocity if linear_velocity is not None else lin)
        q, qd = d.qpos.copy(), d.qvel.copy()
        q[qa : qa + 3] = pos - offset
        q[qa + 3 : qa + 7] = _wxyz(qframe)
        qd[va : va + 3] = v - np.cross(w, offset)
        qd[va + 3 : va + 6] = quat_rotate(_conj(qframe), _v(w))
        self._write(q, qd)

    # ---------------------------------------------------------------- ball joints
    # A ball joint is a SPHERICAL row; its coordinates are MuJoCo's own: the quaternion that
    # turns the child body's frame from its pose at qpos0 (read x, y, z, w, as simbridge's
    # spherical joints), and the angular velocity relative to the parent in the child body's
    # frame (rad/s). Under this reading those frames are MuJoCo's body frames, not the
    # inertial frames PyBullet's reading uses (the same numbers on every engine).

    @exclusive
    def joint_states_multi_dof(self, body: int, joints: np.ndarray) -> list[JointStateMultiDof]:
        """See Backend.joint_states_multi_dof: MuJoCo's ``qpos``/``qvel`` of each joint (a ball
        joint: its quaternion x, y, z, w and angular velocity, child body frame) and the
        actuator force MuJoCo's formulas gave the last step."""
        self._sync()
        b, d = self._bodies[body], self.d
        out = []
        for j in joints.tolist():
            row = b.table[j]
            qa, va = row.q_index, row.u_index
            if row.type == JointType.SPHERICAL:
                out.append(
                    JointStateMultiDof(
                        _xyzw(d.qpos[qa : qa + 4]),
                        _v(d.qvel[va : va + 3]),
                        _v(d.qfrc_actuator[va : va + 3]),
                    )
                )
            elif row.type == JointType.FIXED:
                out.append(JointStateMultiDof((), (), ()))
            else:
                out.append(
                    JointStateMultiDof(
                        (float(d.qpos[qa]),), (float(d.qvel[va]),), (float(d.qfrc_actuator[va]),)
                    )
                )
        return out

    @exclusive
    def reset_joint_state_multi_dof(
        self,
        body: int,
        joints: np.ndarray,
        positions: list[list[float]],
        velocities: list[list[float]],
    ) -> None:
        """See Backend.reset_joint_state_multi_dof: ``qpos``/``qvel`` at the joints' addresses
        (a ball joint's quaternion x, y, z, w written as MuJoCo's w, x, y, z)."""
        self._sync()
        q, v = self.d.qpos.copy(), self.d.qvel.copy()
        b = self._bodies[body]
        for j, pos, vel in zip(joints.tolist(), positions, velocities, strict=True):
            row = b.table[j]
            qa, va = row.q_index, row.u_index
            if row.type == JointType.SPHERICAL:
                q[qa : qa + 4] = _wxyz((pos[0], pos[1], pos[2], pos[3]))
                v[va : va + 3] = vel[:3]
            else:
                q[qa], v[va] = pos[0], vel[0]
        self._write(q, v)

    @exclusive
    def spherical_states(self, body: int) -> list[SphericalJointState]:
        """See Backend.spherical_states: each ball joint's MuJoCo coordinates (x, y, z, w; the
        angular velocity in the child body's frame) and a released motor (a brake of force 0,
        as :meth:`joint_commands` reads every joint)."""
        self._sync()
        d = self.d
        out = []
        for j, row in enumerate(self._bodies[body].table):
            if row.type != JointType.SPHERICAL:
                continue
            qa, va = row.q_index, row.u_index
            zero = (0.0, 0.0, 0.0)
            out.append(
                SphericalJointState(
                    j,
                    _xyzw(d.qpos[qa : qa + 4]),
                    _v(d.qvel[va : va + 3]),
                    int(MotorMode.VELOCITY),
                    (0.0, 0.0, 0.0, 1.0),
                    zero,
                    zero,
                    (1.0, 1.0, 1.0),
                    zero,
                )
            )
        return out

    @exclusive
    def set_spherical_states(
        self, body: int, states: list[SphericalJointState], positions: bool
    ) -> None:
        """See Backend.set_spherical_states: the positions and velocities (unless a bit-exact
        restore put them back); only released motors and no pending torque.

        Raises:
            BackendUnsupportedError: For a motor with a force, or a pending torque.
        """
        if any(any(e.motor_max_force) or any(e.pending_torque) for e in states):
            raise BackendUnsupportedError(self.name, *_COMMANDS)
        if not positions or not states:
            return
        self._sync()
        q, v = self.d.qpos.copy(), self.d.qvel.copy()
        table = self._bodies[body].table
        for e in states:
            row = table[e.joint]
            q[row.q_index : row.q_index + 4] = _wxyz(e.position)
            v[row.u_index : row.u_index + 3] = e.velocity
        self._write(q, v)

    # ---------------------------------------------------------------- PyBullet's commands
    # Refused under this reading on every engine: the model's own actuators drive it.

    def set_joint_velocity(self, *args: Any, **kwargs: Any) -> None:
        """See Backend.set_joint_velocity.

        Raises:
            BackendUnsupportedError: Always (the model's actuators drive it).
        """
        raise BackendUnsupportedError(self.name, *_COMMANDS)

    def set_joint_position(self, *args: Any, **kwargs: Any) -> None:
        """See Backend.set_joint_position.

        Raises:
            BackendUnsupportedError: Always (the model's actuators drive it).
        """
        raise BackendUnsupportedError(self.name, *_COMMANDS)

    def set_joint_torque(self, *args: Any, **kwargs: Any) -> None:
        """See Backend.set_joint_torque.

        Raises:
            BackendUnsupportedError: Always (the model's actuators drive it).
        """
        raise BackendUnsupportedError(self.name, *_COMMANDS)

    def joint_commands(self, body: int) -> JointCommands:
        """See Backend.joint_commands: every joint reads as a released motor."""
        n = len(self._bodies[body].table)
        z = np.zeros(n)
        return JointCommands(
            np.full(n, int(MotorMode.VELOCITY)), z, z.copy(), z.copy(), np.ones(n), z.copy()
        )

    def set_joint_commands(self, body: int, commands: JointCommands) -> None:
        """See Backend.set_joint_commands: only released motors and no pending torque.

        Raises:
            BackendUnsupportedError: For any motor with a force, or a pending torque.
        """
        if np.asarray(commands.max_force).any() or np.asarray(commands.pending_torque).any():
            raise BackendUnsupportedError(self.name, *_COMMANDS)

    def load(self, *args: Any, **kwargs: Any) -> int:
        """See Backend.load.

        Raises:
            BackendUnsupportedError: Always: a model read with semantics='mujoco' is the whole
                world.
        """
        raise BackendUnsupportedError(
            self.name,
            "loading into a world that holds a model read with semantics='mujoco'",
            "that model is the whole world (its <option>, contacts and ground are MuJoCo's); "
            "reset() the Sim or use another Sim",
        )

    def remove(self, body: int) -> None:
        """See Backend.remove.

        Raises:
            BackendUnsupportedError: Always: the model's bodies are one compiled world.
        """
        raise BackendUnsupportedError(
            self.name,
            "removing one body of a model read with semantics='mujoco'",
            "the model is one compiled world: reset() removes it whole",
        )
