"""Where another thread of this process is, for the tests that must act once a thread waits at a
known point (for a lock, say) rather than after a pause that assumes it has got there."""

from __future__ import annotations

import linecache
import sys
import threading
import time


def waiting_in(thread: threading.Thread, function: str, line: str = "") -> bool:
    """Whether a frame of ``thread``'s stack now runs ``function``, at a source line that holds
    ``line`` (any line where empty)."""
    frame = sys._current_frames().get(thread.ident or -1)
    while frame is not None:
        code = frame.f_code
        if code.co_name == function and line in linecache.getline(code.co_filename, frame.f_lineno):
            return True
        frame = frame.f_back
    return False


def wait_until_waiting(
    thread: threading.Thread, function: str, line: str = "", timeout: float = 20
) -> None:
    """Return once ``thread`` is seen in ``function`` (at ``line``); fail if it ends or after
    ``timeout`` s (a bound on a hang only: the tests' threads get there at once)."""
    deadline = time.monotonic() + timeout
    while not waiting_in(thread, function, line):
        assert thread.is_alive(), f"{thread.name} ended before it reached {function}"
        assert time.monotonic() < deadline, f"{thread.name} never reached {function} ({line})"
        time.sleep(0.001)
