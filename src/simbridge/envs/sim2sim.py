"""``simbridge sim2sim``: does a policy trained on one engine still succeed on the others?
(:func:`sim2sim`)

The policy (:func:`simbridge.envs.policies.load_policy`) runs the same seeds on every engine,
the training engine first: the same seed gives the same initial state and commands on each
(``SimEnv.reset(seed=...)``), so the episodes pair up. Per engine:

- success, successes of N with a 95% Wilson interval (:func:`simbridge.envs.evaluate.wilson`);
- against the training engine, the paired difference judged by McNemar's exact test: a
  two-sided binomial test of the discordant pairs (seeds that succeed on one engine only)
  against one half (:func:`mcnemar`);
- the mean return and the mean paired return difference, each with a 95% bootstrap interval
  (percentile, :data:`BOOTSTRAP_RESAMPLES` resamples of the episodes);
- episode length, the share of episodes still running (not failed) at each quarter of the
  episode (Kaplan-Meier: a success or a truncation ends an episode without a failure), the
  median time to failure;
- the share of steps with a clipped action entry and the action's sign changes per step (summed
  over its entries): a policy that saturates or chatters on one engine only;
- the share of physics steps with an action joint at its effort limit, and of control steps
  with a joint at its position limit (:mod:`simbridge.envs.sim2sim_effort`);
- a NaN or infinite action ends its episode as a failure (``failure = "nan_action"``), counted
  and said in the report, never passed to the engine.

A policy whose training engine succeeds on less than :data:`TRAINED_FLOOR` of the seeds points
at the contract (joint order, observation layout and scales, action meaning, gains, dt and
decimation), not at the engines: the headline says so.

An engine is named ``BACKEND`` or ``BACKEND+KEY=VALUE+...``: the task's profile with those
entries or engine settings changed (:func:`simbridge.profiles.derived_profile`), e.g.
``mujoco+lateral_friction=0.05``. The same engine may appear twice (its label then takes
``#2``).

``trained_on="external:NAME"`` evaluates a policy trained outside simbridge against the contract
its task states: no engine is the training engine, every pair is tested
(:mod:`simbridge.envs.sim2sim_external`). ``openloop=K`` replays the training engine's actions of
the first K seeds open loop on every engine and judges where the physics parts
(:mod:`simbridge.envs.sim2sim_openloop`).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from simbridge.envs.evaluate import Rate, wilson
from simbridge.envs.paired import (
    NAN_ACTION,
    Engine,
    EngineRun,
    Record,
    mcnemar,
    parse_engines,
    run_engine,
)
from simbridge.envs.task import Task
from simbridge.exceptions import InvalidArgumentError

__all__ = [
    "ALPHA",
    "BOOTSTRAP_RESAMPLES",
    "TRAINED_FLOOR",
    "Engine",
    "EngineFigures",
    "EngineRun",
    "Interval",
    "Record",
    "Sim2SimResult",
    "figures",
    "mcnemar",
    "parse_engines",
    "run_engine",
    "sim2sim",
    "NAN_ACTION",
]

ALPHA = 0.05
"""The significance level of McNemar's test in the verdicts."""
BOOTSTRAP_RESAMPLES = 2000
"""Resamples of each bootstrap interval."""
TRAINED_FLOOR = 0.5
"""A training engine's success share below this: the policy points at the contract."""


class Interval(NamedTuple):
    """A value with a 95% interval."""

    value: float
    """The estimate."""
    low: float
    """The interval's lower end."""
    high: float
    """Its upper end."""


@dataclass
class EngineFigures:
    """One engine's figures, each against the training engine where paired."""

    label: str
    rate: Rate
    discordant: tuple[int, int]  # (training succeeded here failed, training failed here succeeded)
    p_value: float  # McNemar's exact test against the training engine (1.0 for itself)
    ret: Interval
    ret_difference: Interval  # paired, this engine minus the training engine
    steps: Interval
    survival: list[float]  # share not failed at 1/4, 1/2, 3/4 and all of the episode
    median_failure_s: float | None  # among failed episodes, None without one
    failures: dict[str, int]
    clipped_share: float
    sign_changes: float
    nan_actions: int
    saturated_share: float = 0.0  # physics steps with an action joint at its effort limit
    limit_share: float = 0.0  # control steps with a joint at or past its position limit

    @property
    def verdict(self) -> str:
        """``same`` (p >= :data:`ALPHA`), ``drop`` or ``rise`` against the training engine."""
        if self.p_value >= ALPHA:
            return "same"
        b, c = self.discordant
        return "drop" if b > c else "rise"


@dataclass
class Sim2SimResult:
    """A sim2sim run: its inputs, every engine's episodes, figures and the explanation."""

    task: str
    policy: str
    trained_on: str
    seeds: list[int]
    runs: list[EngineRun]
    figures: list[EngineFigures]
    explain: list[dict[str, Any]] = field(default_factory=list)  # sim2sim_explain's, if run
    openloop: Any = None  # sim2sim_openloop.OpenLoop, if run
    replay: Any = None  # sim2sim_replay.record_replay's EpisodeReplay, if run
    statistics: Any = None  # vecnormalize.VecNormalizeFile: a VecNormalize file read, if any

    def task_run(self, task: Task) -> Task:
        """``task`` as this run ran it: with the statistics of its ``VecNormalize`` file
        (:attr:`statistics`), which a task reloaded by name lacks.

        Args:
            task: the run's task.

        Returns:
            The task, its ``normalisation`` the file's where the run read one.
        """
        norm = None if self.statistics is None else self.statistics.normalisation
        if norm is None or task.normalisation == norm:
            return task
        import dataclasses

        return dataclasses.replace(task, normalisation=norm)

    @property
    def points_at_contract(self) -> bool:
        """True when the training engine's success share is below :data:`TRAINED_FLOOR` (for a
        policy trained outside simbridge: every engine's)."""
        from simbridge.envs.trained_on import outside

        rates = [f.rate for f in (self.figures if outside(self.trained_on) else self.figures[:1])]
        return max(r.successes / r.n for r in rates) < TRAINED_FLOOR


def _bootstrap_mean(values: Sequence[float], seed: int) -> Interval:
    """The mean with a 95% percentile bootstrap interval (a point where every value is equal)."""
    from scipy.stats import bootstrap

    x = np.asarray(values, dtype=np.float64)
    mean = float(np.mean(x))
    if x.size < 2 or np.all(x == x[0]):
        return Interval(mean, mean, mean)
    res = bootstrap(
        (x,),
        np.mean,
        n_resamples=BOOTSTRAP_RESAMPLES,
        method="percentile",
        random_state=np.random.default_rng(seed),
    )
    ci = res.confidence_interval
    return Interval(mean, float(ci.low), float(ci.high))


def _survival(records: Sequence[Record], episode_steps: int) -> list[float]:
    """Kaplan-Meier: the share not failed at 1/4, 1/2, 3/4 and all of ``episode_steps``; an
    episode that ended without a failure is censored at its length
    (:func:`simbridge.envs.survival.kaplan_meier`)."""
    from simbridge.envs.survival import kaplan_meier

    km = kaplan_meier(records)
    return [km.at(episode_steps * quarter / 4) for quarter in (1, 2, 3, 4)]


def _pooled(shares: Sequence[float], records: Sequence[Record]) -> float:
    """Episodes' shares of their steps pooled into the share of all of them, each weighted by
    its control steps (every one of them ``decimation`` physics steps)."""
    steps = np.array([r.steps for r in records], dtype=np.float64)
    return float(np.average(shares, weights=steps)) if steps.sum() > 0 else 0.0


def figures(runs: Sequence[EngineRun], seed: int = 0) -> list[EngineFigures]:
    """Every engine's figures against the first (the training engine).

    Args:
        runs: the engines' runs, the training engine first, the same seeds in the same order.
        seed: the bootstrap's seed.

    Returns:
        One :class:`EngineFigures` per run.
    """
    base = runs[0].records
    out = []
    for run in runs:
        rec = run.records
        ok = [r.success for r in rec]
        b, c, p = mcnemar([r.success for r in base], ok)
        fails = [r.steps for r in rec if r.failure]
        dt = float(run.contract["control_dt"])
        counts: dict[str, int] = {}
        for r in rec:
            if r.failure:
                counts[r.failure] = counts.get(r.failure, 0) + 1
        out.append(
            EngineFigures(
                label=run.engine.label,
                rate=wilson(sum(ok), len(ok)),
                discordant=(b, c),
                p_value=p,
                ret=_bootstrap_mean([r.ret for r in rec], seed),
                ret_difference=_bootstrap_mean(
                    [r.ret - q.ret for r, q in zip(rec, base, strict=True)], seed
                ),
                steps=_bootstrap_mean([r.steps for r in rec], seed),
                survival=_survival(rec, int(run.contract["episode_steps"])),
                median_failure_s=float(np.median(fails)) * dt if fails else None,
                failures=counts,
                clipped_share=float(np.mean([r.clipped_share for r in rec])),
                sign_changes=float(np.mean([r.sign_changes for r in rec])),
                nan_actions=counts.get(NAN_ACTION, 0),
                saturated_share=_pooled([r.saturated_share for r in rec], rec),
                limit_share=_pooled([r.limit_share for r in rec], rec),
            )
        )
    return out


def sim2sim(
    policy: str,
    task: Task | str,
    *,
    trained_on: str,
    backends: Sequence[str] = ("pybullet", "mujoco", "physx"),
    episodes: int = 20,
    seed: int = 0,
    openloop: int = 0,
    openloop_ensemble: int = 8,
    normalisation: str | os.PathLike[str] | None = "auto",
) -> Sim2SimResult:
    """Run ``policy`` on ``task`` over paired seeds on every engine, the training engine first.

    Args:
        policy: ``reference``, ``module:callable`` or a policy file
            (:func:`~simbridge.envs.policies.load_policy`).
        task: a :class:`Task`, a shipped task's name or a task file.
        trained_on: the engine the policy was trained on (``BACKEND[+KEY=VALUE...]``), or
            ``external:NAME`` for a training run outside simbridge (``external:isaaclab``):
            then ``backends`` run in their order, none of them the training engine.
        backends: the engines to check it on (the training engine is added first if absent).
        episodes: episodes per engine (seeds ``seed .. seed + episodes - 1``).
        seed: the first seed (and the bootstrap's).
        openloop: replay the training engine's actions of the first ``openloop`` seeds open
            loop on every engine (0: none; the command line's default is 4; for an outside
            policy, the first engine's actions stand in: simbridge has no log of its training
            run).
        openloop_ensemble: runs per engine and seed of the replays.
        normalisation: the policy's observation statistics, a Stable-Baselines3
            ``VecNormalize.save`` pickle (read without running its code:
            :mod:`simbridge.envs.vecnormalize`); ``"auto"``: the file beside a ``.zip`` policy
            (``vec_normalize.pkl``, ``vecnormalize.pkl`` or RL Zoo's ``STEM/vecnormalize.pkl``),
            when there is one; ``"none"`` or None: no file. The result's ``statistics`` says
            which file was used.

    Returns:
        The :class:`Sim2SimResult`.

    Raises:
        InvalidArgumentError: ``episodes`` below 1, ``openloop`` below 0.
        UnknownBackendError: an engine that is not registered
            (``UnknownTrainingEngineError`` for ``trained_on``, naming the external form).
        TaskFileError: an unknown task.
        PolicyError: a policy that does not load or does not fit the task.
        NormalisationFileError: a statistics file that does not read, is no
            ``VecNormalize`` pickle, does not fit the task's observation (both layouts named),
            or comes with a task that states its own ``[normalisation]``.
    """
    from simbridge.envs.reader import load_task
    from simbridge.envs.trained_on import check_trained_on, outside
    from simbridge.envs.vecnormalize import resolve
    from simbridge.registry import available_backends

    if episodes < 1:
        raise InvalidArgumentError("episodes", f"expected at least 1, got {episodes}")
    if openloop < 0:
        raise InvalidArgumentError("openloop", f"expected 0 or more seeds, got {openloop}")
    available = available_backends()
    check_trained_on(trained_on, available)
    external = outside(trained_on) is not None
    if external and not backends:
        raise InvalidArgumentError("backends", "an outside policy needs at least one engine")
    t = task if isinstance(task, Task) else load_task(task)
    t, statistics = resolve(t, policy, normalisation)
    first = backends[0] if external else trained_on  # outside: the engines in their order
    engines = parse_engines(backends, first, t.profile, available)
    seeds = list(range(seed, seed + episodes))
    runs = [run_engine(t, e, policy, seeds) for e in engines]
    result = Sim2SimResult(t.name, policy, trained_on, seeds, runs, figures(runs, seed))
    result.statistics = statistics
    if openloop:
        from simbridge.envs.sim2sim_openloop import openloop as replay

        result.openloop = replay(
            t,
            engines,
            policy,
            seeds[:openloop],
            ensemble=openloop_ensemble,
            seed=seed,
            outside=outside(trained_on) or "",
        )
    return result
