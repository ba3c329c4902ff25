"""The envs tests' fixtures: every shipped backend, required as the rest of the suite requires
it (tests/_engines.py), and Gymnasium (the ``envs`` extra)."""

from __future__ import annotations

import pytest

BACKENDS = ("pybullet", "mujoco", "physx")

pytest.importorskip("gymnasium", reason='Gymnasium is not installed: pip install "simbridge[envs]"')


@pytest.fixture(params=BACKENDS)
def backend(request: pytest.FixtureRequest) -> str:
    """Each shipped backend, skipped (with the pip line) only where the suite allows it."""
    from _engines import require_backend  # tests/_engines.py: the suite's one rule

    return require_backend(request.param)
