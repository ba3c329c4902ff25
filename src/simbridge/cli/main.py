"""simbridge: run robot scenarios on several physics engines and report where they disagree.

  simbridge compare r2d2                      every installed engine, into reports/r2d2/
  simbridge compare r2d2 --timestep 1/240 1/480 1/960
                                              speed against accuracy over time steps
  simbridge compare my_scenario.toml --out reports/mine
  simbridge compare r2d2 --workers 8 --cache /tmp/sbcache
                                              runs as jobs on 8 processes, cached by content
  simbridge report reports/r2d2               the report again, from the cache: nothing runs
  simbridge compare r2d2-gentle --resolve     halve the time step until the verdict resolves
  simbridge sweep r2d2-gentle --vary lateral_friction=0.3,0.5,0.9
                                              the gap and spreads against a setting's values
  simbridge explain r2d2-gentle               which setting explains the gap
  simbridge scenarios                         the shipped scenarios, one line each
  simbridge joints r2d2.urdf --movable        the joint table as a backend loads it
  simbridge joints r2d2.urdf --json           the same, every field, for machines
  simbridge replay reports/r2d2               a report's 3D replay, live in the browser
  simbridge sim2sim reference --task husky_goto --trained-on pybullet
                                              a policy on every engine: paired success rates

stdout carries the results alone; the engines' own banners and warnings go to the log, which
--verbose (-v) shows on stderr.

Exit status: 0 on success, 1 when the work failed (one line on stderr says why), 2 on bad usage
(an unknown scenario name included).
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from simbridge.cli.args import (
    add_job_options,
    duration,
    job_options,
    nonnegative_float,
    nonnegative_int,
    positive_int,
    timestep,
)
from simbridge.cli.usage import ChoiceParser, command_parser, scenario_argument
from simbridge.cli.usage import Usage as _Usage

__all__ = ["main", "build_parser"]

PROG = "simbridge"


def build_parser() -> argparse.ArgumentParser:
    """The ``simbridge`` command line: every command and its options.

    Returns:
        The parser (commands that set a ``handler`` run it; the others are run by name).
    """
    from simbridge import __version__, available_backends
    from simbridge.cli import cache as cli_cache
    from simbridge.cli import info as cli_info
    from simbridge.cli import joints as cli_joints
    from simbridge.cli import sim2sim as cli_sim2sim
    from simbridge.cli import study as cli_study
    from simbridge.cli.settings import add_settings_parser

    backends = available_backends()
    parser = ChoiceParser(
        prog=PROG, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--version", action="version", version=f"simbridge {__version__}")
    _verbose(parser, default=False)
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _add_compare(sub, backends)
    _add_report(sub)
    _add_scenarios(sub)
    _add_replay(sub)
    cli_joints.add_command(sub, backends, _verbose)
    cli_sim2sim.add_command(sub, backends, _verbose)
    _verbose(add_settings_parser(sub, backends))
    cli_study.add_commands(sub, _verbose, add_job_options)
    cli_cache.add_commands(sub, _verbose)
    cli_info.add_command(sub, _verbose)
    return parser


def _add_compare(sub: Any, backends: list[str]) -> None:
    """``simbridge compare``: a scenario on two or more engines, every pair judged."""
    from simbridge import PROFILES
    from simbridge.cli import study as cli_study
    from simbridge.cli.settings import add_set_option

    p = sub.add_parser(
        "compare",
        help="run a scenario on two or more engines and write a divergence report",
        description="Run SCENARIO on two or more engines (and each at half its time step), diff "
        "the trajectories of every pair and write report.md, summary.json, figures and "
        "trajectories.",
    )
    p.add_argument("scenario", metavar="SCENARIO", help="a shipped scenario name or a TOML file")
    p.add_argument(
        "--backends",
        nargs="+",
        metavar="NAME",
        default=None,
        choices=backends,
        help="two or more backends, every pair judged, the first two in the headline (default: "
        "every installed one, the report naming those left out; registered: "
        f"{', '.join(backends)})",
    )
    p.add_argument(
        "--profile",
        nargs="+",
        metavar="PROFILE",
        type=cli_study.profile_name,
        help="profile for every backend, or one per backend (default: the scenario's; one of "
        f"{', '.join(sorted(PROFILES))}, or one with changes: pybullet+lateral_friction=0.9)",
    )
    p.add_argument(
        "--timestep",
        nargs="+",
        type=timestep,
        metavar="DT",
        help="time step(s) in seconds or as 1/240; several make a sweep, the first one is the "
        "headline's (default: the scenario's)",
    )
    p.add_argument("--out", type=Path, help="report folder (default: reports/<scenario>/)")
    p.add_argument("--duration", type=duration, metavar="SECONDS", help="only the first SECONDS")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    p.add_argument(
        "--no-replay",
        action="store_true",
        help="skip the pictures of the runs (report.html's 3D replay, report.md's key frames "
        "and animation)",
    )
    from simbridge.compare.run.ensemble import DEFAULT_ENSEMBLE, DEFAULT_PERTURB, DEFAULT_SEED

    p.add_argument(
        "--ensemble",
        type=positive_int,
        default=DEFAULT_ENSEMBLE,
        metavar="N",
        help="runs per engine, the nominal one and N-1 from perturbed spawn poses, in parallel "
        f"processes; 1: no perturbed run (default: {DEFAULT_ENSEMBLE})",
    )
    p.add_argument(
        "--perturb",
        type=nonnegative_float,
        default=DEFAULT_PERTURB,
        metavar="EPS",
        help=f"spawn-pose offset of each perturbed run, m and rad (default: {DEFAULT_PERTURB:g})",
    )
    p.add_argument(
        "--seed",
        type=nonnegative_int,
        default=DEFAULT_SEED,
        metavar="S",
        help=f"seed of the offsets, bootstrap and test (default: {DEFAULT_SEED})",
    )
    p.add_argument(
        "--resync-every",
        type=nonnegative_int,
        metavar="K",
        help="every K steps set each engine's state into the other engine (and into a second "
        "Sim of its own, the floor) and step once: the one-step model error; 0: none "
        "(default: about 150 points per run)",
    )
    add_set_option(p)
    add_job_options(p)
    cli_study.add_resolve_arguments(p)
    _verbose(p)


def _add_report(sub: Any) -> None:
    """``simbridge report``: a report folder's report again, from the cache."""
    r = sub.add_parser(
        "report",
        help="write a report folder's report again from the cache, running nothing",
        description="Read DIR/study.json (written by `simbridge compare`) and write DIR's "
        "report.md, summary.json and figures again from the cached results of the study's "
        "runs: no engine runs. Fails, naming the first one, when a run is not in the cache.",
    )
    r.add_argument("folder", metavar="DIR", type=Path, help="a report folder")
    r.add_argument(
        "--cache",
        type=Path,
        metavar="DIR",
        help="the cache the study used (default: $XDG_CACHE_HOME/simbridge, else "
        "~/.cache/simbridge)",
    )
    r.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    r.add_argument("--no-replay", action="store_true", help="skip the key frames and the animation")
    _verbose(r)


def _add_scenarios(sub: Any) -> None:
    """``simbridge scenarios``: the shipped scenarios."""
    s = sub.add_parser(
        "scenarios",
        help="list the shipped scenarios",
        description="The shipped scenarios, one line each: name, simulated time, description.",
    )
    _verbose(s)


def _add_replay(sub: Any) -> None:
    """``simbridge replay``: a written report's 3D replay, served live."""
    r = sub.add_parser(
        "replay",
        help="serve a written report's 3D replay live in the browser",
        description="Serve the 3D replay of the report in REPORT_DIR (its trajectories/*.npz) "
        "from a local viser server and print its URL; Ctrl-C stops it. Needs viser "
        "(pip install 'simbridge[report]').",
    )
    r.add_argument("report_dir", metavar="REPORT_DIR", type=Path, help="a report folder")
    r.add_argument(
        "--host", default="127.0.0.1", help="address to listen on (default: %(default)s)"
    )
    r.add_argument(
        "--port", type=int, default=8080, help="port (default: %(default)s, or the next free)"
    )
    _verbose(r)


def _report(args: argparse.Namespace) -> int:
    from simbridge.compare.report.rebuild import rebuild

    if not args.folder.exists():
        raise _Usage(f"argument DIR: no such folder: {str(args.folder)!r}")
    if not args.folder.is_dir():
        raise _Usage(f"argument DIR: {str(args.folder)!r} is not a folder")
    path = rebuild(
        args.folder, cache=args.cache, plots=not args.no_plots, replay=not args.no_replay
    )
    print(f"report: {path}")
    return 0


def _verbose(parser: argparse.ArgumentParser, default: Any = argparse.SUPPRESS) -> None:
    # on the main parser and on each command (`simbridge compare r2d2 -v`); a command's
    # default is SUPPRESS so that it does not overwrite a -v given before the command
    parser.add_argument(
        "-v",
        "--verbose",
        action="store_true",
        default=default,
        help="show the log on stderr (the engines' banners and warnings, debug records too)",
    )


def _compare(args: argparse.Namespace) -> int:
    from simbridge.cli.settings import settings_from_args

    if args.backends is None:  # every installed backend: compare() records those left out
        from simbridge.compare import installed_backends

        n = len(installed_backends()[0])
    elif len(args.backends) < 2:
        raise _Usage("--backends takes two or more backends")
    else:
        n = len(args.backends)
    if args.profile is not None and len(args.profile) not in (1, n):
        many = "two" if n == 2 else str(n)
        raise _Usage(f"--profile takes one profile, or one per backend ({many})")
    from simbridge.cli import study as cli_study

    cli_study.check_engines(args)  # --set for an engine not run: bad usage
    scenario = scenario_argument(args.scenario)
    engine_settings = settings_from_args(args.engine_settings)  # checked before any run
    out = args.out if args.out is not None else Path("reports") / scenario.name
    made = _check_writable(out)  # before the engines run, not after
    _warn_self_check(args, scenario, n)
    try:
        path, resolver, result = _compare_into(args, scenario, engine_settings, out)
    except BaseException:  # an error, Ctrl-C, SIGTERM: no empty or half-written folder left
        _remove_made(made)
        raise
    from simbridge.compare.report import summary
    from simbridge.compare.report.brief import brief

    cli_study.finish_resolve(resolver, out)  # --resolve: its table, and a line here
    print("\n".join(brief(summary(result), path)))  # the paragraphs are in report.md
    return 0


def _compare_into(
    args: argparse.Namespace, scenario: Any, engine_settings: Any, out: Path
) -> tuple[Path, Any, Any]:
    """``compare``'s study and its report in ``out``: (report.md, the resolver, the result)."""
    from simbridge.cli import study as cli_study
    from simbridge.compare import compare, report
    from simbridge.compare.report.progress import ProgressBar

    resolver = cli_study.resolver_of(args)  # --resolve: compare, halving dt while unresolved
    with ProgressBar() as bar:
        if args.log is not None:
            args.log.bar = bar  # a record clears the bar's line first
        result = (resolver or compare)(
            scenario,
            args.backends,
            profile=args.profile,
            timesteps=args.timestep,
            duration=args.duration,
            progress=bar,
            ensemble=args.ensemble,
            perturb=args.perturb,
            seed=args.seed,
            resync_every=args.resync_every,
            engine_settings=engine_settings,
            **job_options(args),
            command_line=[PROG, *sys.argv[1:]] if args.argv is None else [PROG, *args.argv],
        )
        path = report(result, out, plots=not args.no_plots, replay=not args.no_replay)
    return path, resolver, result


def _warn_self_check(args: argparse.Namespace, scenario: Any, n: int) -> None:
    """A line on stderr where two --backends entries are one engine under one profile (a null
    comparison; the run goes on: a self-check is legitimate)."""
    if args.backends is None:
        return
    from simbridge.compare.pipeline import engine_labels
    from simbridge.compare.report.self_check import self_check_words

    profiles = args.profile or [scenario.profile]
    profiles = list(profiles) * n if len(profiles) == 1 else list(profiles)
    words = self_check_words(args.backends, profiles, engine_labels(args.backends, profiles))
    if words:
        print(words, file=sys.stderr)


def _settings(args: argparse.Namespace) -> int:
    from simbridge import available_backends
    from simbridge.cli.settings import settings_command

    return settings_command(args, available_backends())


def _check_writable(out: Path) -> list[Path]:
    """The report folder can be made and written to (an OSError naming it, else). Returns the
    folders it made (``out`` and its missing parents, deepest first: :func:`_remove_made`)."""
    import tempfile

    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"report folder {str(out)!r} exists and is not a folder")
    made = []
    for folder in (out, *out.absolute().parents):
        if folder.exists():
            break
        made.append(folder)
    try:
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=out):
            pass
    except BaseException:
        _remove_made(made)
        raise
    return made


def _remove_made(made: list[Path]) -> None:
    """Remove the folders :func:`_check_writable` made (a study that failed or was stopped
    before its report was written): ``made[0]`` with what the study put in it, then each
    parent it made while it is empty. A folder that was there before is never touched."""
    import shutil

    if not made:
        return
    shutil.rmtree(made[0], ignore_errors=True)
    for folder in made[1:]:
        try:
            folder.rmdir()
        except OSError:  # something else was written there meanwhile
            break


def _replay(args: argparse.Namespace) -> int:
    from simbridge.compare.report import replay

    if not replay.available():
        print(
            f"{PROG}: error: the replay needs viser: pip install 'simbridge[report]'",
            file=sys.stderr,
        )
        return 1

    def ready(url: str) -> None:
        print(f"replay of {args.report_dir}: {url} (Ctrl-C stops it)", flush=True)

    try:
        replay.serve(args.report_dir, host=args.host, port=args.port, ready=ready)
    except KeyboardInterrupt:  # Ctrl-C: the way to stop it
        print("replay stopped", file=sys.stderr)
    return 0


def _scenarios(args: argparse.Namespace) -> int:
    from simbridge.compare import list_scenarios

    items = list_scenarios()
    width = max(len(s.name) for s in items)
    for s in items:
        print(f"{s.name:<{width}}  {s.duration:5.2f} s  {s.description}")
    return 0


class _StderrLog(logging.StreamHandler):
    """The simbridge log on stderr (--verbose), clearing a progress bar drawn there first."""

    def __init__(self) -> None:
        super().__init__(sys.stderr)
        self.setFormatter(logging.Formatter(f"{PROG}: %(levelname)s: %(message)s"))
        self.bar: Any = None

    def emit(self, record: logging.LogRecord) -> None:
        if self.bar is not None:
            self.bar.clear()
        super().emit(record)


def main(argv: Sequence[str] | None = None) -> int:
    """Parse the command line, run the command.

    Args:
        argv: The arguments (default ``sys.argv[1:]``).

    Returns:
        The exit status: 0 on success, 1 on an error, 2 on bad usage, 130 on Ctrl-C, 143 on
        SIGTERM.
    """
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: 2 on bad usage, 0 after --help
        return exc.code if isinstance(exc.code, int) else 2
    args.argv = None if argv is None else list(argv)
    handler = (
        getattr(args, "handler", None)
        or {
            "compare": _compare,
            "report": _report,
            "scenarios": _scenarios,
            "replay": _replay,
            "settings": _settings,
        }[args.command]
    )
    log = logging.getLogger("simbridge")
    level = log.level
    args.log = _StderrLog() if args.verbose else None
    if args.log is not None:
        log.addHandler(args.log)
        log.setLevel(logging.DEBUG)
    from simbridge.terminate import sigterm_raises

    try:
        with sigterm_raises():  # SIGTERM (kill, timeout) cleans up as Ctrl-C does
            return _run(handler, args, parser)
    finally:
        if args.log is not None:
            log.removeHandler(args.log)
            log.setLevel(level)


def _run(handler: Any, args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from simbridge.exceptions import SimbridgeError

    try:
        return int(handler(args))
    except _Usage as exc:  # as argparse says it: the command's usage, then the error
        command = command_parser(parser, args)
        command.print_usage(sys.stderr)
        print(f"{command.prog}: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # stdout closed early (`simbridge joints r2d2 | head`)
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except (SimbridgeError, OSError) as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as exc:
        from simbridge.terminate import Terminated

        if isinstance(exc, Terminated):
            print(f"{PROG}: terminated", file=sys.stderr)
            return 128 + 15  # SIGTERM's exit status as a shell reports it
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
