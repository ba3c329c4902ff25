"""Attribute values of a URDF read as PyBullet 3.2.7 reads them, for :mod:`simbridge.model.urdf`.

Numbers with C's ``atof``, vectors split at spaces (their first numbers used), origins as
``parseTransform`` reads them; where a strict reading would differ, a note goes on the file's
leniency record, and an error names the file, the line and the element.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from simbridge.exceptions import UrdfStructureError
from simbridge.model.urdf_model import Vec3
from simbridge.model.urdf_xml import Leniency, XmlElement, c_atof, pybullet_numbers


def _fmt(values: Sequence[float]) -> str:
    return "(" + ", ".join(f"{v:g}" for v in values) + ")"


class _Reader:
    """Attribute values read as PyBullet reads them (``atof``; vectors split at spaces), with
    a note on the leniency record where a strict reading would differ, and errors that name
    the file, the line and the element."""

    def __init__(self, file: str, lenient: Leniency) -> None:
        self.file = file
        self.lenient = lenient

    def error(self, elem: XmlElement | None, where: str, detail: str) -> UrdfStructureError:
        return UrdfStructureError(self.file, where, detail, getattr(elem, "line", None))

    def require(self, elem: XmlElement, attr: str, where: str) -> str:
        text = elem.get(attr)
        if text is None:
            raise self.error(elem, where, f"has no {attr} attribute (PyBullet refuses it too)")
        return text

    def _finite(self, elem: XmlElement, where: str, values: Sequence[float], text: str) -> None:
        if not all(math.isfinite(v) for v in values):
            raise self.error(elem, where, f"numbers must be finite, got {text!r}")

    def number(
        self, elem: XmlElement | None, attr: str, default: float, where: str, required=False
    ) -> float:
        """One number (``atof`` of the whole attribute); ``default`` when it is absent."""
        if elem is None:
            return default
        text = self.require(elem, attr, where) if required else elem.get(attr)
        if text is None:
            return default
        value, whole = c_atof(text)
        if not whole:
            self.lenient.add(
                elem.line, f"{where} {attr}={text!r} read as {value:g} (C atof: its leading number)"
            )
        self._finite(elem, f"{where} {attr}", (value,), text)
        return value

    def vector(self, elem: XmlElement, attr: str, n: int, where: str) -> tuple[float, ...] | None:
        """PyBullet's ``parseVector3`` (n 3: the first 3 numbers, None for fewer) or
        ``parseVector4`` (n 4: exactly 4, else None); None also when the attribute is absent.
        The caller says what None stands for (and notes it)."""
        text = elem.get(attr)
        if text is None:
            return None
        values, clean = pybullet_numbers(text)
        if len(values) < n or (n == 4 and len(values) != n):
            return None
        reasons = []
        if not clean:
            reasons.append(
                "each space-separated piece read with C atof (its leading number, 0 if none)"
            )
        if len(values) > n:
            reasons.append(f"the first {n} of {len(values)} numbers used")
        if reasons:
            self.lenient.add(
                elem.line, f"{where} {text!r} read as {_fmt(values[:n])}: {'; '.join(reasons)}"
            )
        self._finite(elem, where, values[:n], text)
        return tuple(values[:n])

    def short(self, elem: XmlElement, attr: str, where: str, assumed: str) -> None:
        self.lenient.add(
            elem.line,
            f"{where} {elem.get(attr)!r}: fewer than 3 numbers (split at spaces), read as "
            f"{assumed}",
        )

    def origin(self, elem: XmlElement, where: str) -> tuple[Vec3, Vec3]:
        """PyBullet's ``parseTransform``: xyz (0 0 0 if unreadable), rpy (none if unreadable)."""
        origin = elem.find("origin")
        if origin is None:
            return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        xyz = self.vector(origin, "xyz", 3, f"{where} <origin xyz>")  # type: ignore[arg-type]
        if xyz is None and origin.get("xyz") is not None:
            self.short(origin, "xyz", f"{where} <origin xyz>", "(0, 0, 0)")  # type: ignore[arg-type]
        rpy = self.vector(origin, "rpy", 3, f"{where} <origin rpy>")  # type: ignore[arg-type]
        if rpy is None and origin.get("rpy") is not None:
            self.short(origin, "rpy", f"{where} <origin rpy>", "no rotation")  # type: ignore[arg-type]
        return xyz or (0.0, 0.0, 0.0), rpy or (0.0, 0.0, 0.0)  # type: ignore[return-value]
