"""Reading scenario TOML: validation with the key's line in every error (:func:`find_key_line`,
``_Reader``) and :func:`loads_scenario`. The format is described in :mod:`.scenario`.

A little over 600 lines because ``_Reader`` is one class checking one file format top to bottom,
every check naming its key path; splitting it would part each table from its checks."""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import simbridge
from simbridge.engine_settings import freeze
from simbridge.engine_settings import validate as validate_settings
from simbridge.exceptions import InvalidEngineSettingError, ScenarioError, did_you_mean
from simbridge.transforms import quat_from_rpy

from .controllers import ControllerSpec, RefError, absolute_ref, load_object
from .model import (
    HEADLINE_QUANTITIES,
    MAX_STEPS,
    MODES,
    Command,
    JointRef,
    Phase,
    RobotSpec,
    Scenario,
    parse_timestep,
)
from .outcomes import KINDS as OUTCOME_KINDS
from .outcomes import Outcome

# ---------------------------------------------------------------- finding a key's line


_HEADER = re.compile(r"^\s*(\[\[?)\s*([^\]]+?)\s*\]\]?\s*(#.*)?$")
_KEYLINE = re.compile(r"^\s*([A-Za-z0-9_\-\"'. ]+?)\s*=")


def _split_key(key: str) -> list[str]:
    return [part.strip().strip("\"'") for part in key.split(".")]


def find_key_line(text: str, path: Sequence[str | int]) -> int | None:
    """The 1-based line of the key ``path`` (``["phases", 1, "commands", 0, "mode"]``) in TOML
    ``text``, or of its closest enclosing key or table found; None when nothing matches.

    Understands ``[table]``, ``[[array.of.tables]]`` (counting entries) and ``key = value`` lines;
    inside inline tables and arrays it falls back to the line of the enclosing key."""
    target = list(path)
    best_line: int | None = None
    best_len = 0
    header: list[str | int] = []
    counts: dict[tuple[str | int, ...], int] = {}
    depth = 0  # open brackets of a multi-line value
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0] if '"' not in raw and "'" not in raw else raw
        if depth == 0:
            m = _HEADER.match(line)
            if m:
                names = _split_key(m.group(2))
                resolved: list[str | int] = []
                for i, name in enumerate(names):
                    resolved.append(name)
                    is_last = i == len(names) - 1
                    if m.group(1) == "[[" and is_last:
                        key = tuple(resolved)
                        counts[key] = counts.get(key, -1) + 1
                        resolved.append(counts[key])
                    elif tuple(resolved) in counts:  # parent array of tables: its last entry
                        resolved.append(counts[tuple(resolved)])
                header = resolved
                candidate: list[str | int] = list(header)
            else:
                k = _KEYLINE.match(line)
                if not k:
                    depth += line.count("[") - line.count("]")
                    continue
                candidate = [*header, *_split_key(k.group(1))]
                depth += line.count("[") - line.count("]")
                depth += line.count("{") - line.count("}")
            n = 0
            while n < min(len(candidate), len(target)) and candidate[n] == target[n]:
                n += 1
            if n == len(candidate) and n > best_len:
                best_len, best_line = n, lineno
                if n == len(target):
                    return lineno
        else:
            depth += line.count("[") - line.count("]")
            depth += line.count("{") - line.count("}")
            depth = max(depth, 0)
    return best_line


# ---------------------------------------------------------------- reading


def _keystr(path: Sequence[str | int]) -> str:
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else p)
    return out


PYBULLET_KEYS = {
    "basePosition": "position",
    "base_position": "position",
    "baseOrientation": "orientation",
    "base_orientation": "orientation",
    "useFixedBase": "fixed_base",
    "use_fixed_base": "fixed_base",
    "fileName": "urdf",
    "urdf_path": "urdf",
    "timeStep": "timestep",
    "time_step": "timestep",
    "fixedTimeStep": "timestep",
}
"""The names PyBullet's calls and tutorials give a scenario's keys (``p.loadURDF(fileName,
basePosition, baseOrientation, useFixedBase)``, ``p.setTimeStep(timeStep)``) -> the scenario's."""


def _suggest(key: str, allowed: Sequence[str]) -> str:
    """`` (did you mean 'position'?)`` for an unknown key: PyBullet's name of a key allowed
    here (:data:`PYBULLET_KEYS`, saying so), else the closest allowed key, else ``""``."""
    ours = PYBULLET_KEYS.get(key)
    if ours is not None and ours in allowed:
        return f" (did you mean {ours!r}? the scenario's name for PyBullet's {key})"
    return did_you_mean(key, allowed)


class _Reader:
    """Validates the parsed TOML, raising ScenarioError with the key's line."""

    def __init__(self, text: str, file: str):
        self.text = text
        self.file = file

    def error(self, path: Sequence[str | int], detail: str) -> ScenarioError:
        return ScenarioError(self.file, _keystr(path), detail, find_key_line(self.text, path))

    def keys(self, table: dict[str, Any], path: list[str | int], allowed: Sequence[str]) -> None:
        for key in table:
            if key not in allowed:
                raise self.error(
                    [*path, key],
                    f"unknown key{_suggest(str(key), allowed)}; valid keys here: "
                    f"{', '.join(allowed)}",
                )

    def require(self, table: dict[str, Any], path: list[str | int], key: str) -> Any:
        if key not in table:
            where = _keystr(path) or "the top level"
            raise self.error([*path, key], f"missing (required in {where})")
        return table[key]

    def string(self, value: Any, path: list[str | int]) -> str:
        if not isinstance(value, str) or not value:
            raise self.error(path, f"expected a non-empty string, got {value!r}")
        return value

    def number(self, value: Any, path: list[str | int], *, nonneg: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(path, f"expected a number, got {value!r}")
        if not math.isfinite(value):
            raise self.error(path, f"expected a finite number, got {value!r}")
        if nonneg and value < 0:
            raise self.error(path, f"must be >= 0, got {value!r}")
        return float(value)

    def vector(self, value: Any, path: list[str | int], n: int) -> tuple[float, ...]:
        if not isinstance(value, list) or len(value) != n:
            raise self.error(path, f"expected a list of {n} numbers, got {value!r}")
        return tuple(self.number(v, [*path, i]) for i, v in enumerate(value))

    def per_joint(
        self, value: Any, path: list[str | int], n: int, *, nonneg: bool = False
    ) -> tuple[float, ...]:
        if isinstance(value, list):
            if len(value) != n:
                raise self.error(
                    path, f"expected one number or {n} (one per joint), got {len(value)}"
                )
            return tuple(self.number(v, [*path, i], nonneg=nonneg) for i, v in enumerate(value))
        return (self.number(value, path, nonneg=nonneg),) * n

    def joint_ref(self, value: Any, path: list[str | int]) -> JointRef:
        if isinstance(value, bool) or not isinstance(value, (int, str)):
            raise self.error(path, f"expected a joint index or name, got {value!r}")
        if isinstance(value, int) and value < 0:
            raise self.error(path, f"joint indices are >= 0, got {value}")
        return value

    def robot(self, t: Any, path: list[str | int]) -> RobotSpec:
        if not isinstance(t, dict):
            raise self.error(path, "expected a table ([[robots]])")
        self.keys(
            t,
            path,
            (
                "name",
                "urdf",
                "mjcf",
                "body",
                "position",
                "orientation",
                "rpy",
                "fixed_base",
                "joint_positions",
            ),
        )
        kind = "mjcf" if "mjcf" in t else "urdf"
        if kind == "mjcf":
            for key in ("urdf", "position", "orientation", "rpy", "fixed_base"):
                if key in t:
                    raise self.error(
                        [*path, key],
                        "not with mjcf: an MJCF file places its bodies itself (p.loadMJCF "
                        "takes no pose)",
                    )
        elif "body" in t:
            raise self.error([*path, "body"], "only for a robot from an MJCF file (mjcf = ...)")
        urdf = self.string(self.require(t, path, kind), [*path, kind])
        body = t.get("body", 0)
        if isinstance(body, bool) or not isinstance(body, int) or body < 0:
            raise self.error([*path, "body"], f"expected an integer >= 0, got {body!r}")
        name = self.string(t.get("name", Path(urdf).stem), [*path, "name"])
        position = self.vector(t.get("position", [0, 0, 0]), [*path, "position"], 3)
        if "orientation" in t and "rpy" in t:
            raise self.error([*path, "rpy"], "give either orientation or rpy, not both")
        orientation: tuple[float, ...]
        if "rpy" in t:
            orientation = quat_from_rpy(self.vector(t["rpy"], [*path, "rpy"], 3))
        else:
            orientation = self.vector(t.get("orientation", [0, 0, 0, 1]), [*path, "orientation"], 4)
            norm = math.sqrt(sum(c * c for c in orientation))
            if abs(norm - 1) > 1e-3:
                raise self.error(
                    [*path, "orientation"],
                    f"expected a unit quaternion (x, y, z, w), norm is {norm:.6g}",
                )
        fixed = t.get("fixed_base", False)
        if not isinstance(fixed, bool):
            raise self.error([*path, "fixed_base"], f"expected true or false, got {fixed!r}")
        jp = t.get("joint_positions", {})
        if not isinstance(jp, dict):
            raise self.error(
                [*path, "joint_positions"],
                "expected a table of joint name (or index) = position, e.g. { hinge = 0.5 }",
            )
        joints: list[tuple[JointRef, float]] = []
        for k, v in jp.items():
            ref: JointRef = int(k) if k.isascii() and k.isdigit() else k
            joints.append((ref, self.number(v, [*path, "joint_positions", k])))
        return RobotSpec(name, urdf, position, orientation, fixed, tuple(joints), kind, body)  # type: ignore[arg-type]

    def command(
        self, t: Any, path: list[str | int], robots: dict[str, RobotSpec], subject: str
    ) -> Command:
        if not isinstance(t, dict):
            raise self.error(path, "expected a table ([[phases.commands]])")
        self.keys(t, path, ("robot", "joints", "mode", "target", "max_force", "kp", "kd"))
        robot = self.string(t.get("robot", subject), [*path, "robot"])
        if robot not in robots:
            raise self.error([*path, "robot"], f"no robot {robot!r}; robots: {sorted(robots)}")
        raw = self.require(t, path, "joints")
        refs = raw if isinstance(raw, list) else [raw]
        if not refs:
            raise self.error([*path, "joints"], "expected at least one joint")
        joints = tuple(self.joint_ref(j, [*path, "joints"]) for j in refs)
        if len(set(joints)) != len(joints):
            raise self.error([*path, "joints"], f"a joint is given twice in {raw!r}")
        mode = self.require(t, path, "mode")
        if mode not in MODES:
            raise self.error([*path, "mode"], f"expected one of {', '.join(MODES)}, got {mode!r}")
        n = len(joints)
        target = self.per_joint(self.require(t, path, "target"), [*path, "target"], n)
        max_force = None
        if mode == "torque":
            for k in ("max_force", "kp", "kd"):
                if k in t:
                    raise self.error([*path, k], "not used by torque commands")
        else:
            max_force = self.per_joint(
                self.require(t, path, "max_force"), [*path, "max_force"], n, nonneg=True
            )
        kp = kd = None
        if mode != "position":
            for k in ("kp", "kd"):
                if k in t:
                    raise self.error([*path, k], "only position commands take gains")
        else:
            if "kp" in t:
                kp = self.number(t["kp"], [*path, "kp"], nonneg=True)
            if "kd" in t:
                kd = self.number(t["kd"], [*path, "kd"], nonneg=True)
        return Command(robot, joints, mode, target, max_force, kp, kd)

    def controller(self, raw: Any, path: list[str | int], base: Path | None) -> ControllerSpec:
        if isinstance(raw, str):
            raw = {"class": raw}
            key: list[str | int] = path
        elif isinstance(raw, dict):
            self.keys(raw, path, ("class", "every", "params"))
            key = [*path, "class"]
        else:
            raise self.error(
                path,
                'expected a reference ("ctrl.py:Name" or "package.module:Name") or a table '
                "with class, every and params",
            )
        ref = self.string(self.require(raw, path, "class"), key)
        try:
            factory = load_object(ref, base)
        except RefError as exc:
            raise self.error(key, f"controller {ref!r}: {exc}") from None
        if not callable(factory):
            raise self.error(key, f"{ref!r} is not a class or a factory function")
        every = raw.get("every", 1)
        if isinstance(every, bool) or not isinstance(every, int) or not 1 <= every <= MAX_STEPS:
            raise self.error([*path, "every"], f"expected an integer >= 1 (steps), got {every!r}")
        params = raw.get("params", {})
        if not isinstance(params, dict):
            raise self.error(
                [*path, "params"],
                "expected a table of keyword arguments ([phases.controller.params])",
            )
        return ControllerSpec(absolute_ref(ref, base), dict(params), every)

    def outcome(
        self,
        t: Any,
        path: list[str | int],
        robots: dict[str, RobotSpec],
        phases: Sequence[str],
        base: Path | None,
    ) -> Outcome:
        if not isinstance(t, dict):
            raise self.error(path, "expected a table ([[outcomes]])")
        kind = self.require(t, path, "kind")
        if kind not in OUTCOME_KINDS:
            raise self.error(
                [*path, "kind"], f"expected one of {', '.join(OUTCOME_KINDS)}, got {kind!r}"
            )
        common = ("name", "kind", "robot", "phase")
        allowed = {
            "reach": (*common, "link", "point", "within", "by", "hold"),
            "upright": (*common, "max_tilt"),
            "track": (*common, "joints", "quantity", "targets", "link", "points", "max"),
            "final_pose": (*common, "link", "point", "orientation", "joints", "targets", "within"),
            "effort": (*common, "joints", "max"),
            "function": ("name", "kind", "function", "params", "max", "min", "unit"),
        }[kind]
        self.keys(t, path, allowed)
        name = self.string(self.require(t, path, "name"), [*path, "name"])
        robot = ""
        if "robot" in t:
            robot = self.string(t["robot"], [*path, "robot"])
            if robot not in robots:
                raise self.error([*path, "robot"], f"no robot {robot!r}; robots: {sorted(robots)}")
        phase = ""
        if "phase" in t:
            phase = self.string(t["phase"], [*path, "phase"])
            if phase not in phases:
                raise self.error([*path, "phase"], f"no phase {phase!r}; phases: {list(phases)}")
            if list(phases).count(phase) > 1:
                raise self.error(
                    [*path, "phase"], f"two phases are named {phase!r}: name them apart"
                )
        link: JointRef = "base"
        if "link" in t:
            link = t["link"]
            if isinstance(link, bool) or not isinstance(link, (int, str)) or link == "":
                raise self.error(
                    [*path, "link"], f'expected "base", a link name or index, got {link!r}'
                )

        def positive(key: str) -> float | None:
            if key not in t:
                return None
            v = self.number(t[key], [*path, key])
            if v <= 0:
                raise self.error([*path, key], f"must be > 0, got {t[key]!r}")
            return v

        def point(key: str) -> tuple[float, ...] | None:
            if key not in t:
                return None
            v = t[key]
            if not isinstance(v, list) or len(v) not in (2, 3):
                raise self.error(
                    [*path, key], f"expected 2 (x, y) or 3 (x, y, z) numbers, got {v!r}"
                )
            return tuple(self.number(x, [*path, key, i]) for i, x in enumerate(v))

        def joints() -> tuple[JointRef, ...]:
            if "joints" not in t:
                return ()
            raw = t["joints"]
            refs = raw if isinstance(raw, list) else [raw]
            if not refs:
                raise self.error([*path, "joints"], "expected at least one joint")
            return tuple(self.joint_ref(j, [*path, "joints"]) for j in refs)

        if kind == "reach":
            pt = point("point")
            if pt is None:
                raise self.error([*path, "point"], "missing (required by reach)")
            within = positive("within")
            if within is None:
                raise self.error([*path, "within"], "missing (required by reach): metres")
            hold = t.get("hold", False)
            if not isinstance(hold, bool):
                raise self.error([*path, "hold"], f"expected true or false, got {hold!r}")
            return Outcome.reach(
                name, pt, within, robot=robot, link=link, by=positive("by"), hold=hold, phase=phase
            )
        if kind == "upright":
            bound = positive("max_tilt")
            if bound is None:
                raise self.error([*path, "max_tilt"], "missing (required by upright): radians")
            return Outcome.upright(name, bound, robot=robot, phase=phase)
        if kind == "track":
            quantity = t.get("quantity", "position")
            if quantity not in ("position", "velocity"):
                raise self.error(
                    [*path, "quantity"], f"expected position or velocity, got {quantity!r}"
                )
            js = joints()
            pts: list[tuple[float, ...]] = []
            if "points" in t:
                raw_pts = t["points"]
                if not isinstance(raw_pts, list) or not raw_pts:
                    raise self.error(
                        [*path, "points"], "expected a list of [t, x, y] or [t, x, y, z] rows"
                    )
                width = None
                for i, row in enumerate(raw_pts):
                    if not isinstance(row, list) or len(row) not in (3, 4):
                        raise self.error(
                            [*path, "points", i], f"expected [t, x, y] or [t, x, y, z], got {row!r}"
                        )
                    if width is not None and len(row) != width:
                        raise self.error([*path, "points", i], "every row needs the same length")
                    width = len(row)
                    pts.append(tuple(self.number(x, [*path, "points", i]) for x in row))
                times = [p[0] for p in pts]
                if times != sorted(times):
                    raise self.error([*path, "points"], "times must not decrease")
                if js or "targets" in t:
                    raise self.error(
                        [*path, "points"], "track either a link (points) or joints, not both"
                    )
            elif "link" in t:
                raise self.error([*path, "link"], "a tracked link needs points")
            targets: tuple[float, ...] = ()
            if "targets" in t:
                if not js:
                    raise self.error([*path, "targets"], "constant targets need joints")
                targets = self.per_joint(t["targets"], [*path, "targets"], len(js))
            return Outcome.track(
                name,
                robot=robot,
                joints=js,
                quantity=quantity,
                targets=targets,
                link=link,
                points=pts,
                max=positive("max"),
                phase=phase,
            )
        if kind == "final_pose":
            pt = point("point")
            js = joints()
            quat = None
            if "orientation" in t:
                quat = self.vector(t["orientation"], [*path, "orientation"], 4)
                if abs(math.sqrt(sum(c * c for c in quat)) - 1) > 1e-3:
                    raise self.error(
                        [*path, "orientation"], "expected a unit quaternion (x, y, z, w)"
                    )
            if [pt is not None, bool(js), quat is not None].count(True) != 1:
                raise self.error(
                    path,
                    "final_pose takes one of point (a base or link position), orientation (the "
                    "base's, x, y, z, w) or joints",
                )
            targets = ()
            if js:
                if "targets" not in t:
                    raise self.error([*path, "targets"], "missing (joints need targets)")
                targets = self.per_joint(t["targets"], [*path, "targets"], len(js))
            elif "targets" in t:
                raise self.error([*path, "targets"], "targets go with joints")
            return Outcome.final_pose(
                name,
                robot=robot,
                point=pt,
                link=link,
                joints=js,
                targets=targets,
                orientation=quat,
                within=positive("within"),
                phase=phase,
            )
        if kind == "effort":
            return Outcome.effort(
                name, robot=robot, joints=joints(), max=positive("max"), phase=phase
            )
        # function
        ref = self.string(self.require(t, path, "function"), [*path, "function"])
        try:
            fn = load_object(ref, base)
        except RefError as exc:
            raise self.error([*path, "function"], f"function {ref!r}: {exc}") from None
        if not callable(fn):
            raise self.error([*path, "function"], f"{ref!r} is not a function")
        params = t.get("params", {})
        if not isinstance(params, dict):
            raise self.error([*path, "params"], "expected a table of keyword arguments")
        bounds = {}
        for key in ("max", "min"):
            if key in t:
                bounds[key] = self.number(t[key], [*path, key])
        unit = t.get("unit", "")
        if not isinstance(unit, str):
            raise self.error([*path, "unit"], f"expected a string, got {unit!r}")
        return Outcome.function_of(
            name, absolute_ref(ref, base), params=params, unit=unit, **bounds
        )

    def engines(self, data: Any) -> Any:
        """``[engines.BACKEND]`` tables: each backend's engine settings, checked."""
        if not isinstance(data, dict):
            raise self.error(["engines"], "expected [engines.BACKEND] tables")
        out = {}
        for backend, values in data.items():
            path: list[str | int] = ["engines", backend]
            if backend not in simbridge.available_backends():
                raise self.error(
                    path,
                    f"unknown backend {backend!r}"
                    f"{did_you_mean(backend, simbridge.available_backends())}; "
                    f"registered backends: {', '.join(simbridge.available_backends())}",
                )
            if not isinstance(values, dict):
                raise self.error(path, f"expected a table of key = value, got {values!r}")
            try:
                out[backend] = validate_settings(backend, values)
            except InvalidEngineSettingError as exc:
                raise self.error([*path, exc.key], str(exc)) from None
        return freeze(out, "engines")

    def scenario(self, data: dict[str, Any], default_name: str, source: Path | None) -> Scenario:
        self.keys(
            data,
            [],
            (
                "name",
                "description",
                "profile",
                "timestep",
                "gravity",
                "subject",
                "headline",
                "robots",
                "phases",
                "outcomes",
                "engines",
            ),
        )
        name = self.string(data.get("name", default_name), ["name"])
        if "/" in name or "\\" in name or name.strip(".") == "":  # it names the report folder
            raise self.error(["name"], f"expected a folder name (no path), got {name!r}")
        description = data.get("description", "")
        if not isinstance(description, str):
            raise self.error(["description"], f"expected a string, got {description!r}")
        profile = self.string(data.get("profile", "pybullet"), ["profile"])
        if profile not in simbridge.PROFILES:
            raise self.error(
                ["profile"], f"unknown profile {profile!r}; valid: {sorted(simbridge.PROFILES)}"
            )
        try:
            timestep = parse_timestep(data.get("timestep", 1.0 / 240.0))
        except ValueError as exc:
            raise self.error(["timestep"], str(exc)) from None
        gravity = self.vector(data.get("gravity", [0.0, 0.0, -9.8]), ["gravity"], 3)
        raw_robots = self.require(data, [], "robots")
        if not isinstance(raw_robots, list) or not raw_robots:
            raise self.error(["robots"], "expected at least one [[robots]] table")
        robots = [self.robot(t, ["robots", i]) for i, t in enumerate(raw_robots)]
        by_name: dict[str, RobotSpec] = {}
        for i, r in enumerate(robots):
            if r.name in by_name:
                raise self.error(["robots", i, "name"], f"robot name {r.name!r} is used twice")
            by_name[r.name] = r
        subject = self.string(data.get("subject", robots[-1].name), ["subject"])
        if subject not in by_name:
            raise self.error(["subject"], f"no robot {subject!r}; robots: {sorted(by_name)}")
        headline = data.get("headline", "")
        if headline != "" and headline not in HEADLINE_QUANTITIES:
            raise self.error(
                ["headline"], f"expected one of {', '.join(HEADLINE_QUANTITIES)}, got {headline!r}"
            )
        base = source.parent if source is not None else None
        raw_phases = self.require(data, [], "phases")
        if not isinstance(raw_phases, list) or not raw_phases:
            raise self.error(["phases"], "expected at least one [[phases]] table")
        phases = []
        for i, t in enumerate(raw_phases):
            path: list[str | int] = ["phases", i]
            if not isinstance(t, dict):
                raise self.error(path, "expected a table ([[phases]])")
            self.keys(t, path, ("name", "steps", "commands", "controller"))
            steps = self.require(t, path, "steps")
            if isinstance(steps, bool) or not isinstance(steps, int) or not 1 <= steps <= MAX_STEPS:
                raise self.error(
                    [*path, "steps"], f"expected an integer from 1 to {MAX_STEPS}, got {steps!r}"
                )
            pname = self.string(t.get("name", f"phase {i + 1}"), [*path, "name"])
            raw_cmds = t.get("commands", [])
            if not isinstance(raw_cmds, list):
                raise self.error([*path, "commands"], "expected [[phases.commands]] tables")
            cmds = tuple(
                self.command(c, [*path, "commands", j], by_name, subject)
                for j, c in enumerate(raw_cmds)
            )
            ctl = None
            if "controller" in t:
                ctl = self.controller(t["controller"], [*path, "controller"], base)
            phases.append(Phase(pname, steps, cmds, ctl))
        names = [p.name for p in phases]
        raw_outcomes = data.get("outcomes", [])
        if not isinstance(raw_outcomes, list):
            raise self.error(["outcomes"], "expected [[outcomes]] tables")
        outcomes = tuple(
            self.outcome(o, ["outcomes", i], by_name, names, base)
            for i, o in enumerate(raw_outcomes)
        )
        seen: set[str] = set()
        for i, o in enumerate(outcomes):
            if o.name in seen:
                raise self.error(["outcomes", i, "name"], f"outcome name {o.name!r} is used twice")
            seen.add(o.name)
        engines = self.engines(data.get("engines", {}))
        return Scenario(
            engines=engines,
            name=name,
            robots=tuple(robots),
            phases=tuple(phases),
            timestep=timestep,
            gravity=gravity,  # type: ignore[arg-type]
            profile=profile,
            description=description,
            subject=subject,
            headline=headline,
            source=source,
            outcomes=outcomes,
        )


def loads_scenario(text: str, *, file: str = "<scenario>", source: Path | None = None) -> Scenario:
    """Parse scenario TOML text. Raises :class:`ScenarioError` naming ``file``, key and line."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        line = getattr(exc, "lineno", None)
        if line is None:
            m = re.search(r"line (\d+)", str(exc))
            line = int(m.group(1)) if m else None
        detail = str(exc)  # "Invalid value (at line 3, column 10)"
        raise ScenarioError(file, None, f"TOML syntax error: {detail}", line) from None
    except RecursionError:  # tomllib recurses once per nested array or inline table
        raise ScenarioError(file, None, "TOML nested too deeply for the reader") from None
    except ValueError as exc:  # an integer of more digits than Python converts (4300)
        raise ScenarioError(file, None, f"TOML value the reader cannot take: {exc}") from None
    default = source.stem if source is not None else "scenario"
    return _Reader(text, file).scenario(data, default, source)
