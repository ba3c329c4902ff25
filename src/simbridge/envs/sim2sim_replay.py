"""The episode ``simbridge sim2sim``'s report.html replays in 3D (:func:`record_replay`).

The evaluation records no poses: it stays fast. Once every engine has run, one seed is chosen
(:func:`choose_seed`): the first where the engines part, the policy succeeding on the training
engine and failing on another (for a policy trained outside simbridge, with no training engine:
succeeding on one engine and failing on another); else the first seed. That seed is run again
on every engine with every robot's state recorded after each control step, through compare's
recorder (base pose, joint positions, link positions, contacts), into compare's
:class:`~simbridge.compare.run.trajectory.Trajectory`: compare's replay
(:mod:`simbridge.compare.report.replay`) draws it, and ``simbridge replay`` serves it from the
report folder. ``reset(seed=...)`` gives the same episode again on the same engine and machine;
each run's end is checked against the evaluation's (:attr:`EpisodeReplay.matches`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from simbridge.envs.env import SimEnv
from simbridge.envs.paired import NAN_ACTION, Engine, Record
from simbridge.envs.task import Task

if TYPE_CHECKING:
    from simbridge.compare.run.trajectory import BodyTrajectory, Trajectory
    from simbridge.envs.sim2sim import Sim2SimResult

__all__ = ["EpisodeReplay", "choose_seed", "record_episode", "record_replay", "save"]

_TIME_ARRAYS = (
    "base_position",
    "base_orientation",
    "base_linear_velocity",
    "base_angular_velocity",
    "joint_positions",
    "joint_velocities",
    "joint_forces",
    "joint_targets",
    "joint_modes",
    "link_positions",
    "contact_counts",
    "contact_normal_forces",
    "contact_depths",
    "joint_max_forces",
)
"""A recorded body's arrays with one row per recorded instant (cut to the episode's length)."""


@dataclass
class EpisodeReplay:
    """One seed run again on every engine with its poses recorded."""

    seed: int
    """The seed."""
    why: str
    """Why this seed, in words."""
    trajectories: list[Trajectory]
    """One per engine, in the run's order: the state after every control step (row 0: after
    the reset), ``timestep`` the control period."""
    matches: list[bool]
    """Per engine: whether the run again ended as the evaluation's episode of that seed did
    (the same success, failure and number of steps)."""


def choose_seed(result: Sim2SimResult) -> tuple[int, str]:
    """The seed to replay: the first that succeeds on the training engine and fails on another;
    for a policy trained outside simbridge (``external:NAME``, no training engine), the first
    that succeeds on one engine and fails on another; else the first seed.

    Args:
        result: the run.

    Returns:
        ``(seed, why)``, ``why`` in words.
    """
    from simbridge.envs.trained_on import outside

    if outside(result.trained_on) is not None:
        return _first_disagreement(result)
    train = result.runs[0]
    for i, seed in enumerate(result.seeds):
        if not train.records[i].success:
            continue
        lost = [run.engine.label for run in result.runs[1:] if not run.records[i].success]
        if lost:
            return seed, (
                f"seed {seed}, the first where the engines part: the policy succeeds on "
                f"{train.engine.label} (the training engine) and fails on {', '.join(lost)}"
            )
    return result.seeds[0], (
        f"seed {result.seeds[0]}, the first seed: no seed succeeds on the training engine and "
        "fails on another"
    )


def _first_disagreement(result: Sim2SimResult) -> tuple[int, str]:
    """A policy trained outside simbridge has no training engine: the first seed that succeeds
    on one engine and fails on another, else the first seed."""
    for i, seed in enumerate(result.seeds):
        won = [run.engine.label for run in result.runs if run.records[i].success]
        lost = [run.engine.label for run in result.runs if not run.records[i].success]
        if won and lost:
            return seed, (
                f"seed {seed}, the first where the engines part: the policy succeeds on "
                f"{', '.join(won)} and fails on {', '.join(lost)}"
            )
    return result.seeds[0], (
        f"seed {result.seeds[0]}, the first seed: the engines agree on every seed's success"
    )


def _cut(b: BodyTrajectory, rows: int) -> BodyTrajectory:
    """``b`` with its per-row arrays cut to their first ``rows`` rows."""
    cut = {k: getattr(b, k)[:rows] for k in _TIME_ARRAYS if getattr(b, k) is not None}
    return dataclasses.replace(b, **cut)


def record_episode(
    task: Task, engine: Engine, policy: str, seed: int
) -> tuple[Trajectory, Record | None]:
    """Run one seed of ``policy`` on ``engine`` with every robot's state recorded.

    The env steps as the evaluation's does (its effort probe installed: one physics step at a
    time). A NaN or infinite action ends the recording there, as it ends the evaluation's
    episode.

    Args:
        task: the task (its profile replaced by the engine's).
        engine: the engine.
        policy: the policy as :func:`~simbridge.envs.policies.load_policy` takes it.
        seed: the reset's seed.

    Returns:
        The :class:`~simbridge.compare.run.trajectory.Trajectory` (one row per control step and
        one for the reset) and how the episode ended (a :class:`Record` whose shares are 0;
        None after a NaN action).

    Raises:
        PolicyError: a policy that does not load or whose output does not fit the task.
    """
    from simbridge.compare.run.recording import _Recorder
    from simbridge.compare.run.trajectory import Trajectory
    from simbridge.envs.policies import check_output, load_policy
    from simbridge.envs.sim2sim_effort import EffortProbe

    env = SimEnv(dataclasses.replace(task, profile=engine.profile), backend=engine.backend)
    try:
        pol = load_policy(policy, env)
        EffortProbe(env).install()
        obs, _ = env.reset(seed=seed)
        rows = task.episode_steps + 1
        fixed = {r.name: r.fixed_base for r in task.robots}
        recorders = {
            name: _Recorder(env.sim, body, fixed[name], rows)
            for name, body in env.world.bodies.items()
        }
        for rec in recorders.values():
            rec.record(0)
        ended: Record | None = None
        total, steps = 0.0, 0
        while True:
            a = check_output(policy, env, pol(obs))
            if not np.isfinite(a).all():
                break
            obs, reward, terminated, truncated, info = env.step(a)
            total += float(reward)
            steps += 1
            for rec in recorders.values():
                rec.record(steps)
            if terminated or truncated:
                success = bool(info.get("is_success"))
                ended = Record(seed, success, total, steps, info.get("failure"), 0.0, 0.0)
                break
        n = steps + 1
        bodies = {name: _cut(rec.finish(name), n) for name, rec in recorders.items()}
        tr = Trajectory(
            scenario=task.name,
            backend=engine.backend,
            profile=engine.profile,
            timestep=task.control_dt,
            time=np.arange(n) * task.control_dt,
            bodies=bodies,
            subject=task.action.robot,
            phases=[("episode", 0, n - 1)],
            manifest=env.sim.manifest(),
        )
        return tr, ended
    finally:
        env.close()


def record_replay(task: Task | str, result: Sim2SimResult) -> EpisodeReplay:
    """Choose the seed to replay (:func:`choose_seed`) and record it on every engine of
    ``result``; the replay is kept in ``result.replay`` (report.html draws it).

    Args:
        task: the run's task (a :class:`Task`, a shipped task's name or a task file).
        result: the run.

    Returns:
        The :class:`EpisodeReplay`.
    """
    from simbridge.envs.reader import load_task

    t = result.task_run(task if isinstance(task, Task) else load_task(task))
    seed, why = choose_seed(result)
    i = result.seeds.index(seed)
    trajectories, matches = [], []
    for run in result.runs:
        tr, ended = record_episode(t, run.engine, result.policy, seed)
        r = run.records[i]
        trajectories.append(tr)
        if ended is None:  # a NaN action ended it
            matches.append(r.failure == NAN_ACTION)
        else:
            matches.append(
                (ended.success, ended.failure, ended.steps) == (r.success, r.failure, r.steps)
            )
    result.replay = EpisodeReplay(seed, why, trajectories, matches)
    return result.replay


def save(replay: EpisodeReplay, labels: list[str], out: Path) -> list[Path]:
    """Write each engine's trajectory to ``out/trajectories/<engine>.npz`` (``simbridge
    replay`` serves them from the report folder).

    Args:
        replay: the replay.
        labels: the engines' labels, in the replay's order.
        out: the report folder.

    Returns:
        The files written.
    """
    from simbridge.compare.report.fmt import file_stem

    folder = out / "trajectories"
    folder.mkdir(parents=True, exist_ok=True)
    return [
        tr.save(folder / f"{file_stem(label)}.npz")
        for label, tr in zip(labels, replay.trajectories, strict=True)
    ]


def replay_engines(replay: EpisodeReplay, labels: list[str]) -> list[Any]:
    """The replay's engines for compare's viewer, each in its legend colour; an engine whose
    episode ended before the longest holds its last pose to the end (the viewer's clock is the
    first engine's).

    Args:
        replay: the replay.
        labels: the engines' labels, in the replay's order.

    Returns:
        :class:`~simbridge.compare.report.replay.ReplayEngine` each.
    """
    from simbridge.compare.report.replay import ENGINE_COLOURS, ReplayEngine
    from simbridge.compare.run.events import find_events

    longest = max(len(tr.time) for tr in replay.trajectories)
    out = []
    for slot, (label, tr) in enumerate(zip(labels, replay.trajectories, strict=True)):
        colour = ENGINE_COLOURS[slot % len(ENGINE_COLOURS)]
        events = find_events(tr, label=label)
        shown = _held(tr, longest) if slot == 0 else tr
        out.append(ReplayEngine(label, colour, shown, events))
    return out


def _held(tr: Trajectory, rows: int) -> Trajectory:
    """``tr`` with its last row repeated up to ``rows`` rows (its time going on)."""
    n = len(tr.time)
    if n >= rows:
        return tr
    pad = rows - n

    def grow(x: np.ndarray) -> np.ndarray:
        return np.concatenate([x, np.repeat(x[-1:], pad, axis=0)])

    bodies = {
        name: dataclasses.replace(
            b, **{k: grow(getattr(b, k)) for k in _TIME_ARRAYS if getattr(b, k) is not None}
        )
        for name, b in tr.bodies.items()
    }
    time = np.arange(rows) * tr.timestep
    return dataclasses.replace(tr, time=time, bodies=bodies)
