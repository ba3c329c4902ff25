"""The paired runs of ``simbridge sim2sim`` (:mod:`.sim2sim`): its engines
(:func:`parse_engines`), one engine's episodes of a policy over the seeds (:func:`run_engine`,
a NaN or infinite action ending its episode as the failure :data:`NAN_ACTION`), and McNemar's
exact test of two engines' paired successes (:func:`mcnemar`)."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from simbridge.envs.env import SimEnv
from simbridge.envs.policies import check_output, load_policy
from simbridge.envs.sim2sim_effort import EffortProbe
from simbridge.envs.task import Task
from simbridge.exceptions import InvalidArgumentError, UnknownBackendError
from simbridge.profiles import _literal

__all__ = [
    "NAN_ACTION",
    "Engine",
    "EngineRun",
    "Record",
    "mcnemar",
    "parse_engines",
    "run_engine",
    "simulated",
]

NAN_ACTION = "nan_action"
"""An episode's failure when the policy returned a NaN or infinite entry."""


class Engine(NamedTuple):
    """One engine of the comparison."""

    label: str
    """Its name in the report (``mujoco``, ``mujoco+lateral_friction=0.05``, ``pybullet#2``)."""
    backend: str
    """The registered backend."""
    profile: str
    """The profile it runs (the task's, or a derived name with changes)."""


class Record(NamedTuple):
    """One episode of one engine."""

    seed: int
    """The reset's seed."""
    success: bool
    """``info["is_success"]`` at its end (False after a NaN action)."""
    ret: float
    """The sum of its rewards."""
    steps: int
    """Control steps taken."""
    failure: str | None
    """The termination that ended it (``"nan_action"``, ``"diverged"``, a task's), or None."""
    clipped_share: float
    """The share of its steps with at least one action entry clipped."""
    sign_changes: float
    """Action sign changes per step, summed over the entries (0 before the second step)."""
    saturated_share: float = 0.0
    """The share of its physics steps with an action joint at its effort limit
    (:class:`~simbridge.envs.sim2sim_effort.EffortProbe`)."""
    limit_share: float = 0.0
    """The share of its control steps after which a joint is at or past its position limit."""


@dataclass
class EngineRun:
    """Every episode of one engine and its contract."""

    engine: Engine
    records: list[Record]
    contract: dict[str, Any]
    wall_s: float


def parse_engines(
    specs: Sequence[str], trained_on: str, task_profile: str, available: Sequence[str]
) -> list[Engine]:
    """The engines of a run, the training engine first (added when ``specs`` lacks it).

    Args:
        specs: ``BACKEND`` or ``BACKEND+KEY=VALUE+...`` each.
        trained_on: the training engine, in the same form.
        task_profile: the task's profile, which the changes are made to.
        available: the registered backends.

    Returns:
        The engines, labels unique (a repeat takes ``#2``, ``#3``...).

    Raises:
        UnknownBackendError: a backend that is not registered (the message lists them).
        InvalidArgumentError: a change that is no profile entry or engine setting.
    """
    from simbridge.profiles import derived_profile

    others = list(specs)
    if trained_on in others:
        others.remove(trained_on)  # the first of specs naming it is the training run
    ordered = [trained_on, *others]
    out: list[Engine] = []
    for spec in ordered:
        backend, _, rest = spec.partition("+")
        if backend not in available:
            raise UnknownBackendError(backend, available)
        changes: dict[str, Any] = {}
        for part in filter(None, rest.split("+")):
            key, eq, value = part.partition("=")
            if not eq:
                raise InvalidArgumentError(
                    "backends", f"expected BACKEND+KEY=VALUE, got {spec!r} (part {part!r})"
                )
            changes[key] = _literal(value)
        profile = derived_profile(task_profile, changes) if changes else task_profile
        label = spec
        n = sum(e.label.split("#")[0] == spec for e in out)
        if n:
            label = f"{spec}#{n + 1}"
        out.append(Engine(label, backend, profile))
    return out


def _episode(env: SimEnv, policy: Any, spec: str, seed: int, probe: EffortProbe) -> Record:
    obs, _ = env.reset(seed=seed)
    probe.start()
    clip = env.task.action.clip
    total, steps, clipped, flips = 0.0, 0, 0, 0
    prev: np.ndarray | None = None
    while True:
        a = check_output(spec, env, policy(obs))
        if not np.isfinite(a).all():
            return Record(
                seed,
                False,
                total,
                steps,
                NAN_ACTION,
                clipped / max(steps, 1),
                flips / max(steps, 1),
                *probe.shares(),
            )
        sign = np.sign(a)
        if prev is not None:
            flips += int(np.count_nonzero((sign * prev) < 0))
        prev = sign
        clipped += bool(np.any(np.abs(a) > clip))
        obs, reward, terminated, truncated, info = env.step(a)
        probe.after_control_step()
        total += float(reward)
        steps += 1
        if terminated or truncated:
            return Record(
                seed,
                bool(info.get("is_success")),
                total,
                steps,
                info.get("failure"),
                clipped / steps,
                flips / steps,
                *probe.shares(),
            )


def simulated(engine: Engine) -> dict[str, Any]:
    """What an engine simulates beyond the task: its profile's entries and its own settings.

    Args:
        engine: the engine.

    Returns:
        ``profile_entries`` (every entry of the profile but its name, time step and gravity,
        which the task states) and ``engine_settings`` (every setting of the backend with the
        value it takes: :func:`simbridge.engine_settings.effective`), JSON-ready.
    """
    from simbridge.engine_settings import effective
    from simbridge.profiles import get_profile

    prof = get_profile(engine.profile)
    entries = {
        k: list(v) if isinstance(v, tuple) else v
        for k, v in prof.as_dict().items()
        if k not in ("name", "engines", "timestep", "gravity")
    }
    return {"profile_entries": entries, "engine_settings": effective(engine.backend, prof)}


def run_engine(task: Task, engine: Engine, policy: str, seeds: Sequence[int]) -> EngineRun:
    """The policy's episodes on one engine, one per seed.

    Args:
        task: the task (its profile replaced by the engine's).
        engine: the engine.
        policy: the policy as :func:`~simbridge.envs.policies.load_policy` takes it.
        seeds: one episode per seed.

    Returns:
        The :class:`EngineRun`.

    Raises:
        PolicyError: a policy that does not load or whose output does not fit the task.
    """
    env = SimEnv(dataclasses.replace(task, profile=engine.profile), backend=engine.backend)
    try:
        start = time.perf_counter()
        pol = load_policy(policy, env)
        probe = EffortProbe(env).install()
        records = [_episode(env, pol, policy, s, probe) for s in seeds]
        contract = env.contract()
        contract["profile"] = engine.profile
        contract["simulated"] = simulated(engine)
        return EngineRun(engine, records, contract, time.perf_counter() - start)
    finally:
        env.close()


def mcnemar(first: Sequence[bool], second: Sequence[bool]) -> tuple[int, int, float]:
    """McNemar's exact test of paired successes.

    Args:
        first: each pair's success on the first engine.
        second: the same seeds' on the second.

    Returns:
        ``(b, c, p)``: pairs that succeeded on the first only, on the second only, and the
        two-sided p-value of ``b`` of ``b + c`` under one half (1.0 when ``b + c == 0``).
    """
    from scipy.stats import binomtest

    f, s = np.asarray(first, bool), np.asarray(second, bool)
    b, c = int(np.sum(f & ~s)), int(np.sum(~f & s))
    p = 1.0 if b + c == 0 else float(binomtest(b, b + c, 0.5).pvalue)
    return b, c, p
