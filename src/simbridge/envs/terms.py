"""The named terms a task is made of: observations, rewards, terminations and successes, each a
function of the running world (:class:`World`) and the term's parameters.

Frames and units: SI; ``base_*`` terms are in the base's frame (the base's centre-of-mass
frame, as :meth:`simbridge.Sim.base_state` reports it); joint terms follow the action's joint
order. Each observation term's size is fixed by the task (its entries are named in the env's
contract).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from simbridge.sim import Sim
from simbridge.transforms import quat_to_matrix

__all__ = [
    "NATIVE_TERMS",
    "OBSERVATIONS",
    "REWARDS",
    "SUCCESSES",
    "TERMINATIONS",
    "World",
    "heading",
    "term_names",
]


@dataclass
class World:
    """What a term reads: the Sim and the task's bodies as an env runs them.

    Attributes:
        sim: the Sim.
        body: the action robot's body id.
        bodies: robot name -> body id.
        joints: the action joints' indices on ``body``, in the action's order.
        joint_names: their names.
        default: the action joints' default positions, ``(n,)``.
        last_action: the last action the policy gave (clipped), ``(n,)``.
        commands: the episode's command vector, ``(m,)``.
        time: seconds since the episode's reset.
        pose: the action robot's default pose, joint name -> position (others at 0).
        control_dt: seconds per control step.
        qpos_start: an MJCF task's MuJoCo ``qpos`` at the episode's reset, ``(nq,)``.
        qpos_before: its ``qpos`` when the control step began (the forward velocity's start).
        xpos_before: its MuJoCo bodies' ``xpos`` then, ``(nbody, 3)``, read only for a
            ``forward_velocity`` term that names a ``body`` (empty otherwise).
        previous_action: the action before ``last_action``, ``(n,)`` (zeros at reset).
        torques: the action joints' torques of the last physics step (N m, ``(n,)``): the
            commanded ones under ``pd`` and ``torque``, zeros under the motor modes.
        start: the base's ``(x, y, yaw)`` at the episode's reset (m, m, rad; world).
    """

    sim: Sim
    body: int
    bodies: dict[str, int]
    joints: np.ndarray
    joint_names: tuple[str, ...]
    default: np.ndarray
    last_action: np.ndarray
    commands: np.ndarray
    time: float = 0.0
    pose: Mapping[str, float] = field(default_factory=dict)
    control_dt: float = 0.0
    qpos_start: np.ndarray = field(default_factory=lambda: np.zeros(0))
    qpos_before: np.ndarray = field(default_factory=lambda: np.zeros(0))
    xpos_before: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    previous_action: np.ndarray = field(default_factory=lambda: np.zeros(0))
    torques: np.ndarray = field(default_factory=lambda: np.zeros(0))
    start: np.ndarray = field(default_factory=lambda: np.zeros(3))
    _read: tuple[np.ndarray, np.ndarray] | None = field(default=None, repr=False)
    _forces: np.ndarray | None = field(default=None, repr=False)
    _index: dict[tuple[str | int, ...], np.ndarray] = field(default_factory=dict, repr=False)
    _one: dict[str | int, int] = field(default_factory=dict, repr=False)  # joint -> index

    def joint_states(
        self, joints: Sequence[str | int] | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """The action robot's joint positions and velocities, read from the engine once per
        control step (one ``Sim.joint_states`` of every joint, which every joint term shares,
        until :meth:`stale`).

        Args:
            joints: joint names (or indices); None: the action's joints, in its order.

        Returns:
            ``(positions, velocities)``, ``(n,)`` each, in ``joints``' order.
        """
        if self._read is None:
            s = self.sim.joint_states(self.body)
            self._read = (np.asarray(s.positions), np.asarray(s.velocities))
        if joints is None:
            idx = self.joints
        else:
            key = tuple(joints)
            idx = self._index.get(key)  # type: ignore[assignment]
            if idx is None:
                idx = self._index[key] = np.array(
                    [j if isinstance(j, int) else self.sim.joint_index(self.body, j) for j in key]
                )
        return self._read[0][idx], self._read[1][idx]

    def joint_position(self, joint: str | int) -> float:
        """One joint's position from the same shared read as :meth:`joint_states` (a
        termination's test: no arrays made).

        Args:
            joint: a joint name or index of the action robot.

        Returns:
            Its position (rad or m).
        """
        i = self._one.get(joint)
        if i is None:
            i = self._one[joint] = (
                joint if isinstance(joint, int) else self.sim.joint_index(self.body, joint)
            )
        if self._read is None:
            s = self.sim.joint_states(self.body)
            self._read = (np.asarray(s.positions), np.asarray(s.velocities))
        return float(self._read[0][i])

    def stale(self) -> None:
        """Forget the joint and force reads: the world has moved (a step, a reset)."""
        self._read = None
        self._forces = None

    def body_forces(self) -> np.ndarray:
        """MuJoCo's ``cfrc_ext`` of an MJCF task, read from the engine once per control step
        (:meth:`simbridge.Sim.body_external_forces`, which every force term shares, until
        :meth:`stale`).

        Returns:
            ``(nbody, 6)``: per MuJoCo body, torque (N m) then force (N), world.
        """
        if self._forces is None:
            self._forces = self.sim.body_external_forces()
        return self._forces

    def rotation(self) -> np.ndarray:
        """The base's orientation.

        Returns:
            A (3, 3) matrix taking base-frame vectors to the world frame.
        """
        return quat_to_matrix(self.sim.base_state(self.body).orientation)

    def link_position(self, link: str | int) -> np.ndarray:
        """A link's centre of mass.

        Args:
            link: a link name or index of the action robot; ``-1``: the base.

        Returns:
            ``(3,)``: its position (m, world).
        """
        if link == -1:
            return np.asarray(self.sim.base_state(self.body).position)
        return np.asarray(self.sim.link_state(self.body, link).com_position)


def _q(w: World, p: Mapping[str, Any]) -> np.ndarray:
    if "joints" not in p:
        q = w.joint_states()[0]
        return q - w.default if p.get("relative", False) else q
    q = w.joint_states(p["joints"])[0]
    if p.get("relative", False):
        q = q - np.array([w.pose.get(j, 0.0) for j in p["joints"]])
    return q


def _qd(w: World, p: Mapping[str, Any]) -> np.ndarray:
    return w.joint_states(p.get("joints"))[1]


def _gravity(w: World, p: Mapping[str, Any]) -> np.ndarray:
    return w.rotation().T @ np.array([0.0, 0.0, -1.0])


def _lin(w: World, p: Mapping[str, Any]) -> np.ndarray:
    return w.rotation().T @ np.asarray(w.sim.base_state(w.body).linear_velocity)


def _ang(w: World, p: Mapping[str, Any]) -> np.ndarray:
    return w.rotation().T @ np.asarray(w.sim.base_state(w.body).angular_velocity)


def heading(orientation: Sequence[float]) -> float:
    """The heading of an orientation: its yaw about world z.

    Args:
        orientation: a quaternion ``[x, y, z, w]``.

    Returns:
        The yaw (rad, in [-pi, pi]).
    """
    x, y, z, qw = orientation
    return math.atan2(2 * (qw * z + x * y), 1 - 2 * (y * y + z * z))


def _phase(w: World, p: Mapping[str, Any]) -> np.ndarray:
    a = 2 * math.pi * w.time / float(p.get("period", 1.0))
    return np.array([math.sin(a), math.cos(a)])


def _contacts(w: World, p: Mapping[str, Any]) -> np.ndarray:
    links = p.get("links", ())
    return np.array([1.0 if w.sim.contact_points(w.body, link_a=k) else 0.0 for k in links])


def _link_to_command(w: World, p: Mapping[str, Any]) -> np.ndarray:
    return w.commands[:3] - w.link_position(p["link"])


def _command_in_base(w: World, p: Mapping[str, Any]) -> np.ndarray:
    """The command's first two entries (a goal x, y in the world) in the base's heading frame."""
    s = w.sim.base_state(w.body)
    yaw = heading(s.orientation)
    dx, dy = w.commands[0] - s.position[0], w.commands[1] - s.position[1]
    c, n = math.cos(yaw), math.sin(yaw)
    return np.array([c * dx + n * dy, -n * dx + c * dy])


def _healthy(w: World, p: Mapping[str, Any]) -> bool:
    """Gymnasium's ``is_healthy``: qpos and qvel finite, the root's z (``qpos[2]``) within
    ``[z_min, z_max]``."""
    q, v = w.sim.qpos(), w.sim.qvel()
    finite = bool(np.isfinite(q).all() and np.isfinite(v).all())
    return finite and p.get("z_min", -math.inf) <= q[2] <= p.get("z_max", math.inf)


def _clipped_forces(w: World, p: Mapping[str, Any]) -> np.ndarray:
    """``cfrc_ext`` clipped to ``p["range"]`` (Ant-v5's ``contact_forces``), all rows."""
    f = w.body_forces()
    r = p.get("range")
    return f if r is None else np.clip(f, float(r[0]), float(r[1]))


def _contact_cost(w: World, p: Mapping[str, Any]) -> float:
    """Ant-v5's contact cost, negated: ``-sum(clip(cfrc_ext, range)^2)`` over every MuJoCo
    body (the world's row is zeros)."""
    return -float(np.sum(np.square(_clipped_forces(w, p))))


def _forward_velocity(w: World, p: Mapping[str, Any]) -> float:
    """The root's x velocity over the control step: ``(qpos[0] - qpos_before[0]) /
    control_dt`` (HalfCheetah-v5's); with ``body``, that MuJoCo body's ``xpos`` x instead, as
    :meth:`simbridge.Sim.xpos` gives it (Ant-v5's, ``main_body`` 1: see docs/envs.md)."""
    if "body" in p:
        b = int(p["body"])
        return float((w.sim.xpos()[b, 0] - w.xpos_before[b, 0]) / w.control_dt)
    return float((w.sim.qpos()[0] - w.qpos_before[0]) / w.control_dt)


OBSERVATIONS: dict[str, Callable[[World, Mapping[str, Any]], np.ndarray]] = {
    # (n,) rad or m; params: joints (names; default: the action's), relative (bool): minus
    # the default pose
    "joint_pos": _q,
    "joint_vel": _qd,  # (n,) rad/s or m/s; params: joints
    "base_lin_vel": _lin,  # (3,) m/s, base frame
    "base_ang_vel": _ang,  # (3,) rad/s, base frame
    "projected_gravity": _gravity,  # (3,) unit gravity direction, base frame
    "base_height": lambda w, p: np.array([w.sim.base_state(w.body).position[2]]),  # (1,) m
    "last_action": lambda w, p: w.last_action.copy(),  # (n,)
    "commands": lambda w, p: w.commands.copy(),  # (m,)
    "gait_phase": _phase,  # (2,) sin, cos of 2 pi t / period; params: period (s)
    "contacts": _contacts,  # (k,) 1.0 where the link touches anything; params: links
    "link_pos": lambda w, p: w.link_position(p["link"]),  # (3,) m, world; params: link
    "link_to_command": _link_to_command,  # (3,) command[:3] - link (m, world); params: link
    "command_in_base": _command_in_base,  # (2,) goal x, y in the base's heading frame (m)
    # MJCF tasks: MuJoCo's qpos (nq - exclude,) without its first `exclude` entries
    # (Gymnasium's exclude_current_positions_from_observation: 2 for Ant, 1 for HalfCheetah)
    "qpos": lambda w, p: w.sim.qpos()[int(p.get("exclude", 0)) :],
    "qvel": lambda w, p: w.sim.qvel(),  # MJCF tasks: MuJoCo's qvel (nv,)
    # MJCF tasks: MuJoCo's cfrc_ext without its first `exclude` rows (1: the world's, as
    # Ant-v5), clipped to `range` ([-1, 1]: Ant-v5's contact_force_range), flattened:
    # ((nbody - exclude) * 6,), per body torque then force (N m, N; world)
    "cfrc_ext": lambda w, p: _clipped_forces(w, p)[int(p.get("exclude", 0)) :].ravel(),
}
"""Observation term -> function (world, params) -> float64 array."""


def _dist(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b))


def _goal_distance(w: World, p: Mapping[str, Any]) -> float:
    return _dist(np.asarray(w.sim.base_state(w.body).position[:2]), w.commands[:2])


def _link_distance(w: World, p: Mapping[str, Any]) -> float:
    return _dist(w.link_position(p["link"]), w.commands[:3])


def _tilt(w: World) -> float:
    return math.acos(max(-1.0, min(1.0, -float(_gravity(w, {})[2]))))


def _joint_value(w: World, p: Mapping[str, Any]) -> float:
    return w.joint_position(p["joint"])


def _tracking_lin_vel(w: World, p: Mapping[str, Any]) -> float:
    """legged_gym's: exp(-|command[:2] - v_xy|^2 / sigma), v in the base frame."""
    err = float(np.sum((w.commands[:2] - _lin(w, p)[:2]) ** 2))
    return math.exp(-err / float(p.get("sigma", 0.25)))


def _tracking_ang_vel(w: World, p: Mapping[str, Any]) -> float:
    """legged_gym's: exp(-(command[2] - w_z)^2 / sigma), w in the base frame."""
    err = float((w.commands[2] - _ang(w, p)[2]) ** 2)
    return math.exp(-err / float(p.get("sigma", 0.25)))


def _mean_velocity_error(w: World) -> float:
    """|mean planar velocity since the reset - command[:2]| (m/s), the mean velocity in the
    heading frame the base had at its reset (inf before the first step)."""
    if w.time <= 0.0:
        return math.inf
    x0, y0, yaw0 = w.start
    s = w.sim.base_state(w.body)
    dx, dy = s.position[0] - x0, s.position[1] - y0
    c, n = math.cos(yaw0), math.sin(yaw0)
    mean = np.array([c * dx + n * dy, -n * dx + c * dy]) / w.time
    return float(np.linalg.norm(mean - w.commands[:2]))


REWARDS: dict[str, Callable[[World, Mapping[str, Any]], float]] = {
    "alive": lambda w, p: 1.0,
    "link_distance": lambda w, p: -_link_distance(w, p),  # params: link
    "goal_distance": lambda w, p: -_goal_distance(w, p),
    "action_l2": lambda w, p: -float(np.sum(w.last_action**2)),
    "joint_vel_l2": lambda w, p: -float(np.sum(_qd(w, {}) ** 2)),
    "joint_pos_error": lambda w, p: -float(np.sum(_q(w, {"relative": True}) ** 2)),
    "upright": lambda w, p: -float(np.sum(_gravity(w, p)[:2] ** 2)),
    "height_error": lambda w, p: -((w.sim.base_state(w.body).position[2] - p["target"]) ** 2),
    # MJCF tasks: the root's x velocity (m/s) over the control step; params: body (a MuJoCo
    # body index: its xpos x, as Ant-v5's main_body; default: qpos[0])
    "forward_velocity": _forward_velocity,
    # MJCF tasks: -sum(clip(cfrc_ext, range)^2) (Ant-v5's contact cost; weight 5e-4 there)
    "contact_cost": _contact_cost,
    # MJCF tasks: 1 while healthy (params z_min, z_max on qpos[2]), else 0
    "healthy": lambda w, p: 1.0 if _healthy(w, p) else 0.0,
    # legged_gym's locomotion terms (base frame; commands: vx, vy (m/s), yaw rate (rad/s))
    "tracking_lin_vel": _tracking_lin_vel,  # params: sigma (m^2/s^2, 0.25)
    "tracking_ang_vel": _tracking_ang_vel,  # params: sigma (rad^2/s^2, 0.25)
    "lin_vel_z": lambda w, p: -float(_lin(w, p)[2] ** 2),
    "ang_vel_xy": lambda w, p: -float(np.sum(_ang(w, p)[:2] ** 2)),
    "torques": lambda w, p: -float(np.sum(w.torques**2)),
    "action_rate": lambda w, p: -float(np.sum((w.last_action - w.previous_action) ** 2)),
}
"""Reward term -> function (world, params) -> value (weighted by the task)."""

TERMINATIONS: dict[str, Callable[[World, Mapping[str, Any]], bool]] = {
    # params: joint, limit: |q| above limit (rad or m)
    "joint_pos_outside": lambda w, p: abs(_joint_value(w, p)) > p["limit"],
    # params: limit (m): the base's centre of mass below it
    "base_height_below": lambda w, p: w.sim.base_state(w.body).position[2] < p["limit"],
    # params: limit (rad): the base's z axis that far from world up
    "tilt_above": lambda w, p: _tilt(w) > p["limit"],
    # MJCF tasks, params z_min, z_max: qpos[2] outside them, or the state not finite
    "unhealthy": lambda w, p: not _healthy(w, p),
}
"""Failure -> test (world, params) -> True when the episode ends as a failure."""

SUCCESSES: dict[str, Callable[[World, Mapping[str, Any]], bool]] = {
    # no failure until the episode's end (tested at truncation)
    "survive": lambda w, p: True,
    # params: link, within (m): the link's centre of mass that near command[:3]
    "link_near_command": lambda w, p: _link_distance(w, p) < p["within"],
    # params: within (m): the base's x, y that near command[:2]
    "base_near_command": lambda w, p: _goal_distance(w, p) < p["within"],
    # MJCF tasks, params min (m): the root moved at least that far along +x since the reset
    "forward_distance": lambda w, p: float(w.sim.qpos()[0] - w.qpos_start[0]) >= p["min"],
    # params: within (m/s): the base's mean planar velocity since the reset (in its heading
    # at the reset) that near command[:2] (the travelled distance over the elapsed time)
    "mean_velocity_near_command": lambda w, p: _mean_velocity_error(w) < p["within"],
}
"""Success -> test (world, params); the episode succeeds when every test holds (a ``terminate``
parameter ends it there; otherwise it is tested at the episode's last step)."""

PARAMS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    # name -> (required params, optional params)
    "joint_pos": ((), ("relative", "joints")),
    "joint_vel": ((), ("joints",)),
    "gait_phase": ((), ("period",)),
    "contacts": (("links",), ()),
    "link_pos": (("link",), ()),
    "link_to_command": (("link",), ()),
    "link_distance": (("link",), ()),
    "height_error": (("target",), ()),
    "tracking_lin_vel": ((), ("sigma",)),
    "tracking_ang_vel": ((), ("sigma",)),
    "joint_pos_outside": (("joint", "limit"), ()),
    "base_height_below": (("limit",), ()),
    "tilt_above": (("limit",), ()),
    "link_near_command": (("link", "within"), ("terminate",)),
    "base_near_command": (("within",), ("terminate",)),
    "mean_velocity_near_command": (("within",), ("terminate",)),
    "survive": ((), ()),
    "qpos": ((), ("exclude",)),
    "cfrc_ext": ((), ("exclude", "range")),
    "contact_cost": ((), ("range",)),
    "forward_velocity": ((), ("body",)),
    "healthy": (("z_min", "z_max"), ()),
    "unhealthy": (("z_min", "z_max"), ()),
    "forward_distance": (("min",), ("terminate",)),
}
"""A term's parameters: those it needs and those it may take (others are refused)."""


NATIVE_TERMS = (
    "qpos",
    "qvel",
    "cfrc_ext",
    "forward_velocity",
    "contact_cost",
    "healthy",
    "unhealthy",
    "forward_distance",
)
"""The terms that read MuJoCo's generalized coordinates (``Sim.qpos``) or bodies
(``Sim.body_external_forces``): only in a task over an MJCF read as MuJoCo reads it."""


def term_names(kind: str) -> tuple[str, ...]:
    """The terms of one kind.

    Args:
        kind: ``"observation"``, ``"reward"``, ``"termination"`` or ``"success"``.

    Returns:
        Their names, sorted.

    Raises:
        KeyError: another kind.
    """
    table: dict[str, Mapping[str, Any]] = {
        "observation": OBSERVATIONS,
        "reward": REWARDS,
        "termination": TERMINATIONS,
        "success": SUCCESSES,
    }
    return tuple(sorted(table[kind]))
