"""A one-line progress bar on stderr for long comparisons.

Silent when the stream is not a terminal, and for runs shorter than ``delay`` seconds: nothing
is drawn until a run has lasted that long. Calls from several threads draw one at a time; a
line printed on the same stream (a log record) calls :meth:`ProgressBar.clear` first, and the
bar comes back with the next update.
"""

from __future__ import annotations

import sys
import threading
import time
from typing import TextIO

__all__ = ["ProgressBar"]


class ProgressBar:
    """Call it as ``bar(what, done, total)``; :meth:`close` clears the line."""

    def __init__(
        self,
        stream: TextIO | None = None,
        *,
        width: int = 30,
        delay: float = 0.5,
        enabled: bool | None = None,
    ):
        self.stream = sys.stderr if stream is None else stream
        if enabled is None:
            isatty = getattr(self.stream, "isatty", None)
            enabled = bool(isatty and isatty())
        self.enabled = enabled
        self.width = width
        self.delay = delay
        self.start = time.perf_counter()
        self.drawn = False
        self._last = 0.0
        self._lock = threading.Lock()

    def __call__(self, what: str, done: int, total: int) -> None:
        if not self.enabled:
            return
        now = time.perf_counter()
        if now - self.start < self.delay:
            return
        if now - self._last < 0.05 and done < total:
            return
        self._last = now
        frac = done / total if total else 1.0
        filled = int(round(frac * self.width))
        bar = "#" * filled + "-" * (self.width - filled)
        with self._lock:
            self.stream.write(f"\r[{bar}] {frac * 100:5.1f}%  {what:<32.32}")
            self.stream.flush()
            self.drawn = True

    def clear(self) -> None:
        """Blank the bar's line (the next update draws it again)."""
        with self._lock:
            if self.drawn:
                self.stream.write("\r" + " " * (self.width + 44) + "\r")
                self.stream.flush()
                self.drawn = False
                self._last = 0.0  # the next update draws at once

    def close(self) -> None:
        self.clear()

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
