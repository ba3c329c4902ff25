"""The world's compiled state: the robots by id, and everything derived from one compile.

A :class:`Robot` lives from ``load`` to ``remove`` and keeps what must survive a recompile (its
motor settings, by motor slot: one per hinge or slide joint, three per ball joint, one per
axis of the child's frame). A :class:`Compiled` is built by :func:`compile_state` after
every compile of the world spec and replaced whole by the next one: the model and data, the
motor table in dof order, the joint damping and link damping to apply per step, the torques
pending for the next step, the compiled loop bound to this model, and the caches of the hot
paths. Nothing here steps or raises a simulation error: the backend does.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from simbridge.model.urdf import UrdfModel
from simbridge.profiles import Profile
from simbridge.types import JointInfo

from . import kernel as kernel_loader
from .damping import LinkDamping
from .model import RobotSpec
from .motor_rows import (
    LIMIT_DEEP,
    LIMIT_ERP,
    MOTOR_DMAX,
    MOTOR_R_SCALE,
    SPHERICAL_BRAKE_IMPULSE,
    SPHERICAL_BRAKE_KP,
    MotorTable,
)

__all__ = ["BAD_WARNINGS", "MOTOR_FIELDS", "Compiled", "Robot", "compile_state", "default_motors"]

MOTOR_FIELDS = ("target_velocity", "target_position", "kp", "kd", "max_force", "effort")
BAD_WARNINGS = (
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
    mujoco.mjtWarning.mjWARN_BADQACC,
)


def _no_ids() -> np.ndarray:
    return np.zeros(0, dtype=np.intp)


@dataclass(eq=False)
class Robot:
    """One loaded URDF: its model, what the spec holds of it, its joint table, and its motor
    settings by motor slot (columns as :class:`MotorTable`, kept across recompiles): one slot
    per movable joint, three per spherical joint (its axes, in order), in joint order."""

    id: int
    model: UrdfModel
    spec: RobotSpec
    table: list[JointInfo]
    fixed: bool
    movable: list[int]  # joint indices
    motor_state: dict[str, np.ndarray] = field(default_factory=dict)
    balls: list[int] = field(default_factory=list)  # the spherical joints' indices, in order
    # compiled indices (refreshed by every compile_state)
    body_ids: np.ndarray = field(default_factory=_no_ids)  # (links + 1,) base first
    # (joints,) the address of PyBullet's first position coordinate (a ball's quaternion x,
    # after MuJoCo's w) and velocity; -1 for fixed joints
    qadr: np.ndarray = field(default_factory=_no_ids)
    dofadr: np.ndarray = field(default_factory=_no_ids)  # (joints,) -1 for fixed joints
    motor_index: np.ndarray = field(default_factory=_no_ids)  # (movable,) its first slot
    slot_index: np.ndarray = field(default_factory=_no_ids)  # (slots,) every slot, in order
    free_qadr: int = -1
    free_dofadr: int = -1
    # joints array id -> (joints, movable mask, qadr, dofadr, motor slots, all movable)
    cache: dict[int, tuple[Any, ...]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        # the robot's own slots (kept across compiles): the joint of each, each movable
        # joint's first, each spherical joint's first
        self.slot_joint = slot_joints(self.model, self.movable)
        first: list[int] = []
        ball_slots: list[int] = []
        for k, j in enumerate(self.slot_joint):
            if k == 0 or self.slot_joint[k - 1] != j:
                first.append(k)
                if self.model.joints[j].type == "spherical":
                    ball_slots.append(k)
                    self.balls.append(j)
        self.first_slots = np.asarray(first, dtype=np.intp)
        self.ball_slots = np.asarray(ball_slots, dtype=np.intp)


def slot_joints(model: UrdfModel, movable: list[int]) -> list[int]:
    """The joint of each motor slot of a robot: one per movable joint, three per spherical.

    Args:
        model: The robot.
        movable: The indices of its movable joints.

    Returns:
        A joint index per slot, in slot order.
    """
    return [j for j in movable for _ in range(3 if model.joints[j].type == "spherical" else 1)]


def default_motors(model: UrdfModel, movable: list[int], profile: Profile) -> dict[str, np.ndarray]:
    """The motor every movable joint starts with, per slot.

    PyBullet's brake (velocity 0, impulse 1 N·s per step; on a spherical joint PyBullet's spherical
    motor, which holds the joint at the identity quaternion with kp 0.2 and an impulse of 1000 N·m·s
    per step per axis) or, under joint_brake "urdf_friction", the file's friction (a spherical
    joint's on each axis).

    Args:
        model: The robot.
        movable: The indices of its movable joints.
        profile: The physics settings (time step, joint brake, effort limits).

    Returns:
        The motor table's fields (``MOTOR_FIELDS``), each an (n,) array per slot, and
        ``ball_target``: each spherical joint's target quaternion (x, y, z, w), shape (b, 4).
    """
    slots = [model.joints[j] for j in slot_joints(model, movable)]
    n = len(slots)
    ball = np.array([j.type == "spherical" for j in slots], dtype=bool)
    kp = np.zeros(n)
    if profile.joint_brake == "pybullet":
        brake = np.full(n, 1.0 / profile.timestep)
        brake[ball] = SPHERICAL_BRAKE_IMPULSE / profile.timestep
        kp[ball] = SPHERICAL_BRAKE_KP
    else:
        brake = np.array([j.friction for j in slots], dtype=float)
    effort = np.full(n, np.inf)
    if profile.enforce_effort_limit:
        effort = np.array([j.effort if j.effort > 0 else np.inf for j in slots], float)
    nb = sum(model.joints[j].type == "spherical" for j in movable)
    return {
        "target_velocity": np.zeros(n),
        "target_position": np.zeros(n),
        "kp": kp,
        "kd": np.ones(n),
        "max_force": brake,
        "effort": effort,
        "torque": np.zeros(n),
        "ball_target": np.tile([0.0, 0.0, 0.0, 1.0], (nb, 1)),
    }


@dataclass(eq=False)
class Compiled:
    """Everything derived from one compile of the world (see the module docstring)."""

    m: Any  # mujoco.MjModel
    d: Any  # mujoco.MjData
    dt: float
    inv_dt: float
    limit_k: float  # the joint-limit rows' position gain, LIMIT_ERP / dt^2
    motors: MotorTable
    damping: LinkDamping | None  # PyBullet's link damping, None when the profile has none
    damp_dof: np.ndarray  # dofs with joint damping, and -damping per dof
    damp_coef: np.ndarray
    clamp: float | None  # PyBullet's joint speed clamp (rad/s), None: none
    torque: np.ndarray  # (motors,) torque commands pending for the next step, table order
    kernel: Any = None  # the compiled loop bound to m, d; None: the Python loop steps
    pending_torque: bool = False
    stale: bool = True  # poses and velocities not yet recomputed since the last step
    motor_force_valid: bool = False  # efc_force holds the last step's motor forces
    motor_rows_valid: bool = False  # ... and the current motor set's rows
    # the joint-limit rows' position gain inside the range: 1 / dt^2 under limit_rule "hard"
    # (the joint stops on its limit), 0 under "pybullet" (motor_rows.py)
    limit_k_in: float = 0.0
    # the command hot paths (commands.py), per joints array id: set_joint_velocity's
    # (commands.VelocityPath) and set_joint_position's (commands.PositionPath); an entry lives
    # while the row layout holds and no other command rewrites one of its motors
    fast: dict[int, Any] = field(default_factory=dict)
    fast_position: dict[int, Any] = field(default_factory=dict)
    # joint_states' motor rows: joints array id -> (joints, epoch, rows, positions, full)
    torque_map: dict[int, tuple[Any, ...]] = field(default_factory=dict)
    state_out: np.ndarray = field(default_factory=lambda: np.empty(20))
    warnings: list[int] = field(default_factory=list)  # MuJoCo's divergence warning counts

    def bad_warnings(self) -> int | None:
        """The divergence warning MuJoCo raised since the last call, if any.

        The counts are taken afresh either way.

        Returns:
            The warning's index (0 qpos, 1 qvel, 2 qacc), or None.
        """
        w = self.d.warning
        for i, code in enumerate(BAD_WARNINGS):
            if w[code].number != self.warnings[i]:
                self.warnings = [w[c].number for c in BAD_WARNINGS]
                return i
        return None

    def refresh_motors(self, commanded: np.ndarray | None = None) -> None:
        """Push the motor table into the model and rebuild the rows after a change of the table.

        The model's ``dof_frictionloss`` and ``dof_solref`` take the motors' force limits and gains.

        Args:
            commanded: The motor slots a command has just rewritten (the hot paths of other joints
                stay while the rows keep their layout, and so do the bound commands the compiled
                loop writes); None: any entry may have changed (a restored state, a new compile):
                every hot path is dropped and every bound command is checked against the table again
                at the next step.
        """
        t, m = self.motors, self.m
        force = np.minimum(t.max_force, t.effort)
        m.dof_frictionloss[t.dof] = force
        m.dof_solref[t.dof, 0] = 0.0
        m.dof_solref[t.dof, 1] = -t.kd * MOTOR_DMAX * self.inv_dt
        before, before_position = t.active, t.position_rows
        t.refresh(self.dt, force, m.nv)
        moved = not (
            np.array_equal(before, t.active) and np.array_equal(before_position, t.position_rows)
        )
        if moved:
            t.layout += 1
        if commanded is None or moved:
            self.fast.clear()
            self.fast_position.clear()
        else:  # the commanded motors' own entries go; the others' stay
            slots = set(commanded.tolist())
            for cache in (self.fast, self.fast_position):
                for key in [k for k, e in cache.items() if not slots.isdisjoint(e.slot_set)]:
                    del cache[key]
        if self.kernel is not None:
            self.kernel.bind_motors(
                t.offset_rows,
                t.position_rows,
                t.position_qadr,
                t.position_gain,
                t.kd_rows,
                t.kd_dof,
                t.kd_factor,
                t.dof_rows,
                t.force_rows_slack,
                t.position_target,
                commanded is not None and not moved,  # bound commands keep their rows
            )
            if len(t.ball) or len(t.ball_rows):
                self.kernel.bind_balls(
                    t.ball_rows, t.ball_row_error, t.ball_gain, t.ball_pos_qadr, t.ball_pos_target
                )
        if len(before) != len(t.active) or (before != t.active).any():
            self.motor_rows_valid = False  # the last solve's rows belong to the old set

    def save_motor_state(self, robots: dict[int, Robot]) -> None:
        """Copy the motor settings and pending torques back to each robot.

        Called before a compile rebuilds the table.

        Args:
            robots: The world's robots, by body id.
        """
        table = self.motors
        for robot in robots.values():
            idx = robot.slot_index
            if len(robot.motor_index) != len(robot.movable):
                continue  # compiled before this robot existed
            for key in MOTOR_FIELDS:
                robot.motor_state[key] = getattr(table, key)[idx].copy()
            robot.motor_state["torque"] = self.torque[idx].copy()  # pending for the next step
            if robot.balls:
                first = idx[robot.ball_slots]
                robot.motor_state["ball_target"] = table.ball_target[table.ball_of[first]].copy()


def _index_robots(m: Any, robots: dict[int, Robot]) -> list[tuple[Robot, int, int, int]]:
    """Refresh every robot's compiled indices; (robot, slot k, dof, qadr) per motor slot (a
    ball's three slots: its three dofs; qadr its quaternion's, w first)."""
    owners: list[tuple[Robot, int, int, int]] = []
    for robot in robots.values():
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
            ball = m.jnt_type[jid] == mujoco.mjtJoint.mjJNT_BALL
            qadr[j] = m.jnt_qposadr[jid] + (1 if ball else 0)  # PyBullet's first: x
            dofadr[j] = m.jnt_dofadr[jid]
        robot.qadr, robot.dofadr = qadr, dofadr
        if robot.spec.free_joint is not None:
            jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, robot.spec.free_joint)
            robot.free_qadr = int(m.jnt_qposadr[jid])
            robot.free_dofadr = int(m.jnt_dofadr[jid])
        k = 0
        for j in robot.movable:
            if robot.model.joints[j].type == "spherical":
                for axis in range(3):
                    owners.append((robot, k, int(dofadr[j]) + axis, int(qadr[j]) - 1))
                    k += 1
            else:
                owners.append((robot, k, int(dofadr[j]), int(qadr[j])))
                k += 1
        robot.cache.clear()
    return owners


def _bind_kernel(c: Compiled) -> Any:
    """The compiled step loop bound to this compile's model and arrays (None: step in
    Python; kernel.reason() says why)."""
    cls = kernel_loader.kernel_class()
    if cls is None:
        return None
    m, d = c.m, c.d
    kernel = cls(m, d, m._address, d._address, kernel_loader.functions(), c.dt)
    kernel.bind_commands(c.motors.target_velocity, c.motors.max_force, c.motors.target_position)
    damping = c.damping
    empty = np.zeros(0)
    kernel.bind_world(
        damping.first if damping is not None else 0,
        damping.lin_gain if damping is not None else empty,
        damping.ang_gain if damping is not None else empty,
        c.damp_dof,
        c.damp_coef,
        c.motors.dof,
        c.torque,
        c.clamp,
        MOTOR_R_SCALE,
        c.limit_k,
        LIMIT_DEEP,
        c.limit_k_in,
    )
    return kernel


def compile_state(
    m: Any, d: Any, robots: dict[int, Robot], profile: Profile, *, use_kernel: bool
) -> Compiled:
    """The :class:`Compiled` state of a freshly compiled model.

    Indices, the motor table in dof order (the order of MuJoCo's friction rows) filled from each
    robot's motor state, joint and link damping, pending torques, and the compiled loop.

    Args:
        m: The ``MjModel``.
        d: The ``MjData``.
        robots: The world's robots, by body id.
        profile: The physics settings.
        use_kernel: Whether to make the compiled loop (False: the world refuses to step after an
            engine error or a divergence).

    Returns:
        The compiled state.
    """
    dt = profile.timestep
    owners = _index_robots(m, robots)
    order = np.argsort(np.asarray([o[2] for o in owners], dtype=np.intp), kind="stable")
    table = MotorTable(len(owners))
    table.dof = np.asarray([o[2] for o in owners], np.intp)[order]
    table.qadr = np.asarray([o[3] for o in owners], np.intp)[order]
    position_of = np.empty(len(order), np.intp)
    position_of[order] = np.arange(len(order))
    for robot in robots.values():
        robot.slot_index = np.zeros(len(robot.motor_state["kd"]), np.intp)
    for w, (robot, k, _, _) in enumerate(owners):
        slot = position_of[w]
        robot.slot_index[k] = slot
        for key in MOTOR_FIELDS:
            getattr(table, key)[slot] = robot.motor_state[key][k]
    balls: list[tuple[int, int, np.ndarray]] = []  # (first slot, qpos address, target)
    for robot in robots.values():
        robot.motor_index = robot.slot_index[robot.first_slots]
        targets = robot.motor_state["ball_target"]
        for b, k in enumerate(robot.ball_slots.tolist()):
            balls.append(
                (int(robot.slot_index[k]), int(table.qadr[robot.slot_index[k]]), targets[b])
            )
    table.set_balls(balls)
    # joint damping applied explicitly, as PyBullet's server does each step
    damp = np.zeros(len(owners))
    if profile.apply_joint_damping:
        for w, (robot, k, _, _) in enumerate(owners):
            damp[position_of[w]] = robot.model.joints[robot.slot_joint[k]].damping
    damping = None
    link_damped = profile.linear_damping != 0.0 or profile.angular_damping != 0.0
    if link_damped and robots and m.nbody > 1:
        damping = LinkDamping(m, 1, profile.linear_damping, profile.angular_damping)
    torque = np.zeros(table.n)
    for robot in robots.values():  # torques set before a load or remove still apply
        torque[robot.slot_index] = robot.motor_state["torque"]
    c = Compiled(
        m=m,
        d=d,
        dt=dt,
        inv_dt=1.0 / dt,
        limit_k=LIMIT_ERP / dt / dt,
        motors=table,
        damping=damping,
        damp_dof=table.dof[damp != 0.0],
        damp_coef=-damp[damp != 0.0],
        clamp=profile.max_joint_velocity,
        torque=torque,
        pending_torque=bool(torque.any()),
        limit_k_in=1.0 / dt / dt if profile.engine("mujoco").get("limit_rule") == "hard" else 0.0,
    )
    if use_kernel:
        c.kernel = _bind_kernel(c)
    c.refresh_motors()
    c.warnings = [d.warning[w].number for w in BAD_WARNINGS]
    return c
