"""Studies: sets of comparisons that answer the question after "do the engines differ?".

- :func:`resolve` (``simbridge compare --resolve``): halve the time step while the verdict is
  unresolved because the gap lies within an engine's own time-step error;
- :func:`sweep` (``simbridge sweep``): the gap and the spreads against a setting's values;
- :func:`explain` (``simbridge explain``): which setting, moved toward the other engine's
  behaviour, removes the gap.

Each is a set of :func:`~simbridge.compare.compare` calls.
"""

from __future__ import annotations

from .explain import Candidate, Explanation, explain
from .points import Setting, parse_vary
from .report import write_explanation, write_resolution, write_sweep
from .resolve import DEFAULT_LIMIT, Resolution, Resolver, resolve
from .sweep import Sweep, sweep

__all__ = [
    "resolve",
    "Resolver",
    "Resolution",
    "DEFAULT_LIMIT",
    "sweep",
    "Sweep",
    "Setting",
    "parse_vary",
    "explain",
    "Explanation",
    "Candidate",
    "write_resolution",
    "write_sweep",
    "write_explanation",
]
