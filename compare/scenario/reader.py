"""Reading scenario TOML: :func:`loads_scenario`, validating each table (``_Reader``) with the
key's line in every error. The format is described in :mod:`.scenario`; the checks every value
goes through are :mod:`.checks`', an ``[[outcomes]]`` table's :mod:`.outcome_reader`'s."""

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
from simbridge.exceptions import (
    InvalidEngineSettingError,
    MjcfCompileError,
    UrdfNotFoundError,
    did_you_mean,
)
from simbridge.transforms import quat_from_rpy

from ..errors import ScenarioError
from .checks import TableReader
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
from .outcome_reader import read_outcome
from .outcomes import Outcome

MJCF_SEMANTICS = ("pybullet", "mujoco")
"""How a scenario's MJCF robot may be read (``Sim.load_mjcf``'s ``semantics``)."""

SCENARIO_KEYS = (
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
)
"""The keys at a scenario file's top level."""


class _Reader(TableReader):
    """Validates the parsed TOML, raising ScenarioError with the key's line."""

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
                "semantics",
            ),
        )
        kind = "mjcf" if "mjcf" in t else "urdf"
        semantics = t.get("semantics", "pybullet")
        if semantics not in MJCF_SEMANTICS:
            raise self.error(
                [*path, "semantics"],
                f"expected one of {', '.join(map(repr, MJCF_SEMANTICS))}, got {semantics!r}",
            )
        if "semantics" in t and kind != "mjcf":
            raise self.error(
                [*path, "semantics"], "only for a robot from an MJCF file (mjcf = ...)"
            )
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
        return RobotSpec(
            name,
            urdf,
            position,  # type: ignore[arg-type]
            orientation,  # type: ignore[arg-type]
            fixed,
            tuple(joints),
            kind,
            body,
            semantics,
        )

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
        """One ``[[outcomes]]`` table (:func:`.outcome_reader.read_outcome`)."""
        return read_outcome(self, t, path, robots, phases, base)

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
        """The scenario a parsed file holds, checked top to bottom (the first wrong key raises).

        Args:
            data: the file's TOML, parsed.
            default_name: its name when it names none (the file's stem).
            source: the file (None for text not read from one): paths in it are relative to
                its folder.

        Raises:
            ScenarioError: anything wrong, at its key and line.
        """
        self.keys(data, [], SCENARIO_KEYS)
        name = self.string(data.get("name", default_name), ["name"])
        if "/" in name or "\\" in name or name.strip(".") == "":  # it names the report folder
            raise self.error(["name"], f"expected a folder name (no path), got {name!r}")
        description = data.get("description", "")
        if not isinstance(description, str):
            raise self.error(["description"], f"expected a string, got {description!r}")
        profile = self.profile(data)
        try:
            timestep = parse_timestep(data.get("timestep", 1.0 / 240.0))
        except ValueError as exc:
            raise self.error(["timestep"], str(exc)) from None
        gravity = self.vector(data.get("gravity", [0.0, 0.0, -9.8]), ["gravity"], 3)
        robots = self.robots(data)
        native = [r for r in robots if r.semantics == "mujoco"]
        if native:
            timestep, gravity = self.native_world(
                data, robots, native[0], source, timestep, gravity
            )
        by_name = {r.name: r for r in robots}
        subject = self.string(data.get("subject", robots[-1].name), ["subject"])
        if subject not in by_name:
            raise self.error(["subject"], f"no robot {subject!r}; robots: {sorted(by_name)}")
        headline = data.get("headline", "")
        if headline != "" and headline not in HEADLINE_QUANTITIES:
            raise self.error(
                ["headline"], f"expected one of {', '.join(HEADLINE_QUANTITIES)}, got {headline!r}"
            )
        base = source.parent if source is not None else None
        phases = self.phases(data, by_name, subject, base)
        outcomes = self.outcomes(data, by_name, [p.name for p in phases], base)
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

    def profile(self, data: dict[str, Any]) -> str:
        """The file's ``profile``, a known one (default ``pybullet``)."""
        profile = self.string(data.get("profile", "pybullet"), ["profile"])
        if profile not in simbridge.PROFILES:
            raise self.error(
                ["profile"], f"unknown profile {profile!r}; valid: {sorted(simbridge.PROFILES)}"
            )
        return profile

    def native_world(
        self,
        data: dict[str, Any],
        robots: list[RobotSpec],
        native: RobotSpec,
        source: Path | None,
        timestep: float,
        gravity: tuple[float, ...],
    ) -> tuple[float, tuple[float, ...]]:
        """The time step and gravity of a scenario whose robot is an MJCF read as MuJoCo reads
        it: that file is the whole world (its only robot), and its ``<option>`` gives what the
        scenario does not (MuJoCo's compiler reads it; its refusal is the scenario's error)."""
        from simbridge.model.mjcf_native import compile_mjcf

        at: list[str | int] = ["robots", robots.index(native)]
        if len(robots) > 1:
            others = sorted(r.name for r in robots if r is not native)
            raise self.error(
                [*at, "semantics"],
                f"an MJCF read as MuJoCo reads it is the whole world (its own floor and "
                f"<option>): it cannot share the scenario with {others}",
            )
        path = native.urdf
        if source is not None and (source.parent / path).is_file():
            path = str(source.parent / path)
        try:
            option = compile_mjcf(path).model.opt
        except (UrdfNotFoundError, MjcfCompileError) as exc:
            raise self.error([*at, "mjcf"], str(exc)) from None
        if "timestep" not in data:
            timestep = float(option.timestep)
        if "gravity" not in data:
            gravity = tuple(float(g) for g in option.gravity)
        return timestep, gravity

    def robots(self, data: dict[str, Any]) -> list[RobotSpec]:
        """The ``[[robots]]`` tables, at least one, each name once."""
        raw_robots = self.require(data, [], "robots")
        if not isinstance(raw_robots, list) or not raw_robots:
            raise self.error(["robots"], "expected at least one [[robots]] table")
        robots = [self.robot(t, ["robots", i]) for i, t in enumerate(raw_robots)]
        seen: set[str] = set()
        for i, r in enumerate(robots):
            if r.name in seen:
                raise self.error(["robots", i, "name"], f"robot name {r.name!r} is used twice")
            seen.add(r.name)
        return robots

    def phases(
        self, data: dict[str, Any], robots: dict[str, RobotSpec], subject: str, base: Path | None
    ) -> list[Phase]:
        """The ``[[phases]]`` tables, at least one."""
        raw_phases = self.require(data, [], "phases")
        if not isinstance(raw_phases, list) or not raw_phases:
            raise self.error(["phases"], "expected at least one [[phases]] table")
        return [self.phase(t, i, robots, subject, base) for i, t in enumerate(raw_phases)]

    def phase(
        self, t: Any, i: int, robots: dict[str, RobotSpec], subject: str, base: Path | None
    ) -> Phase:
        """The ``i``-th ``[[phases]]`` table: its steps, commands and controller."""
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
            self.command(c, [*path, "commands", j], robots, subject) for j, c in enumerate(raw_cmds)
        )
        ctl = None
        if "controller" in t:
            ctl = self.controller(t["controller"], [*path, "controller"], base)
        return Phase(pname, steps, cmds, ctl)

    def outcomes(
        self,
        data: dict[str, Any],
        robots: dict[str, RobotSpec],
        phases: Sequence[str],
        base: Path | None,
    ) -> tuple[Outcome, ...]:
        """The ``[[outcomes]]`` tables (none by default), each name once."""
        raw_outcomes = data.get("outcomes", [])
        if not isinstance(raw_outcomes, list):
            raise self.error(["outcomes"], "expected [[outcomes]] tables")
        outcomes = tuple(
            self.outcome(o, ["outcomes", i], robots, phases, base)
            for i, o in enumerate(raw_outcomes)
        )
        seen: set[str] = set()
        for i, o in enumerate(outcomes):
            if o.name in seen:
                raise self.error(["outcomes", i, "name"], f"outcome name {o.name!r} is used twice")
            seen.add(o.name)
        return outcomes


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
