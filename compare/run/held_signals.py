"""Ctrl-C and SIGTERM held while a study's jobs run (:class:`HeldSignals`) and the wait for the
first finished job that raises them between two waits (:func:`wait_first`), outside
:func:`concurrent.futures.wait`'s locks: :mod:`.executors`' every path waits through them."""

from __future__ import annotations

import signal
import threading
from concurrent.futures import FIRST_COMPLETED, Future, wait
from typing import Any

__all__ = ["WAIT_POLL_S", "HeldSignals", "wait_first"]

WAIT_POLL_S = 0.25
"""How long a wait for the first finished job lasts before it looks for a Ctrl-C or SIGTERM."""


class HeldSignals:
    """Ctrl-C and SIGTERM recorded, not raised, while the jobs run: they are raised by
    :meth:`check` between two waits. Raised from the handler, a ``KeyboardInterrupt`` can land
    inside :func:`concurrent.futures.wait` while it holds the futures' locks one by one (with
    hundreds of jobs pending most of the main thread's time is spent there): the locks it took
    stay taken, the pool's result thread then blocks on them, and the pool's shutdown never
    returns (a killed ``simbridge compare`` hung for 30 s and more under load). Only the main
    thread handles signals, and only a handler that is Python's default (or
    :mod:`simbridge.terminate`'s) is replaced; a caller's own handler is left alone."""

    def __init__(self) -> None:
        self.caught: BaseException | None = None
        self.previous: dict[int, Any] = {}
        self.active = False

    def __enter__(self) -> HeldSignals:
        if threading.current_thread() is not threading.main_thread():
            return self
        from simbridge.terminate import Terminated, raises_terminated

        # A handler of a block no longer active (one left installed by a signal that landed
        # inside __enter__ itself) raises as the handler it replaced would: never a Ctrl-C lost.
        def hold_int(signum: int, frame: Any) -> None:
            if not self.active:
                raise KeyboardInterrupt
            self.caught = self.caught or KeyboardInterrupt()

        def hold_term(signum: int, frame: Any) -> None:
            if not self.active:
                raise Terminated()
            self.caught = self.caught or Terminated()

        self.active = True
        try:
            for sig, ours, default in (
                (signal.SIGINT, hold_int, signal.default_int_handler),
                (getattr(signal, "SIGTERM", None), hold_term, None),
            ):
                if sig is None:
                    continue
                try:
                    now = signal.getsignal(sig)
                except (AttributeError, ValueError):
                    continue
                if now is default or (default is None and raises_terminated(now)):
                    self.previous[sig] = (now, ours)
                    signal.signal(sig, ours)
        except BaseException:
            self._restore()
            raise
        return self

    def _restore(self) -> None:
        self.active = False
        for sig, (handler, ours) in self.previous.items():
            if signal.getsignal(sig) is ours:  # else another handler was set since: keep it
                signal.signal(sig, handler)
        self.previous.clear()

    def __exit__(self, kind: type[BaseException] | None, *exc: object) -> None:
        self._restore()
        if kind is None:  # a Ctrl-C or SIGTERM after the last check: raised, not lost
            self.check()

    def check(self) -> None:
        """Raise the Ctrl-C or SIGTERM recorded since the jobs started, if any."""
        if self.caught is not None:
            caught, self.caught = self.caught, None
            raise caught


def wait_first(
    pending: set[Future[Any]], held: HeldSignals
) -> tuple[set[Future[Any]], set[Future[Any]]]:
    """The futures done and those still pending, once at least one is done; a Ctrl-C or
    SIGTERM recorded meanwhile is raised here, outside ``wait``'s locks."""
    while True:
        held.check()
        done, rest = wait(pending, timeout=WAIT_POLL_S, return_when=FIRST_COMPLETED)
        held.check()
        if done:
            return done, rest
