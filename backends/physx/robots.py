"""The robots of one PhysX world: what the backend keeps of each body between calls."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from simbridge.model.urdf import UrdfModel
from simbridge.profiles import Profile
from simbridge.types import JointInfo, JointType

from .model import BuiltRobot

__all__ = ["Robot", "default_motors", "SPHERICAL_BRAKE_KP", "SPHERICAL_BRAKE_IMPULSE"]

SPHERICAL_BRAKE_KP = 0.2  # PyBullet's spherical joint motor at load
SPHERICAL_BRAKE_IMPULSE = 1000.0  # N·m·s per step per axis


@dataclass(eq=False)
class Robot:
    """One body: its model, joint table, PhysX objects and motor table.

    ``dof[j]`` is the first entry of joint ``j`` in the articulation's ``qpos``/``qvel`` (-1 for
    a fixed joint); ``movable`` the movable 1-DoF and spherical joints in index order. The motor
    arrays run over ``movable``."""

    id: int
    model: UrdfModel
    built: BuiltRobot
    table: list[JointInfo]
    fixed: bool
    movable: list[int]
    dof: np.ndarray
    ndof: int
    joints: list[Any]  # PhysxArticulationJoint per URDF joint (None for a static body)
    motors: dict[str, np.ndarray] = field(default_factory=dict)
    pending: bool = False  # a torque waits for the next step
    slot: dict[int, int] = field(default_factory=dict)  # joint -> index in the motor arrays
    damping: np.ndarray | None = None  # <dynamics damping> per dof where the profile applies it
    qf_set: bool = False  # joint forces were handed to PhysX for the coming step
    # the joint forces (per dof, float32 as PhysX took them) of the last step: the torque
    # commands and <dynamics damping>, which joint_states takes off the joint's incoming force,
    # so that it reads the motor's force alone (PyBullet's appliedJointMotorTorque); None: none
    step_qf: np.ndarray | None = None
    drive_force: list[float] = field(default_factory=list)  # per slot, as set (NaN: not yet)
    has_position: bool = False  # a position motor needs its velocity target every step
    # the slots array of the last velocity command while nothing else has changed a motor's
    # mode or gains since: those slots are velocity motors with kp 0 and kd 1 already
    velocity_slots: np.ndarray | None = None
    # the commands' shortcuts (commands.py), per joints array (keyed by its id; a few at most):
    # velocity: (joints array, max_force as given, slots as a list, their PhysX joints);
    # position: (joints array, max_force, kp, kd as given, slots as a list). Each stands while
    # no other command has changed a motor of its slots: a velocity or position command drops
    # every plan that shares a slot with it, set_joint_commands all of them. Made only where
    # every slot is a distinct 1-DoF joint driven (force > 0)
    velocity_plans: dict[int, tuple[np.ndarray, list[float], list[int], list[Any]]] = field(
        default_factory=dict
    )
    position_plans: dict[
        int, tuple[np.ndarray, list[float], list[float], list[float], list[int]]
    ] = field(default_factory=dict)
    moving_links: list[Any] = field(default_factory=list)  # the links not welded to the world
    moving_rows: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.intp))  # theirs
    ball_dofs: dict[int, tuple[int, int, int]] = field(default_factory=dict)  # spherical joints
    dof_joint: dict[int, Any] = field(default_factory=dict)  # dof -> its PhysX joint
    balls: dict[int, dict[str, Any]] = field(default_factory=dict)  # spherical joints' motors
    read_cache: dict[int, tuple[np.ndarray, Any]] = field(default_factory=dict)
    base_inverse: Any = None  # the base's link frame in its centre-of-mass frame, once asked
    joint_cache: dict[int, tuple[np.ndarray, list[Any]]] = field(default_factory=dict)
    slot_cache: dict[int, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    call_cache: dict[int, tuple[np.ndarray, Any]] = field(default_factory=dict)
    # per motor slot, the range a position target is clamped into (-inf, inf: no limit)
    target_lo: np.ndarray = field(default_factory=lambda: np.zeros(0))
    target_hi: np.ndarray = field(default_factory=lambda: np.zeros(0))
    # spherical joints with PyBullet's swing/twist <limit>, which the stand-in does not enforce
    unlimited_spherical: list[str] = field(default_factory=list)
    # PyBullet's link damping for the coming step, one call made once (commands.py _damper;
    # None where the profile has none), and whether the step has nothing else to do before it
    damper: Callable[[], None] | None = None
    damping_only: bool = False
    # after an exact restore, until the next step or write: every link's (linear, angular)
    # velocity as PhysX reported it when the snapshot was taken, shape (links, 2, 3) float32.
    # PhysX recomputes link velocities from the joint velocities at unpack, and those differ
    # from the ones its step left (backend.DEPARTURES["snapshot"]); the link damping law and
    # link_state read these instead, so that the next step is the uninterrupted one
    restored_velocities: np.ndarray | None = None
    # the limited 1-DoF joints (limits.py): (dof, PhysX joint, lower, upper) as PhysX holds
    # them, and per joint its limits; whether a joint is past its limit (the step stands in
    # for PyBullet's limit row) and which rows' PhysX limits are moved meanwhile
    limit_rows: list[tuple[int, Any, float, float]] = field(default_factory=list)
    limit_of: list[tuple[float, float]] = field(default_factory=list)  # per joint (-inf, inf)
    past_limit: bool = False
    # limit_rule "pybullet": PhysX's own limits this far out of the range (0: "hard", PhysX's)
    limit_clear: float = 0.0
    pinocchio: Any = None  # SAPIEN's Pinocchio model of the articulation, made when needed
    moved: set[int] = field(default_factory=set)
    # this step's rows (dof, the moved bound, the row's speed, 1 upper or -1 lower, 2 float32
    # steps at the bound), for the fix after the step
    held: list[tuple[int, float, float, float, float]] = field(default_factory=list)

    @property
    def static(self) -> bool:
        return self.built.static

    def slot_calls(
        self, slots: np.ndarray, effort: np.ndarray, ball: np.ndarray
    ) -> tuple[list[int], list[Any], list[float], list[bool]]:
        """Motor ``slots`` as Python values (cached per slots array; all of it fixed at load).

        Args:
            slots: (n,) ``np.intp`` motor slots.
            effort: The robot's effort limit per slot (N·m or N, inf: none).
            ball: Whether each slot is a spherical joint's.

        Returns:
            The slots as a list, their PhysX joints, their effort limits and which are spherical.
        """
        key = id(slots)
        hit = self.call_cache.get(key)
        if hit is not None and hit[0] is slots:
            return hit[1]
        out = (
            slots.tolist(),
            self.slot_joints(slots),
            effort[slots].tolist(),
            ball[slots].tolist(),
        )
        self.call_cache[key] = (slots, out)
        return out

    def slot_joints(self, slots: np.ndarray) -> list[Any]:
        """The PhysX joints of motor ``slots`` (cached per slots array).

        Args:
            slots: (n,) ``np.intp`` motor slots.

        Returns:
            One PhysX joint per slot.
        """
        key = id(slots)
        hit = self.joint_cache.get(key)
        if hit is not None and hit[0] is slots:
            return hit[1]
        out = [self.joints[self.movable[s]] for s in slots.tolist()]
        self.joint_cache[key] = (slots, out)
        return out


def default_motors(model: UrdfModel, movable: list[int], profile: Profile) -> dict[str, np.ndarray]:
    """PyBullet's motor at load per movable joint.

    The brake (velocity 0, impulse 1 N·s per step), PyBullet's spherical motor on a spherical joint,
    or under joint_brake "urdf_friction" the file's friction.

    Args:
        model: The robot.
        movable: The indices of its movable joints.
        profile: The physics settings (time step, joint brake, effort limits).

    Returns:
        The motor table: per movable joint ``mode``, ``target``, ``max_force``, ``kp``, ``kd``,
        ``effort``, ``torque``, ``applied`` and ``ball``, each an (n,) array.
    """
    joints = [model.joints[j] for j in movable]
    n = len(joints)
    ball = np.array([j.type == "spherical" for j in joints], dtype=bool)
    kp = np.zeros(n)
    mode = np.zeros(n, dtype=int)
    if profile.joint_brake == "pybullet":
        brake = np.full(n, 1.0 / profile.timestep)
        brake[ball] = SPHERICAL_BRAKE_IMPULSE / profile.timestep
        kp[ball] = SPHERICAL_BRAKE_KP
        mode[ball] = 2
    else:
        brake = np.array([j.friction for j in joints], dtype=float)
    effort = np.full(n, np.inf)
    if profile.enforce_effort_limit:
        effort = np.array([j.effort if j.effort > 0 else np.inf for j in joints], float)
    return {
        "mode": mode,  # MotorMode: 0 VELOCITY, 2 POSITION
        "target": np.zeros(n),
        "max_force": brake,
        "kp": kp,
        "kd": np.ones(n),
        "effort": effort,
        "torque": np.zeros(n),
        "applied": np.zeros(n),
        "ball": ball,
    }


def movable_joints(table: list[JointInfo]) -> list[int]:
    """The movable joints of a joint table.

    Args:
        table: The joint table.

    Returns:
        The indices of its joints that are not fixed, in order.
    """
    return [j.index for j in table if j.type != JointType.FIXED]
