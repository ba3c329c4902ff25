"""The fenced code blocks of the project's Markdown (README.md, the site's docs/**/*.md), and the
one way the tests run them: each Python block in a fresh interpreter, in an empty folder,
nothing defined before it.

A block is written for a reader, so it runs as written. Three things a page may add, each in
the Markdown source where a reader of the source sees it:

- ``title="hold.py"`` in the fence's info string (```` ```python title="hold.py" ````, which
  the site shows as the block's file name): the block is that file, written into the folder
  before any block of the same page runs (a controller file, a scenario the next block reads).
- an HTML comment on the line right before the fence, ``<!-- doc-test: slow -->``: the block
  runs under ``pytest.mark.slow`` (a long run: the quick tier leaves it out, the full suite
  runs it).
- ``<!-- doc-test: setup`` followed by lines of code and ``-->``: code run before the block, for
  a fragment that continues a page's prose (``sim`` and ``robot`` made earlier in words). The
  block itself still runs whole.

An unknown word after ``doc-test:`` is an error naming the file and the line (a typo would
otherwise leave a block unmarked).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Block", "MARKS", "blocks", "run_python"]

MARKS = ("slow", "setup")

_FENCE = re.compile(r"^```(?P<lang>[\w+-]*)(?P<info>[^\n]*)\n(?P<code>.*?)^```$", re.S | re.M)
_TITLE = re.compile(r'\btitle="(?P<title>[^"]+)"')
_MARK = re.compile(r"<!-- doc-test: (?P<body>(?:(?!-->).)*)-->\n", re.S)


@dataclass(frozen=True)
class Block:
    """One fenced block.

    Attributes:
        file: the Markdown file.
        line: the line of its opening fence (1-based).
        language: the fence's language (``python``, ``toml``, ``bash``...; "" for none).
        title: the file the block is (``title="..."``), or None.
        code: the block's text.
        marks: the words of its ``<!-- doc-test: ... -->`` comment (``slow``, ``setup``).
        setup: the code its ``setup`` mark runs before it ("" without one).
    """

    file: Path
    line: int
    language: str
    title: str | None
    code: str
    marks: tuple[str, ...] = ()
    setup: str = ""

    @property
    def name(self) -> str:
        """``file.md:LINE``, a test id."""
        return f"{self.file.name}:{self.line}"


def _marks(text_before: str, file: Path, line: int) -> tuple[tuple[str, ...], str]:
    """The marks and setup code of the comment that ends right before a fence."""
    start = text_before.rfind("<!-- doc-test:")
    found = _MARK.fullmatch(text_before, max(start, 0)) if start >= 0 else None
    if found is None:
        return (), ""
    first, _, rest = found.group("body").partition("\n")
    marks = tuple(word.strip() for word in first.replace(",", " ").split())
    unknown = [m for m in marks if m not in MARKS]
    if unknown:
        raise ValueError(f"{file}:{line}: doc-test mark {unknown[0]!r}; the marks are {MARKS}")
    return marks, rest if "setup" in marks else ""


def blocks(file: Path, language: str | None = None) -> list[Block]:
    """Every fenced block of ``file`` (of ``language`` alone, when given), in order.

    Raises:
        ValueError: a ``<!-- doc-test: ... -->`` comment with an unknown mark.
    """
    text = file.read_text(encoding="utf-8")
    found = []
    for m in _FENCE.finditer(text):
        line = text.count("\n", 0, m.start()) + 1
        marks, setup = _marks(text[: m.start()], file, line)
        title = _TITLE.search(m.group("info"))
        block = Block(
            file=file,
            line=line,
            language=m.group("lang"),
            title=title.group("title") if title else None,
            code=m.group("code"),
            marks=marks,
            setup=setup,
        )
        if language is None or block.language == language:
            found.append(block)
    return found


def run_python(block: Block, folder: Path, *, code: str | None = None) -> str:
    """Run ``block`` (or ``code`` in its place) in a fresh interpreter in ``folder``, after
    writing the titled blocks of its page there and running its setup; returns stdout.

    The study cache goes into ``folder`` (``XDG_CACHE_HOME``): a block never reads a result
    another run left, nor leaves one.

    Raises:
        AssertionError: the block exits with an error (its file, line and stderr's end).
    """
    for other in blocks(block.file):
        if other.title is not None:
            (folder / other.title).write_text(other.code, encoding="utf-8")
    env = dict(os.environ, XDG_CACHE_HOME=str(folder / "cache"))
    done = subprocess.run(
        [sys.executable, "-c", block.setup + (block.code if code is None else code)],
        cwd=folder,
        capture_output=True,
        text=True,
        timeout=1200,
        env=env,
    )
    assert done.returncode == 0, f"{block.file}:{block.line}:\n{done.stderr[-3000:]}"
    return done.stdout
