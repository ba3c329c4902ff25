"""``report.md``: every section written from the one ``summary.json`` dict (:func:`markdown`),
whose body lists the sections in the order they appear, so the document's layout reads top to
bottom in one place; each section is written by its own function in a sibling module.

The first lines of ``report.md`` give the headline in words (:mod:`.opening`): the verdict
(``agree``, ``differ``, ``chaotic`` naming the engine, or ``unresolved``) with its test and
intervals, the predictability horizons, then how far apart the nominal runs end, when they part,
which quantity goes first, and what halving the time step changes in each engine.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..pipeline import Comparison
from .born_section import born_section
from .engine_figures import engines_section, pair_reasons
from .engine_settings import settings_section
from .gap_sections import (
    final_poses_section,
    over_time_section,
    own_error_section,
    parts_section,
    sweep_section,
)
from .opening import first_pair_lines, headline, left_out_words, pairs_lines
from .outcomes import outcomes_section
from .pair_sections import crossings_section, pairs_section, phases_section
from .pair_sections import parts_section as pairs_parts_section
from .resync import resync_section
from .run_sections import departures_section, figures_section, reproduce_section, setup_section
from .self_check import self_check_words
from .verdict_section import verdict_section

__all__ = ["headline", "left_out_words", "markdown", "pairs_lines"]


def markdown(
    c: Comparison,
    s: dict[str, Any],
    images: dict[str, Path],
    files: list[str],
    pictures: list[str] | None = None,
) -> str:
    """``report.md`` from ``summary.json``'s dict ``s``, section by section.

    Args:
        c: the comparison the summary is of.
        s: its ``summary.json`` dict.
        images: the PNG figures' paths by key; the resync figures' keys are taken out of it
            (shown in their section, not in *Figures*).
        files: the report's files, named under *Reproduce*.
        pictures: the lines of the runs' pictures
            (:func:`~simbridge.compare.report.frames.frames_section`), after the headline.

    Returns:
        The document's text.
    """
    many = _many(s)
    a, b = s["labels"][:2]
    of = f" ({a} and {b})" if many else ""  # a section on the first pair alone
    lines = _opening(s) + (pictures or [])
    lines += _verdict_sections(s, of)
    lines += setup_section(c, s) + settings_section(s)
    if many:  # a row per pair in each (:mod:`.pair_sections`)
        lines += crossings_section(s) + phases_section(s)
    else:
        lines += over_time_section(c.cross[c.timestep])
    lines += born_section(s)
    lines += pairs_parts_section(s) if many else parts_section(s)
    resync_images = {k: images.pop(k) for k in list(images) if _is_resync(k)}
    lines += resync_section(s, resync_images)  # their figures here, not in Figures
    lines += final_poses_section(c, s)
    lines += own_error_section(c, s)
    lines += sweep_section(c, s, of)
    lines += figures_section(images)
    lines += departures_section(s)
    lines += reproduce_section(c, s, files)
    return "\n".join(lines)


def _many(s: dict[str, Any]) -> bool:
    """Whether the report speaks of more than one pair (more than two engines, pairs judged)."""
    return len(s["labels"]) > 2 and len(s.get("pairs") or []) > 1


def _is_resync(key: str) -> bool:
    """A resync figure's key: ``resync`` (the first pair's), ``resync_<a>_<b>``."""
    return key == "resync" or key.startswith("resync_")


def _opening(s: dict[str, Any]) -> list[str]:
    """The title, the headline's statements (a paragraph each, the pairs' bullets one list),
    then the engines left out, an engine compared with itself, and the scenario's
    description."""
    a, b = s["labels"][:2]
    if len(s["labels"]) > 2:
        title = ", ".join(s["labels"][:-1]) + f" and {s['labels'][-1]}"
    else:
        title = f"{a} against {b}"
    lines = [f"# {s['scenario']}: {title}", ""]
    for statement in headline(s):  # a paragraph each; the pairs' bullets one list
        if statement.startswith("- ") and lines[-2].startswith("- "):
            lines.pop()
        lines += [statement, ""]
    left = left_out_words(s)
    if left:
        lines += [f"*{left}*", ""]
    same = self_check_words(s["backends"], s["profiles"], s["labels"])
    if same:  # an engine compared with itself
        lines += [f"**{same[0].upper()}{same[1:]}**", ""]
    if s["description"]:
        lines += [f"*Scenario:* {s['description']}", ""]
    return lines


def _verdict_sections(s: dict[str, Any], of: str) -> list[str]:
    """The scenario's outcomes, with more than two engines the pair table, what decides each
    pair and every engine's own figures, then the first pair's figures and its verdict."""
    a, b = s["labels"][:2]
    lines = outcomes_section(s)
    lines += pairs_section(s) + pair_reasons(s)  # with more than two: what decides each
    lines += engines_section(s)  # and every engine's own figures
    if _many(s):
        lines += [f"## {a} and {b}, the first pair", ""]
        for statement in first_pair_lines(s):
            lines += [statement, ""]
    if s.get("verdict"):
        lines += verdict_section(s, of)
    return lines
