"""The Sim's lock, as every built-in backend holds it (no engine is imported here).

Every call that touches the world holds the backend's ``_stepping`` lock (a re-entrant lock: a
call's own nested calls pass, and so do the stepping thread's bound-command sends). A call that
finds it taken by another thread waits for that thread's call to end, unless that call is a
step (the holder set ``_in_step``): a step(n) runs for as long as n says, so the call is
refused (SimBusyError) and nothing waits for it. The wait looks at the holder every
WAIT_SLICE_S, the GIL's switch interval (a refusal instead of a wait, or a shorter slice,
refuses readers that merely overlap: tests/conformance/test_world.py's
``test_reads_from_several_threads_at_once_are_not_refused`` has the figures), and gives up
after WAIT_LIMIT_S.

A hot call takes the lock inline (``if not lock.acquire(False): wait_for_lock(self)``, then
``try``/``finally: lock.release()``): a decorator's extra call frame costs about as much as the
lock itself.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar

from simbridge.exceptions import SimBusyError, SimClosedError

__all__ = ["WAIT_LIMIT_S", "WAIT_SLICE_S", "exclusive", "reading", "wait_for_lock"]

_F = TypeVar("_F", bound=Callable[..., Any])

WAIT_SLICE_S = 0.005
# a call that holds the Sim longer than any load or read takes (a thread stopped while holding
# it, say): SimBusyError, never a hang
WAIT_LIMIT_S = 10.0


def wait_for_lock(backend: Any) -> None:
    """Take ``backend._stepping`` after its non-blocking acquire failed (another thread holds it).

    Args:
        backend: A built-in backend (its ``_stepping`` lock, ``_in_step`` and ``_closed`` flags).

    Raises:
        SimBusyError: Once the holder is seen stepping (``backend._in_step``), or after
            ``WAIT_LIMIT_S`` seconds.
        SimClosedError: The holder closed the Sim meanwhile (``backend._closed``).
    """
    lock = backend._stepping
    for _ in range(int(WAIT_LIMIT_S / WAIT_SLICE_S)):
        if backend._in_step:
            raise SimBusyError()
        if lock.acquire(True, WAIT_SLICE_S):
            if backend._closed:
                lock.release()
                raise SimClosedError()
            return
    raise SimBusyError(
        f"a call in another thread has held this Sim for over {WAIT_LIMIT_S:g} s; a Sim takes "
        "one call at a time (give each thread its own Sim)"
    )


def exclusive(method: _F) -> _F:
    """A call that touches the world: it holds the Sim's lock while it runs.

    Args:
        method: A backend method.

    Returns:
        The method wrapped: it waits for another thread's call, and is refused with
        ``SimBusyError`` while another thread steps (``SimClosedError`` once that thread closed the
        Sim), as :func:`wait_for_lock` says.
    """

    @functools.wraps(method)
    def call(self: Any, *args: Any, **kwargs: Any) -> Any:
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        try:
            return method(self, *args, **kwargs)
        finally:
            lock.release()

    return call  # type: ignore[return-value]


@contextmanager
def reading(backend: Any) -> Iterator[None]:
    """``Backend.reading`` of every built-in backend (``reading = locking.reading`` in its class).

    The Sim's lock is held for a read (or a write) of several calls, re-entrant (its calls pass),
    so that no step in another thread lands between its parts.

    Args:
        backend: The backend whose lock is held.

    Yields:
        Nothing; the lock is held until the ``with`` block ends.
    """
    lock = backend._stepping
    if not lock.acquire(False):
        wait_for_lock(backend)
    try:
        yield
    finally:
        lock.release()
