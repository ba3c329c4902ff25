"""What an engine writes from C to stdout and stderr goes to the ``simbridge`` logger instead.

PyBullet prints its ``pybullet build time`` banner on import and its ``b3Warning``/``b3Error``
lines while loading a URDF with C's ``printf``, past Python's ``sys.stdout``. Around the engine
calls that print, :func:`captured` points file descriptors 1 and 2 at two anonymous temporary
files (no pipe: an engine writing more than a pipe buffer would block on itself), and when the
call returns hands the text to the engine's *classifier*. What the classifier claims becomes
log records on ``simbridge.<engine>`` (a child of the ``simbridge`` logger); everything else is
written back, byte for byte, to the descriptor it was meant for.

The rule for threads (file descriptors belong to the whole process):

- One capture window at a time in the process (a process-wide lock). A second thread that
  opens a window waits until the first closes.
- A window opened inside another on the same thread joins it (the lock's owner is
  remembered): nothing is redirected twice, and the outer window's engine classifies the text.
- While a window is open, whatever any thread writes to fd 1 or 2 lands in the window's files;
  a line the engine's classifier does not claim (a user's ``print`` from another thread,
  simbridge's own progress bar) is written back when the window closes: held back for the
  length of one engine call (a URDF load: milliseconds), never dropped.
- A process forked while another thread holds a window starts with its descriptors put back
  and the lock free. A child process started (``subprocess``) by another thread while a window
  is open inherits the window's file as its stdout and stderr: start children outside engine
  loads, or give them their own ``stdout=``.
- Only calls measured to print are wrapped (the engine's import, connect, URDF load); steps,
  commands and state reads are not, and cost nothing more.

This module imports no engine: a backend registers its classifier with
:func:`register_classifier` under its backend name. The classifier is looked up when the window
closes, so the registry's window around a backend's first import (which imports the engine,
then the backend module, which registers the classifier) reads the engine's banner with it. An
engine without a classifier has nothing claimed: its text goes through unchanged.

Importing this module gives the ``simbridge`` logger a :class:`logging.NullHandler`, as a
library's logger should: records are shown only where the application configures logging
(``logging.basicConfig()``, or ``simbridge --verbose``), never through Python's last-resort
handler on stderr.
"""

from __future__ import annotations

import atexit
import ctypes
import logging
import os
import sys
import tempfile
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import IO

__all__ = ["LOGGER_NAME", "Classifier", "Record", "captured", "register_classifier"]

LOGGER_NAME = "simbridge"
logging.getLogger(LOGGER_NAME).addHandler(logging.NullHandler())

Record = tuple[int, str]
"""A log record: (logging level, message)."""
Classifier = Callable[[str], tuple[list[Record], str]]
"""Text an engine call wrote -> (the records it is, the text that is not the engine's)."""

_classifiers: dict[str, Classifier] = {}
_lock = threading.Lock()  # one window at a time in the process
_owner: int | None = None  # the thread holding the window (read unlocked by that thread only)
_open: list[tuple[int, int, IO[bytes]]] = []  # the open window's (fd, its copy, its file)
# one anonymous file per fd, made on first use and emptied after each window: making them
# costs far more than emptying them (the figures: docs/compare.md, the engines' own output)
_sinks: dict[int, IO[bytes]] = {}


@atexit.register
def _close_sinks() -> None:
    """Close the anonymous files at exit (they are unnamed: nothing is left on disk either way;
    closing them keeps Python's ResourceWarning about open files away)."""
    for sink in _sinks.values():
        sink.close()
    _sinks.clear()


_libc: ctypes.CDLL | None = None


def register_classifier(engine: str, classify: Classifier) -> None:
    """Read what ``engine`` writes with ``classify`` from now on.

    Args:
        engine: A backend's name.
        classify: Takes the captured text, returns the records to log and the text to pass on.
    """
    _classifiers[engine] = classify


def _pass_through(text: str) -> tuple[list[Record], str]:
    return [], text


def _flush_c_streams() -> None:
    """C's stdio buffers (a ``printf`` to a file is buffered) go out before the descriptors
    move back; PyBullet flushes its own messages, this is for anything that does not."""
    global _libc
    try:
        if _libc is None:
            _libc = ctypes.CDLL(None)
        _libc.fflush(None)
    except (OSError, AttributeError, TypeError):  # no C library by that name (Windows)
        pass


def _flush_python_streams() -> None:
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream is not None:
                stream.flush()
        except (OSError, ValueError):  # closed, or a broken pipe: nothing more can go out
            pass


@contextmanager
def captured(engine: str, during: str = "", classify: Classifier | None = None) -> Iterator[None]:
    """Capture fds 1 and 2 while the body runs an engine call; see the module's rules.

    Records are logged when the window closes, also when the body raised (an engine's error
    lines come before its exception). A window opened inside this thread's open window does
    nothing: the outer one captures.

    Args:
        engine: Names the classifier (a backend name) and the logger (``simbridge.<engine>``).
        during: What the call was ("loading r2d2.urdf"), put in each record's message.
        classify: Replaces the registered classifier for this window; None: the registered one.

    Yields:
        None, once: the body runs with the descriptors captured.
    """
    global _owner
    me = threading.get_ident()
    if _owner == me:  # inside this thread's open window: that one captures
        yield
        return
    texts: dict[int, bytes] = {}
    try:
        with _lock:
            _owner = me
            try:
                _open[:] = _redirect()
                try:
                    yield
                finally:
                    _restore(_open, texts)
                    _open.clear()
            finally:
                _owner = None
    finally:  # outside the lock: a log handler may itself open a window
        _emit(engine, during, classify, texts)


def _after_fork_in_child() -> None:
    """A process forked while another thread held a window: that thread is not in the child,
    so the child puts its fds 1 and 2 back and starts with a free lock (else its first engine
    call would wait forever). Forked by the window's own thread: the window closes as usual."""
    global _lock, _owner, _sinks
    if _owner == threading.get_ident():
        return
    for fd, copy, _ in _open:
        os.dup2(copy, fd)
        os.close(copy)
    _open.clear()
    _owner = None
    _lock = threading.Lock()
    _sinks = {}  # the parent's files share their offsets with the parent: the child makes its own


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


def _redirect() -> list[tuple[int, int, IO[bytes]]]:
    """Point fds 1 and 2 at their anonymous files; return (fd, a copy of it, its file)."""
    _flush_python_streams()
    saved: list[tuple[int, int, IO[bytes]]] = []
    try:
        for fd in (1, 2):
            try:
                copy = os.dup(fd)
            except OSError:  # this descriptor is closed: nothing can be written to it
                continue
            try:
                sink = _sinks.get(fd)
                if sink is None:  # unnamed (no file is left behind), open for the process's life
                    sink = _sinks[fd] = tempfile.TemporaryFile(buffering=0)  # noqa: SIM115
            except BaseException:
                os.close(copy)
                raise
            saved.append((fd, copy, sink))
            os.dup2(sink.fileno(), fd)
    except BaseException:
        _restore(saved, {})
        raise
    return saved


def _restore(saved: list[tuple[int, int, IO[bytes]]], texts: dict[int, bytes]) -> None:
    """Put fds 1 and 2 back; what was written to them meanwhile goes into ``texts``."""
    _flush_python_streams()
    _flush_c_streams()
    for fd, copy, sink in saved:
        os.dup2(copy, fd)
        os.close(copy)
        sink.seek(0)
        texts[fd] = sink.read()
        sink.seek(0)
        sink.truncate()


def _emit(engine: str, during: str, classify: Classifier | None, texts: dict[int, bytes]) -> None:
    """Log what the engine's classifier claims; write the rest back where it was going."""
    read = classify or _classifiers.get(engine, _pass_through)
    log = logging.getLogger(f"{LOGGER_NAME}.{engine}")
    prefix = f"{engine} ({during})" if during else engine
    for fd, raw in sorted(texts.items()):
        if not raw:
            continue
        records, rest = read(raw.decode("utf-8", "surrogateescape"))
        for level, message in records:
            log.log(level, "%s: %s", prefix, message)
        if rest:
            data = rest.encode("utf-8", "surrogateescape")
            try:
                while data:
                    data = data[os.write(fd, data) :]
            except OSError:  # closed, or a reader gone: as if it had been written then
                pass
