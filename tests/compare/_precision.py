"""The precision a backend keeps its state in, for the compare tests' figures (a module of its
own: a helper imported from conftest can resolve to another folder's conftest)."""

from __future__ import annotations

from simbridge.registry import state_dtype, unavailable_reason

__all__ = ["float32"]


def float32(name: str) -> bool:
    """True for an installed backend that declares a float32 state (``Backend.state_dtype``):
    the tests' figures measured on double-precision engines then take the float32 figures
    written beside them."""
    return unavailable_reason(name) is None and state_dtype(name) == "float32"
