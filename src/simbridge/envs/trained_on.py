"""``--trained-on``: a simbridge engine (``BACKEND[+KEY=VALUE...]``) or a training run outside
simbridge, ``external:NAME`` (:func:`outside`, :func:`check_trained_on`). An unknown name is
taken only in the external form, so that a misspelt engine still errors naming the engines."""

from __future__ import annotations

from collections.abc import Sequence

__all__ = ["EXTERNAL", "check_trained_on", "outside"]

EXTERNAL = "external:"
"""The prefix of a training run outside simbridge (``external:isaaclab``)."""


def outside(trained_on: str) -> str | None:
    """Where a policy was trained when outside simbridge.

    Args:
        trained_on: ``--trained-on``'s value.

    Returns:
        ``NAME`` of ``external:NAME``, or None for an engine.
    """
    return trained_on[len(EXTERNAL) :] if trained_on.startswith(EXTERNAL) else None


def check_trained_on(trained_on: str, available: Sequence[str]) -> None:
    """Check ``--trained-on``: a registered backend (with changes), or ``external:NAME``.

    Args:
        trained_on: the value.
        available: the registered backends.

    Raises:
        UnknownTrainingEngineError: a backend that is not registered (the message lists them
            and the external form).
        InvalidArgumentError: ``external:`` without a name, or with a ``+`` change.
    """
    from simbridge.envs.errors import UnknownTrainingEngineError
    from simbridge.exceptions import InvalidArgumentError

    name = outside(trained_on)
    if name is None:
        backend = trained_on.partition("+")[0]
        if backend not in available:
            raise UnknownTrainingEngineError(backend, available)
    elif not name or "+" in name:
        raise InvalidArgumentError(
            "trained_on",
            f"expected external:NAME, a name without '+' (external:isaaclab), got {trained_on!r}",
        )
