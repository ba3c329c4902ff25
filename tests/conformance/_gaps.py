"""Known gaps of the conformance suite (a module of its own: ``from conftest import gap`` found
another folder's conftest when pytest collected tests/conformance and tests/compare in one
call)."""

from __future__ import annotations

__all__ = ["KNOWN_GAPS", "gap"]

# Known gaps: what a backend cannot do exactly, with the measured size. A test that meets one uses
# the measured size as its tolerance instead of skipping (gz-physics' CHECK_UNSUPPORTED_ENGINE with
# a number). Keyed by gap, then backend; ``gap()`` returns None where a backend has no such gap.
KNOWN_GAPS: dict[str, dict[str, float]] = {
    # PyBullet's getLinkState returns link poses rounded to float32 (the shared-memory link-state
    # buffer), and so does a fixed base's pose; a free base's pose and joint states stay double.
    # Measured worst error against yourdfpy's double-precision kinematics on the suite's robots
    # (test_kinematics.py, poses within ~2 m of the origin): 3.3e-7 (laikago_toes.urdf), 2.1e-7
    # (r2d2), 7e-8 (pendulum); limit 5e-7 (float32 eps 1.19e-7 times |x| <= ~2, plus composition).
    "link_state_float32": {"pybullet": 5e-7},
}


def gap(backend: str, name: str) -> float | None:
    """The measured size of a known gap of ``backend``, or None when it has none."""
    return KNOWN_GAPS[name].get(backend)
