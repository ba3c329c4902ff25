"""Numbers in words for the report and its figures: distances in m / cm / mm, angles in degrees."""

from __future__ import annotations

import math
import re

from ..run.quantities import DEG

__all__ = [
    "file_stem",
    "fmt_apart",
    "fmt_distance",
    "fmt_time",
    "fmt_value",
    "fmt_threshold",
    "table",
]


def fmt_distance(x: float | None, more: int = 0) -> str:
    """Metres for people: ``3.27 m``, ``4.2 cm``, ``0.83 mm``, ``2.1e-06 m`` (``more``: that
    many more digits, in the same unit)."""
    if x is None:
        return "n/a"
    if not math.isfinite(x):
        return str(x)
    a = abs(x)
    if a >= 1:
        return f"{x:.{2 + more}f} m"
    if a >= 0.01:
        return f"{x * 100:.{1 + more}f} cm"
    if a >= 1e-4:
        return f"{x * 1000:.{2 + more}f} mm"
    if a == 0:
        return "0 m"
    return f"{x:.{1 + more}e} m"


def fmt_time(t: float | None) -> str:
    return "never" if t is None else f"{t:.3f} s"


def fmt_value(x: float, unit: str, more: int = 0) -> str:
    """A quantity in its report unit: distances as :func:`fmt_distance`, angles in degrees
    (``more``: that many more digits)."""
    if unit == "m":
        return fmt_distance(x, more)
    d = 3 + more
    if unit == "rad":
        return f"{x / DEG:.{d}g}°" if abs(x) < 2 * math.pi else f"{x:.{d}g} rad"
    return f"{x:.{d}g} {unit}".rstrip()  # a function outcome's value may have no unit


def fmt_apart(values: list[float], unit: str) -> list[str]:
    """``values`` as :func:`fmt_value` writes them, each that reads like a different one with as
    many more digits (up to 3) as it takes to read differently (an interval's ends and value);
    values closer than that are written as :func:`fmt_value` writes them."""
    more = [0] * len(values)
    while True:
        out = [fmt_value(x, unit, m) for x, m in zip(values, more, strict=True)]
        alike = {
            k
            for k, a in enumerate(out)
            for j, b in enumerate(out)
            if a == b and values[k] != values[j]
        }
        if not alike:
            return out
        if any(more[k] >= 3 for k in alike):  # closer than any reader needs: as the report
            return [fmt_value(x, unit) for x in values]
        for k in alike:  # more digits only where two different values read alike
            more[k] += 1


def fmt_threshold(x: float, unit: str) -> str:
    if unit == "m":
        return f"{x * 100:g} cm" if x < 1 else f"{x:g} m"
    if unit == "rad":
        return f"{x / DEG:g}°"
    return f"{x:g} {unit}"


def file_stem(label: str) -> str:
    """An engine label as a file name: every run of other characters than letters, digits, ``-``
    and ``_`` one ``-``, none at either end (``pybullet (2)``: ``pybullet-2``; ``mujoco
    (urdf)``: ``mujoco-urdf``)."""
    return re.sub(r"[^A-Za-z0-9_-]+", "-", label).strip("-") or "engine"


def table(header: list[str], rows: list[list[str]]) -> list[str]:
    """A Markdown table's lines: the header, its rule, a line per row.

    Args:
        header: the column titles.
        rows: the cells of each row, as many as ``header``.

    Returns:
        The lines, with no blank line before or after.
    """
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return out
