"""`SimEnv`: a Gymnasium 1.x environment over a :class:`~simbridge.Sim`, made from a
:class:`~simbridge.envs.task.Task`, on any registered backend.

::

    env = SimEnv("cartpole", backend="mujoco")
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    env.contract()          # joint order, action meaning, gains, dt x decimation, obs layout

One control step: the action is checked (shape and finiteness: :class:`ActionError`), clipped to
``[-clip, clip]`` (the entries clipped are counted in ``info["action_clipped"]``), delayed by the
task's latency, turned into joint targets and held over ``decimation`` physics steps; then the
observation, reward, termination and success are read. ``reset(seed=...)`` reproduces an episode
bit for bit on the same engine and machine: the world is restored exactly or rebuilt (the task's
``reset``), then the initial state and commands are drawn from the env's seeded generator.
"""

from __future__ import annotations

import os
from collections import deque
from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from simbridge.envs.errors import ActionError, NormalisationFileError, TaskJointError
from simbridge.envs.task import Condition, ObsTerm, RewardTerm, RobotSpec, Task
from simbridge.envs.terms import OBSERVATIONS, REWARDS, SUCCESSES, TERMINATIONS, World, heading
from simbridge.exceptions import (
    BackendUnsupportedError,
    InvalidArgumentError,
    SimulationDivergedError,
    UnknownJointError,
)
from simbridge.sim import Sim
from simbridge.transforms import quat_from_rpy, quat_multiply

__all__ = ["SimEnv"]


class SimEnv(gym.Env[np.ndarray, np.ndarray]):
    """A task on one engine, as a Gymnasium environment.

    Args:
        task: a :class:`Task`, a shipped task's name (``"cartpole"``: see
            :func:`simbridge.envs.shipped_tasks`) or a TOML file's path.
        backend: a registered backend name (``"pybullet"``, ``"mujoco"``, ``"physx"``).
        render_mode: None, ``"rgb_array"`` (:meth:`render` returns a picture from the task's
            camera) or ``"human"`` (the engine's own window: ``Sim(gui=True)``).
        render_size: (width, height) of ``"rgb_array"`` pictures.
        engine_settings: the backend's own settings (``Sim(engine_settings=...)``).

    Attributes:
        task: the task.
        sim: the Sim it runs on.
        observation_space: ``Box(float32, (size * history,))``.
        action_space: ``Box(-clip, clip, (n,), float32)``, one entry per action joint.

    Raises:
        UnknownJointError: a joint the task names that the robot lacks (the message lists the
            robot's joints).
        InvalidArgumentError: a bad ``render_mode``, or normalisation statistics of another
            size than the observation.
        NormalisationFileError: a ``VecNormalize`` file's statistics of another size than the
            observation (the message names the file and both layouts).
        TaskFileError: a task file that says something invalid (``FILE:LINE``).
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array", "human"], "render_fps": 60}

    def __init__(
        self,
        task: Task | str | os.PathLike[str] = "cartpole",
        *,
        backend: str = "pybullet",
        render_mode: str | None = None,
        render_size: tuple[int, int] = (320, 240),
        engine_settings: dict[str, Any] | None = None,
    ) -> None:
        from simbridge.envs.reader import load_task

        self.task = task if isinstance(task, Task) else load_task(task)
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise InvalidArgumentError(
                "render_mode",
                f"expected None or one of {self.metadata['render_modes']}, got {render_mode!r}",
            )
        self.render_mode = render_mode
        self.render_size = render_size
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self.task.control_dt)}
        t = self.task
        self.sim = Sim(
            backend,
            timestep=t.timestep,
            gravity=t.gravity,
            profile=t.profile,
            gui=render_mode == "human",
            engine_settings=engine_settings,
        )
        self.backend = backend
        n = len(t.action.joints)
        self._scale = np.broadcast_to(np.asarray(t.action.scale, float), (n,)).copy()
        self._limit = np.asarray(t.action.max_force, float)  # the torque modes' clip
        self._snapshot: Any = None
        self._actuators: list[int] = []  # the actuator action's indices in MuJoCo's ctrl
        self._shadow: Sim | None = None  # PyBullet's pictures of an engine that draws none
        self._shadow_body = 0
        self._diverged = False
        # a forward velocity read from a MuJoCo body's xpos (Ant-v5's): xpos kept at each start
        self._reads_xpos = any(
            r.name == "forward_velocity" and "body" in r.params for r in t.rewards
        )
        self._build()
        self._history: deque[np.ndarray] = deque(maxlen=t.history)
        frame = self._frame()
        self._frame_size = frame.size
        size = frame.size * t.history
        self._check_normalisation(size)
        bound = np.inf if t.normalisation is None else t.normalisation.clip
        self.observation_space = gym.spaces.Box(-bound, bound, (size,), np.float32)
        c = t.action.clip
        self.action_space = gym.spaces.Box(-c, c, (n,), np.float32)
        self._steps = 0
        self._queue: deque[np.ndarray] = deque([np.zeros(n)] * t.action.latency)
        self.physics_hook: Callable[[np.ndarray | None], None] | None = None
        """Called after every physics step when set (``simbridge sim2sim``'s effort probe,
        :mod:`simbridge.envs.sim2sim_effort`), with the ``(n,)`` torques the env commanded for
        that step (the torque and PD modes), the controls it wrote (the actuator mode) or None
        (the position and velocity modes, whose motors the engine runs: these then run their
        ``decimation`` steps one at a time)."""

    # ---------------------------------------------------------------- the world

    def _build(self) -> None:
        """Load the robots, set the default pose and the action joints' motors."""
        if self.task.native is not None:
            self._build_native(self.task.native)
            return
        sim, t = self.sim, self.task
        bodies = {}
        for i, r in enumerate(t.robots):
            bodies[r.name] = body = sim.load_urdf(
                r.urdf,
                base_position=r.position,
                base_orientation=r.orientation,
                fixed_base=r.fixed_base,
            )
            if r.joint_positions:
                names = list(r.joint_positions)
                idx = [self._joint(body, j, ["robots", i, "joint_positions", j]) for j in names]
                sim.reset_joint_state(body, idx, [r.joint_positions[j] for j in names])
            if r.released:
                idx = [self._joint(body, j, ["robots", i, "released"]) for j in r.released]
                sim.set_joint_velocity(body, idx, 0.0, max_force=0.0)
        body = bodies[t.action.robot]
        joints = np.array(
            [self._joint(body, j, ["action", "joints"]) for j in t.action.joints], dtype=np.int64
        )
        spec = t.robot(t.action.robot)
        default = np.array([spec.joint_positions.get(j, 0.0) for j in t.action.joints])
        n = len(joints)
        commands = np.zeros(0 if t.commands is None else len(t.commands.names))
        w = World(sim, body, bodies, joints, t.action.joints, default, np.zeros(n), commands)
        w.pose = dict(spec.joint_positions)
        w.previous_action, w.torques = np.zeros(n), np.zeros(n)
        self.world = w
        self._check_term_joints(body)
        spread = t.randomisation.joints or t.action.joints
        key = ["randomisation", "joints"] if t.randomisation.joints else ["action", "joints"]
        self._spread = [self._joint(body, j, key) for j in spread]
        self._spread_default = np.array([w.pose.get(j, 0.0) for j in spread])
        self._spawn = sim.base_state(body)
        self._hold(default)
        if t.reset == "restore":
            self._snapshot = sim.get_state(exact=True)

    def _joint(self, body: int, name: str, path: Sequence[str | int]) -> int:
        """The index of a joint the task names at ``path``.

        Raises:
            TaskJointError: the robot lacks it; the task's file, key and line, then its joints.
        """
        try:
            return self.sim.joint_index(body, name)
        except UnknownJointError as e:
            from simbridge.envs.reader import _keystr, key_line

            t = self.task
            file = t.source if t.source is not None else f"<task {t.name}>"
            raise TaskJointError(file, _keystr(list(path)), e, key_line(t.source, path)) from None

    def _check_term_joints(self, body: int) -> None:
        """Look up, once at load, every joint a term's ``params`` name (``joint``, ``joints``):
        the terms themselves look them up at the first step, where an error could not say
        which line of the task named the joint.

        Raises:
            TaskJointError: the robot lacks one; the term's line in the task file.
        """
        t = self.task
        groups: tuple[tuple[str, Sequence[ObsTerm | RewardTerm | Condition]], ...] = (
            ("observation", t.observation),
            ("rewards", t.rewards),
            ("terminations", t.terminations),
            ("success", t.success),
        )
        for group, terms in groups:
            for i, term in enumerate(terms):
                one = term.params.get("joint")
                for name in (*term.params.get("joints", ()), *([] if one is None else [one])):
                    if isinstance(name, str):
                        self._joint(body, name, [group, i, "params"])

    def _build_native(self, r: RobotSpec) -> None:
        """Load the MJCF read as MuJoCo reads it (the whole world), controls at 0."""
        sim, t = self.sim, self.task
        body = sim.load_mjcf(r.mjcf, semantics="mujoco")[r.body]
        table = {a.name: a for a in sim.actuators()}
        self._actuators = [table[name].index for name in t.action.joints]
        joints = [sim.joint_index(body, table[name].target) for name in t.action.joints]
        n = len(joints)
        commands = np.zeros(0 if t.commands is None else len(t.commands.names))
        w = World(
            sim,
            body,
            {r.name: body},
            np.array(joints, dtype=np.int64),
            t.action.joints,
            np.zeros(n),
            np.zeros(n),
            commands,
            control_dt=t.control_dt,
        )
        w.previous_action, w.torques = np.zeros(n), np.zeros(n)
        self.world = w
        self._spread, self._spread_default = [], np.zeros(0)
        self._spawn = sim.base_state(body)
        self._qpos0, self._qvel0 = sim.qpos(), sim.qvel()
        self._hold(np.zeros(n))
        if t.reset == "restore":
            self._snapshot = sim.get_state(exact=True)

    def _hold(self, q: np.ndarray) -> None:
        """The action joints' motors at rest: position held at ``q``, velocity 0, or released
        (torque and pd)."""
        a, w = self.task.action, self.world
        if a.mode == "actuator":
            self.sim.set_actuator_controls(np.zeros(len(self._actuators)), self._actuators)
        elif a.mode == "position":
            self.sim.set_joint_position(
                w.body,
                w.joints,
                q,
                max_force=np.asarray(a.max_force),
                kp=np.asarray(a.kp),
                kd=np.asarray(a.kd),
            )
        elif a.mode == "velocity":
            self.sim.set_joint_velocity(w.body, w.joints, 0.0, max_force=np.asarray(a.max_force))
        else:
            self.sim.set_joint_velocity(w.body, w.joints, 0.0, max_force=0.0)

    def _check_normalisation(self, size: int) -> None:
        norm = self.task.normalisation
        if norm is not None and (len(norm.mean) != size or len(norm.var) != size):
            if norm.source is not None:  # a VecNormalize file: both layouts named
                from simbridge.envs.contract import observation_layout

                raise NormalisationFileError(
                    norm.source,
                    f"its statistics have {len(norm.mean)} entries (VecNormalize over "
                    f"observations of shape ({len(norm.mean)},)); the task "
                    f"{self.task.name!r}'s observation has {size}: {observation_layout(self)}",
                )
            raise InvalidArgumentError(
                "normalisation",
                f"mean and var must have one entry per observation entry ({size}: "
                f"{self._frame_size} x history {self.task.history}), got {len(norm.mean)} and "
                f"{len(norm.var)}",
            )

    # ---------------------------------------------------------------- Gymnasium's calls

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode.

        Args:
            seed: seeds the env's generator (initial state, commands, noise); the same seed
                gives the same episode, bit for bit, on the same engine and machine.
            options: ``{"commands": [...]}`` sets the episode's command vector instead of
                drawing it.

        Returns:
            The first observation (float32, the contract's layout) and an info dict
            (``commands``).

        Raises:
            InvalidArgumentError: ``options["commands"]`` of the wrong size.
        """
        super().reset(seed=seed)
        if self._snapshot is not None and not self._diverged:
            self.sim.set_state(self._snapshot)
        else:
            self.sim.reset()
            self._build()
        self._diverged = False
        self._randomise(options or {})
        self.world.stale()
        self._steps = 0
        self._history.clear()
        frame = self._frame()
        for _ in range(self.task.history):
            self._history.append(frame)
        if self.render_mode == "human":
            self.render()
        return self._observation(), {"commands": self.world.commands.copy()}

    def _randomise(self, options: dict[str, Any]) -> None:
        """Draw the initial state and the commands, always in the same order."""
        t, w, rng = self.task, self.world, self.np_random
        r = t.randomisation
        if t.native is not None:
            self._randomise_native(options)
            return
        n, k = len(w.joints), len(self._spread)
        q0 = self._spread_default + rng.uniform(-1.0, 1.0, k) * r.joint_position
        qd0 = rng.uniform(-1.0, 1.0, k) * r.joint_velocity
        dp = rng.uniform(-1.0, 1.0, 3) * np.asarray(r.base_position)
        yaw = float(rng.uniform(-1.0, 1.0)) * r.base_yaw
        self.sim.reset_joint_state(w.body, self._spread, q0, qd0)
        if not t.robot(t.action.robot).fixed_base and (yaw or dp.any()):
            s = self._spawn
            turn = quat_from_rpy((0.0, 0.0, yaw))
            self.sim.reset_base_state(
                w.body, np.asarray(s.position) + dp, quat_multiply(turn, s.orientation)
            )
        self._hold(self.sim.joint_states(w.body, w.joints).positions)
        self._draw_commands(options)
        w.last_action, w.previous_action, w.torques = np.zeros(n), np.zeros(n), np.zeros(n)
        w.time = 0.0
        s = self.sim.base_state(w.body)
        w.start = np.array([s.position[0], s.position[1], heading(s.orientation)])
        self._queue = deque([np.zeros(n)] * t.action.latency)

    def _draw_commands(self, options: dict[str, Any]) -> None:
        """The episode's commands: drawn from the task's range with the episode's generator
        (after the initial state, in that order), or ``options["commands"]`` in their place."""
        t, w = self.task, self.world
        if t.commands is not None:
            lo, hi = np.asarray(t.commands.low), np.asarray(t.commands.high)
            w.commands = lo + (hi - lo) * self.np_random.uniform(0.0, 1.0, len(lo))
        if "commands" in options:
            c = np.asarray(options["commands"], dtype=float)
            if c.shape != w.commands.shape:
                raise InvalidArgumentError(
                    "options['commands']", f"expected {w.commands.size} values, got {c.shape}"
                )
            w.commands = c

    def _randomise_native(self, options: dict[str, Any]) -> None:
        """An MJCF task's initial state, drawn as Gymnasium's MuJoCo ``reset_model`` draws it:
        ``qpos0 + uniform(-h, h, nq)``, then ``qvel0 + s * standard_normal(nv)``, both drawn
        even when zero; then the commands."""
        t, w, rng = self.task, self.world, self.np_random
        r = t.randomisation
        h = r.qpos_uniform
        qpos = self._qpos0 + rng.uniform(low=-h, high=h, size=self._qpos0.size)
        qvel = self._qvel0 + r.qvel_normal * rng.standard_normal(self._qvel0.size)
        self.sim.set_qpos_qvel(qpos, qvel)
        self._hold(np.zeros(len(self._actuators)))
        self._draw_commands(options)
        n = len(t.action.joints)
        w.last_action, w.previous_action, w.torques = np.zeros(n), np.zeros(n), np.zeros(n)
        w.time = 0.0
        s = self.sim.base_state(w.body)
        w.start = np.array([s.position[0], s.position[1], heading(s.orientation)])
        w.qpos_start = w.qpos_before = self.sim.qpos()
        if self._reads_xpos:
            w.xpos_before = self.sim.xpos()
        self._queue = deque([np.zeros(n)] * t.action.latency)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """One control step: the action held over ``decimation`` physics steps.

        Args:
            action: ``(n,)``, one entry per action joint in the task's order (see
                :meth:`contract`); clipped to ``[-clip, clip]``.

        Returns:
            ``(observation, reward, terminated, truncated, info)``; info holds
            ``reward_terms`` (each term's weighted value), ``action_clipped`` (entries
            clipped this step), ``failure`` (the termination that ended the episode, or
            ``"diverged"`` when the engine's state went non-finite) and, at an episode's end,
            ``is_success``.

        Raises:
            ActionError: an action of another shape, or with a NaN or an infinite entry (the
                message gives the task's action layout).
        """
        a, clipped = self._check_action(action)
        w, t = self.world, self.task
        self._queue.append(a)
        applied = self._queue.popleft()
        info: dict[str, Any] = {"action_clipped": clipped}
        if t.native is not None:
            w.qpos_before = self.sim.qpos()
            if self._reads_xpos:
                w.xpos_before = self.sim.xpos()
        try:
            self._actuate(applied)
        except SimulationDivergedError:
            self._diverged = True
            info.update(failure="diverged", is_success=False)
            obs = self._observation()
            return obs, 0.0, True, False, info
        w.stale()
        w.previous_action, w.last_action = w.last_action, a
        w.time += t.control_dt
        self._steps += 1
        self._history.append(self._frame())
        reward, info["reward_terms"] = self._reward()
        failure = next((c.name for c in t.terminations if TERMINATIONS[c.name](w, c.params)), None)
        success = bool(t.success) and all(SUCCESSES[c.name](w, c.params) for c in t.success)
        early = success and any(c.params.get("terminate", False) for c in t.success)
        terminated = failure is not None or early
        truncated = not terminated and self._steps >= t.episode_steps
        if failure is not None:
            info["failure"] = failure
        if terminated or truncated:
            info["is_success"] = failure is None and success
        if self.render_mode == "human":
            self.render()
        return self._observation(), reward, terminated, truncated, info

    def _check_action(self, action: Any) -> tuple[np.ndarray, int]:
        t = self.task.action
        if type(action) is np.ndarray and action.dtype.kind == "f" and action.ndim == 1:
            values = action.tolist()  # a float array, the common case: checked in floats
            clip = t.clip
            if len(values) == len(t.joints) and all(-clip <= v <= clip for v in values):
                return np.array(values, dtype=np.float64), 0  # finite, within (NaN: False)
        try:
            a = np.asarray(action, dtype=np.float64)
        except (TypeError, ValueError):
            raise ActionError(
                f"got {type(action).__name__} {action!r:.60}", self.task.name, t.joints, t.mode
            ) from None
        if a.shape != (len(t.joints),):
            raise ActionError(f"got shape {a.shape}", self.task.name, t.joints, t.mode)
        if np.abs(a).max(initial=0.0) <= t.clip:  # finite and within the clip (NaN compares False)
            return a.copy(), 0  # the caller may reuse its array
        if not np.isfinite(a).all():
            bad = [t.joints[i] for i in np.flatnonzero(~np.isfinite(a))]
            raise ActionError(f"got a non-finite value for {bad}", self.task.name, t.joints, t.mode)
        c = np.clip(a, -t.clip, t.clip)
        return c, int(np.count_nonzero(c != a))

    def _actuate(self, applied: np.ndarray) -> None:
        """Turn the (delayed) action into targets and run ``decimation`` physics steps."""
        sim, w, a = self.sim, self.world, self.task.action
        base: np.ndarray | float
        if a.offset == "default":
            base = w.default
        elif a.offset == "current":
            base = sim.joint_states(w.body, w.joints).positions
        else:
            base = 0.0
        target = base + self._scale * applied
        n = self.task.decimation
        if a.mode == "actuator":  # held over the control period; ctrlrange clamps (the model's)
            sim.set_actuator_controls(target, self._actuators)
            self._physics(n, target)  # the hook's effort: the controls as written
        elif a.mode == "position":
            sim.set_joint_position(
                w.body,
                w.joints,
                target,
                max_force=np.asarray(a.max_force),
                kp=np.asarray(a.kp),
                kd=np.asarray(a.kd),
            )
            self._physics(n)
        elif a.mode == "velocity":
            sim.set_joint_velocity(w.body, w.joints, target, max_force=np.asarray(a.max_force))
            self._physics(n)
        elif a.mode == "torque":  # the same torque each physics step: clipped once
            tau = np.minimum(np.maximum(target, -self._limit), self._limit)
            w.torques = tau
            for _ in range(n):
                sim.set_joint_torque(w.body, w.joints, tau)
                self._physics(1, tau)
        else:
            limit = np.asarray(a.max_force)
            kp, kd = np.asarray(a.kp), np.asarray(a.kd)
            for _ in range(n):
                s = sim.joint_states(w.body, w.joints)
                tau = np.clip(kp * (target - s.positions) - kd * s.velocities, -limit, limit)
                sim.set_joint_torque(w.body, w.joints, tau)
                self._physics(1, tau)
            w.torques = tau

    def _physics(self, n: int, torque: np.ndarray | None = None) -> None:
        """``n`` physics steps, :attr:`physics_hook` called after each when set (with
        ``torque``, the torques commanded for them, the actuator mode's controls, or None)."""
        hook = self.physics_hook
        if hook is None:
            self.sim.step(n)
            return
        for _ in range(n):
            self.sim.step()
            hook(torque)

    def _reward(self) -> tuple[float, dict[str, float]]:
        terms = {
            r.name: r.weight * REWARDS[r.name](self.world, r.params) for r in self.task.rewards
        }
        return float(sum(terms.values())), terms

    def _frame(self) -> np.ndarray:
        """One observation frame: every term (noise added, then scaled), float64."""
        parts = []
        rng = self.np_random
        for term in self.task.observation:
            v = np.asarray(OBSERVATIONS[term.name](self.world, term.params), dtype=np.float64)
            if term.noise:
                v = v + rng.uniform(-term.noise, term.noise, v.shape)
            parts.append(v if term.scale == 1.0 else v * np.asarray(term.scale))
        return np.concatenate(parts) if parts else np.zeros(0)

    def _observation(self) -> np.ndarray:
        obs = self._history[0] if len(self._history) == 1 else np.concatenate(self._history)
        norm = self.task.normalisation
        if norm is None:
            return obs.astype(np.float32)
        # VecNormalize.normalize_obs's own arithmetic on the float32 observation it is given
        # (float64 statistics), then float32: the same numbers, bit for bit
        # (tests/envs/test_vecnormalize_file.py)
        obs32 = obs.astype(np.float32)
        mean, var = np.asarray(norm.mean), np.asarray(norm.var)
        out = np.clip((obs32 - mean) / np.sqrt(var + norm.epsilon), -norm.clip, norm.clip)
        return out.astype(np.float32)

    # ---------------------------------------------------------------- pictures, contract

    def render(self) -> np.ndarray | None:
        """A picture of the world (``render_mode="rgb_array"``), or None.

        Returns:
            ``(height, width, 3)`` uint8 RGB from the task's camera (default: 2 m off the
            action robot's base, looking at it) under "rgb_array" (on an engine that draws no
            pictures, MuJoCo's and PhysX's backends today, PyBullet's renderer draws this
            world's state: the same robots, set from ``get_state``); None under "human" (the
            engine's window shows the world as it steps) and without a render mode.
        """
        if self.render_mode != "rgb_array":
            return None
        base = np.asarray(self.sim.base_state(self.world.body).position)
        cam = self.task.camera
        target = cam.get("target", tuple(base))
        eye = cam.get("eye", tuple(base + np.array([1.6, -1.6, 1.0])))
        width, height = self.render_size
        try:
            return self.sim.render(width, height, eye=eye, target=target)
        except BackendUnsupportedError:  # an engine that draws no pictures: PyBullet draws
            return self._painter().render(width, height, eye=eye, target=target)

    def _painter(self) -> Sim:
        """A PyBullet Sim of the same robots set to this world's state, for pictures."""
        if self.task.native is not None:
            return self._native_painter(self.task.native)
        if self._shadow is None:
            self._shadow = Sim("pybullet", timestep=self.task.timestep)
            for r in self.task.robots:
                self._shadow.load_urdf(
                    r.urdf,
                    base_position=r.position,
                    base_orientation=r.orientation,
                    fixed_base=r.fixed_base,
                )
        self._shadow.set_state(self.sim.get_state(exact=False))
        return self._shadow

    def _native_painter(self, r: RobotSpec) -> Sim:
        """PyBullet's reading of the same MJCF (which PyBullet draws), its joints set by name
        to this world's and, for a free-floating robot, its base to this world's base pose."""
        sim, w = self.sim, self.world
        if self._shadow is None:
            self._shadow = Sim("pybullet", timestep=self.task.timestep)
            ids = self._shadow.load_mjcf(r.mjcf)
            own = {sim.joint_info(w.body, j).name for j in range(sim.num_joints(w.body))}

            def shared(b: int) -> int:
                n = self._shadow.num_joints(b)  # type: ignore[union-attr]
                return sum(self._shadow.joint_info(b, j).name in own for j in range(n))  # type: ignore[union-attr]

            self._shadow_body = max(ids, key=shared)
        shadow, body = self._shadow, self._shadow_body
        names = [shadow.joint_info(body, j).name for j in range(shadow.num_joints(body))]
        mine = {sim.joint_info(w.body, j).name: j for j in range(sim.num_joints(w.body))}
        pairs = [(i, mine[n]) for i, n in enumerate(names) if n in mine]
        q = sim.joint_states(w.body, [j for _, j in pairs]).positions
        shadow.reset_joint_state(body, [i for i, _ in pairs], q)
        if sim.qpos().size == 7 + len(mine):  # a free joint, then one coordinate per joint
            base = sim.base_state(w.body)
            shadow.reset_base_state(body, base.position, base.orientation)
        return shadow

    def contract(self) -> dict[str, Any]:
        """What a policy trained on this task depends on, as plain data (JSON-ready).

        Returns:
            A dict: ``task``, ``backend``, ``timestep``, ``decimation``, ``control_dt``,
            ``episode_steps``; ``action`` (joints in order, mode, scale, offset, clip, kp,
            kd, max_force, latency, and each joint's limits, damping and friction as the
            engine's joint table gives them); ``observation`` (``terms``: name, start, size,
            scale, noise, params and one name per entry; ``frame_size``, ``history`` and its
            order, ``size``, ``dtype``, ``normalisation``); ``commands``; ``randomisation``;
            ``reset``.
        """
        from simbridge.envs.contract import contract

        return contract(self)

    def close(self) -> None:
        """Close the Sim (and its window)."""
        if not self.sim.closed:
            self.sim.close()
        if self._shadow is not None:
            self._shadow.close()
            self._shadow = None
