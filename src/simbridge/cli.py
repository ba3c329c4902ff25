"""simbridge: run robot scenarios on several physics engines and report where they disagree.

  simbridge compare r2d2                      PyBullet against MuJoCo, into reports/r2d2/
  simbridge compare r2d2 --timestep 1/240 1/480 1/960
                                              speed against accuracy over time steps
  simbridge compare my_scenario.toml --out reports/mine
  simbridge scenarios                         the shipped scenarios, one line each
  simbridge joints r2d2.urdf --backend mujoco the joint table (17 fields per joint)

Exit status: 0 on success, 1 when the work failed (one line on stderr says why), 2 on bad usage.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path

__all__ = ["main", "build_parser"]

PROG = "simbridge"


def _timestep(text: str) -> float:
    from simbridge.compare.scenario import parse_timestep

    try:
        return parse_timestep(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _duration(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected seconds, got {text!r}") from None
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text!r}")
    return value


def build_parser() -> argparse.ArgumentParser:
    from simbridge import PROFILES, available_backends

    backends = available_backends()
    parser = argparse.ArgumentParser(
        prog=PROG, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    from simbridge import __version__

    parser.add_argument("--version", action="version", version=f"simbridge {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser(
        "compare",
        help="run a scenario on two engines and write a divergence report",
        description="Run SCENARIO on two engines (and each at half its time step), diff the "
        "trajectories and write report.md, summary.json, figures and trajectories.",
    )
    p.add_argument("scenario", metavar="SCENARIO", help="a shipped scenario name or a TOML file")
    p.add_argument(
        "--backends",
        nargs=2,
        metavar=("A", "B"),
        default=["pybullet", "mujoco"],
        choices=backends,
        help=f"the two backends (default: pybullet mujoco; registered: {', '.join(backends)})",
    )
    p.add_argument(
        "--profile",
        nargs="+",
        metavar="PROFILE",
        choices=sorted(PROFILES),
        help="profile for both backends, or one per backend (default: the scenario's)",
    )
    p.add_argument(
        "--timestep",
        nargs="+",
        type=_timestep,
        metavar="DT",
        help="time step(s) in seconds or as 1/240; several make a sweep, the first one is the "
        "headline's (default: the scenario's)",
    )
    p.add_argument("--out", type=Path, help="report folder (default: reports/<scenario>/)")
    p.add_argument("--duration", type=_duration, metavar="SECONDS", help="only the first SECONDS")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG figures")

    sub.add_parser(
        "scenarios",
        help="list the shipped scenarios",
        description="The shipped scenarios, one line each: name, simulated time, description.",
    )

    j = sub.add_parser(
        "joints",
        help="print a URDF's joint table as a backend loads it",
        description="Print every joint's 17 fields (PyBullet's getJointInfo order) as loaded "
        "by a backend, one dict per joint, as the tutorial does.",
    )
    j.add_argument("urdf", metavar="URDF", help="a path or a name on the search path")
    j.add_argument("--backend", default="pybullet", choices=backends)
    j.add_argument("--fixed-base", action="store_true", help="load with a fixed base")
    return parser


def _compare(args: argparse.Namespace) -> int:
    from simbridge.compare import compare, load_scenario, report
    from simbridge.compare.progress import ProgressBar

    if args.profile is not None and len(args.profile) > 2:
        raise _Usage("--profile takes one profile, or one per backend (two)")
    scenario = load_scenario(args.scenario)
    out = args.out if args.out is not None else Path("reports") / scenario.name
    _check_writable(out)  # before the engines run, not after
    with ProgressBar() as bar:
        result = compare(
            scenario,
            args.backends,
            profile=args.profile,
            timesteps=args.timestep,
            duration=args.duration,
            progress=bar,
            command_line=[PROG, *sys.argv[1:]] if args.argv is None else [PROG, *args.argv],
        )
        path = report(result, out, plots=not args.no_plots)
    from simbridge.compare.report import headline

    print("\n".join(line.replace("**", "") for line in headline(result.summary())))
    print(f"report: {path}")
    return 0


def _check_writable(out: Path) -> None:
    """The report folder can be made and written to (an OSError naming it, else)."""
    import tempfile

    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"report folder {str(out)!r} exists and is not a folder")
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryFile(dir=out):
        pass


def _scenarios(args: argparse.Namespace) -> int:
    from simbridge.compare import list_scenarios

    items = list_scenarios()
    width = max(len(s.name) for s in items)
    for s in items:
        print(f"{s.name:<{width}}  {s.duration:5.2f} s  {s.description}")
    return 0


def _joints(args: argparse.Namespace) -> int:
    import simbridge

    with simbridge.Sim(args.backend) as sim:
        body = sim.load_urdf(args.urdf, fixed_base=args.fixed_base)
        for info in sim.joints(body):
            row = info._asdict()
            row["type"] = int(row["type"])  # PyBullet's numbers: 0 revolute, 1 prismatic, 4 fixed
            print(row)
    return 0


class _Usage(Exception):
    pass


def main(argv: Sequence[str] | None = None) -> int:
    """Parse ``argv`` (default ``sys.argv[1:]``), run the command, return the exit status."""
    from simbridge.exceptions import SimbridgeError

    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: 2 on bad usage, 0 after --help
        return exc.code if isinstance(exc.code, int) else 2
    args.argv = None if argv is None else list(argv)
    handler = {"compare": _compare, "scenarios": _scenarios, "joints": _joints}[args.command]
    try:
        return handler(args)
    except _Usage as exc:
        parser.print_usage(sys.stderr)
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # stdout closed early (`simbridge joints r2d2 | head`)
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except (SimbridgeError, OSError) as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
