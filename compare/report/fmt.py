"""Numbers in words for the report and its figures: distances in m / cm / mm, angles in degrees."""

from __future__ import annotations

import math

from ..run.quantities import DEG

__all__ = ["fmt_distance", "fmt_time", "fmt_value", "fmt_threshold"]


def fmt_distance(x: float | None) -> str:
    """Metres for people: ``3.27 m``, ``4.2 cm``, ``0.83 mm``, ``2.1e-06 m``."""
    if x is None:
        return "n/a"
    if not math.isfinite(x):
        return str(x)
    a = abs(x)
    if a >= 1:
        return f"{x:.2f} m"
    if a >= 0.01:
        return f"{x * 100:.1f} cm"
    if a >= 1e-4:
        return f"{x * 1000:.2f} mm"
    if a == 0:
        return "0 m"
    return f"{x:.1e} m"


def fmt_time(t: float | None) -> str:
    return "never" if t is None else f"{t:.3f} s"


def fmt_value(x: float, unit: str) -> str:
    """A quantity in its report unit: distances as :func:`fmt_distance`, angles in degrees."""
    if unit == "m":
        return fmt_distance(x)
    if unit == "rad":
        return f"{x / DEG:.3g}°" if abs(x) < 2 * math.pi else f"{x:.3g} rad"
    return f"{x:.3g} {unit}".rstrip()  # a function outcome's value may have no unit


def fmt_threshold(x: float, unit: str) -> str:
    if unit == "m":
        return f"{x * 100:g} cm" if x < 1 else f"{x:g} m"
    if unit == "rad":
        return f"{x / DEG:g}°"
    return f"{x:g} {unit}"
