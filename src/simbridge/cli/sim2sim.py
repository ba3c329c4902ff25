"""``simbridge sim2sim POLICY --task T --trained-on ENGINE``: a policy trained on one engine, run
on paired seeds on every engine (:func:`simbridge.envs.sim2sim.sim2sim`), into report.md,
summary.json, report.html (the 3D replay of a chosen seed) and the survival figure, with a
headline on stdout. With ``--fail-on-drop`` it exits :data:`DROP_EXIT` when an engine's success
drops significantly against the training engine, or, for a policy trained outside simbridge
(``external:NAME``), when any two engines' successes differ significantly."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import Any

from simbridge.cli.args import nonnegative_int, positive_int

__all__ = ["DROP_EXIT", "add_command"]

DROP_EXIT = 3
"""The exit status under ``--fail-on-drop`` when an engine dropped (1 stays an error, 2 bad
usage)."""

DESCRIPTION = """\
Run POLICY on the task's paired seeds on every engine, the training engine first, and write
report.md, summary.json and report.html: success per engine with a 95%% Wilson interval and N,
McNemar's exact test against the training engine, returns with bootstrap intervals, survival
curves, clipped actions, sign changes, torque saturation and joint-limit hits, the contract
engine beside engine, and a 3D replay of the first seed where the engines part.

Exit status: 0, also when an engine drops; with --fail-on-drop, 3 when an engine's success
drops significantly (McNemar p < 0.05) against the training engine, or, trained outside
simbridge, when any two engines differ significantly; 1 on an error, 2 on bad usage.

POLICY: 'reference' (the task's reference controller), module:callable (a function obs ->
action, or a class made with the env: simbridge.envs.controllers:DriveToGoal), or a file:
.onnx (onnxruntime), .pt/.ts/.jit (TorchScript), .zip (Stable-Baselines3).

A policy trained under Stable-Baselines3's VecNormalize needs its observation statistics:
--normalisation FILE reads the pickle VecNormalize.save(path) wrote (without running its code)
and the env normalises its observation as VecNormalize.normalize_obs does. By default (auto) a
.zip policy's own file is used when one lies beside it (vec_normalize.pkl, vecnormalize.pkl,
or RL Zoo's STEM/vecnormalize.pkl), and the run names it; --normalisation none uses none. A
task that states its own [normalisation] takes no file.

An engine is BACKEND or BACKEND+KEY=VALUE: the task's profile with an entry or engine setting
changed (mujoco+lateral_friction=0.05). A policy trained outside simbridge: --trained-on
external:NAME (external:isaaclab); the task states its contract, every engine is evaluated
against it and every pair of engines is tested.

The training engine's actions of the first K seeds (--openloop K) are replayed open loop on
every engine and judged by compare's verdicts (agree, chaotic, unresolved, differ): where the
physics parts. For a policy trained outside simbridge, the first engine's actions stand in for
the training run's (simbridge has no log of it).
"""


def add_command(
    sub: Any, backends: list[str], verbose: Callable[[argparse.ArgumentParser], None]
) -> None:
    """Add ``simbridge sim2sim`` (its parser's ``handler`` set).

    Args:
        sub: The top-level parser's subparsers.
        backends: The installed backends' names (the default engines).
        verbose: Adds ``--verbose`` to a parser.
    """
    p = sub.add_parser(
        "sim2sim",
        help="check a trained policy on every engine: paired success rates and the contract",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("policy", metavar="POLICY", help="reference, module:callable or a policy file")
    p.add_argument("--task", required=True, help="a shipped task's name or a task file")
    p.add_argument(
        "--trained-on",
        required=True,
        metavar="ENGINE",
        help="the engine it was trained on, or external:NAME for a training run outside simbridge",
    )
    p.add_argument(
        "--backends",
        nargs="+",
        metavar="ENGINE",
        default=list(backends),
        help=f"engines to run it on (default: every installed one: {', '.join(backends)})",
    )
    p.add_argument("--episodes", type=positive_int, default=20, metavar="N")
    p.add_argument("--seed", type=nonnegative_int, default=0, metavar="S", help="first seed")
    p.add_argument(
        "--normalisation",
        default="auto",
        metavar="FILE",
        help="the policy's VecNormalize statistics (a VecNormalize.save pickle); auto (default): "
        "the file beside a .zip policy, if any; none: no file",
    )
    p.add_argument("--out", type=Path, help="report folder (default: reports/sim2sim-<task>/)")
    p.add_argument(
        "--explain",
        action="store_true",
        help="rank the settings that, moved toward the training engine, recover success",
    )
    p.add_argument(
        "--openloop",
        type=nonnegative_int,
        default=4,
        metavar="K",
        help="replay the training engine's actions of the first K seeds open loop on every "
        "engine (default 4; 0: none)",
    )
    p.add_argument(
        "--openloop-ensemble",
        type=positive_int,
        default=8,
        metavar="N",
        help="runs per engine and seed of the open-loop replays, all but one perturbed (default 8)",
    )
    p.add_argument(
        "--no-replay",
        action="store_true",
        help="no 3D replay in report.html (the chosen seed is not run again)",
    )
    p.add_argument(
        "--fail-on-drop",
        action="store_true",
        help=f"exit {DROP_EXIT} when an engine's success drops significantly (external:NAME: "
        "when any two engines differ)",
    )
    verbose(p)
    p.set_defaults(handler=_sim2sim)


def _sim2sim(args: argparse.Namespace) -> int:
    import sys

    try:
        from simbridge.envs.sim2sim import sim2sim
        from simbridge.envs.sim2sim_report import headline, write
    except ModuleNotFoundError as exc:  # the envs extra
        if exc.name != "gymnasium":
            raise
        print(
            'simbridge: error: sim2sim needs Gymnasium: pip install "simbridge[envs]"',
            file=sys.stderr,
        )
        return 1
    from simbridge.envs.trained_on import outside

    if args.explain and outside(args.trained_on) is not None:
        from simbridge.exceptions import InvalidArgumentError

        raise InvalidArgumentError(
            "--explain",
            f"trained outside simbridge ({args.trained_on}): no training engine to move "
            "settings toward",
        )
    result = sim2sim(
        args.policy,
        args.task,
        trained_on=args.trained_on,
        backends=args.backends,
        episodes=args.episodes,
        seed=args.seed,
        openloop=args.openloop,
        openloop_ensemble=args.openloop_ensemble,
        normalisation=args.normalisation,
    )
    if args.explain:
        from simbridge.envs.sim2sim_explain import explain_drops

        explain_drops(args.task, result)
    if not args.no_replay:
        from simbridge.envs.sim2sim_replay import record_replay

        record_replay(args.task, result)
    out = args.out or Path("reports") / f"sim2sim-{result.task}"
    files = write(result, out)
    if result.statistics is not None:
        print(result.statistics.describe())
    for line in headline(result):
        print(line)
    from simbridge.envs.sim2sim_openloop_report import lines

    for line in lines(result.openloop):
        print(line)
    for e in result.explain:
        for c in e["candidates"]:
            if c["rank"] == 1:
                print(
                    f"explain {e['engine']}: {c['setting']} recovers {c['successes']}/{e['n']} "
                    f"(from {e['before']}/{e['n']})"
                )
        if e.get("note"):
            print(f"explain {e['engine']}: {e['note']}")
    print(f"wrote {', '.join(str(f) for f in files)}")
    from simbridge.envs.sim2sim_external import dropped as drops

    dropped = drops(result)
    if args.fail_on_drop and dropped:
        where = "between engines: " if outside(args.trained_on) else "on "
        print(
            f"simbridge: sim2sim: success dropped significantly {where}{', '.join(dropped)} "
            f"(--fail-on-drop: exit {DROP_EXIT})",
            file=sys.stderr,
        )
        return DROP_EXIT
    return 0
