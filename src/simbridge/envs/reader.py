"""Reading a task from TOML: :func:`load_task` (a shipped task's name or a file) and
:func:`loads_task` (text). Every value goes through the checks scenario files go through
(:class:`simbridge.compare.scenario.checks.TableReader`), so a wrong key or value is named with
its ``FILE:LINE`` (:class:`~simbridge.envs.errors.TaskFileError`). The format: docs/envs.md.
"""

from __future__ import annotations

import math
import os
import re
import tomllib
from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

from simbridge.compare.scenario.checks import TableReader, find_key_line
from simbridge.compare.scenario.model import parse_timestep
from simbridge.envs.errors import TaskFileError
from simbridge.envs.task import (
    ACTION_MODES,
    ACTION_OFFSETS,
    RESET_MODES,
    ActionSpec,
    CommandSpec,
    Condition,
    Normalisation,
    ObsTerm,
    Randomisation,
    RewardTerm,
    RobotSpec,
    Task,
    TrainedSpec,
)
from simbridge.envs.terms import (
    NATIVE_TERMS,
    OBSERVATIONS,
    PARAMS,
    REWARDS,
    SUCCESSES,
    TERMINATIONS,
)
from simbridge.transforms import quat_from_rpy

__all__ = [
    "TASK_KEYS",
    "TRAINED_KEYS",
    "key_line",
    "load_task",
    "loads_task",
    "shipped_tasks",
]

TASK_KEYS = (
    "name",
    "description",
    "timestep",
    "decimation",
    "episode_steps",
    "history",
    "profile",
    "gravity",
    "reset",
    "robots",
    "action",
    "observation",
    "normalisation",
    "rewards",
    "terminations",
    "success",
    "commands",
    "randomisation",
    "camera",
    "trained",
)
"""The keys at a task file's top level."""

TRAINED_KEYS = ("framework", "effort_limit", "velocity_limit", "damping", "friction", "armature")
"""The keys of a task file's ``[trained]`` table (:class:`~simbridge.envs.task.TrainedSpec`)."""

_TERMS: dict[str, Mapping[str, Any]] = {
    "observation": OBSERVATIONS,
    "rewards": REWARDS,
    "terminations": TERMINATIONS,
    "success": SUCCESSES,
}

_PARAM_KINDS = {
    "limit": "number", "within": "number", "period": "number", "target": "number",
    "sigma": "number",
    "relative": "bool", "terminate": "bool", "link": "name", "joint": "name",
    "links": "names", "joints": "names", "exclude": "count", "z_min": "number",
    "z_max": "number", "min": "number", "range": "interval",
    "body": "count",
}  # fmt: skip


def shipped_tasks() -> dict[str, Path]:
    """The tasks shipped with simbridge.

    Returns:
        Name -> TOML file (``simbridge/envs/tasks/*.toml``).
    """
    folder = Path(str(resources.files("simbridge.envs") / "tasks"))
    return {p.stem: p for p in sorted(folder.glob("*.toml"))}


def load_task(source: str | os.PathLike[str]) -> Task:
    """A task from a shipped task's name or a TOML file.

    Args:
        source: a name of :func:`shipped_tasks` (``"cartpole"``) or a path.

    Returns:
        The task.

    Raises:
        TaskFileError: no such task or file (the message lists the shipped ones), or a file
            that says something invalid (``FILE:LINE``).
    """
    shipped = shipped_tasks()
    path = shipped.get(str(source)) or Path(source)
    if not path.is_file():
        raise TaskFileError(
            str(source), None, f"no such task file or shipped task; shipped: {sorted(shipped)}"
        )
    return loads_task(path.read_text(encoding="utf-8"), file=str(path))


def loads_task(text: str, *, file: str = "<task>") -> Task:
    """Parse task TOML text.

    Args:
        text: the TOML.
        file: its file name, for messages.

    Returns:
        The task.

    Raises:
        TaskFileError: naming ``file``, the key and its line.
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        m = re.search(r"line (\d+)", str(exc))
        raise TaskFileError(
            file, None, f"TOML syntax error: {exc}", int(m.group(1)) if m else None
        ) from None
    return _Reader(text, file).task(data)


def _keystr(path: list[str | int]) -> str:
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out


class _Reader(TableReader):
    """A task file's checks: the scenario reader's, raising :class:`TaskFileError`."""

    def error(self, path: Any, detail: str) -> TaskFileError:
        return TaskFileError(self.file, _keystr(list(path)), detail, find_key_line(self.text, path))

    def integer(self, t: dict[str, Any], key: str, default: int, low: int) -> int:
        v = t.get(key, default)
        if isinstance(v, bool) or not isinstance(v, int) or v < low:
            raise self.error([key], f"expected an integer >= {low}, got {v!r}")
        return v

    def _clip_and_latency(self, t: dict[str, Any], path: list[str | int]) -> tuple[float, int]:
        """An ``[action]`` table's ``clip`` (> 0, default 1) and ``latency`` (control steps,
        an integer >= 0, default 0), whatever the action's mode."""
        clip = self.number(t.get("clip", 1.0), [*path, "clip"])
        if clip <= 0:
            raise self.error([*path, "clip"], f"must be > 0, got {clip!r}")
        latency = t.get("latency", 0)
        if isinstance(latency, bool) or not isinstance(latency, int) or latency < 0:
            raise self.error(
                [*path, "latency"], f"expected an integer >= 0 (control steps), got {latency!r}"
            )
        return clip, latency

    def choice(
        self,
        t: dict[str, Any],
        path: list[str | int],
        key: str,
        default: str,
        valid: tuple[str, ...],
    ) -> str:
        v = t.get(key, default)
        if v not in valid:
            raise self.error([*path, key], f"expected one of {', '.join(valid)}, got {v!r}")
        return v

    def task(self, data: dict[str, Any]) -> Task:
        self.keys(data, [], TASK_KEYS)
        try:
            dt = parse_timestep(data.get("timestep", "1/240"))
        except ValueError as exc:
            raise self.error(["timestep"], str(exc)) from None
        robots = self.robots(data)
        gravity = self.vector(data.get("gravity", [0, 0, -9.8]), ["gravity"], 3)
        self.native = None
        if any(r.mjcf for r in robots):
            self.native = self.native_world(data, robots)
            option = self.native.model.opt
            dt = dt if "timestep" in data else float(option.timestep)
            if "gravity" not in data:
                gravity = (
                    float(option.gravity[0]),
                    float(option.gravity[1]),
                    float(option.gravity[2]),
                )
        return Task(
            name=self.string(data.get("name", Path(self.file).stem), ["name"]),
            description=str(data.get("description", "")),
            robots=robots,
            action=self.action(data, robots),
            observation=tuple(
                self.obs_term(o, i) for i, o in enumerate(self.tables(data, "observation", 1))
            ),
            timestep=dt,
            decimation=self.integer(data, "decimation", 4, 1),
            episode_steps=self.integer(data, "episode_steps", 500, 1),
            history=self.integer(data, "history", 1, 1),
            normalisation=self.normalisation(data),
            rewards=tuple(self.reward(r, i) for i, r in enumerate(self.tables(data, "rewards", 0))),
            terminations=tuple(
                self.condition(c, "terminations", i)
                for i, c in enumerate(self.tables(data, "terminations", 0))
            ),
            success=tuple(
                self.condition(c, "success", i)
                for i, c in enumerate(self.tables(data, "success", 0))
            ),
            commands=self.commands(data),
            randomisation=self.randomisation(data),
            profile=self.string(data.get("profile", "pybullet"), ["profile"]),
            gravity=gravity,
            reset=self.choice(data, [], "reset", "restore", RESET_MODES),
            camera=self.camera(data),
            source=None if self.file.startswith("<") else self.file,
            trained=self.trained(data, self.action_size),  # after the action's checks
        )

    def trained(self, data: dict[str, Any], n: int) -> TrainedSpec | None:
        if "trained" not in data:
            return None
        t, path = data["trained"], ["trained"]
        if not isinstance(t, dict):
            raise self.error(path, "expected a table ([trained])")
        self.keys(t, path, TRAINED_KEYS)
        per = {k: self.per_joint(t[k], [*path, k], n, nonneg=True) for k in t if k != "framework"}
        framework = self.string(t["framework"], [*path, "framework"]) if "framework" in t else ""
        return TrainedSpec(framework=framework, **per)

    def tables(self, data: dict[str, Any], key: str, least: int) -> list[Any]:
        raw = data.get(key, [])
        if not isinstance(raw, list) or len(raw) < least:
            raise self.error([key], f"expected at least {least} [[{key}]] table(s)")
        for i, t in enumerate(raw):
            if not isinstance(t, dict):
                raise self.error([key, i], f"expected a table ([[{key}]])")
        return raw

    def robots(self, data: dict[str, Any]) -> tuple[RobotSpec, ...]:
        out = []
        for i, t in enumerate(self.tables(data, "robots", 1)):
            path: list[str | int] = ["robots", i]
            keys = (
                "name",
                "urdf",
                "mjcf",
                "semantics",
                "body",
                "position",
                "orientation",
                "rpy",
                "fixed_base",
                "joint_positions",
                "released",
            )
            self.keys(t, path, keys)
            if "mjcf" in t:
                out.append(self.mjcf_robot(t, path))
                continue
            if "semantics" in t or "body" in t:
                key = "semantics" if "semantics" in t else "body"
                raise self.error([*path, key], "only for a robot from an MJCF file (mjcf = ...)")
            urdf = self.string(self.require(t, path, "urdf"), [*path, "urdf"])
            orientation = self.vector(t.get("orientation", [0, 0, 0, 1]), [*path, "orientation"], 4)
            if "rpy" in t:
                orientation = quat_from_rpy(self.vector(t["rpy"], [*path, "rpy"], 3))
            if abs(math.sqrt(sum(c * c for c in orientation)) - 1) > 1e-3:
                raise self.error([*path, "orientation"], "expected a unit quaternion (x, y, z, w)")
            jp = t.get("joint_positions", {})
            if not isinstance(jp, dict):
                raise self.error([*path, "joint_positions"], "expected a table of joint = position")
            fixed = t.get("fixed_base", False)
            if not isinstance(fixed, bool):
                raise self.error([*path, "fixed_base"], f"expected true or false, got {fixed!r}")
            out.append(
                RobotSpec(
                    name=self.string(t.get("name", Path(urdf).stem), [*path, "name"]),
                    urdf=urdf,
                    position=self.vector(t.get("position", [0, 0, 0]), [*path, "position"], 3),
                    orientation=orientation,
                    fixed_base=fixed,
                    joint_positions={
                        k: self.number(v, [*path, "joint_positions", k]) for k, v in jp.items()
                    },
                    released=self.names(t.get("released", []), [*path, "released"]),
                )
            )
        return tuple(out)

    def mjcf_robot(self, t: dict[str, Any], path: list[str | int]) -> RobotSpec:
        """An ``mjcf = ...`` robot: read as MuJoCo reads it, the file placing everything."""
        mjcf = self.string(t["mjcf"], [*path, "mjcf"])
        semantics = t.get("semantics")
        if semantics != "mujoco":
            raise self.error(
                [*path, "semantics" if "semantics" in t else "mjcf"],
                f"an environment reads an MJCF as MuJoCo reads it: expected semantics = "
                f"'mujoco', got {semantics!r}",
            )
        for key in (
            "urdf",
            "position",
            "orientation",
            "rpy",
            "fixed_base",
            "joint_positions",
            "released",
        ):
            if key in t:
                raise self.error(
                    [*path, key],
                    "not with mjcf: the file read as MuJoCo reads it places its bodies and "
                    "holds its own initial state",
                )
        body = t.get("body", 0)
        if isinstance(body, bool) or not isinstance(body, int) or body < 0:
            raise self.error([*path, "body"], f"expected an integer >= 0, got {body!r}")
        name = self.string(t.get("name", Path(mjcf).stem), [*path, "name"])
        near = Path(self.file).parent / mjcf
        if not self.file.startswith("<") and not mjcf.startswith("package://") and near.is_file():
            mjcf = str(near)  # a path relative to the task file
        return RobotSpec(name=name, urdf="", mjcf=mjcf, body=body)

    def native_world(self, data: dict[str, Any], robots: tuple[RobotSpec, ...]) -> Any:
        """The MJCF read as MuJoCo reads it, compiled by MuJoCo (its refusal is the task's
        error): it must be the task's only robot, and hold the body ``body`` names."""
        from simbridge.exceptions import MjcfCompileError, UrdfNotFoundError
        from simbridge.model.mjcf_native import compile_mjcf

        i = next(k for k, r in enumerate(robots) if r.mjcf)
        at: list[str | int] = ["robots", i]
        if len(robots) > 1:
            others = sorted(r.name for r in robots if not r.mjcf)
            raise self.error(
                [*at, "mjcf"],
                f"an MJCF read as MuJoCo reads it is the whole world (its own floor and "
                f"<option>): it cannot share the task with {others}",
            )
        path = robots[i].mjcf
        try:
            native = compile_mjcf(path)
        except (UrdfNotFoundError, MjcfCompileError) as exc:
            raise self.error([*at, "mjcf"], str(exc)) from None
        if robots[i].body >= len(native.bodies):
            raise self.error(
                [*at, "body"],
                f"the file has {len(native.bodies)} top-level bodies "
                f"({[b.name for b in native.bodies]}), got body = {robots[i].body}",
            )
        return native

    def names(self, raw: Any, path: list[str | int]) -> tuple[str, ...]:
        if not isinstance(raw, list):
            raise self.error(path, f"expected a list of joint names, got {raw!r}")
        out = tuple(self.string(j, [*path, i]) for i, j in enumerate(raw))
        if len(set(out)) != len(out):
            raise self.error(path, "a joint is named twice")
        return out

    def action(self, data: dict[str, Any], robots: tuple[RobotSpec, ...]) -> ActionSpec:
        path: list[str | int] = ["action"]
        t = self.require(data, [], "action")
        if not isinstance(t, dict):
            raise self.error(path, "expected a table ([action])")
        keys = (
            "robot",
            "joints",
            "actuators",
            "mode",
            "scale",
            "offset",
            "clip",
            "kp",
            "kd",
            "max_force",
            "latency",
        )
        self.keys(t, path, keys)
        names = [r.name for r in robots]
        robot = self.string(t.get("robot", names[0]), [*path, "robot"])
        if robot not in names:
            raise self.error([*path, "robot"], f"no robot {robot!r}; robots: {names}")
        if t.get("mode") == "actuator" or (self.native is not None and "joints" not in t):
            return self.actuator_action(t, path, robot)
        if "actuators" in t:
            raise self.error([*path, "actuators"], "only with mode = 'actuator'")
        joints = self.names(self.require(t, path, "joints"), [*path, "joints"])
        if not joints:
            raise self.error([*path, "joints"], "expected at least one joint name")
        self.require(t, path, "mode")
        mode = self.choice(t, path, "mode", "", ACTION_MODES)
        n = self.action_size = len(joints)
        needs = {
            "position": ("max_force",),
            "velocity": ("max_force",),
            "pd": ("kp", "kd", "max_force"),
            "torque": ("max_force",),
        }
        for key in needs[mode]:
            self.require(t, path, key)
        for key in ("kp", "kd"):
            if key in t and mode not in ("pd", "position"):
                raise self.error([*path, key], "only position and pd actions take gains")
        per = {
            k: self.per_joint(t[k], [*path, k], n, nonneg=True)
            for k in ("kp", "kd", "max_force")
            if k in t
        }
        if mode == "position":
            per.setdefault("kp", (0.1,) * n)
            per.setdefault("kd", (1.0,) * n)
        clip, latency = self._clip_and_latency(t, path)
        return ActionSpec(
            robot=robot,
            joints=joints,
            mode=mode,
            scale=self.per_joint(t.get("scale", 1.0), [*path, "scale"], n),
            offset=self.choice(t, path, "offset", "default", ACTION_OFFSETS),
            clip=clip,
            latency=latency,
            **per,
        )

    def actuator_action(self, t: dict[str, Any], path: list[str | int], robot: str) -> ActionSpec:
        """``mode = "actuator"``: the model's actuator controls, by name or in MuJoCo's order."""
        if self.native is None:
            raise self.error(
                [*path, "mode"],
                "an actuator action needs a robot read from an MJCF as MuJoCo reads it "
                "(mjcf = ..., semantics = 'mujoco')",
            )
        if t.get("mode") != "actuator":
            raise self.error(
                [*path, "mode"] if "mode" in t else path,
                f"a task over an MJCF read as MuJoCo reads it drives its actuators: expected "
                f"mode = 'actuator', got {t.get('mode')!r}",
            )
        for key in ("joints", "kp", "kd", "max_force"):
            if key in t:
                raise self.error(
                    [*path, key],
                    "not with mode = 'actuator': the model's actuators hold their own joints, "
                    "gains and force ranges (name them with actuators = [...])",
                )
        valid = [a.name for a in self.native.actuators]
        names = (
            self.names(t["actuators"], [*path, "actuators"]) if "actuators" in t else tuple(valid)
        )
        for i, name in enumerate(names):
            if name not in valid:
                raise self.error(
                    [*path, "actuators", i],
                    f"the model has no actuator {name!r}; actuators: {valid}",
                )
        if not names:
            raise self.error([*path, "actuators"], "the model has no actuators to drive")
        offset = self.choice(t, path, "offset", "zero", ("zero",))
        clip, latency = self._clip_and_latency(t, path)
        self.action_size = len(names)
        return ActionSpec(
            robot=robot,
            joints=names,
            mode="actuator",
            scale=self.per_joint(t.get("scale", 1.0), [*path, "scale"], len(names)),
            offset=offset,
            clip=clip,
            latency=latency,
        )

    def params(self, t: dict[str, Any], path: list[str | int], name: str) -> dict[str, Any]:
        raw = t.get("params", {})
        if not isinstance(raw, dict):
            raise self.error([*path, "params"], "expected a table of the term's parameters")
        need, may = PARAMS.get(name, ((), ()))
        self.keys(raw, [*path, "params"], need + may)
        for key in need:
            self.require(raw, [*path, "params"], key)
        out = dict(raw)
        for key, value in raw.items():
            where = [*path, "params", key]
            kind = _PARAM_KINDS[key]
            if kind == "number":
                out[key] = self.number(value, where)
            elif kind == "bool" and not isinstance(value, bool):
                raise self.error(where, f"expected true or false, got {value!r}")
            elif kind == "name" and (isinstance(value, bool) or not isinstance(value, (str, int))):
                raise self.error(where, f"expected a name or an index, got {value!r}")
            elif kind == "names":
                out[key] = self.names(value, where)
            elif kind == "count" and (
                isinstance(value, bool) or not isinstance(value, int) or value < 0
            ):
                raise self.error(where, f"expected an integer >= 0, got {value!r}")
            elif kind == "interval":
                out[key] = self.interval(value, where)
        if name in NATIVE_TERMS and self.native is None:
            raise self.error(
                [*path, "term"],
                f"{name!r} reads MuJoCo's generalized coordinates: only for a task over an MJCF "
                f"read as MuJoCo reads it (mjcf = ..., semantics = 'mujoco')",
            )
        return out

    def interval(self, value: Any, where: list[str | int]) -> tuple[float, float]:
        """``[low, high]``: two numbers, low <= high."""
        if not isinstance(value, list) or len(value) != 2:
            raise self.error(where, f"expected [low, high], got {value!r}")
        low, high = (self.number(v, [*where, i]) for i, v in enumerate(value))
        if not low <= high:
            raise self.error(where, f"expected low <= high, got {value!r}")
        return low, high

    def term(self, t: dict[str, Any], path: list[str | int], kind: str) -> str:
        name = self.string(self.require(t, path, "term"), [*path, "term"])
        valid = sorted(_TERMS[kind])
        if name not in valid:
            raise self.error([*path, "term"], f"unknown term {name!r}; valid: {', '.join(valid)}")
        return name

    def obs_term(self, t: dict[str, Any], i: int) -> ObsTerm:
        path: list[str | int] = ["observation", i]
        self.keys(t, path, ("term", "scale", "noise", "params"))
        name = self.term(t, path, "observation")
        scale = t.get("scale", 1.0)
        sc: float | tuple[float, ...] = (
            tuple(self.number(v, [*path, "scale", k]) for k, v in enumerate(scale))
            if isinstance(scale, list)
            else self.number(scale, [*path, "scale"])
        )
        noise = self.number(t.get("noise", 0.0), [*path, "noise"], nonneg=True)
        return ObsTerm(name, sc, noise, self.params(t, path, name))

    def reward(self, t: dict[str, Any], i: int) -> RewardTerm:
        path: list[str | int] = ["rewards", i]
        self.keys(t, path, ("term", "weight", "params"))
        name = self.term(t, path, "rewards")
        weight = self.number(t.get("weight", 1.0), [*path, "weight"])
        return RewardTerm(name, weight, self.params(t, path, name))

    def condition(self, t: dict[str, Any], kind: str, i: int) -> Condition:
        path: list[str | int] = [kind, i]
        self.keys(t, path, ("term", "params"))
        name = self.term(t, path, kind)
        return Condition(name, self.params(t, path, name))

    def normalisation(self, data: dict[str, Any]) -> Normalisation | None:
        t = data.get("normalisation")
        if t is None:
            return None
        path: list[str | int] = ["normalisation"]
        self.keys(t, path, ("mean", "var", "clip", "epsilon"))
        mean, var = self.require(t, path, "mean"), self.require(t, path, "var")
        if not isinstance(mean, list) or not isinstance(var, list) or len(mean) != len(var):
            raise self.error(path, "expected lists mean and var of one length")
        return Normalisation(
            tuple(self.number(v, [*path, "mean", i]) for i, v in enumerate(mean)),
            tuple(self.number(v, [*path, "var", i], nonneg=True) for i, v in enumerate(var)),
            self.number(t.get("clip", 10.0), [*path, "clip"], nonneg=True),
            self.number(t.get("epsilon", 1e-8), [*path, "epsilon"], nonneg=True),
        )

    def commands(self, data: dict[str, Any]) -> CommandSpec | None:
        t = data.get("commands")
        if t is None:
            return None
        path: list[str | int] = ["commands"]
        self.keys(t, path, ("names", "low", "high"))
        names = self.require(t, path, "names")
        if not isinstance(names, list) or not names:
            raise self.error([*path, "names"], "expected a list of names")
        n = len(names)
        low = self.vector(self.require(t, path, "low"), [*path, "low"], n)
        high = self.vector(self.require(t, path, "high"), [*path, "high"], n)
        if any(h < lo for lo, h in zip(low, high, strict=True)):
            raise self.error([*path, "high"], "expected high >= low, entry by entry")
        return CommandSpec(tuple(str(x) for x in names), low, high)

    def randomisation(self, data: dict[str, Any]) -> Randomisation:
        t = data.get("randomisation", {})
        path: list[str | int] = ["randomisation"]
        keys = ("joint_position", "joint_velocity", "base_position", "base_yaw", "joints")
        native = ("qpos_uniform", "qvel_normal")
        self.keys(t, path, keys + native)
        for key in keys if self.native is not None else native:
            if key in t:
                raise self.error(
                    [*path, key],
                    "not with an MJCF read as MuJoCo reads it: its spread is qpos_uniform and "
                    "qvel_normal"
                    if self.native is not None
                    else "only for a task over an MJCF read as MuJoCo reads it",
                )
        return Randomisation(
            self.number(t.get("joint_position", 0.0), [*path, "joint_position"], nonneg=True),
            self.number(t.get("joint_velocity", 0.0), [*path, "joint_velocity"], nonneg=True),
            self.vector(t.get("base_position", [0, 0, 0]), [*path, "base_position"], 3),
            self.number(t.get("base_yaw", 0.0), [*path, "base_yaw"], nonneg=True),
            self.names(t.get("joints", []), [*path, "joints"]),
            self.number(t.get("qpos_uniform", 0.0), [*path, "qpos_uniform"], nonneg=True),
            self.number(t.get("qvel_normal", 0.0), [*path, "qvel_normal"], nonneg=True),
        )

    def camera(self, data: dict[str, Any]) -> dict[str, tuple[float, ...]]:
        t = data.get("camera", {})
        self.keys(t, ["camera"], ("eye", "target"))
        return {k: self.vector(v, ["camera", k], 3) for k, v in t.items()}


def key_line(source: str | None, path: Sequence[str | int]) -> int | None:
    """The 1-based line of the key ``path`` (``["robots", 0, "released"]``) in the task file
    ``source``, for an error found after reading (a joint the robot lacks).

    Args:
        source: the task's file (``Task.source``), or None for a task made in Python.
        path: the key's path, an array of tables' entry by its index.

    Returns:
        The line, or None when there is no file or it cannot be read any more.
    """
    if source is None:
        return None
    try:
        text = Path(source).read_text(encoding="utf-8")
    except OSError:
        return None
    return find_key_line(text, path)
