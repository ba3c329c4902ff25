"""``simbridge sim2sim --explain``: which setting, moved toward the training engine, recovers the
most success on an engine where the policy's success dropped (:func:`explain_drops`).

The candidates are ``simbridge explain``'s (:mod:`simbridge.compare.study.candidates`), for the
pair (this engine, the training engine):

- each profile entry or engine setting on which the two engines' profiles differ, this engine
  given the training engine's value (the known answer: an engine run with a friction changed on
  purpose gets the training engine's friction back);
- where the backends differ, the contact settings that move this engine's contacts toward the
  training engine's (MuJoCo's contact time constant, cone and no-slip iterations; PhysX's rest
  and contact offsets), with explain's reasons.

Only candidates that move this engine are run: the training engine stays as it was trained.
Each is one more run of the same seeds with the setting moved. It is scored on success, paired
on the seeds: the successes after against before (McNemar's exact test) and the share of the
drop it recovers, ``(after - before) / (training - before)``. The candidates are ranked by
their successes after; candidates with the same successes share a rank (listed in explain's
order).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from simbridge.envs.evaluate import wilson
from simbridge.envs.task import Task
from simbridge.exceptions import InvalidArgumentError

if TYPE_CHECKING:
    from simbridge.envs.paired import Engine
    from simbridge.envs.sim2sim import Sim2SimResult

__all__ = ["explain_drops", "moves_toward"]


def moves_toward(engine: Engine, training: Engine) -> list[Any]:
    """The candidates that move ``engine`` toward ``training`` (explain's, slot 0 alone).

    Args:
        engine: the engine whose success dropped.
        training: the training engine.

    Returns:
        :class:`simbridge.compare.study.candidates.Candidate` each, every move in slot 0.
    """
    from simbridge.compare.study.candidates import _engine_candidates, candidates

    backends = (engine.backend, training.backend)
    profiles = (engine.profile, training.profile)
    labels = (engine.label, training.label)
    found, _ = candidates(backends, profiles, labels)
    if engine.backend != training.backend:
        from simbridge.profiles import get_profile

        dt = get_profile(engine.profile).timestep
        found += _engine_candidates(backends, profiles, labels, dt)
    return [c for c in found if all(slot == 0 for slot, _, _ in c.moves)]


def explain_drops(task: Task | str, result: Sim2SimResult) -> list[dict[str, Any]]:
    """Rank the candidates of every engine whose success dropped significantly, and keep them
    in ``result.explain``.

    Args:
        task: the task run (a :class:`Task`, a shipped task's name or a task file).
        result: the sim2sim run (its figures computed).

    Returns:
        One dict per engine with a drop: ``engine``, ``before`` (successes), ``training``
        (the training engine's successes), ``n``, ``candidates`` ranked (each ``name``,
        ``setting`` in words, ``why``, ``successes``, ``interval``, ``p_value`` against before,
        ``recovered`` share of the drop, ``rank``, shared by equal successes), and ``note`` when
        there was nothing to try.

    Raises:
        InvalidArgumentError: a policy trained outside simbridge (no training engine).
    """
    from simbridge.compare.study.points import _with_change, format_value
    from simbridge.envs.paired import Engine, mcnemar, run_engine
    from simbridge.envs.reader import load_task
    from simbridge.envs.trained_on import outside

    if outside(result.trained_on):
        raise InvalidArgumentError(
            "explain",
            f"trained outside simbridge ({result.trained_on}): no training engine to move "
            "settings toward",
        )
    task = result.task_run(task if isinstance(task, Task) else load_task(task))
    train = result.runs[0]
    trained_ok = [r.success for r in train.records]
    out = []
    for run, fig in zip(result.runs[1:], result.figures[1:], strict=True):
        if fig.verdict != "drop":
            continue
        before = [r.success for r in run.records]
        entry: dict[str, Any] = {
            "engine": run.engine.label,
            "before": sum(before),
            "training": sum(trained_ok),
            "n": len(before),
            "candidates": [],
        }
        for cand in moves_toward(run.engine, train.engine):
            profile = run.engine.profile
            for _, key, value in cand.moves:
                profile = _with_change(profile, key, value)
            moved = Engine(f"{run.engine.label} ({cand.name})", run.engine.backend, profile)
            after = [
                r.success for r in run_engine(task, moved, result.policy, result.seeds).records
            ]
            _, _, p = mcnemar(before, after)
            rate = wilson(sum(after), len(after))
            gap = sum(trained_ok) - sum(before)
            entry["candidates"].append(
                {
                    "name": cand.name,
                    "setting": "; ".join(f"{k} = {format_value(v)}" for _, k, v in cand.moves),
                    "why": cand.why,
                    "profile": profile,
                    "successes": sum(after),
                    "interval": [rate.low, rate.high],
                    "p_value": p,
                    "recovered": (sum(after) - sum(before)) / gap if gap else 0.0,
                }
            )
        entry["candidates"].sort(key=lambda c: -c["successes"])  # stable: explain's order
        for c in entry["candidates"]:  # candidates with the same successes share a rank
            c["rank"] = 1 + sum(o["successes"] > c["successes"] for o in entry["candidates"])
        if not entry["candidates"]:
            entry["note"] = (
                "no profile entry or engine setting differs from the training engine's, and no "
                "contact setting is known to move this engine toward it: the drop is the "
                "engines' own physics"
            )
        out.append(entry)
    result.explain = out
    return out
