"""Typed, read-only results, in PyBullet's field order.

Every result is a ``NamedTuple``, so both PyBullet-style positional indexing (``info[12]``) and
named access (``info.link_name``) work. Units are SI (m, rad, kg, s, N, N·m); quaternions are
``(x, y, z, w)``; positions and velocities are in the world frame unless a field says otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from enum import IntEnum
from typing import Any, NamedTuple

import numpy as np

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]  # x, y, z, w

__all__ = [
    "JointType",
    "JointInfo",
    "DynamicsInfo",
    "LinkState",
    "LinkStates",
    "LINK_STATE_WIDTH",
    "BaseState",
    "JointStates",
    "JointStateMultiDof",
    "ContactPoint",
    "MotorMode",
    "JointCommands",
    "SphericalJointState",
    "ActuatorInfo",
    "SiteState",
    "BodyState",
    "WorldState",
]


class JointType(IntEnum):
    """Joint types with PyBullet's numbers (``p.JOINT_REVOLUTE`` is 0 ...)."""

    REVOLUTE = 0  # URDF revolute and continuous
    PRISMATIC = 1
    SPHERICAL = 2
    PLANAR = 3
    FIXED = 4


class JointInfo(NamedTuple):
    """One row of the joint table: the 17 fields of ``p.getJointInfo``, in its order."""

    index: int  # type: ignore[assignment]  # PyBullet's field name; shadows tuple.index
    """Joint index; joint i moves link i."""
    name: str
    """The joint's name in the file (bytes in PyBullet, a str here)."""
    type: JointType
    """Its type, PyBullet's number (a URDF continuous joint is REVOLUTE)."""
    q_index: int
    """Index of this joint's first position in the body's state vector (-1 for fixed joints).
    PyBullet's layout: the 7 base coordinates come first, with a fixed base too."""
    u_index: int
    """Index of this joint's first velocity (after the 6 base velocities, -1 for fixed)."""
    flags: int
    """1 for revolute and prismatic joints (they carry the default motor), else 0."""
    damping: float
    """URDF ``<dynamics damping>`` (N·m·s/rad or N·s/m)."""
    friction: float
    """URDF ``<dynamics friction>`` (N·m or N)."""
    lower_limit: float
    """Lower position limit (rad or m); see ``upper_limit``."""
    upper_limit: float
    """Position limits. PyBullet reports lower 0, upper -1 when the URDF gives none
    (continuous joints); limits are reported, and enforced only for revolute/prismatic joints
    whose lower <= upper."""
    max_force: float
    """URDF ``<limit effort>``: reported, not applied (PyBullet semantics)."""
    max_velocity: float
    """URDF ``<limit velocity>``: reported, not applied."""
    link_name: str
    """Name of the child link (link i)."""
    axis: Vec3
    """Joint axis in the child link's inertial (centre-of-mass) frame."""
    parent_frame_position: Vec3
    """Joint frame position in the parent's inertial (centre-of-mass) frame."""
    parent_frame_orientation: Quat
    """PyBullet's value: the rotation from the parent's inertial frame into the child's
    inertial frame at zero joint position, (x, y, z, w) (Rc^T·Rj^T·Rp, measured on 3.2.7)."""
    parent_index: int
    """Index of the parent link, -1 for the base."""


class DynamicsInfo(NamedTuple):
    """The first eight fields of ``p.getDynamicsInfo``, in its order."""

    mass: float
    """The link's mass (kg)."""
    lateral_friction: float
    """Coefficient of sliding friction."""
    local_inertia_diagonal: Vec3
    """Principal moments of inertia in the link's inertial frame (kg·m²)."""
    local_inertial_position: Vec3
    """Centre of mass in the link frame."""
    local_inertial_orientation: Quat
    """Orientation of the inertial frame in the link frame (x, y, z, w)."""
    restitution: float
    """Coefficient of restitution."""
    rolling_friction: float
    """Coefficient of rolling friction."""
    spinning_friction: float
    """Coefficient of spinning friction."""


class LinkState(NamedTuple):
    """``p.getLinkState(..., computeLinkVelocity=1, computeForwardKinematics=1)``, in its order.

    Always current: read after ``step`` it describes the state after that step.
    """

    com_position: Vec3
    """World position of the link's centre of mass (PyBullet's ``linkWorldPosition``)."""
    com_orientation: Quat
    """World orientation of the link's inertial frame."""
    local_inertial_position: Vec3
    """Centre of mass in the link frame (as in ``DynamicsInfo``)."""
    local_inertial_orientation: Quat
    """Orientation of the inertial frame in the link frame (x, y, z, w)."""
    link_frame_position: Vec3
    """World position of the URDF link frame (``worldLinkFramePosition``)."""
    link_frame_orientation: Quat
    """World orientation of the URDF link frame (x, y, z, w)."""
    linear_velocity: Vec3
    """World linear velocity of the centre of mass (m/s)."""
    angular_velocity: Vec3
    """World angular velocity (rad/s)."""


LINK_STATE_WIDTH = 27
"""The floats of one :class:`LinkState` laid end to end (3 + 4 + 3 + 4 + 3 + 4 + 3 + 3): a row
of the block a :class:`LinkStates` is made of."""


class LinkStates(NamedTuple):
    """Several links' :class:`LinkState`, one row per link in the order asked for
    (``Sim.link_states``): each field the same quantity as :class:`LinkState`'s, stacked.

    Row k holds the very floats ``Sim.link_state(body, links[k])`` returns (the same engine
    reads, made in one pass). The fields are float64 views of one ``(n, 27)`` block whose rows
    are :class:`LinkState`'s floats end to end (:meth:`of`); quaternions (x, y, z, w).
    """

    com_position: np.ndarray  # (n, 3)
    """(n, 3) m, world: each link's centre of mass (``linkWorldPosition``)."""
    com_orientation: np.ndarray  # (n, 4)
    """(n, 4) x, y, z, w, world: each link's inertial frame."""
    local_inertial_position: np.ndarray  # (n, 3)
    """(n, 3) m: the centre of mass in the link frame."""
    local_inertial_orientation: np.ndarray  # (n, 4)
    """(n, 4) x, y, z, w: the inertial frame in the link frame."""
    link_frame_position: np.ndarray  # (n, 3)
    """(n, 3) m, world: the URDF link frame's origin (``worldLinkFramePosition``)."""
    link_frame_orientation: np.ndarray  # (n, 4)
    """(n, 4) x, y, z, w, world: the URDF link frame."""
    linear_velocity: np.ndarray  # (n, 3)
    """(n, 3) m/s, world: the centre of mass's linear velocity."""
    angular_velocity: np.ndarray  # (n, 3)
    """(n, 3) rad/s, world."""

    @classmethod
    def of(cls, block: np.ndarray) -> LinkStates:
        """The fields of a float64 ``(n, 27)`` block whose rows are :class:`LinkState`'s floats
        end to end (views of it, no copy).

        Args:
            block: ``(n, LINK_STATE_WIDTH)`` float64.

        Returns:
            The :class:`LinkStates` over ``block``.
        """
        return cls(
            block[:, 0:3],
            block[:, 3:7],
            block[:, 7:10],
            block[:, 10:14],
            block[:, 14:17],
            block[:, 17:21],
            block[:, 21:24],
            block[:, 24:27],
        )


class BaseState(NamedTuple):
    """The base's centre-of-mass pose and velocity, as ``getBasePositionAndOrientation`` and
    ``getBaseVelocity`` report them (world frame)."""

    position: Vec3
    """World position of the base's centre of mass (m)."""
    orientation: Quat
    """World orientation of the base's inertial frame (x, y, z, w)."""
    linear_velocity: Vec3
    """World linear velocity of the centre of mass (m/s)."""
    angular_velocity: Vec3
    """World angular velocity (rad/s)."""


class JointStates(NamedTuple):
    """Joint positions, velocities and applied motor torques, each a float array of shape (n,)
    in the order the joints were asked for.

    A spherical joint reports its first coordinate, as ``p.getJointState`` does: the quaternion's
    x, the angular velocity's x, the motor torque about x (all of them:
    :class:`JointStateMultiDof`).

    ``applied_torques`` is the joint motor's force of the last step (N·m or N), PyBullet's
    ``appliedJointMotorTorque``: the velocity or position motor's force (a motor braking the
    joint, the default velocity motor at 0, included). A torque command is not a motor force:
    it is not included, so a torque alone (the motor released with ``max_force=0``) reads 0,
    and a torque held by the default brake reads the brake's force, minus the command. Joint
    damping and limit forces are not included either. Fixed joints report 0 (every backend:
    tests/conformance/test_applied_torques.py).
    """

    positions: np.ndarray  # (n,)
    """(n,) rad or m."""
    velocities: np.ndarray  # (n,)
    """(n,) rad/s or m/s."""
    applied_torques: np.ndarray  # (n,)
    """(n,) N·m or N, the motor's force of the last step (a torque command excluded)."""


class JointStateMultiDof(NamedTuple):
    """One joint's state with all its coordinates: ``p.getJointStateMultiDof`` without the
    reaction forces. Sizes by joint type: revolute and prismatic 1, 1, 1; spherical 4, 3, 3;
    fixed 0, 0, 0.

    A spherical joint's ``position`` is the rotation of the child link's inertial frame from its
    pose at the zero position, as a quaternion (x, y, z, w) in that frame (PyBullet's joint
    quaternion); ``velocity`` is the child's angular velocity relative to the parent, in the
    child's inertial frame (rad/s); ``applied_torque`` the motor's torque per axis of that frame
    during the last step (N·m).
    """

    position: tuple[float, ...]
    """Coordinates: rad or m; a spherical joint's quaternion (x, y, z, w)."""
    velocity: tuple[float, ...]
    """Velocities: rad/s or m/s; a spherical joint's angular velocity."""
    applied_torque: tuple[float, ...]
    """Motor force of the last step: N·m or N, per axis for a spherical joint."""


class ContactPoint(NamedTuple):
    """One contact point of the last step: the 14 fields of ``p.getContactPoints``, in its order.

    The forces are those the last step applied (N, not impulses) at the contact found at the
    start of that step. ``normal_force * normal_on_b + lateral_friction_1 * lateral_friction_dir_1
    + lateral_friction_2 * lateral_friction_dir_2`` is the contact force on A (world frame); on
    B it is the opposite. Raw PyBullet leaves the friction fields as they are when it swaps A and
    B to answer a query; here they follow the order asked for, so that sum is always A's.
    """

    contact_flag: int
    """0 (PyBullet's reserved field)."""
    body_a: int
    """Body id of A."""
    body_b: int
    """Body id of B."""
    link_a: int
    """Link index of A (-1 = base)."""
    link_b: int
    """Link index of B (-1 = base)."""
    position_on_a: Vec3
    """Contact point on A's surface (m, world)."""
    position_on_b: Vec3
    """Contact point on B's surface (m, world)."""
    normal_on_b: Vec3
    """Unit contact normal on B, pointing from B towards A (world):
    ``position_on_a = position_on_b + distance * normal_on_b``."""
    distance: float
    """Signed separation along the normal (m): negative = penetration. Where an engine keeps
    contacts a margin apart (PyBullet's collision margin, the MuJoCo backend's 1 mm pair margin),
    0 is where the contact force starts."""
    normal_force: float
    """Normal force of the last step (N, >= 0)."""
    lateral_friction_1: float
    """Friction force along ``lateral_friction_dir_1`` on A (N)."""
    lateral_friction_dir_1: Vec3
    """First friction direction (unit, world)."""
    lateral_friction_2: float
    """Friction force along ``lateral_friction_dir_2`` on A (N)."""
    lateral_friction_dir_2: Vec3
    """The second friction direction: ``normal_on_b``, dir 1 and dir 2 are orthonormal."""

    def swapped(self) -> ContactPoint:
        """The same contact with A and B exchanged.

        Returns:
            The contact seen from B: positions and links swapped, the normal and the friction
            directions reversed, so the forces stay the forces on the new A.
        """
        n, d1, d2 = self.normal_on_b, self.lateral_friction_dir_1, self.lateral_friction_dir_2
        return ContactPoint(
            self.contact_flag,
            self.body_b,
            self.body_a,
            self.link_b,
            self.link_a,
            self.position_on_b,
            self.position_on_a,
            (-n[0], -n[1], -n[2]),
            self.distance,
            self.normal_force,
            self.lateral_friction_1,
            (-d1[0], -d1[1], -d1[2]),
            self.lateral_friction_2,
            (-d2[0], -d2[1], -d2[2]),
        )


class MotorMode(IntEnum):
    """The motor of a joint, with PyBullet's control-mode numbers; NONE for a fixed joint."""

    NONE = -1
    VELOCITY = 0  # p.VELOCITY_CONTROL (the default brake is one: target 0)
    POSITION = 2  # p.POSITION_CONTROL


class JointCommands(NamedTuple):
    """The commands in force on a body's joints: arrays of shape (n,) over all its joints in
    index order (see :class:`BodyState`, whose motor fields these are)."""

    mode: np.ndarray  # (n,) int, MotorMode values
    """(n,) int, MotorMode values."""
    target: np.ndarray  # (n,) rad/s, m/s (VELOCITY) or rad, m (POSITION)
    """(n,) rad/s or m/s (VELOCITY), rad or m (POSITION)."""
    max_force: np.ndarray  # (n,) N·m or N
    """(n,) N·m or N, the force asked for."""
    kp: np.ndarray  # (n,)
    """(n,) position gains (VELOCITY: 0)."""
    kd: np.ndarray  # (n,)
    """(n,) velocity gains (VELOCITY: 1)."""
    pending_torque: np.ndarray  # (n,) N·m or N
    """(n,) N·m or N, torque commands given since the last step."""


class SphericalJointState(NamedTuple):
    """A spherical joint's part of a :class:`BodyState` (whose arrays hold its first
    coordinate only, as ``joint_states`` does): every coordinate, and its motor per axis of the
    child's inertial frame (see :mod:`simbridge.spherical`)."""

    joint: int
    """The joint's index."""
    position: Quat
    """(x, y, z, w), as ``JointStateMultiDof.position``."""
    velocity: Vec3
    """rad/s, in the child's inertial frame."""
    motor_mode: int
    """MotorMode.POSITION (towards ``motor_target``) or VELOCITY (a brake: kp 0, kd 1)."""
    motor_target: Quat
    """The position motor's target (x, y, z, w); the identity for a brake."""
    motor_max_force: Vec3
    """N·m per axis (0: that axis released)."""
    motor_kp: Vec3
    """Position gain per axis."""
    motor_kd: Vec3
    """PyBullet's ``damping`` per axis."""
    pending_torque: Vec3
    """N·m, the torques given since the last step (they act during the next one)."""


class BodyState(NamedTuple):
    """One body's part of a :class:`WorldState`. Arrays are float64 of shape (n,) over all the
    body's joints in index order (fixed joints: 0, mode NONE).

    The motor in force per joint is PyBullet's motor: VELOCITY drives towards ``motor_target``
    (rad/s or m/s) with ``motor_kd`` = 1 and ``motor_kp`` = 0; POSITION towards
    ``motor_target`` (rad or m) with gains ``motor_kp``, ``motor_kd``; both limited to
    ``motor_max_force`` (N·m or N, 0 = released). The default brake is VELOCITY, target 0. A
    position command with kp 0 is the same row as a velocity command with target 0 and may read
    back as one."""

    body: int
    """The body's id in the Sim the state was taken from."""
    name: str
    """``<robot name>``."""
    joint_names: tuple[str, ...]
    """Every joint's name, in index order."""
    base_position: Vec3
    """The base's centre of mass (m, world), as :class:`BaseState`."""
    base_orientation: Quat
    """The base's inertial frame (x, y, z, w, world)."""
    base_linear_velocity: Vec3
    """m/s, world."""
    base_angular_velocity: Vec3
    """rad/s, world."""
    joint_positions: np.ndarray  # (n,)
    """(n,) rad or m."""
    joint_velocities: np.ndarray  # (n,)
    """(n,) rad/s or m/s."""
    motor_mode: np.ndarray  # (n,) int, MotorMode values
    """(n,) int, MotorMode values."""
    motor_target: np.ndarray  # (n,)
    """(n,) rad/s or m/s (VELOCITY), rad or m (POSITION)."""
    motor_max_force: np.ndarray  # (n,)
    """(n,) N·m or N (0 = released)."""
    motor_kp: np.ndarray  # (n,)
    """(n,) position gains."""
    motor_kd: np.ndarray  # (n,)
    """(n,) velocity gains."""
    pending_torque: np.ndarray
    """(n,) torque commands given since the last step (they act during the next one)."""
    spherical: tuple[SphericalJointState, ...] = ()
    """Every spherical joint's full state and motor, in joint order (its entries in the arrays
    above are its first coordinate and first axis)."""


@dataclass(frozen=True, eq=False)
class WorldState:
    """Everything ``Sim.set_state`` needs to put a world back where it was: the time and, per
    body in load order, its :class:`BodyState`. Returned by ``Sim.get_state``.

    ``native`` is the engine's own data (MuJoCo: qpos, qvel and the solver's warm start;
    PyBullet: a ``saveState`` snapshot with its contact caches) that makes a restore into the
    same world bit-exact; it is never used by another engine or world. :meth:`portable` drops
    it: what another engine would get (the one-step error floor of a state carried across).
    """

    backend: str
    timestep: float
    time: float
    bodies: tuple[BodyState, ...]
    native: Any = field(default=None, repr=False)

    def portable(self) -> WorldState:
        """This state without the engine's own data.

        Returns:
            A copy with ``native`` None: what another engine or world can take.
        """
        return replace(self, native=None)


class ActuatorInfo(NamedTuple):
    """One MuJoCo actuator of a model loaded with ``load_mjcf(..., semantics="mujoco")``
    (``Sim.actuators()``), as MuJoCo compiled it."""

    index: int  # type: ignore[assignment]  # shadows tuple.index, as JointInfo's
    """Its index in MuJoCo's ``ctrl`` (``Sim.set_actuator_controls`` takes it)."""
    name: str
    """Its name in the file (``actuator<index>`` when unnamed)."""
    transmission: str
    """MuJoCo's transmission type: ``"joint"``, ``"jointinparent"``, ``"tendon"``,
    ``"site"``, ``"slidercrank"``, ``"body"`` or ``"so3"``."""
    target: str
    """The name of the joint (tendon, site or body) it drives; ``""`` when unnamed."""
    gear: tuple[float, float, float, float, float, float]
    """MuJoCo's ``gear`` (the first entry scales a joint actuator's force)."""
    ctrl_range: tuple[float, float] | None
    """``ctrlrange`` where ``ctrllimited`` (MuJoCo clamps ``ctrl`` to it at every step), else
    None."""
    force_range: tuple[float, float] | None
    """``forcerange`` where ``forcelimited`` (N·m or N), else None."""
    dynamics: str
    """MuJoCo's ``dyntype`` in lower case: ``"none"``, ``"integrator"``, ``"filter"``,
    ``"filterexact"``, ``"muscle"``... (MuJoCo's ``mjtDyn``)."""
    gain: str
    """``gaintype`` in lower case: ``"fixed"``, ``"affine"``, ``"muscle"``... (``mjtGain``)."""
    gain_params: tuple[float, float, float]
    """The first three of ``gainprm`` (a motor: (1, 0, 0); a position actuator: (kp, 0, 0))."""
    bias: str
    """``biastype`` in lower case: ``"none"``, ``"affine"``, ``"muscle"``... (``mjtBias``)."""
    bias_params: tuple[float, float, float]
    """The first three of ``biasprm`` (a position actuator: (0, -kp, -kv))."""


class SiteState(NamedTuple):
    """A MuJoCo site's pose as it stands now (``Sim.site``)."""

    position: Vec3
    """m, world."""
    orientation: Quat
    """(x, y, z, w), world."""
