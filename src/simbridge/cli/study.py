"""The studies' command lines: ``simbridge compare --resolve``, ``simbridge sweep`` and
``simbridge explain`` (:mod:`simbridge.compare.study`)."""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from simbridge.cli import args as cli_args

__all__ = [
    "add_resolve_arguments",
    "add_commands",
    "add_study_options",
    "check_engines",
    "resolver_of",
    "finish_resolve",
    "profile_name",
]


def profile_name(text: str) -> str:
    """``--profile``'s argument type: a profile's name, checked.

    Args:
        text: The argument as given (``pybullet`` or ``pybullet+lateral_friction=0.9``).

    Returns:
        ``text``.

    Raises:
        argparse.ArgumentTypeError: not a profile (the message of :func:`get_profile`).
    """
    from simbridge.exceptions import SimbridgeError
    from simbridge.profiles import get_profile

    try:
        get_profile(text)
    except SimbridgeError as exc:  # argparse names the option: "argument --profile: ..."
        raise argparse.ArgumentTypeError(str(exc).removeprefix("argument 'profile': ")) from None
    return text


def _vary(text: str) -> Any:
    from simbridge.compare.study import parse_vary
    from simbridge.exceptions import SimbridgeError

    try:
        return parse_vary(text)
    except SimbridgeError as exc:  # argparse names the option: "argument --vary: ..."
        raise argparse.ArgumentTypeError(str(exc).removeprefix("argument 'vary': ")) from None


def add_resolve_arguments(p: argparse.ArgumentParser) -> None:
    """Add ``--resolve`` and ``--resolve-limit`` to ``simbridge compare``.

    Args:
        p: ``simbridge compare``'s parser.
    """
    from simbridge.compare.study import DEFAULT_LIMIT

    p.add_argument(
        "--resolve",
        action="store_true",
        help="where the verdict is unresolved because the gap lies within an engine's own "
        "time-step error, halve the time step until it resolves (the report shows the verdict "
        "at each step size)",
    )
    p.add_argument(
        "--resolve-limit",
        type=cli_args.nonnegative_int,
        metavar="N",
        help=f"halvings at most with --resolve (default: {DEFAULT_LIMIT}; implies --resolve)",
    )


def resolver_of(args: argparse.Namespace) -> Any:
    """The :class:`~simbridge.compare.study.Resolver` ``--resolve`` asks for.

    Args:
        args: The parsed command line.

    Returns:
        The resolver, or None without ``--resolve`` or ``--resolve-limit``.
    """
    if not (getattr(args, "resolve", False) or getattr(args, "resolve_limit", None) is not None):
        return None
    from simbridge.compare.study import DEFAULT_LIMIT, Resolver

    limit = args.resolve_limit
    return Resolver(DEFAULT_LIMIT if limit is None else limit)


def finish_resolve(resolver: Any, out: Path) -> None:
    """Add the resolve table to the report and say on stdout how it went.

    Args:
        resolver: What :func:`resolver_of` returned (None: nothing to do).
        out: The report folder.
    """
    if resolver is None or resolver.resolution is None:
        return
    from simbridge.compare.study import write_resolution
    from simbridge.compare.study.report import resolution_headline

    write_resolution(resolver.resolution, out)
    print(resolution_headline(resolver.resolution))


def add_study_options(p: argparse.ArgumentParser, backends: list[str], ensemble: int) -> None:
    """Add the options of every study command: the scenario, its engines, the runs and the report
    folder.

    Args:
        p: The command's parser.
        backends: The registered backends (the choices of ``--backends``).
        ensemble: The default of ``--ensemble``.
    """
    from simbridge.compare.run.ensemble import DEFAULT_PERTURB, DEFAULT_SEED

    p.add_argument("scenario", metavar="SCENARIO", help="a shipped scenario name or a TOML file")
    p.add_argument(
        "--backends",
        nargs="+",
        metavar="NAME",
        default=None,
        choices=backends,
        help="two or more backends (default: every installed one; the same one twice compares "
        f"two profiles of it; registered: {', '.join(backends)})",
    )
    p.add_argument(
        "--profile",
        nargs="+",
        type=profile_name,
        metavar="PROFILE",
        help="profile for every backend, or one per backend; a profile with changes reads "
        "pybullet+lateral_friction=0.9 (default: the scenario's)",
    )
    p.add_argument(
        "--timestep",
        type=cli_args.timestep,
        metavar="DT",
        help="time step (default: the scenario's)",
    )
    p.add_argument(
        "--duration", type=cli_args.duration, metavar="SECONDS", help="only the first SECONDS"
    )
    p.add_argument(
        "--ensemble",
        type=cli_args.positive_int,
        default=ensemble,
        metavar="N",
        help=f"runs per engine in every comparison (default: {ensemble})",
    )
    p.add_argument(
        "--perturb",
        type=cli_args.nonnegative_float,
        default=DEFAULT_PERTURB,
        metavar="EPS",
        help=f"spawn-pose offset of each perturbed run, m and rad (default: {DEFAULT_PERTURB:g})",
    )
    p.add_argument(
        "--seed",
        type=cli_args.nonnegative_int,
        default=DEFAULT_SEED,
        metavar="S",
        help=f"seed of the offsets and the bootstrap (default: {DEFAULT_SEED})",
    )
    p.add_argument("--out", type=Path, help="report folder (default: reports/<scenario>-<study>/)")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    from simbridge.cli.settings import add_set_option

    add_set_option(p)


def add_commands(
    sub: Any,
    verbose: Callable[[argparse.ArgumentParser], None],
    jobs_arguments: Callable[[argparse.ArgumentParser], None] | None = None,
) -> None:
    """Add ``simbridge sweep`` and ``simbridge explain`` (each parser's ``handler`` set).

    Args:
        sub: The top-level parser's subparsers.
        verbose: Adds ``--verbose`` to a parser.
        jobs_arguments: Adds the job options (``--workers``, ``--cache`` ...) to each command,
            when given.
    """
    from simbridge.compare.run.ensemble import DEFAULT_ENSEMBLE
    from simbridge.compare.study.explain import DEFAULT_ENSEMBLE as EXPLAIN_ENSEMBLE
    from simbridge.registry import available_backends

    backends = list(available_backends())
    s = sub.add_parser(
        "sweep",
        help="compare a scenario over the values of settings: the gap and spreads against each",
        description="One comparison per value of each --vary setting (the time step, a profile "
        "entry such as lateral_friction, an engine setting BACKEND.KEY), one setting at a time "
        "or, with --grid, every combination: report.md with a table and plots of the "
        "cross-engine gap (with its interval) and each engine's spread against each value, and "
        "summary.json.",
    )
    add_study_options(s, backends, DEFAULT_ENSEMBLE)
    s.add_argument(
        "--vary",
        action="append",
        type=_vary,
        required=True,
        metavar="KEY=V1,V2,...",
        help="a setting and its values (repeatable): timestep=1/240,1/480, "
        "lateral_friction=0.3,0.5,0.9, mujoco.impratio=1,10",
    )
    s.add_argument("--grid", action="store_true", help="every combination of the values")

    e = sub.add_parser(
        "explain",
        help="rank the settings that could explain the gap between engines",
        description="For each pair of engines and each setting that could explain their gap in "
        "this scenario (profile entries on which their profiles differ, the profile departures "
        "that apply here and that a setting moves), rerun with that setting moved toward the "
        "other engine's behaviour and rank the settings by the share of the gap each removes "
        "(95% bootstrap intervals over the ensembles). report.md and summary.json.",
    )
    add_study_options(e, backends, EXPLAIN_ENSEMBLE)
    for p, handler in ((s, _sweep), (e, _explain)):
        p.set_defaults(handler=handler)
        if jobs_arguments is not None:
            jobs_arguments(p)
        verbose(p)


def _bar_for(args: argparse.Namespace) -> Any:
    from simbridge.compare.report.progress import ProgressBar

    bar = ProgressBar()
    if getattr(args, "log", None) is not None:
        args.log.bar = bar
    return bar


def _out(args: argparse.Namespace, name: str, study: str) -> Path:
    out = args.out if args.out is not None else Path("reports") / f"{name}-{study}"
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"report folder {str(out)!r} exists and is not a folder")
    # made by the study's writer when there is something to write: a study that fails or is
    # stopped before leaves no empty folder; whether it can be made is checked now
    there = next(p for p in (out, *out.absolute().parents) if p.exists())
    if not there.is_dir() or not os.access(there, os.W_OK | os.X_OK):
        raise PermissionError(f"report folder {str(out)!r} cannot be made in {str(there)!r}")
    return out


def _check_profiles(args: argparse.Namespace) -> None:
    n = len(args.backends) if args.backends is not None else None
    if args.backends is not None and len(args.backends) < 2:
        raise _usage("--backends takes two or more backends")
    if args.profile is not None and n is not None and len(args.profile) not in (1, n):
        raise _usage(f"--profile takes one profile, or one per backend ({n})")


def check_engines(args: argparse.Namespace) -> None:
    """Check ``--set`` and ``--vary`` against the engines the command runs (``--backends``, else
    every installed one), before any engine runs.

    Args:
        args: The parsed command line.

    Raises:
        Usage: a setting of an engine not run, or a ``KEY@N`` past them (bad usage, exit 2).
    """
    from simbridge.cli.settings import settings_from_args
    from simbridge.compare.run.asked import require_engines
    from simbridge.compare.study.points import check_vary
    from simbridge.exceptions import InvalidArgumentError

    names = args.backends
    if names is None:
        from simbridge.compare import installed_backends

        names = installed_backends()[0]
    try:
        require_engines("set", settings_from_args(args.engine_settings), names)
        check_vary(getattr(args, "vary", None) or (), names)
    except InvalidArgumentError as exc:  # as argparse names an option: "argument --set: ..."
        text = str(exc).removeprefix(f"argument {exc.argument!r}: ")
        raise _usage(f"argument --{exc.argument}: {text}") from None


def _start(args: argparse.Namespace, study: str) -> tuple[Any, Path]:
    """The scenario of a study command and its report folder, the options checked first."""
    from simbridge.cli.usage import scenario_argument

    _check_profiles(args)
    check_engines(args)
    sc = scenario_argument(args.scenario)
    return sc, _out(args, sc.name, study)


def _run_options(args: argparse.Namespace, bar: Any, prefix: list[str]) -> dict[str, Any]:
    """The arguments every study takes from ``add_study_options`` and the job options; the
    progress bar's lines start with ``prefix[0]`` (the point or run under way)."""
    from simbridge.cli.settings import settings_from_args

    return dict(
        profile=args.profile,
        timestep=args.timestep,
        duration=args.duration,
        ensemble=args.ensemble,
        perturb=args.perturb,
        seed=args.seed,
        engine_settings=settings_from_args(args.engine_settings),
        **cli_args.job_options(args),
        progress=lambda what, d, t: bar(f"{prefix[0]}: {what}", d, t),
    )


def _usage(text: str) -> Exception:
    from simbridge.cli.usage import Usage

    return Usage(text)  # exit 2, the command's usage and the text, as argparse says it


def _sweep(args: argparse.Namespace) -> int:
    from simbridge.compare.study import sweep, write_sweep
    from simbridge.compare.study.report import point_line

    sc, out = _start(args, "sweep")
    prefix = [""]
    settings = {s.key: s for s in args.vary}
    with _bar_for(args) as bar:

        def on_point(i: int, n: int, values: dict[str, Any]) -> None:
            prefix[0] = f"{i + 1}/{n} " + ",".join(
                f"{k}={settings[k].shown(v)}" for k, v in values.items()
            )

        result = sweep(
            sc,
            args.backends,
            args.vary,
            grid=args.grid,
            on_point=on_point,
            **_run_options(args, bar, prefix),
        )
        path = write_sweep(result, out, plots=not args.no_plots)
    for p in result.points:
        print(point_line(p))  # report.md's verdict words and units
    print(f"report: {path}")
    return 0


def _explain(args: argparse.Namespace) -> int:
    from simbridge.compare.study import explain, write_explanation

    sc, out = _start(args, "explain")
    prefix = [""]
    with _bar_for(args) as bar:

        def on_run(what: str) -> None:
            prefix[0] = what

        result = explain(sc, args.backends, on_run=on_run, **_run_options(args, bar, prefix))
        path = write_explanation(result, out, plots=not args.no_plots)
    for p in result.pairs:
        print(p.conclusion)
    print(f"report: {path}")
    return 0
