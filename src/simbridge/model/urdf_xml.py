"""A URDF's text as PyBullet reads it: its lines, its XML tree (with line numbers) and its numbers.

PyBullet 3.2.7 is lenient where Python's XML parser is not. Measured on raw PyBullet and read
in bullet3 (``plugins/fileIOPlugin/fileIOPlugin.cpp`` ``InMemoryFileIO::readLine``,
``Importers/ImportURDFDemo/UrdfParser.cpp``, TinyXML-2 6.2):

* **lines**: a file is read one line at a time; a line ends at a newline *or a NUL byte*, is
  at most 8191 bytes (a longer one is broken there), and is cut at its first carriage return;
* **document**: blank lines (and a byte-order mark) before the ``<?xml?>`` declaration are
  skipped; top-level elements other than the first ``<robot>``, and text before an element, are
  ignored; an ``&`` that starts no entity is the character ``&``;
* **numbers**: every number is C's ``atof`` of its text (a number's longest prefix; text where a
  number belongs is 0); a vector is split at spaces alone (not tabs nor line breaks) and its
  first three numbers used; fewer than three leave it at zero.

:func:`read_urdf_xml` gives the tree PyBullet sees, with each element's source line, and the text
simbridge hands on (what PyBullet reads, in a form Python's XML parser takes, line for line).
:class:`Leniency` gathers what was read differently from the strict reading; the parser logs it
as one warning on the ``simbridge.model.urdf`` logger.
"""

from __future__ import annotations

import logging
import re
import xml.etree.ElementTree as ET
import xml.parsers.expat as expat
from collections.abc import Sequence
from dataclasses import dataclass, field

from simbridge.exceptions import UrdfParseError, UrdfStructureError

__all__ = ["Leniency", "UrdfXml", "XmlElement", "read_urdf_xml", "c_atof", "pybullet_numbers"]

LOGGER = logging.getLogger("simbridge.model.urdf")

LINE_BYTES = 8191  # PyBullet's line buffer holds 8191 bytes and the terminating NUL

_SHOWN = 10  # assumptions listed in full in one warning


@dataclass
class Leniency:
    """What one file's reading assumed where PyBullet is lenient: (source line, text) notes,
    logged together as one warning naming the file."""

    file: str
    notes: list[tuple[int, str]] = field(default_factory=list)

    def add(self, line: int | None, text: str) -> None:
        """Note one assumption.

        Args:
            line: The source line (1-based), or None where no one line is to blame.
            text: What was assumed.
        """
        self.notes.append((line or 0, text))

    def message(self) -> str:
        """The warning's text.

        Returns:
            The file, then every note (line: text), the first ten in full and a count of the rest.
        """
        parts = [f"line {line}: {text}" if line else text for line, text in self.notes]
        more = len(parts) - _SHOWN
        shown = parts[:_SHOWN] + ([f"... and {more} more"] if more > 0 else [])
        return f"{self.file}: read as PyBullet reads it: " + "; ".join(shown)

    def log(self) -> None:
        """Log :meth:`message` as one warning on the ``simbridge.model.urdf`` logger (if any
        note)."""
        if self.notes:
            LOGGER.warning("%s", self.message())


class XmlElement(ET.Element):
    """An ElementTree element that knows the source line of its start tag (1-based)."""

    __slots__ = ("line",)
    line: int


@dataclass(frozen=True)
class UrdfXml:
    """The ``<robot>`` element PyBullet reads, and the text simbridge passes on: PyBullet's
    reading of the file in a form Python's XML parser takes (same elements and values)."""

    root: XmlElement
    text: str


# ---------------------------------------------------------------- numbers

_C_NUMBER = re.compile(
    r"[ \t\n\v\f\r]*("
    r"[+-]?(?:"
    r"0[xX](?:[0-9a-fA-F]+(?:\.[0-9a-fA-F]*)?|\.[0-9a-fA-F]+)(?:[pP][+-]?[0-9]+)?"
    r"|(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"
    r"|[iI][nN][fF](?:[iI][nN][iI][tT][yY])?"
    r"|[nN][aA][nN](?:\([0-9A-Za-z_]*\))?"
    r"))"
)
_C_SPACE = " \t\n\v\f\r"


def c_atof(text: str) -> tuple[float, bool]:
    """C's ``atof`` (``strtod`` in the C locale).

    Args:
        text: The text to read.

    Returns:
        The value of the longest prefix that is a number (0.0 when there is none), and whether
        the whole text (blanks around it aside) was that number.
    """
    if text.isascii() and text.isprintable() and "_" not in text:  # float reads as strtod
        try:
            return float(text), True
        except ValueError:
            pass
    m = _C_NUMBER.match(text)
    if m is None:
        return 0.0, False
    s = m.group(1)
    body = s.lstrip("+-")
    if body[:2] in ("0x", "0X"):
        value = float.fromhex(s)
    elif body[:1] in "nN":
        value = float("nan")
    else:
        value = float(s)
    return value, not text[m.end() :].strip(_C_SPACE)


def pybullet_numbers(text: str) -> tuple[list[float], bool]:
    """A vector as PyBullet's ``parseVector3``/``parseVector4`` read it: the text split at spaces
    (only), each non-empty piece through :func:`c_atof`.

    Args:
        text: An attribute's text.

    Returns:
        The numbers, and whether every piece was a number as written.
    """
    values, clean = [], True
    for piece in text.split(" "):
        if piece:
            value, whole = c_atof(piece)
            values.append(value)
            clean = clean and whole
    return values, clean


# ---------------------------------------------------------------- lines


def _longest_line(data: bytes) -> int:
    return len(data) if len(data) <= LINE_BYTES else max(map(len, data.split(b"\n")))


def _pybullet_lines(data: bytes, lenient: Leniency) -> tuple[bytes, list[int]]:
    """The bytes PyBullet's line reader passes on (lines joined by newlines) and the source
    line of each of its lines."""
    if b"\0" not in data and _longest_line(data) <= LINE_BYTES:
        plain = data.replace(b"\r\n", b"\n")  # a carriage return ending a line: no matter
        if b"\r" not in plain:
            return plain, list(range(1, plain.count(b"\n") + 2))
    out: list[bytes] = []
    line_of: list[int] = []
    line = 1
    pieces = re.split(rb"([\n\0])", data)
    # pieces: content, separator, content, ...; a file ending in a separator ends there
    if len(pieces) > 1 and pieces[-1] == b"":
        pieces.pop()
    for k in range(0, len(pieces), 2):
        content = pieces[k]
        if len(content) > LINE_BYTES:
            lenient.add(
                line, f"longer than {LINE_BYTES} bytes: broken after every {LINE_BYTES} bytes"
            )
        for start in range(0, max(len(content), 1), LINE_BYTES):
            chunk = content[start : start + LINE_BYTES]
            cr = chunk.find(b"\r")
            if cr >= 0:
                if chunk[cr + 1 :]:
                    lenient.add(line, "text after a carriage return dropped")
                chunk = chunk[:cr]
            out.append(chunk)
            line_of.append(line)
        if k + 1 < len(pieces):
            if pieces[k + 1] == b"\0":
                if k + 2 < len(pieces) and pieces[k + 2].strip():
                    lenient.add(line, "a NUL byte, read as a line break")
                else:
                    lenient.add(line, "a NUL byte at the end of a line, ignored")
            else:
                line += 1
    return b"\n".join(out), line_of


_DECLARATION = re.compile(r"<\?xml[ \t\n\r][^>]*?\?>|<\?xml\?>")
_LEADING = re.compile(r"[ \t\n\r\v\f]*\ufeff?")
_AMPERSAND_OUTSIDE = re.compile(
    r"<!--.*?-->|<!\[CDATA\[.*?\]\]>|<\?.*?\?>|(&)(?!(?:amp|lt|gt|quot|apos|#[0-9]+|#x[0-9a-fA-F]+);)",
    re.S,
)
_RAW_SPACE_IN_VALUE = re.compile(r"""=\s*(?:"[^"<]*[\t\n][^"<]*"|'[^'<]*[\t\n][^'<]*')""")
_START_TAG = re.compile(
    r"<!--.*?-->|<!\[CDATA\[.*?\]\]>|<[?!][^>]*>|<[^/!?](?:\"[^\"]*\"|'[^']*'|[^>\"'])*>",
    re.S,
)
_VALUE = re.compile(r"\"[^\"]*\"|'[^']*'")
_START_TAG_BYTES = re.compile(rb"<(?:\"[^\"]*\"|'[^']*'|[^>\"'])*>")


def _blank(text: str) -> str:
    """Spaces for every character but line breaks (line numbers stay)."""
    return re.sub(r"[^\n]", " ", text)


def _prolog(text: str, line_at, lenient: Leniency) -> str:
    """Blank lines (and a byte-order mark) before the XML declaration, or several
    declarations: TinyXML-2 skips them, Python's parser refuses them. Blanked, line for line."""
    lead = _LEADING.match(text)
    pos = lead.end() if lead else 0
    found = []
    while (m := _DECLARATION.match(text, pos)) is not None:
        found.append(m)
        pos = m.end()
        blanks = _LEADING.match(text, pos)
        pos = blanks.end() if blanks else pos
    if not found or (found[0].start() == 0 and len(found) == 1):
        return text
    first = found[0]
    what = "several XML declarations" if len(found) > 1 else "the XML declaration"
    lenient.add(
        line_at(text.count("\n", 0, first.start()) + 1),
        f"{what} after blank lines at the start of the file: read past, as PyBullet does",
    )
    end = found[-1].end()
    return _blank(text[:end]) + text[end:]


def _ampersands(text: str, line_at, lenient: Leniency) -> str:
    """An '&' that starts no entity is the character '&' for TinyXML-2; Python's parser
    refuses it outside comments and CDATA: written there as '&amp;'."""
    noted: list[int] = []

    def fix(m: re.Match[str]) -> str:
        if m.group(1) is None:  # a comment, CDATA or a processing instruction: as it is
            return m.group(0)
        if not noted:
            noted.append(line_at(text.count("\n", 0, m.start()) + 1))
        return "&amp;"

    out = _AMPERSAND_OUTSIDE.sub(fix, text)
    if noted:
        lenient.add(noted[0], "an '&' that starts no XML entity read as the character '&'")
    return out


def _raw_attribute_spaces(text: str, line_of: list[int]) -> tuple[str, list[int]]:
    """Tabs and line breaks inside attribute values kept as character references: PyBullet
    reads them as written (a vector splits at spaces alone), Python's parser would turn them
    into spaces. A line break so moved into a value joins two lines: the line map follows."""
    joined: list[int] = []  # output line index (0-based) after which a break was removed

    def tag(m: re.Match[str]) -> str:
        s = m.group(0)
        if s.startswith(("<!", "<?")) or ("\t" not in s and "\n" not in s):
            return s
        first = text.count("\n", 0, m.start())

        def value(v: re.Match[str]) -> str:
            body = v.group(0)
            if "\n" in body:
                at = first + s.count("\n", 0, v.start())
                joined.extend(at + i for i in range(body.count("\n")))
            return body.replace("\t", "&#9;").replace("\n", "&#10;")

        return _VALUE.sub(value, s)

    out = _START_TAG.sub(tag, text)
    if joined:
        drop = {k + 1 for k in joined}
        line_of = [n for k, n in enumerate(line_of) if k not in drop]
    return out, line_of


# ---------------------------------------------------------------- the tree


class _Builder:
    """Expat events into an ElementTree of :class:`XmlElement`, each with its source line."""

    def __init__(self, parser: expat.XMLParserType, line_of: Sequence[int]) -> None:
        self.parser = parser
        self.line_of = line_of
        self.tree = ET.TreeBuilder(element_factory=XmlElement)
        self.open: list[XmlElement] = []
        self.first_start: int | None = None
        parser.StartElementHandler = self.start
        parser.EndElementHandler = self.end

    def source_line(self, line: int) -> int:
        if 1 <= line <= len(self.line_of):
            return self.line_of[line - 1]
        return self.line_of[-1] if self.line_of else line

    def start(self, tag: str, attrib: dict[str, str]) -> None:
        if self.first_start is None:
            self.first_start = self.parser.CurrentByteIndex
        elem = self.tree.start(tag, attrib)
        elem.line = self.source_line(self.parser.CurrentLineNumber)  # type: ignore[attr-defined]
        self.open.append(elem)  # type: ignore[arg-type]

    def end(self, tag: str) -> None:
        self.tree.end(tag)
        self.open.pop()


def _context(open_elements: list[XmlElement]) -> str:
    if not open_elements:
        return ""
    elem = open_elements[-1]
    name = elem.get("name")
    named = f" {name!r}" if name is not None else ""
    return f" (inside <{elem.tag}>{named} of line {elem.line})"


def _parse(data: bytes, line_of: Sequence[int]) -> XmlElement:
    parser = expat.ParserCreate("utf-8")
    builder = _Builder(parser, line_of)
    try:
        parser.Parse(data, True)
    except expat.ExpatError as exc:
        message = expat.ErrorString(exc.code)
        line = builder.source_line(exc.lineno)
        raise _XmlError(
            exc.code,
            f"{message}: line {line}, column {exc.offset}{_context(builder.open)}",
            builder.first_start is not None,
        ) from None
    return builder.tree.close()  # type: ignore[return-value]


class _XmlError(Exception):
    def __init__(self, code: int, detail: str, started: bool) -> None:
        super().__init__(detail)
        self.code = code
        self.detail = detail
        self.started = started  # an element had begun when the error came


_JUNK_AFTER_ROOT = expat.errors.codes[expat.errors.XML_ERROR_JUNK_AFTER_DOC_ELEMENT]
_SYNTAX = expat.errors.codes[expat.errors.XML_ERROR_SYNTAX]
_PROLOG = re.compile(rb"(?:\xef\xbb\xbf)?(?:<\?xml[ \t\n][^>]*?\?>|<\?xml\?>)?")
_WRAPPER = "simbridge-document"


def _first_robot(data: bytes, line_of: Sequence[int], file: str, lenient: Leniency) -> bytes:
    """Several top-level elements (or text before one): TinyXML-2 keeps them all and PyBullet
    reads the first ``<robot>``; everything else at the top level is blanked here. Text after
    the last element is an error for TinyXML-2 too."""
    opening, closing = f"<{_WRAPPER}>".encode(), f"</{_WRAPPER}>".encode()
    prolog = _PROLOG.match(data)
    root_start = prolog.end() if prolog else 0
    wrapped = data[:root_start] + opening + data[root_start:] + closing
    shift = len(opening)
    parser = expat.ParserCreate("utf-8")
    items: list[tuple[str, int]] = []  # top level, in order: (tag, "" text, "!" comment; line)
    robot: list[int] = []  # start and end offsets of the first <robot> in data
    depth = 0

    def start(tag: str, attrib: dict[str, str]) -> None:
        nonlocal depth
        depth += 1
        if depth == 2:
            items.append((tag, parser.CurrentLineNumber))
            if tag == "robot" and not robot:
                robot.append(parser.CurrentByteIndex - shift)

    def end(tag: str) -> None:
        nonlocal depth
        if depth == 2 and tag == "robot" and len(robot) == 1:
            at = parser.CurrentByteIndex
            if at - shift == robot[0]:  # <robot .../>: one event for the whole tag
                m = _START_TAG_BYTES.match(wrapped, at)
                robot.append(m.end() - shift if m else at - shift)
            else:
                robot.append(wrapped.index(b">", at) + 1 - shift)
        depth -= 1

    def text(chars: str) -> None:
        if depth == 1 and chars.strip():
            items.append(("", parser.CurrentLineNumber))

    def comment(chars: str) -> None:
        if depth == 1:
            items.append(("!", parser.CurrentLineNumber))

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = text
    parser.CommentHandler = comment

    def src(line: int) -> int:
        return line_of[min(max(line, 1), len(line_of)) - 1] if line_of else line

    try:
        parser.Parse(wrapped, True)
    except expat.ExpatError as exc:
        raise UrdfParseError(
            file, f"{expat.ErrorString(exc.code)}: line {src(exc.lineno)}, column {exc.offset}"
        ) from None
    if items and items[-1][0] == "":
        raise UrdfParseError(
            file,
            f"text after the last element: line {src(items[-1][1])} "
            "(PyBullet's XML parser refuses it too)",
        )
    if len(robot) != 2:
        tag = next(t for t, _ in items if t not in ("", "!"))
        line = next(n for t, n in items if t not in ("", "!"))
        raise UrdfStructureError(file, f"<{tag}>", "the root element must be <robot>", src(line))
    seen_robot = False
    for tag, line in items:
        if tag == "!":
            continue
        if tag == "robot" and not seen_robot:
            seen_robot = True
            continue
        what = f"<{tag}> element" if tag else "text"
        where = "after" if seen_robot else "before"
        lenient.add(src(line), f"{what} {where} the <robot> element ignored")
    first, last = robot
    blank = re.compile(rb"[^\n]")
    return (
        data[:root_start]
        + blank.sub(b" ", data[root_start:first])
        + data[first:last]
        + blank.sub(b" ", data[last:])
    )


def _long_line(raw: bytes) -> str:
    """Why a file with a line over :data:`LINE_BYTES` may be malformed for PyBullet ("" when
    every line fits)."""
    if _longest_line(raw) <= LINE_BYTES:
        return ""
    for number, line in enumerate(re.split(rb"[\n\0]", raw), 1):
        if len(line) > LINE_BYTES:
            return (
                f"; line {number} is {len(line)} bytes long: PyBullet reads a URDF in lines of "
                f"at most {LINE_BYTES} bytes (its file reader's line buffer) and breaks a longer "
                "one there, which is likely what broke the XML here (raw PyBullet refuses such a "
                "file too); break the line between elements"
            )
    return ""  # pragma: no cover - _longest_line found one


def _utf16(raw: bytes) -> str:
    """What a file in UTF-16 or UTF-32 looks like at its start ("" for anything else)."""
    for bom, name in (
        (b"\xff\xfe\0\0", "UTF-32 text (byte-order mark FF FE 00 00)"),
        (b"\0\0\xfe\xff", "UTF-32 text (byte-order mark 00 00 FE FF)"),
        (b"\xff\xfe", "UTF-16 text (byte-order mark FF FE)"),
        (b"\xfe\xff", "UTF-16 text (byte-order mark FE FF)"),
    ):
        if raw.startswith(bom):
            return name
    if raw[:2] in (b"<\0", b"\0<"):
        return "UTF-16 text (a NUL byte beside its first '<')"
    return ""


def read_urdf_xml(text: str, file: str, lenient: Leniency) -> UrdfXml:
    """The ``<robot>`` element of ``text`` as PyBullet reads it (see the module docstring).

    Args:
        text: The file's text (bytes that are not UTF-8 as surrogate escapes).
        file: The file's name, for messages.
        lenient: Takes a note of what a strict reading would not have read so.

    Returns:
        The root element, every element with its source line, and the text as read.

    Raises:
        UrdfParseError: what PyBullet's parser also refuses (naming the line, the column and
            the element it is in), or a UTF-16 file.
    """
    try:
        raw = text.encode("utf-8", errors="surrogateescape")  # a file's bytes as they were
    except UnicodeEncodeError:  # text with a lone surrogate of its own
        lenient.add(None, "a lone surrogate in the text written as '?'")
        raw = text.encode("utf-8", errors="replace")
    wide = _utf16(raw)
    if wide:
        raise UrdfParseError(
            file,
            f"the file is {wide}: PyBullet reads a URDF as UTF-8 (ASCII included) and refuses "
            "it too (XML_ERROR_PARSING, measured); save it as UTF-8",
        )
    data, line_of = _pybullet_lines(raw, lenient)
    try:
        view = data.decode("utf-8")
    except UnicodeDecodeError as exc:  # TinyXML-2 takes any byte: each kept as U+FFFD
        line = line_of[min(data.count(b"\n", 0, exc.start), len(line_of) - 1)]
        lenient.add(line, f"byte {data[exc.start]:#04x} is not UTF-8: read as U+FFFD")
        view = data.decode("utf-8", errors="replace")

    def line_at(n: int) -> int:
        return line_of[min(max(n, 1), len(line_of)) - 1] if line_of else n

    view = _prolog(view, line_at, lenient)
    if "&" in view:
        view = _ampersands(view, line_at, lenient)
    if _RAW_SPACE_IN_VALUE.search(view):
        view, line_of = _raw_attribute_spaces(view, line_of)
    data = view.encode("utf-8")
    try:
        root = _parse(data, line_of)
    except _XmlError as exc:
        # top-level text or elements besides the root: TinyXML-2 takes them
        if exc.code != _JUNK_AFTER_ROOT and (exc.code != _SYNTAX or exc.started):
            raise UrdfParseError(file, exc.detail + _long_line(raw)) from None
        data = _first_robot(data, line_of, file, lenient)
        view = data.decode("utf-8")
        try:
            root = _parse(data, line_of)
        except _XmlError as again:  # pragma: no cover - the blanked text parsed above
            raise UrdfParseError(file, again.detail) from None
    return UrdfXml(root, view)
