"""A one-line progress bar on stderr for long comparisons, drawn by tqdm (with the rate and the
time left).

Silent when the stream is not a terminal, and for runs shorter than ``delay`` seconds: nothing
is drawn until a run has lasted that long. Calls from several threads draw one at a time; a
line printed on the same stream (a log record) calls :meth:`ProgressBar.clear` first, and the
bar comes back with the next update.
"""

from __future__ import annotations

import sys
import threading
import time
from typing import Any, TextIO

__all__ = ["ProgressBar"]

REDRAW_S = 0.05
"""At most one redraw per this many seconds (a run reports its progress every few steps)."""


class ProgressBar:
    """Call it as ``bar(what, done, total)``; :meth:`close` clears the line.

    ``width``: the bar's own width in characters (the line also holds ``what``, the counts,
    the rate and the time left)."""

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
        self._bar: Any = None
        self._last = 0.0
        self._lock = threading.Lock()

    def __call__(self, what: str, done: int, total: int) -> None:
        if not self.enabled:
            return
        now = time.perf_counter()
        if now - self.start < self.delay:
            return
        if now - self._last < REDRAW_S and done < total:
            return
        with self._lock:
            if self._bar is None:
                from tqdm import tqdm

                self._bar = tqdm(
                    total=total,
                    file=self.stream,
                    leave=False,
                    unit="step",
                    disable=False,
                    mininterval=0,
                    bar_format=f"{{l_bar}}{{bar:{self.width}}}{{r_bar}}",
                )
                self._bar.start_t = self._bar.last_print_t = time.time() - (now - self.start)
            bar = self._bar
            bar.total = total
            bar.n = done
            bar.set_description_str(what, refresh=False)
            bar.refresh()
            self._last = now
            self.drawn = True

    def clear(self) -> None:
        """Blank the bar's line (the next update draws it again)."""
        with self._lock:
            if self.drawn and self._bar is not None:
                self._bar.clear()
                self.stream.flush()
                self.drawn = False
                self._last = 0.0  # the next update draws at once

    def close(self) -> None:
        with self._lock:
            if self._bar is not None:
                self._bar.close()  # leave=False: the line is cleared
                self._bar = None
                self.drawn = False

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
