"""Writing a :class:`Scenario` back as TOML that :func:`loads_scenario` reads to an equal one."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from .model import Scenario, format_timestep


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if v == int(v) and abs(v) < 1e15:
            return f"{v:.1f}"
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        items = ", ".join(f"{_toml_key(str(k))} = {_toml_value(x)}" for k, x in v.items())
        return "{ " + items + " }" if items else "{}"
    raise TypeError(f"cannot write {v!r} as TOML")


def _toml_key(k: str) -> str:
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else _toml_value(k)


def _lines(s: Scenario) -> Iterator[str]:
    yield f"name = {_toml_value(s.name)}"
    if s.description:
        yield f"description = {_toml_value(s.description)}"
    yield f"profile = {_toml_value(s.profile)}"
    dt = format_timestep(s.timestep)
    yield f"timestep = {_toml_value(dt if '/' in dt else s.timestep)}"
    yield f"gravity = {_toml_value(s.gravity)}"
    yield f"subject = {_toml_value(s.subject)}"
    if s.headline:
        yield f"headline = {_toml_value(s.headline)}"
    for backend, settings in s.engine_settings().items():
        yield ""
        yield f"[engines.{_toml_key(backend)}]"
        for k, v in settings.items():
            yield f"{_toml_key(k)} = {_toml_value(v)}"
    for r in s.robots:
        yield ""
        yield "[[robots]]"
        yield f"name = {_toml_value(r.name)}"
        yield f"{r.kind} = {_toml_value(r.urdf)}"
        if r.kind == "mjcf":
            yield f"body = {r.body}"
            if r.semantics != "pybullet":
                yield f"semantics = {_toml_value(r.semantics)}"
        else:
            yield f"position = {_toml_value(r.position)}"
            yield f"orientation = {_toml_value(r.orientation)}"
            yield f"fixed_base = {_toml_value(r.fixed_base)}"
        if r.joint_positions:
            items = ", ".join(
                f"{_toml_key(str(k))} = {_toml_value(v)}" for k, v in r.joint_positions
            )
            yield f"joint_positions = {{ {items} }}"
    for p in s.phases:
        yield ""
        yield "[[phases]]"
        yield f"name = {_toml_value(p.name)}"
        yield f"steps = {p.steps}"
        for c in p.commands:
            yield "[[phases.commands]]"
            yield f"robot = {_toml_value(c.robot)}"
            yield f"joints = {_toml_value(c.joints)}"
            yield f"mode = {_toml_value(c.mode)}"
            yield f"target = {_toml_value(c.target)}"
            if c.max_force is not None:
                yield f"max_force = {_toml_value(c.max_force)}"
            if c.kp is not None:
                yield f"kp = {_toml_value(c.kp)}"
            if c.kd is not None:
                yield f"kd = {_toml_value(c.kd)}"
        if p.controller is not None:
            yield "[phases.controller]"
            yield f"class = {_toml_value(p.controller.ref)}"
            yield f"every = {p.controller.every}"
            if p.controller.params:
                yield "[phases.controller.params]"
                for k, v in p.controller.params.items():
                    yield f"{_toml_key(k)} = {_toml_value(v)}"
    for o in s.outcomes:
        yield ""
        yield "[[outcomes]]"
        for k, v in o.to_dict().items():
            if k != "unit" or o.kind == "function":
                yield f"{_toml_key(k)} = {_toml_value(v)}"


def dumps_scenario(scenario: Scenario) -> str:
    """TOML text that :func:`loads_scenario` reads back to an equal Scenario."""
    return "\n".join(_lines(scenario)) + "\n"


def save_scenario(scenario: Scenario, path: str | Path) -> Path:
    path = Path(path)
    path.write_text(dumps_scenario(scenario), encoding="utf-8")
    return path
