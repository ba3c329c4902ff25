"""What a test does where an engine (or a test dependency) it needs is missing: one rule for
the whole suite, and the only place that skips for it.

- A backend that is there but breaks on import fails (``unavailable_reason`` raises).
- A missing one fails where :data:`CORE` names it (PyBullet and MuJoCo are dependencies of the
  package: missing, the install is broken), where the caller says it must always run
  (``always=True``: the conformance suite's shipped backends), and in CI: where ``CI`` is set to
  a true value (CI runners set ``CI=true``) or ``SIMBRIDGE_REQUIRE_ALL_BACKENDS=1``.
- Otherwise (a developer's machine without the physx extra) it is skipped with the reason,
  which names what to install.

In a test or a fixture: :func:`require_backend`, :func:`require`. As a mark:
``@pytest.mark.needs_backend("physx")`` (tests/conftest.py applies :func:`require_backend` before
the test runs). Where a test runs every engine installed: :func:`installed_backends`.
"""

from __future__ import annotations

import os

import pytest

__all__ = ["CORE", "installed_backends", "require", "require_backend", "strict"]

CORE = ("pybullet", "mujoco")  # the package's own dependencies: never skipped


def strict() -> bool:
    """True in CI (``CI`` set, and not to 0/false/no) or with
    ``SIMBRIDGE_REQUIRE_ALL_BACKENDS=1``: a missing engine fails there."""
    ci = os.environ.get("CI", "").strip().lower()
    return ci not in ("", "0", "false", "no") or (
        os.environ.get("SIMBRIDGE_REQUIRE_ALL_BACKENDS") == "1"
    )


def require(missing: str | None, *, always: bool = False, module_level: bool = False) -> None:
    """Nothing where ``missing`` is None; else the test fails (``always``, or :func:`strict`)
    or is skipped, saying ``missing`` (what is not installed, and how to install it)."""
    if missing is None:
        return
    if always or strict():
        where = "required here" if always else "CI: a missing engine fails, it is not skipped"
        pytest.fail(f"{missing} ({where})", pytrace=False)
    pytest.skip(missing, allow_module_level=module_level)


def require_backend(name: str, *, always: bool = False) -> str:
    """``name``, where its engine loads here; else :func:`require` with the registry's reason
    (it names the package to install). A core backend is always required."""
    from simbridge.registry import unavailable_reason

    reason = unavailable_reason(name)
    if reason is not None:
        reason = f"backend {name!r} is registered but unavailable here: {reason}"
    require(reason, always=always or name in CORE)
    return name


def installed_backends() -> list[str]:
    """Every registered backend whose engine loads here, in registration order; in CI a
    registered one that does not load fails instead of being left out."""
    import simbridge

    return [name for name in simbridge.available_backends() if _installed(name)]


def _installed(name: str) -> bool:
    from simbridge.registry import unavailable_reason

    reason = unavailable_reason(name)
    if reason is not None and (strict() or name in CORE):
        pytest.fail(f"backend {name!r} is registered but unavailable here: {reason}", False)
    return reason is None
