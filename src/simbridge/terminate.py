"""SIGTERM as Ctrl-C: :func:`sigterm_raises` makes a SIGTERM raise :class:`Terminated` (a
:class:`KeyboardInterrupt`) in the main thread, so that what cleans up after Ctrl-C (a process
pool's workers stopped and reaped, its semaphores released, a report folder left unwritten
removed) runs for ``kill`` or ``timeout`` too; by default SIGTERM ends Python at once, and the
multiprocessing resource tracker then reports the pool's "leaked semaphore objects"."""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

__all__ = ["Terminated", "raises_terminated", "sigterm_raises"]


class Terminated(KeyboardInterrupt):
    """The process got SIGTERM (handled as Ctrl-C is)."""

    def __init__(self) -> None:
        super().__init__("terminated (SIGTERM)")


def _raise(signum: int, frame: FrameType | None) -> None:
    raise Terminated()


def raises_terminated(handler: object) -> bool:
    """Whether ``handler`` is the one :func:`sigterm_raises` installs.

    Args:
        handler: A signal handler, as ``signal.getsignal`` returns it.

    Returns:
        True for :func:`sigterm_raises`'s handler.
    """
    return handler is _raise


@contextmanager
def sigterm_raises() -> Iterator[None]:
    """Within the block, SIGTERM raises :class:`Terminated` in the main thread.

    Outside the main thread, or where SIGTERM already has a handler other than the default (the
    caller's own, or an enclosing block's), it changes nothing.

    Yields:
        None, once; the previous handler is put back when the block ends.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    try:
        previous = signal.getsignal(signal.SIGTERM)
    except (AttributeError, ValueError):  # a platform without SIGTERM
        yield
        return
    if previous is not signal.SIG_DFL:
        yield
        return
    signal.signal(signal.SIGTERM, _raise)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
