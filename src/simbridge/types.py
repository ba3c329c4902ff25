"""Typed, read-only results, in PyBullet's field order.

Every result is a ``NamedTuple``, so both PyBullet-style positional indexing (``info[12]``) and
named access (``info.link_name``) work. Units are SI (m, rad, kg, s, N, N·m); quaternions are
``(x, y, z, w)``; positions and velocities are in the world frame unless a field says otherwise.
"""

from __future__ import annotations

from enum import IntEnum
from typing import NamedTuple

import numpy as np

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]  # x, y, z, w

__all__ = [
    "JointType",
    "JointInfo",
    "DynamicsInfo",
    "LinkState",
    "BaseState",
    "JointStates",
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
    type: JointType
    q_index: int
    """Index of this joint's first position in the body's state vector (-1 for fixed joints).
    PyBullet's layout: the 7 base coordinates come first, with a fixed base too."""
    u_index: int
    """Index of this joint's first velocity (after the 6 base velocities, -1 for fixed)."""
    flags: int
    damping: float
    """URDF ``<dynamics damping>`` (N·m·s/rad or N·s/m)."""
    friction: float
    """URDF ``<dynamics friction>`` (N·m or N)."""
    lower_limit: float
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
    lateral_friction: float
    local_inertia_diagonal: Vec3
    """Principal moments of inertia in the link's inertial frame (kg·m²)."""
    local_inertial_position: Vec3
    """Centre of mass in the link frame."""
    local_inertial_orientation: Quat
    restitution: float
    rolling_friction: float
    spinning_friction: float


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
    link_frame_position: Vec3
    """World position of the URDF link frame (``worldLinkFramePosition``)."""
    link_frame_orientation: Quat
    linear_velocity: Vec3
    """World linear velocity of the centre of mass (m/s)."""
    angular_velocity: Vec3
    """World angular velocity (rad/s)."""


class BaseState(NamedTuple):
    """The base's centre-of-mass pose and velocity, as ``getBasePositionAndOrientation`` and
    ``getBaseVelocity`` report them (world frame)."""

    position: Vec3
    orientation: Quat
    linear_velocity: Vec3
    angular_velocity: Vec3


class JointStates(NamedTuple):
    """Joint positions, velocities and applied motor torques, each a float array of shape (n,)
    in the order the joints were asked for.

    ``applied_torques`` is the joint motor force of the last step (N·m or N): the velocity or
    position motor's force, or the torque command; PyBullet's ``appliedJointMotorTorque``.
    Fixed joints report 0.
    """

    positions: np.ndarray  # (n,)
    velocities: np.ndarray  # (n,)
    applied_torques: np.ndarray  # (n,)
