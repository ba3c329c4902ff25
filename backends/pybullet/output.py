"""PyBullet's own printout (banner, b3Warning/b3Error/b3Printf lines, the merge tree, the
GUI's lines) classified into log records for simbridge.engine_output; the classifier is
registered and pybullet imported here, its banner captured."""

from __future__ import annotations

import logging
import re

from simbridge.engine_output import Record, captured, register_classifier

__all__ = ["_pybullet_gui_output", "_pybullet_merge_output", "_pybullet_output", "p"]


# What PyBullet writes from C: ``b3Warning[file,line]:\n`` (b3Error, b3Printf alike) and the
# message, often without a newline before the next marker; the banner on import.
_B3_MARKER = re.compile(r"b3(Warning|Error|Printf)\[[^\]\n]*\]:\n?")
_B3_LEVEL = {"Warning": logging.WARNING, "Error": logging.ERROR, "Printf": logging.INFO}
_BANNER = re.compile(r"^pybullet build time: [^\n]*\n?", re.MULTILINE)
# PyBullet's warnings that simbridge's URDF reader already gives, on every backend, with the
# file and line (urdf.py: check_file_inertia, warn_missing_inertials): kept at DEBUG, so that
# a user reads each once
_SAID_BY_THE_READER = ("Bad inertia tensor properties", "No inertial data for link")
# ... and its two lines about an .stl it cannot read (the collision and the visual converter's):
# the reader refuses a file that is no STL and leaves out, with one warning, an ASCII STL
# (urdf.py: _without_unread_stl), so every such line is one the reader has said
_STL_SAID_BY_THE_READER = re.compile(
    r"(: cannot extract mesh from '|^issue extracting mesh from COLLADA/STL file ).*\.stl'?$",
    re.IGNORECASE,
)


def _said_by_the_reader(message: str) -> bool:
    return message.startswith(_SAID_BY_THE_READER) or bool(_STL_SAID_BY_THE_READER.search(message))


def _pybullet_output(text: str) -> tuple[list[Record], str]:
    """PyBullet's own lines in ``text`` as log records (the banner at DEBUG, b3Warning at
    WARNING, b3Error at ERROR, b3Printf at INFO; a message is the text after its marker up to
    the next marker or the end of its line; a one-word message after the same marker names the
    subject of the one before, and joins it), and the rest of ``text``, which is not PyBullet's
    (whitespace alone left between PyBullet's lines is dropped)."""
    records: list[Record] = []
    rest: list[str] = []
    at = 0
    markers = list(_B3_MARKER.finditer(text))
    for k, m in enumerate(markers):
        rest.append(text[at : m.start()])
        end = markers[k + 1].start() if k + 1 < len(markers) else len(text)
        newline = text.find("\n", m.end(), end)
        at = end if newline < 0 else newline + 1
        level, message = _B3_LEVEL[m.group(1)], text[m.end() : at].strip()
        if (
            records
            and message
            and not any(c.isspace() for c in message)
            and records[-1][0] == level
            and k > 0
            and markers[k - 1].group() == m.group()
        ):
            # Bullet reports a link's problem in two calls, the sentence and then the link's
            # name ("No inertial data for link, ...", "base_footprint"): one record
            records[-1] = (level, f"{records[-1][1].rstrip(':')}: {message}")
        else:
            records.append((level, message))
    records = [
        (logging.DEBUG if lv == logging.WARNING and _said_by_the_reader(msg) else lv, msg)
        for lv, msg in records
    ]
    rest.append(text[at:])
    left = "".join(rest)
    for m in _BANNER.finditer(left):
        records.insert(0, (logging.DEBUG, m.group().strip()))
    left = _BANNER.sub("", left)
    return records, left if left.strip() else ""


# URDF_MERGE_FIXED_LINKS makes Bullet print the link tree as it merges (printf, no b3 marker)
_MERGE_TREE = re.compile(r"^\t*(?:processing \S.*|merge \S.* into \S.*!|relink \S.*!)\n?", re.M)


def _pybullet_merge_output(text: str) -> tuple[list[Record], str]:
    """A load with merged fixed links: Bullet's printout of the merge at DEBUG, the rest as
    :func:`_pybullet_output` classifies it."""
    merged: list[Record] = [(logging.DEBUG, m.group().strip()) for m in _MERGE_TREE.finditer(text)]
    records, rest = _pybullet_output(_MERGE_TREE.sub("", text))
    return merged + records, rest


def _pybullet_gui_output(text: str) -> tuple[list[Record], str]:
    """Opening and closing the GUI prints lines of its own (threads, OpenGL versions), all
    PyBullet's: every line is claimed, those without a b3 marker at DEBUG."""
    records, rest = _pybullet_output(text)
    records += [(logging.DEBUG, line.strip()) for line in rest.splitlines() if line.strip()]
    return records, ""


register_classifier("pybullet", _pybullet_output)
with captured("pybullet", "importing"):  # its banner, also where this module is imported first
    import pybullet as p  # noqa: E402
