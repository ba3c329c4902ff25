"""The contract of an env: everything a trained policy depends on, as plain data
(:meth:`SimEnv.contract() <simbridge.envs.env.SimEnv.contract>`), so that two engines' (or a
training framework's and simbridge's) can be set side by side."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from simbridge.envs.task import ObsTerm

SimEnv = Any  # a simbridge.envs.env.SimEnv (not imported: env.py imports this module)

__all__ = ["contract", "entry_names", "observation_layout"]

_XYZ = ("x", "y", "z")


def entry_names(env: SimEnv, term: ObsTerm, size: int) -> list[str]:
    """One name per entry of an observation term (``joint_pos[cart_to_pole]``).

    Args:
        env: the env.
        term: one of its task's observation terms.
        size: the term's size as read.

    Returns:
        ``size`` names.
    """
    t = env.task
    if term.name in ("joint_pos", "joint_vel", "last_action"):
        parts: list[str] = list(t.action.joints)
    elif term.name == "commands" and t.commands is not None:
        parts = list(t.commands.names)
    elif term.name == "gait_phase":
        parts = ["sin", "cos"]
    elif term.name == "contacts":
        parts = [str(k) for k in term.params.get("links", ())]
    elif term.name in ("qpos", "qvel"):
        first = int(term.params.get("exclude", 0))
        parts = [str(i) for i in range(first, first + size)]
    elif term.name == "cfrc_ext":  # MuJoCo body index, then torque / force component
        first = int(term.params.get("exclude", 0))
        axes = ("tx", "ty", "tz", "fx", "fy", "fz")
        parts = [f"{first + i // 6}.{axes[i % 6]}" for i in range(size)]
    elif term.name == "command_in_base":
        parts = ["x", "y"]
    elif size == 3:
        parts = list(_XYZ)
    else:
        parts = [str(i) for i in range(size)]
    return [f"{term.name}[{p}]" for p in parts[:size]]


def _observation(env: SimEnv) -> dict[str, Any]:
    t = env.task
    terms = []
    start = 0
    world = env.world
    from simbridge.envs.terms import OBSERVATIONS

    for term in t.observation:
        size = int(np.asarray(OBSERVATIONS[term.name](world, term.params)).size)
        scale = term.scale if isinstance(term.scale, float) else list(term.scale)
        terms.append(
            {
                "name": term.name,
                "start": start,
                "size": size,
                "scale": scale,
                "noise": term.noise,
                "params": dict(term.params),
                "entries": entry_names(env, term, size),
            }
        )
        start += size
    norm = t.normalisation
    return {
        "terms": terms,
        "frame_size": start,
        "history": t.history,
        "history_order": "oldest first; at reset the first frame fills every slot",
        "size": start * t.history,
        "dtype": "float32",
        "noise_then_scale": True,
        "normalisation": None if norm is None else dataclasses.asdict(norm),
    }


def observation_layout(env: SimEnv) -> str:
    """The observation's layout in words, as the errors name it: each term's name and size,
    then the history (``joint_pos[2], joint_vel[2] (x1 frames)``).

    Args:
        env: the env.

    Returns:
        The words.
    """
    obs = _observation(env)
    terms = ", ".join(f"{t['name']}[{t['size']}]" for t in obs["terms"])
    return f"{terms} (x{obs['history']} frames)"


def _action(env: SimEnv) -> dict[str, Any]:
    a = env.task.action
    sim, w = env.sim, env.world
    joints = []
    for name, index in zip(a.joints, w.joints, strict=True):
        info = sim.joint_info(w.body, int(index))
        joints.append(
            {
                "name": name,
                "index": int(index),
                "lower_limit": info.lower_limit,
                "upper_limit": info.upper_limit,
                "max_force": info.max_force,
                "max_velocity": info.max_velocity,
                "damping": info.damping,
                "friction": info.friction,
            }
        )
    if a.mode == "actuator":
        table = {u.name: u for u in sim.actuators()}
        for row, name in zip(joints, a.joints, strict=True):
            u = table[name]
            row.update(
                name=sim.joint_info(w.body, row["index"]).name,
                actuator=name,
                actuator_index=u.index,
                gear=u.gear[0],
                ctrl_range=u.ctrl_range,
                force_range=u.force_range,
            )
    out = dataclasses.asdict(a)
    out["default"] = w.default.tolist()
    out["meaning"] = (
        f"target = {a.offset} + scale * clip(action, -{a.clip}, {a.clip}); mode {a.mode}"
        + (
            "; the actuators' controls, clamped to ctrl_range by the model"
            if a.mode == "actuator"
            else ""
        )
    )
    out["joint_table"] = joints
    return out


def _plain(value: Any) -> Any:
    """JSON's types: tuples and mappings turned into lists and dicts, all the way down."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def contract(env: SimEnv) -> dict[str, Any]:
    """The contract of ``env`` (see :meth:`SimEnv.contract`).

    Args:
        env: the env.

    Returns:
        The contract as a JSON-ready dict.
    """
    t = env.task
    out = {
        "task": t.name,
        "source": t.source,
        "backend": env.backend,
        "profile": t.profile,
        "timestep": t.timestep,
        "decimation": t.decimation,
        "control_dt": t.control_dt,
        "episode_steps": t.episode_steps,
        "gravity": list(t.gravity),
        "robots": [dataclasses.asdict(r) for r in t.robots],
        "action": _action(env),
        "observation": _observation(env),
        "commands": None if t.commands is None else dataclasses.asdict(t.commands),
        "randomisation": dataclasses.asdict(t.randomisation),
        "rewards": [dataclasses.asdict(r) for r in t.rewards],
        "terminations": [dataclasses.asdict(c) for c in t.terminations],
        "success": [dataclasses.asdict(c) for c in t.success],
        "reset": t.reset,
        "trained": None if t.trained is None else dataclasses.asdict(t.trained),
    }
    return _plain(out)
