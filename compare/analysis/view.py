"""What the analyses of a finished comparison read from it: :class:`ComparisonView`.

:class:`simbridge.compare.pipeline.Comparison` satisfies it. The analyses that feed the
comparison's summary (:mod:`.born`, :mod:`.departures`) take this view instead of importing the
pipeline, which imports them: no import circle.
"""

from __future__ import annotations

from typing import Protocol

from ..run.trajectory import Trajectory
from ..scenario import Scenario
from .diff import Divergence

__all__ = ["ComparisonView"]


class ComparisonView(Protocol):
    """The nominal runs of two or more engines on one scenario and the first pair's diffs (see
    ``Comparison``)."""

    scenario: Scenario
    runs: dict[tuple[int, float], Trajectory]  # (engine slot, time step) -> run
    cross: dict[float, Divergence]  # time step -> engine 0 against engine 1

    @property
    def timestep(self) -> float:
        """The time step the headline speaks of (s)."""
        ...

    @property
    def labels(self) -> tuple[str, ...]:
        """The engines' names in the report, in slot order."""
        ...

    @property
    def headline_quantity(self) -> str:
        """The quantity the headline follows (a key of ``diff.QUANTITIES``)."""
        ...
