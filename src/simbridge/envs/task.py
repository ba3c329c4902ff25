"""A task: what an environment simulates, what its action means, what it observes, how an
episode is scored and ends. Read-only dataclasses, written in Python or read from TOML
(:mod:`simbridge.envs.reader`); :class:`~simbridge.envs.env.SimEnv` runs one on any backend.

Every field is part of the *contract* a trained policy depends on (joint order, action meaning,
gains, time step and decimation, observation layout, scales, normalisation, history, latency):
:meth:`SimEnv.contract() <simbridge.envs.env.SimEnv.contract>` gives it back as plain data.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

__all__ = [
    "ACTION_MODES",
    "ACTION_OFFSETS",
    "RESET_MODES",
    "ActionSpec",
    "CommandSpec",
    "Condition",
    "Normalisation",
    "ObsTerm",
    "Randomisation",
    "RewardTerm",
    "RobotSpec",
    "Task",
    "TrainedSpec",
]

ACTION_MODES = ("position", "velocity", "torque", "pd", "actuator")
"""How an action drives its joints: ``position`` and ``velocity`` set the Sim's motors (PyBullet's
law, ``max_force``), held over the control period; ``torque`` applies the target as a torque
every physics step; ``pd`` computes ``kp * (target - q) - kd * qd`` every physics step and
applies it as a torque (legged RL's PD); ``actuator`` writes the scaled action as the controls
of the actuators an MJCF read as MuJoCo reads it names (``Sim.set_actuator_controls``, held
over the control period, as a Gymnasium MuJoCo task's action is); the model's ``ctrlrange``
then limits them where the model says so (MuJoCo's ``ctrllimited``), on every engine."""

ACTION_OFFSETS = ("default", "current", "zero")
"""What the scaled action is added to: the task's default joint pose, the joints' positions when
the action arrives, or nothing."""

RESET_MODES = ("restore", "rebuild")
"""How ``reset`` puts the world back: ``restore`` sets the exact state taken right after the
world was built (bit for bit where no contact changed since); ``rebuild`` removes every body and
loads them again (bit for bit on every engine, at the cost of a load)."""


@dataclass(frozen=True)
class RobotSpec:
    """One body of the world.

    Attributes:
        name: the task's name for it (terms and the action name robots by it).
        urdf: a URDF path or a name on simbridge's search path (pybullet_data included);
            empty for an MJCF robot.
        mjcf: an MJCF file read as MuJoCo reads it (``Sim.load_mjcf(..., semantics=
            "mujoco")``): a path or ``package://gymnasium/envs/mujoco/assets/ant.xml``; the
            file is the whole world (its floor, ``<option>``, actuators), the robot its
            ``body``-th top-level body, placed by the file (no ``position``, ``orientation``,
            ``fixed_base``, ``joint_positions`` or ``released``). Empty for a URDF robot.
        body: which top-level body of ``mjcf`` is the robot (MuJoCo's order).
        position: where its base goes (m, world).
        orientation: its base orientation (x, y, z, w).
        fixed_base: weld the base to the world.
        joint_positions: joint name -> position (rad or m) of the default pose; joints left
            out are at 0.
        released: joints whose default motor (PyBullet's velocity brake) is released, so they
            move freely (the action's torque and pd joints are released without being named).
    """

    name: str
    urdf: str
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    orientation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    fixed_base: bool = False
    joint_positions: Mapping[str, float] = field(default_factory=dict)
    released: tuple[str, ...] = ()
    mjcf: str = ""
    body: int = 0


@dataclass(frozen=True)
class ActionSpec:
    """What the action vector means. Entry i drives ``joints[i]``:
    ``target[i] = base[i] + scale[i] * clip(action[i], -clip, clip)``, ``base`` as ``offset``
    says. Under the ``actuator`` mode ``joints`` are the model's actuator names and the target
    is the actuator's control (offset ``zero``).

    Attributes:
        robot: the robot (a :class:`RobotSpec` name) whose joints these are.
        joints: joint names, in the action's order.
        mode: one of :data:`ACTION_MODES`.
        scale: per joint (rad, rad/s, N·m... per unit of action); one number: every joint.
        offset: one of :data:`ACTION_OFFSETS`.
        clip: the action's bound; the action space is ``[-clip, clip]``.
        kp: per joint: position gain (``pd``: N·m/rad; ``position``: PyBullet's law, 0.1
            when not given).
        kd: per joint: velocity gain (``pd``: N·m·s/rad; ``position``: PyBullet's law, 1.0
            when not given).
        max_force: per joint, N·m or N: the motor's force limit (``position``,
            ``velocity``), the torque clip (``torque``, ``pd``). Each per-joint field takes one
            number for every joint.

    Raises:
        InvalidArgumentError: a mode or offset not listed, a per-joint field of another
            length, gains missing from a ``pd`` or ``position`` action.
        latency: control steps between an action and its effect (0: at once); the actions
            before the first are zeros.
    """

    robot: str
    joints: tuple[str, ...]
    mode: str
    scale: tuple[float, ...]
    offset: str = "default"
    clip: float = 1.0
    kp: tuple[float, ...] = ()
    kd: tuple[float, ...] = ()
    max_force: tuple[float, ...] = ()
    latency: int = 0

    def __post_init__(self) -> None:
        from simbridge.exceptions import InvalidArgumentError

        n = len(self.joints)
        if self.mode not in ACTION_MODES:
            raise InvalidArgumentError("mode", f"expected one of {ACTION_MODES}, got {self.mode!r}")
        if self.offset not in ACTION_OFFSETS:
            raise InvalidArgumentError(
                "offset", f"expected one of {ACTION_OFFSETS}, got {self.offset!r}"
            )
        if self.mode == "position":  # PyBullet's default gains
            object.__setattr__(self, "kp", self.kp or (0.1,))
            object.__setattr__(self, "kd", self.kd or (1.0,))
        needed = {"pd": ("kp", "kd", "max_force"), "actuator": ()}
        for name in ("scale", "kp", "kd", "max_force"):
            raw = getattr(self, name)
            values = (float(raw),) if isinstance(raw, (int, float)) else tuple(map(float, raw))
            if not values and name in needed.get(self.mode, ("max_force",)):
                raise InvalidArgumentError(name, f"a {self.mode} action needs {name}")
            if len(values) == 1:
                values = values * n
            if values and len(values) != n:
                raise InvalidArgumentError(
                    name,
                    f"expected one value or {n} (one per joint of {list(self.joints)}), "
                    f"got {len(values)}",
                )
            object.__setattr__(self, name, values)


@dataclass(frozen=True)
class ObsTerm:
    """One term of the observation vector (its size: :mod:`simbridge.envs.terms`).

    Attributes:
        name: a term of :data:`simbridge.envs.terms.OBSERVATIONS`.
        scale: multiplies the term (after the noise).
        noise: half-width of the uniform noise added to the term, in its own units (0: none);
            drawn from the env's seeded generator.
        params: the term's own parameters (``{"link": "lbr_iiwa_link_7"}``...).
    """

    name: str
    scale: float | tuple[float, ...] = 1.0
    noise: float = 0.0
    params: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Normalisation:
    """A trained policy's observation statistics, as Stable-Baselines3's ``VecNormalize``
    stores them (``obs_rms.mean``, ``obs_rms.var``, ``clip_obs``, ``epsilon``):
    ``clip((obs - mean) / sqrt(var + epsilon), -clip, clip)`` over the whole (stacked) vector.

    The env applies it as ``VecNormalize.normalize_obs`` does, to the float32 observation.

    Attributes:
        mean: one per entry of the stacked observation.
        var: likewise (>= 0).
        clip: the bound after normalising.
        epsilon: added to ``var``.
        source: the ``VecNormalize`` file they were read from
            (:mod:`simbridge.envs.vecnormalize`), or None: the task's own ``[normalisation]``.
    """

    mean: tuple[float, ...]
    var: tuple[float, ...]
    clip: float = 10.0
    epsilon: float = 1e-8
    source: str | None = None


@dataclass(frozen=True)
class RewardTerm:
    """One term of the reward: ``weight * value`` (values: :data:`simbridge.envs.terms.REWARDS`).

    Attributes:
        name: the term.
        weight: its weight.
        params: its parameters.
    """

    name: str
    weight: float = 1.0
    params: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Condition:
    """A termination or success test (:data:`simbridge.envs.terms.TERMINATIONS`,
    :data:`~simbridge.envs.terms.SUCCESSES`).

    Attributes:
        name: the test.
        params: its parameters.
    """

    name: str
    params: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class CommandSpec:
    """The episode's command vector (a goal, a velocity to track), drawn uniformly in
    ``[low, high]`` at each reset from the env's seeded generator.

    Attributes:
        names: one name per entry (``("x", "y", "z")``).
        low: lower bounds.
        high: upper bounds (>= low; equal: a fixed command).
    """

    names: tuple[str, ...]
    low: tuple[float, ...]
    high: tuple[float, ...]


@dataclass(frozen=True)
class Randomisation:
    """The initial state's spread, drawn at each reset from the env's seeded generator.

    Attributes:
        joint_position: half-width (rad or m) of a uniform offset on each joint's default
            position.
        joint_velocity: half-width (rad/s or m/s) of each joint's initial velocity.
        base_position: half-widths (m) of a uniform offset of the base position, x y z.
        base_yaw: half-width (rad) of a turn of the base about world z.
        joints: the joints ``joint_position`` and ``joint_velocity`` spread, on the action's
            robot (empty: the action's joints); each starts at its default position.
        qpos_uniform: an MJCF task's: half-width of a uniform offset on every entry of
            MuJoCo's initial ``qpos`` (a free joint's quaternion included, as Gymnasium's
            ``reset_model`` does), drawn first.
        qvel_normal: an MJCF task's: standard deviation of a normal draw on every entry of
            the initial ``qvel``, drawn after (Gymnasium's ``reset_noise_scale *
            standard_normal(nv)``).
    """

    joint_position: float = 0.0
    joint_velocity: float = 0.0
    base_position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_yaw: float = 0.0
    joints: tuple[str, ...] = ()
    qpos_uniform: float = 0.0
    qvel_normal: float = 0.0


@dataclass(frozen=True)
class TrainedSpec:
    """The training run of a policy trained outside simbridge (Isaac Lab, MuJoCo Playground,
    Gymnasium), as far as the rest of the task does not state it: the action joints' dynamics
    the training simulator had. The contract table sets them beside every engine's joint
    table. The rest of the contract (joint order, observation layout and scales, action meaning
    and scale, gains, dt and decimation) is the task's own.

    Attributes:
        framework: where it was trained (``"isaaclab"``), as ``--trained-on external:NAME``
            names it.
        effort_limit: per action joint (N·m or N); one number: every joint; empty: not stated.
        velocity_limit: likewise (rad/s or m/s).
        damping: likewise (N·m·s/rad or N·s/m).
        friction: likewise (N·m or N).
        armature: likewise (kg·m² or kg): the rotor inertia added to each joint, which the
            Sim interface does not read back from an engine (shown as stated only).
    """

    framework: str = ""
    effort_limit: tuple[float, ...] = ()
    velocity_limit: tuple[float, ...] = ()
    damping: tuple[float, ...] = ()
    friction: tuple[float, ...] = ()
    armature: tuple[float, ...] = ()


@dataclass(frozen=True)
class Task:
    """Everything an environment needs.

    Attributes:
        name: the task's name.
        robots: the bodies, in load order.
        action: the action's meaning.
        observation: the observation's terms, in order.
        timestep: the physics step (s).
        decimation: physics steps per control step (the action is held over them).
        episode_steps: control steps before the episode is truncated.
        description: one line.
        history: observations stacked (oldest first; 1: the current one alone); at reset the
            first observation fills every slot.
        normalisation: the policy's observation statistics, or None.
        rewards: the reward's terms.
        terminations: failures that end the episode.
        success: what counts as success (each must hold; a ``terminate`` parameter ends the
            episode when it does).
        commands: the episode's command vector, or None.
        randomisation: the initial state's spread.
        profile: the Sim's profile (``"pybullet"``, ``"urdf"``).
        gravity: world gravity (m/s²).
        reset: one of :data:`RESET_MODES`.
        camera: ``{"eye": [x, y, z], "target": [x, y, z]}`` for ``render_mode="rgb_array"``.
        source: the file it was read from, if any.
        trained: a policy's training run outside simbridge (its joints' dynamics), or None.
    """

    name: str
    robots: tuple[RobotSpec, ...]
    action: ActionSpec
    observation: tuple[ObsTerm, ...]
    timestep: float = 1.0 / 240.0
    decimation: int = 4
    episode_steps: int = 500
    description: str = ""
    history: int = 1
    normalisation: Normalisation | None = None
    rewards: tuple[RewardTerm, ...] = ()
    terminations: tuple[Condition, ...] = ()
    success: tuple[Condition, ...] = ()
    commands: CommandSpec | None = None
    randomisation: Randomisation = field(default_factory=Randomisation)
    profile: str = "pybullet"
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.8)
    reset: str = "restore"
    camera: Mapping[str, tuple[float, ...]] = field(default_factory=dict)
    source: str | None = None
    trained: TrainedSpec | None = None

    @property
    def native(self) -> RobotSpec | None:
        """The robot whose MJCF is read as MuJoCo reads it (the whole world), or None."""
        return next((r for r in self.robots if r.mjcf), None)

    @property
    def control_dt(self) -> float:
        """Seconds per control step: ``timestep * decimation``."""
        return self.timestep * self.decimation

    def robot(self, name: str) -> RobotSpec:
        """The robot named ``name``.

        Args:
            name: a :class:`RobotSpec` name.

        Returns:
            Its spec.

        Raises:
            KeyError: no such robot (the message lists the task's).
        """
        for r in self.robots:
            if r.name == name:
                return r
        raise KeyError(
            f"task {self.name!r} has no robot {name!r}; robots: {[r.name for r in self.robots]}"
        )
