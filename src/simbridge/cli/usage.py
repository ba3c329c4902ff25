"""Bad usage on the command line, said as argparse says it: exit 2, the command's usage, then
``simbridge COMMAND: error: ...``. The parser class that suggests the closest choice, the
exception a command raises for bad usage found after parsing, and the scenario argument."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

__all__ = ["ChoiceParser", "Usage", "command_parser", "scenario_argument"]


class Usage(Exception):
    """Bad usage found after parsing: ``simbridge.cli.main`` prints the command's usage and
    this message, and exits 2."""


class ChoiceParser(argparse.ArgumentParser):
    """argparse's parser, whose 'invalid choice' error names the closest choice ("did you mean
    'mujoco'?"); its commands' parsers are of this class too."""

    def _check_value(self, action: argparse.Action, value: Any) -> None:
        try:
            super()._check_value(action, value)
        except argparse.ArgumentError as exc:
            from simbridge.exceptions import did_you_mean

            hint = did_you_mean(str(value), [str(c) for c in action.choices or ()])
            if not hint:
                raise
            raise argparse.ArgumentError(action, f"{exc.message}{hint}") from None


def command_parser(parser: argparse.ArgumentParser, args: argparse.Namespace) -> Any:
    """The parser of the command ``args`` ran.

    Args:
        parser: The top-level parser.
        args: What it parsed.

    Returns:
        The innermost command's parser (``simbridge compare``'s, ``simbridge cache prune``'s),
        else ``parser``.
    """
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction) and action.dest:
            found = action.choices.get(str(getattr(args, action.dest, "")))
            if found is not None:
                return command_parser(found, args)
    return parser


def scenario_argument(text: str) -> Any:
    """The scenario a command line names.

    Args:
        text: A scenario file's path or a shipped scenario's name.

    Returns:
        The loaded scenario.

    Raises:
        Usage: neither a file nor a shipped scenario's name (bad usage, exit 2).
        ScenarioError: an invalid file, as it is.
    """
    from simbridge.compare import load_scenario
    from simbridge.compare.errors import ScenarioError

    try:
        return load_scenario(text)
    except ScenarioError as exc:
        if exc.key is None and not Path(text).exists():  # neither a file nor a name
            raise Usage(str(exc)) from None
        raise
