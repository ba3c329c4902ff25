"""The ``simbridge`` command line: a thin layer over library calls.

:mod:`~simbridge.cli.main` parses and dispatches (``main``, ``build_parser``); each command's
own module holds the rest: :mod:`~simbridge.cli.study` (``--resolve``, ``sweep``, ``explain``),
:mod:`~simbridge.cli.settings` (``settings`` and ``--set``), :mod:`~simbridge.cli.cache`
(``cache info``/``prune``), :mod:`~simbridge.cli.info` (``info``), with the argument types and
job options in :mod:`~simbridge.cli.args` and bad usage in :mod:`~simbridge.cli.usage`.
"""

from simbridge.cli.main import build_parser, main

__all__ = ["build_parser", "main"]
